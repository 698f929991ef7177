// kdray against three-mesh-bvh in Node, one thread, the same meshes and the same rays: build time
// and raycasts per second of `raycast` (one call per ray, as three.js users cast), `raycastMany`
// (one call for all rays) and three-mesh-bvh's `raycastFirst` (DoubleSide: kdray has no culling).
//
//   node bench/bench.mjs [--rounds N] [--meshes bunny,torusknot,dragon] [--leaves groups,list]
//
// Meshes (bench/meshes.mjs): the bunny (host/scenes/meshes/bunny.ply.gz, 3,674 triangles), three.js's
// TorusKnotGeometry(1, 0.3, 512, 100) (102,400 triangles) and the full Stanford dragon
// (data/dragon.ply, 871,414 triangles; `bash scripts/fetch-meshes.sh`, left out when absent).
// Rays: `primary` — a 256×256 pinhole camera grid looking at the mesh from outside its box
// (coherent, what mouse picking and visibility tests cast), and `random` — from random points on a
// sphere around the box to random points inside it (incoherent). Directions are unit length.
// Each measurement runs N rounds (default 5), alternating the engines within a round so that a
// busy machine slows both alike; the table gives medians. three-mesh-bvh is built with its SAH
// strategy (kdray builds an SAH kd-tree), and its default CENTER build is timed too. kdray is
// measured with each kind of leaves in --leaves (Scene.build's options.leaves; default both), in
// the same rounds. Both engines are warmed up first (below).
import { performance } from 'node:perf_hooks';
import os from 'node:os';
import * as THREE from 'three';
import { MeshBVH, SAH, CENTER } from 'three-mesh-bvh';
import { Scene, moduleVariant, init } from '../src/index.js';
import { bunny, rays as randomRays } from '../test/meshes.mjs';
import { meshByName } from './meshes.mjs';
import { primaryRays } from './primary.mjs';

const args = process.argv.slice(2);
const opt = (name, dflt) => { const i = args.indexOf(`--${name}`); return i < 0 ? dflt : args[i + 1]; };
const rounds = +opt('rounds', 5);
const meshNames = opt('meshes', 'bunny,torusknot,dragon').split(',');
const leavesKinds = opt('leaves', 'groups,list').split(',');

const median = (xs) => { const s = [...xs].sort((a, b) => a - b); return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2; };

// A geometry of its own for each BVH: three-mesh-bvh reorders the index buffer in place.
function geometryOf({ positions, indices }) {
  const g = new THREE.BufferGeometry();
  positions = positions.slice();
  indices = indices.slice();
  g.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  g.setIndex(new THREE.BufferAttribute(indices, 1));
  return g;
}

await init();
// Warm-up, untimed: V8 first runs WebAssembly (and JavaScript) through its baseline compiler and
// tiers hot functions up in the background; on a loaded machine the first builds of the bunny
// took 8× as long as later ones (204 ms, then 24–25 ms). Both engines get the same warm-up.
{
  const m = bunny();
  const rs = randomRays(m.positions, 20000, 99);
  // Every kind of leaves measured: each has kernels of its own to tier up.
  for (let w = 0; w < 5; w++) {
    const ss = [];
    for (const leaves of leavesKinds) ss.push(await Scene.build(m.positions, m.indices, { leaves }));
    const peer = new MeshBVH(geometryOf(m), { strategy: SAH });
    new MeshBVH(geometryOf(m), { strategy: CENTER });
    for (const s of ss) s.raycastMany(rs);
    for (let i = 0; i < 20000; i++) {
      for (const s of ss) s.raycast(rs.subarray(8 * i, 8 * i + 3), rs.subarray(8 * i + 3, 8 * i + 6));
      peer.raycastFirst(new THREE.Ray(new THREE.Vector3(rs[8 * i], rs[8 * i + 1], rs[8 * i + 2]), new THREE.Vector3(rs[8 * i + 3], rs[8 * i + 4], rs[8 * i + 5])), THREE.DoubleSide);
    }
    for (const s of ss) s.dispose();
  }
}
const rows = [];
for (const name of meshNames) {
  const mesh = meshByName(name);
  if (!mesh) { console.error(`bench: leaving out ${name} (bash scripts/fetch-meshes.sh fetches it)`); continue; }
  const tris = mesh.indices.length / 3;
  // Build: alternating rounds (the dragon's builds take seconds: fewer rounds).
  const buildRounds = tris > 100000 ? Math.min(rounds, 3) : rounds;
  const tb = { kdray: Object.fromEntries(leavesKinds.map((l) => [l, []])), sah: [], center: [] };
  const scenes = {};
  let bvh = null;
  for (let r = 0; r < buildRounds; r++) {
    for (const leaves of leavesKinds) {
      const t0 = performance.now();
      const s = await Scene.build(mesh.positions, mesh.indices, { leaves });
      tb.kdray[leaves].push(performance.now() - t0);
      scenes[leaves]?.dispose();
      scenes[leaves] = s;
    }
    let t0 = performance.now();
    bvh = new MeshBVH(geometryOf(mesh), { strategy: SAH });
    tb.sah.push(performance.now() - t0);
    t0 = performance.now();
    new MeshBVH(geometryOf(mesh), { strategy: CENTER });
    tb.center.push(performance.now() - t0);
  }
  const mb = Object.fromEntries(leavesKinds.map((l) => [l, scenes[l].toBytes().length / 1e6]));
  for (const [kind, rs] of [['primary', primaryRays(mesh.positions, 256)], ['random', randomRays(mesh.positions, 65536, 1)]]) {
    const n = rs.length / 8;
    const origins = [], dirs = [], threeRays = [];
    for (let i = 0; i < n; i++) {
      origins.push(rs.subarray(8 * i, 8 * i + 3));
      dirs.push(rs.subarray(8 * i + 3, 8 * i + 6));
      threeRays.push(new THREE.Ray(new THREE.Vector3(rs[8 * i], rs[8 * i + 1], rs[8 * i + 2]), new THREE.Vector3(rs[8 * i + 3], rs[8 * i + 4], rs[8 * i + 5])));
    }
    const hits = new Float32Array(4 * n);
    const t = { peer: [] };
    for (const l of leavesKinds) Object.assign(t, { [`single-${l}`]: [], [`many-${l}`]: [] });
    const agree = {}, hitCount = {};
    for (let r = 0; r < rounds; r++) {
      for (const l of leavesKinds) {
        const scene = scenes[l];
        let t0 = performance.now();
        let k = 0;
        for (let i = 0; i < n; i++) if (scene.raycast(origins[i], dirs[i]) !== null) k++;
        t[`single-${l}`].push(performance.now() - t0);
        t0 = performance.now();
        scene.raycastMany(rs, hits);
        t[`many-${l}`].push(performance.now() - t0);
        hitCount[l] = k;
        if (r === 0) {
          // The same answers (hit or miss, and the distance), checked once outside the timing.
          agree[l] = 0;
          for (let i = 0; i < n; i++) {
            const a = bvh.raycastFirst(threeRays[i], THREE.DoubleSide);
            const d = hits[4 * i];
            if ((a == null && d === Infinity) || (a && Math.abs(a.distance - d) <= 1e-5 * d)) agree[l]++;
          }
        }
      }
      const t0 = performance.now();
      let p = 0;
      for (let i = 0; i < n; i++) if (bvh.raycastFirst(threeRays[i], THREE.DoubleSide)) p++;
      t.peer.push(performance.now() - t0);
    }
    const mr = (ms) => n / (median(ms) * 1e3);
    for (const l of leavesKinds) {
      rows.push({ mesh: name, tris, kind, leaves: l, mb: mb[l], n, hitCount: hitCount[l], agree: agree[l], build: median(tb.kdray[l]), sah: median(tb.sah), center: median(tb.center), single: mr(t[`single-${l}`]), many: mr(t[`many-${l}`]), peer: mr(t.peer) });
    }
  }
  for (const s of Object.values(scenes)) s.dispose();
}

const cpu = os.cpus()[0]?.model ?? 'unknown CPU';
console.log(`Node ${process.version}, ${cpu} (${os.cpus().length} cores, load ${os.loadavg().map((x) => x.toFixed(1)).join(' ')}), module ${moduleVariant()}, ${rounds} rounds, medians`);
console.log('| mesh | rays | leaves (tree MB) | kdray build ms | three-mesh-bvh SAH build ms (CENTER) | build ratio | raycast Mrays/s | raycastMany Mrays/s | three-mesh-bvh raycastFirst Mrays/s | raycast × | raycastMany × | same answers |');
console.log('|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|');
for (const r of rows) {
  console.log(`| ${r.mesh} (${r.tris.toLocaleString('en')} tris) | ${r.kind}, ${r.n} (${r.hitCount} hit) | ${r.leaves} (${r.mb.toFixed(1)}) | ${r.build.toFixed(1)} | ${r.sah.toFixed(1)} (${r.center.toFixed(1)}) | ${(r.build / r.sah).toFixed(2)} | ${r.single.toFixed(2)} | ${r.many.toFixed(2)} | ${r.peer.toFixed(2)} | ${(r.single / r.peer).toFixed(1)} | ${(r.many / r.peer).toFixed(1)} | ${r.agree}/${r.n} |`);
}
