// The first answer in Node: a user's clock from their arrays to their results — the build plus N
// rays — for kdray's default Scene.build + raycastMany against three-mesh-bvh's default build
// (CENTER) + raycastFirst per ray, N = 1, 1,000, 100,000 and 1,000,000, one thread.
//
//   node bench/first-answer.mjs [--rounds N] [--meshes torusknot,dragon] [--ns 1,1000,...]
//
// Rays: test/meshes.mjs `rays` (from random points on a sphere around the box to random points in
// it), the same for both. Each round times one whole run of each engine for every N, the engines
// taking turns (kdray first in odd rounds); both are warmed up on the bunny first (V8 tiers
// WebAssembly and JavaScript up while they run). The table gives medians and kdray ÷
// three-mesh-bvh (below 1: kdray answers first).
import { performance } from 'node:perf_hooks';
import os from 'node:os';
import * as THREE from 'three';
import { MeshBVH, CENTER } from 'three-mesh-bvh';
import { Scene, moduleVariant, init } from '../src/index.js';
import { bunny, rays as randomRays } from '../test/meshes.mjs';
import { geometryOf, meshByName } from './meshes.mjs';

const args = process.argv.slice(2);
const opt = (name, dflt) => { const i = args.indexOf(`--${name}`); return i < 0 ? dflt : args[i + 1]; };
const rounds = +opt('rounds', 5);
const meshNames = opt('meshes', 'torusknot,dragon').split(',');
const ns = opt('ns', '1,1000,100000,1000000').split(',').map(Number);
const median = (xs) => { const s = [...xs].sort((a, b) => a - b); return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2; };

async function kdray(m, rs) {
  const t = performance.now();
  const scene = await Scene.build(m.positions, m.indices);
  const hits = scene.raycastMany(rs);
  const ms = performance.now() - t;
  scene.dispose();
  return [ms, hits];
}

function peer(m, rs) {
  const t = performance.now();
  const bvh = new MeshBVH(geometryOf(m), { strategy: CENTER });
  const ray = new THREE.Ray();
  let found = 0;
  for (let i = 0; i < rs.length / 8; i++) {
    ray.origin.set(rs[8 * i], rs[8 * i + 1], rs[8 * i + 2]);
    ray.direction.set(rs[8 * i + 3], rs[8 * i + 4], rs[8 * i + 5]);
    if (bvh.raycastFirst(ray, THREE.DoubleSide)) found++;
  }
  return [performance.now() - t, found];
}

await init();
{
  const m = bunny();
  const rs = randomRays(m.positions, 20000, 99);
  for (let w = 0; w < 5; w++) {
    await kdray(m, rs);
    peer(m, rs);
  }
}
console.log(`Node ${process.version}, ${os.cpus()[0].model}, kdray module ${moduleVariant()}, one thread, medians of ${rounds} rounds`);
console.log('| mesh | N rays | kdray ms | three-mesh-bvh ms | kdray ÷ three-mesh-bvh | hits kdray / three-mesh-bvh |');
console.log('|---|---:|---:|---:|---:|---:|');
for (const name of meshNames) {
  const m = meshByName(name);
  if (!m) continue;
  for (const n of ns) {
    const rs = randomRays(m.positions, n, 7);
    const [tk, tp] = [[], []];
    let hitsK = 0;
    let hitsP = 0;
    for (let r = 0; r < rounds; r++) {
      const order = r % 2 === 0 ? ['k', 'p'] : ['p', 'k'];
      for (const who of order) {
        if (who === 'k') {
          const [ms, hits] = await kdray(m, rs);
          tk.push(ms);
          const prim = new Uint32Array(hits.buffer, hits.byteOffset, hits.length);
          hitsK = 0;
          for (let i = 0; i < n; i++) if (prim[4 * i + 1] !== 0xffffffff) hitsK++;
        } else {
          const [ms, found] = peer(m, rs);
          tp.push(ms);
          hitsP = found;
        }
      }
    }
    const [a, b] = [median(tk), median(tp)];
    console.log(`| ${name} (${m.indices.length / 3} tris) | ${n.toLocaleString('en')} | ${a.toFixed(1)} | ${b.toFixed(1)} | ${(a / b).toFixed(2)} | ${hitsK} / ${hitsP} |`);
  }
}
