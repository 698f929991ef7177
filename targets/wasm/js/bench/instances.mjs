// A scene of many meshes in three.js: `raycaster.intersectObject(scene)` through kdray/three's
// HierarchyRaycaster (every mesh and instance under one top level) against the same call with
// three-mesh-bvh's per-mesh trees (its acceleratedRaycast on Mesh.prototype, as its README
// installs it; InstancedMesh casts each instance through it), one thread, the same rays, both
// with `raycaster.firstHitOnly = true`; then moving every instance of the InstancedMesh and
// casting again.
//
//   node bench/instances.mjs [--rounds N] [--rays N] [--meshes N] [--instances N]
//
// The scene: N meshes (default 1,000) sharing 50 geometries whose sizes run from 100 to 10,000
// triangles (log-spaced; torus knots and spheres), placed, turned and scaled at random in a
// 60-unit cube, and an InstancedMesh of N copies (default 10,000) of a 320-triangle icosphere
// in the same cube. Rays: from random points on a sphere around the cube to random points in
// it. Each round times both engines (alternating which goes first) over all the rays; the table
// gives medians. "same first hits": object, instanceId, faceIndex and distance within 1e-5
// relative, ray by ray. The trees (kdray's per geometry, three-mesh-bvh's computeBoundsTree,
// default options) are built before timing, three-mesh-bvh's first (it reorders the index
// buffers in place; kdray's trees are then built from the same order).
import { performance } from 'node:perf_hooks';
import os from 'node:os';
import * as THREE from 'three';
import { acceleratedRaycast, computeBoundsTree } from 'three-mesh-bvh';
import { acceleratedIntersectObject, init } from '../src/three.js';
import { moduleVariant, Scene, InstancedScene } from '../src/index.js';
import { rng } from '../test/meshes.mjs';

const args = process.argv.slice(2);
const opt = (name, dflt) => { const i = args.indexOf(`--${name}`); return i < 0 ? dflt : +args[i + 1]; };
const rounds = opt('rounds', 5);
const nRays = opt('rays', 300);
const nMeshes = opt('meshes', 1000);
const nInstances = opt('instances', 10000);
const median = (xs) => { const s = [...xs].sort((a, b) => a - b); return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2; };

const r = rng(42);
const root = new THREE.Scene();
const geometries = [];
let distinct = 0;
for (let i = 0; i < 50; i++) {
  const target = 100 * 100 ** (i / 49); // 100 … 10,000 triangles
  const g = i % 2
    ? new THREE.TorusKnotGeometry(1, 0.3, Math.max(3, Math.round(target / 16)), 8)
    : new THREE.SphereGeometry(1, Math.max(3, Math.round(Math.sqrt(target / 2))), Math.max(3, Math.round(Math.sqrt(target / 2))));
  geometries.push(g);
  distinct += g.index.count / 3;
}
let meshTriangles = 0;
for (let i = 0; i < nMeshes; i++) {
  const g = geometries[i % 50];
  const mesh = new THREE.Mesh(g, new THREE.MeshBasicMaterial());
  mesh.position.set(60 * r() - 30, 60 * r() - 30, 60 * r() - 30);
  mesh.rotation.set(6 * r(), 6 * r(), 6 * r());
  mesh.scale.setScalar(0.5 + 1.5 * r());
  root.add(mesh);
  meshTriangles += g.index.count / 3;
}
const ico = new THREE.IcosahedronGeometry(0.5, 3); // 320 triangles, not indexed
const instanced = new THREE.InstancedMesh(ico, new THREE.MeshBasicMaterial(), nInstances);
const m = new THREE.Matrix4();
const positions = [];
for (let i = 0; i < nInstances; i++) {
  const p = new THREE.Vector3(60 * r() - 30, 60 * r() - 30, 60 * r() - 30);
  positions.push(p);
  m.compose(p, new THREE.Quaternion().setFromEuler(new THREE.Euler(6 * r(), 6 * r(), 6 * r())), new THREE.Vector3().setScalar(0.5 + r()));
  instanced.setMatrixAt(i, m);
}
root.add(instanced);
root.updateMatrixWorld(true);
const icoTriangles = (ico.index ? ico.index.count : ico.attributes.position.count) / 3;

const rays = [];
for (let i = 0; i < nRays; i++) {
  const z = 2 * r() - 1, a = 2 * Math.PI * r(), s = Math.sqrt(1 - z * z);
  const o = new THREE.Vector3(60 * s * Math.cos(a), 60 * s * Math.sin(a), 60 * z);
  const t = new THREE.Vector3(60 * r() - 30, 60 * r() - 30, 60 * r() - 30);
  const c = new THREE.Raycaster(o, t.sub(o).normalize());
  c.firstHitOnly = true;
  rays.push(c);
}

const plainMesh = THREE.Mesh.prototype.raycast;
const plainIntersect = THREE.Raycaster.prototype.intersectObject;
const asBvh = () => { THREE.Mesh.prototype.raycast = acceleratedRaycast; THREE.Raycaster.prototype.intersectObject = plainIntersect; };
const asKdray = () => { THREE.Mesh.prototype.raycast = plainMesh; THREE.Raycaster.prototype.intersectObject = acceleratedIntersectObject; };
const castAll = () => rays.map((c) => c.intersectObject(root)[0] ?? null);

// Trees: three-mesh-bvh's first (it reorders index buffers), then kdray's (the first call).
let t0 = performance.now();
for (const g of [...geometries, ico]) computeBoundsTree.call(g);
const bvhBuild = performance.now() - t0;
await init();
asKdray();
t0 = performance.now();
castAll();
const kdFirst = performance.now() - t0;

// Warm-up, untimed, both engines.
for (let w = 0; w < 2; w++) { asBvh(); castAll(); asKdray(); castAll(); }

const times = { kdray: [], bvh: [], move: [], moveCast: [], place: [] };
let refHits, kdHits;
for (let round = 0; round < rounds; round++) {
  for (const engine of round % 2 ? ['bvh', 'kdray'] : ['kdray', 'bvh']) {
    if (engine === 'bvh') asBvh(); else asKdray();
    t0 = performance.now();
    const hits = castAll();
    times[engine].push(performance.now() - t0);
    if (engine === 'bvh') refHits = hits; else kdHits = hits;
  }
}
let same = 0, hitCount = 0;
for (let i = 0; i < nRays; i++) {
  const [a, b] = [kdHits[i], refHits[i]];
  if (b) hitCount++;
  if (a === null && b === null) { same++; continue; }
  if (a && b && a.object === b.object && a.instanceId === b.instanceId && a.faceIndex === b.faceIndex
      && Math.abs(a.distance - b.distance) <= 1e-5 * b.distance) same++;
}

// Moving every instance a little, then one cast through kdray: the top level is built again.
asKdray();
const one = rays[0];
for (let round = 0; round < 3 * rounds; round++) {
  for (let i = 0; i < nInstances; i++) {
    instanced.getMatrixAt(i, m);
    m.elements[12] += 0.01 * (r() - 0.5);
    instanced.setMatrixAt(i, m);
  }
  instanced.instanceMatrix.needsUpdate = true;
  t0 = performance.now();
  one.intersectObject(root);
  times.move.push(performance.now() - t0);
  t0 = performance.now();
  one.intersectObject(root);
  times.moveCast.push(performance.now() - t0);
}
THREE.Mesh.prototype.raycast = plainMesh;
THREE.Raycaster.prototype.intersectObject = plainIntersect;

// Of which the module's part: InstancedScene.setInstances of as many placements (the host's
// top_level, then the core's validation of its words), without the hierarchy.
const unit = await Scene.build(new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0]));
const alone = new InstancedScene([unit]);
const transforms = positions.flatMap((p) => [1, 0, 0, p.x, 0, 1, 0, p.y, 0, 0, 1, p.z]);
const meshIds = new Uint32Array(nInstances);
for (let round = 0; round < 3 * rounds; round++) {
  t0 = performance.now();
  alone.setInstances({ meshes: meshIds, transforms });
  times.place.push(performance.now() - t0);
}
alone.dispose();
unit.dispose();

const kd = median(times.kdray) / nRays, bvh = median(times.bvh) / nRays;
console.log(`# ${nMeshes} meshes (${geometries.length} geometries, ${distinct.toLocaleString('en')} distinct triangles, ${meshTriangles.toLocaleString('en')} placed), InstancedMesh of ${nInstances} × ${icoTriangles} triangles; ${nRays} rays, firstHitOnly; medians of ${rounds} rounds`);
console.log(`# Node ${process.version}, ${os.cpus()[0].model}, load ${os.loadavg().map((x) => x.toFixed(2)).join(' ')}, module ${moduleVariant()}`);
console.log(`| | kdray ms a ray | three-mesh-bvh ms a ray | ratio | same first hits | build ms (kdray first call / three-mesh-bvh) |`);
console.log(`|---|---:|---:|---:|---:|---:|`);
console.log(`| intersectObject(scene) | ${kd.toFixed(3)} | ${bvh.toFixed(3)} | ${(bvh / kd).toFixed(1)}× | ${same}/${nRays} (${hitCount} hits) | ${kdFirst.toFixed(0)} / ${bvhBuild.toFixed(0)} |`);
console.log(`moving ${nInstances} instances, then intersectObject(scene): ${median(times.move).toFixed(2)} ms (the next call, nothing moved: ${median(times.moveCast).toFixed(2)} ms); InstancedScene.setInstances of ${nInstances} placements alone: ${median(times.place).toFixed(2)} ms`);
