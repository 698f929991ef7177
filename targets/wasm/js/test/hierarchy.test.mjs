// kdray/three's HierarchyRaycaster against three.js's own Raycaster (plain, and with
// three-mesh-bvh's per-mesh trees): the same first hit — object, instanceId, batchId,
// faceIndex, distance, point — over a hierarchy of Meshes (one mirrored by a negative scale,
// one hidden, one on another layer with a child on the raycaster's, one BackSide and one
// DoubleSide), an InstancedMesh with mirrored instances, and a BatchedMesh with a hidden
// instance; after moving instances and changing a geometry; and bad input.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import * as THREE from 'three';
import { HierarchyRaycaster, acceleratedIntersectObject } from '../src/three.js';
import { acceleratedRaycast as bvhRaycast, computeBoundsTree as bvhCompute } from 'three-mesh-bvh';
import { bunny, rng } from './meshes.mjs';

const threeMeshRaycast = THREE.Mesh.prototype.raycast;

function bunnyGeometry() {
  const { positions, indices } = bunny();
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  g.setIndex(new THREE.BufferAttribute(indices, 1));
  g.scale(0.12, 0.12, 0.12); // about 1.2 across
  return g;
}

function world() {
  const r = rng(21);
  const root = new THREE.Scene();
  const group = new THREE.Group();
  group.position.set(0.5, -0.25, 0);
  group.rotation.set(0.2, 0.4, 0);
  root.add(group);
  const geometries = [bunnyGeometry(), new THREE.TorusKnotGeometry(0.6, 0.2, 64, 12), new THREE.BoxGeometry(1, 1.5, 0.7)];
  const sides = [THREE.FrontSide, THREE.DoubleSide, THREE.BackSide];
  const named = {};
  for (let i = 0; i < 12; i++) {
    const mesh = new THREE.Mesh(geometries[i % 3], new THREE.MeshBasicMaterial({ side: sides[(i >> 2) % 3] }));
    mesh.position.set(8 * r() - 4, 8 * r() - 4, 8 * r() - 4);
    mesh.rotation.set(3 * r(), 3 * r(), 3 * r());
    const s = 0.6 + r();
    mesh.scale.set(s, i === 5 ? -s : s, s); // mesh 5 mirrored
    (i % 2 ? group : root).add(mesh);
    named[i] = mesh;
  }
  // Groups with an array of materials (a box's 6 groups, their sides front, double and back in
  // turn) and a draw range (the first half of a knot's faces).
  const boxed = new THREE.Mesh(new THREE.BoxGeometry(1.5, 1.5, 1.5), [0, 1, 2, 3, 4, 5].map((k) => new THREE.MeshBasicMaterial({ side: sides[k % 3] })));
  boxed.position.set(-2, 1, 2);
  const halfKnot = new THREE.TorusKnotGeometry(0.8, 0.25, 48, 8);
  halfKnot.setDrawRange(0, Math.floor(halfKnot.index.count / 6) * 3);
  const ranged = new THREE.Mesh(halfKnot, new THREE.MeshBasicMaterial({ side: THREE.DoubleSide }));
  ranged.position.set(2, -1, -2);
  root.add(boxed, ranged);
  Object.assign(named, { boxed, ranged });
  named[3].visible = false; // hidden
  named[7].layers.set(2); // not on the raycaster's layer; its child is
  const child = new THREE.Mesh(geometries[2], new THREE.MeshBasicMaterial());
  child.position.set(1.5, 0, 0);
  named[7].add(child);
  const inst = new THREE.InstancedMesh(new THREE.IcosahedronGeometry(0.4, 2), new THREE.MeshBasicMaterial(), 60);
  const m = new THREE.Matrix4();
  const place = (seed) => {
    const q = rng(seed);
    for (let i = 0; i < inst.count; i++) {
      const e = new THREE.Euler(3 * q(), 3 * q(), 3 * q());
      const sc = new THREE.Vector3(0.5 + q(), 0.5 + q(), (0.5 + q()) * (i % 4 === 0 ? -1 : 1));
      m.compose(new THREE.Vector3(10 * q() - 5, 10 * q() - 5, 10 * q() - 5), new THREE.Quaternion().setFromEuler(e), sc);
      inst.setMatrixAt(i, m);
    }
    inst.instanceMatrix.needsUpdate = true;
    inst.computeBoundingSphere();
  };
  place(5);
  root.add(inst);
  const batched = new THREE.BatchedMesh(12, 4000, 12000, new THREE.MeshBasicMaterial());
  const ids = [batched.addGeometry(new THREE.SphereGeometry(0.5, 12, 8)), batched.addGeometry(new THREE.ConeGeometry(0.4, 1, 10))];
  for (let i = 0; i < 10; i++) {
    const k = batched.addInstance(ids[i % 2]);
    m.compose(new THREE.Vector3(8 * r() - 4, 8 * r() - 4, 8 * r() - 4), new THREE.Quaternion().setFromEuler(new THREE.Euler(r(), r(), r())), new THREE.Vector3(1, i === 4 ? -1 : 1, 1));
    batched.setMatrixAt(k, m);
  }
  batched.setVisibleAt(2, false);
  group.add(batched);
  root.updateMatrixWorld(true);
  return { root, named, inst, place, batched, geometries };
}

function rays(n, seed) {
  const r = rng(seed);
  const out = [];
  for (let i = 0; i < n; i++) {
    const z = 2 * r() - 1, a = 2 * Math.PI * r(), s = Math.sqrt(1 - z * z);
    const o = new THREE.Vector3(12 * s * Math.cos(a), 12 * s * Math.sin(a), 12 * z);
    const t = new THREE.Vector3(8 * r() - 4, 8 * r() - 4, 8 * r() - 4);
    out.push(new THREE.Raycaster(o, t.sub(o).normalize()));
  }
  return out;
}

const shown = (o) => o.visible && (o.parent === null || shown(o.parent));

// three's first hit, hidden objects left out (three's Raycaster casts them; kdray skips them by
// default), or null when the two nearest hits are closer than 1e-6 (an edge: either may win).
function threeFirst(caster, root) {
  caster.firstHitOnly = false;
  const all = caster.intersectObject(root, true).filter((h) => shown(h.object));
  if (all.length > 1 && all[1].distance - all[0].distance < 1e-6 * all[0].distance) return undefined;
  return all[0] ?? null;
}

function sameHit(a, b, what) {
  if (b === null) return assert.equal(a, undefined, `${what}: kdray hits where three misses`);
  assert.ok(a, `${what}: kdray misses where three hits at ${b.distance}`);
  assert.equal(a.object, b.object, `${what}: object`);
  assert.equal(a.instanceId, b.instanceId, `${what}: instanceId`);
  assert.equal(a.batchId, b.batchId, `${what}: batchId`);
  assert.equal(a.faceIndex, b.faceIndex, `${what}: faceIndex`);
  assert.ok(Math.abs(a.distance - b.distance) <= 1e-5 * b.distance, `${what}: distance ${a.distance} vs ${b.distance}`);
  assert.ok(a.point.distanceTo(b.point) <= 1e-4, `${what}: point`);
  assert.deepEqual([a.face.a, a.face.b, a.face.c], [b.face.a, b.face.b, b.face.c], `${what}: face`);
  assert.ok(a.face.normal.distanceTo(b.face.normal) <= 1e-4, `${what}: face normal`);
}

function compare(kd, scene, casters, what) {
  let hits = 0, compared = 0;
  casters.forEach((caster, i) => {
    THREE.Mesh.prototype.raycast = threeMeshRaycast;
    const ref = threeFirst(caster, scene.root);
    if (ref === undefined) return;
    compared++;
    if (ref) hits++;
    for (const first of [true, false]) {
      caster.firstHitOnly = first;
      const got = kd.intersectObject(caster, scene.root);
      sameHit(got[0], ref, `${what}, ray ${i}, firstHitOnly ${first}`);
      if (first) assert.ok(got.length <= 1);
      for (let k = 1; k < got.length; k++) assert.ok(got[k].distance >= got[k - 1].distance, 'sorted');
    }
  });
  assert.ok(compared > 0.95 * casters.length && hits > casters.length / 3, `${what}: ${compared} compared, ${hits} hits`);
  return hits;
}

test('the first hit of a hierarchy with InstancedMesh and BatchedMesh is three.js\'s', () => {
  const scene = world();
  const kd = new HierarchyRaycaster();
  const casters = rays(400, 1);
  compare(kd, scene, casters, 'as built');
  // Which kinds were hit, so that each path ran: instances, batches, the layer's child.
  const hit = new Set();
  for (const c of casters) for (const h of kd.intersectObject(c, scene.root)) hit.add(h.instanceId !== undefined ? 'instance' : h.batchId !== undefined ? 'batch' : h.object === scene.named[7].children[0] ? 'child' : 'mesh');
  assert.deepEqual([...hit].sort(), ['batch', 'child', 'instance', 'mesh']);
  const objects = new Set();
  for (const c of casters) for (const h of kd.intersectObject(c, scene.root)) objects.add(h.object);
  assert.ok(objects.has(scene.named.boxed) && objects.has(scene.named.ranged), 'the grouped box and the ranged knot are hit');
  for (const c of casters) {
    for (const h of kd.intersectObject(c, scene.root)) {
      assert.notEqual(h.object, scene.named[3], 'the hidden mesh is skipped');
      assert.notEqual(h.object, scene.named[7], 'the mesh on layer 2 is skipped');
      if (h.batchId !== undefined) assert.notEqual(h.batchId, 2, 'the hidden batch instance is skipped');
    }
  }
  // Moving every instance, a batch instance, and changing a geometry's vertices: the caches follow.
  scene.place(6);
  scene.batched.setMatrixAt(1, new THREE.Matrix4().makeTranslation(0, 0, 1));
  scene.geometries[2].attributes.position.array[0] += 0.3;
  scene.geometries[2].attributes.position.needsUpdate = true;
  scene.root.updateMatrixWorld(true);
  compare(kd, scene, casters, 'moved');
  // Layer 2 on the raycaster too: the mesh on it is cast.
  for (const c of casters) c.layers.enable(2);
  compare(kd, scene, casters, 'with layer 2');
  // includeHidden: as three's Raycaster.
  const all = new HierarchyRaycaster({ includeHidden: true });
  let hidden = 0;
  for (const c of casters) {
    THREE.Mesh.prototype.raycast = threeMeshRaycast;
    c.firstHitOnly = false;
    const ref = c.intersectObject(scene.root, true);
    c.firstHitOnly = true;
    const got = all.intersectObject(c, scene.root);
    if (ref.length > 1 && ref[1].distance - ref[0].distance < 1e-6 * ref[0].distance) continue;
    sameHit(got[0], ref[0] ?? null, 'includeHidden');
    if (ref[0]?.object === scene.named[3]) hidden++;
  }
  assert.ok(hidden > 0, 'the hidden mesh is hit with includeHidden');
  kd.dispose();
  all.dispose();
});

test('the same first hits as three-mesh-bvh\'s per-mesh trees, through Raycaster.intersectObject', () => {
  const scene = world();
  scene.root.traverse((o) => { if (o.isMesh && !o.isBatchedMesh && !o.geometry.boundsTree) bvhCompute.call(o.geometry); });
  const casters = rays(300, 2);
  const kdIntersect = THREE.Raycaster.prototype.intersectObject;
  let hits = 0;
  for (const c of casters) {
    c.firstHitOnly = true;
    THREE.Mesh.prototype.raycast = bvhRaycast;
    const ref = c.intersectObject(scene.root, true).filter((h) => shown(h.object));
    THREE.Raycaster.prototype.intersectObject = acceleratedIntersectObject;
    try {
      const got = c.intersectObject(scene.root);
      // three-mesh-bvh's firstHitOnly is per mesh (and per instance): its first is the nearest.
      if (ref.length > 1 && ref[1].distance - ref[0].distance < 1e-6 * ref[0].distance) continue;
      sameHit(got[0], ref[0] ?? null, 'three-mesh-bvh');
      if (ref[0]) hits++;
    } finally {
      THREE.Raycaster.prototype.intersectObject = kdIntersect;
      THREE.Mesh.prototype.raycast = threeMeshRaycast;
    }
  }
  assert.ok(hits > 100, `${hits} hits`);
});

test('a world matrix that is not finite is refused, naming the object', () => {
  const scene = world();
  const kd = new HierarchyRaycaster();
  const [c] = rays(1, 3);
  scene.named[2].matrixWorld.elements[13] = NaN;
  assert.throws(() => kd.intersectObject(c, scene.root), /Mesh .* has a world matrix that is not finite/);
  scene.root.updateMatrixWorld(true);
  scene.inst.setMatrixAt(7, new THREE.Matrix4().makeScale(Infinity, 1, 1));
  assert.throws(() => kd.intersectObject(c, scene.root), /InstancedMesh .*instance 7 has a world matrix that is not finite/);
  // A scale of 0 (how applications hide an instance) is no error: that instance is never hit.
  scene.inst.setMatrixAt(7, new THREE.Matrix4().makeScale(0, 0, 0));
  assert.ok(Array.isArray(kd.intersectObject(c, scene.root)));
  kd.dispose();
});

test('geometry.dispose() frees its tree; the next call builds it again and answers the same', () => {
  const scene = world();
  const kd = new HierarchyRaycaster();
  const casters = rays(80, 4);
  const first = (c) => {
    c.firstHitOnly = true;
    const h = kd.intersectObject(c, scene.root)[0];
    return h && [h.object.uuid, h.instanceId, h.batchId, h.faceIndex, h.distance];
  };
  const before = casters.map(first);
  const held = (g) => Object.getOwnPropertySymbols(g).length;
  assert.equal(held(scene.geometries[1]), 1, 'the knot holds its tree');
  scene.geometries[1].dispose();
  assert.equal(held(scene.geometries[1]), 0, 'disposed: its tree is gone');
  assert.deepEqual(casters.map(first), before);
  assert.ok(before.some((h) => h && h[0] !== undefined), 'rays hit');
  kd.dispose();
});
