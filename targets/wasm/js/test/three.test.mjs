// kdray/three against three.js's own Mesh.raycast: the same intersections (distance, face,
// point, uv, materialIndex) through a world matrix, with firstHitOnly, near/far, the material's
// side and geometry.groups.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import * as THREE from 'three';
import { computeBoundsTree, disposeBoundsTree, acceleratedRaycast, init, KdTree } from '../src/three.js';
import { bunny, rays } from './meshes.mjs';

const plain = THREE.Mesh.prototype.raycast;

function setup(side, groups) {
  const { positions, indices } = bunny();
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  g.setIndex(new THREE.BufferAttribute(indices, 1));
  const uv = new Float32Array((positions.length / 3) * 2).map((_, i) => (i * 0.37) % 1);
  g.setAttribute('uv', new THREE.BufferAttribute(uv, 2));
  let material = new THREE.MeshBasicMaterial({ side });
  if (groups) {
    // Three groups: the first drawn FrontSide, the second DoubleSide, the third FrontSide again.
    const third = Math.floor(indices.length / 9) * 3;
    g.addGroup(0, third, 0);
    g.addGroup(third, third, 1);
    g.addGroup(2 * third, indices.length - 2 * third, 0);
    material = [new THREE.MeshBasicMaterial({ side: THREE.FrontSide }), new THREE.MeshBasicMaterial({ side: THREE.DoubleSide })];
  }
  const mesh = new THREE.Mesh(g, material);
  mesh.position.set(1, -2, 3);
  mesh.rotation.set(0.3, 1.1, -0.4);
  mesh.scale.set(0.05, 0.08, 0.06);
  mesh.updateMatrixWorld(true);
  return { mesh, positions };
}

function worldRays(mesh, positions, n, seed) {
  const local = rays(positions, n, seed);
  const out = [];
  for (let i = 0; i < n; i++) {
    const o = new THREE.Vector3(local[8 * i], local[8 * i + 1], local[8 * i + 2]).applyMatrix4(mesh.matrixWorld);
    const t = new THREE.Vector3(local[8 * i] + local[8 * i + 3], local[8 * i + 1] + local[8 * i + 4], local[8 * i + 2] + local[8 * i + 5]).applyMatrix4(mesh.matrixWorld);
    out.push([o, t.sub(o).normalize()]);
  }
  return out;
}

function same(a, b, what) {
  assert.equal(a.length, b.length, `${what}: ${a.length} vs ${b.length} intersections`);
  for (let i = 0; i < a.length; i++) {
    const [x, y] = [a[i], b[i]];
    assert.ok(Math.abs(x.distance - y.distance) <= 1e-5 * y.distance, `${what}[${i}]: distance ${x.distance} vs ${y.distance}`);
    assert.equal(x.faceIndex, y.faceIndex, `${what}[${i}]: face`);
    assert.equal(x.object, y.object);
    assert.ok(x.point.distanceTo(y.point) <= 1e-4, `${what}[${i}]: point`);
    assert.ok(x.uv.distanceTo(y.uv) <= 1e-3, `${what}[${i}]: uv`);
    assert.equal(x.face.materialIndex, y.face.materialIndex, `${what}[${i}]: materialIndex`);
    assert.deepEqual([x.face.a, x.face.b, x.face.c], [y.face.a, y.face.b, y.face.c]);
    assert.ok(x.face.normal.distanceTo(y.face.normal) <= 1e-4, `${what}[${i}]: normal`);
  }
}

async function check(side, groups, firstHitOnly, near = 0, far = Infinity) {
  await init();
  const { mesh, positions } = setup(side, groups);
  const raycaster = new THREE.Raycaster();
  raycaster.near = near;
  raycaster.far = far;
  raycaster.firstHitOnly = firstHitOnly;
  THREE.BufferGeometry.prototype.computeBoundsTree = computeBoundsTree;
  THREE.BufferGeometry.prototype.disposeBoundsTree = disposeBoundsTree;
  mesh.geometry.computeBoundsTree();
  assert.ok(mesh.geometry.boundsTree instanceof KdTree);
  let hits = 0;
  for (const [i, [o, d]] of worldRays(mesh, positions, 600, 20).entries()) {
    raycaster.set(o, d);
    THREE.Mesh.prototype.raycast = plain;
    let expected = raycaster.intersectObject(mesh, false);
    if (firstHitOnly) expected = expected.slice(0, 1);
    THREE.Mesh.prototype.raycast = acceleratedRaycast;
    const got = raycaster.intersectObject(mesh, false);
    same(got, expected, `ray ${i}`);
    hits += got.length;
  }
  THREE.Mesh.prototype.raycast = plain;
  assert.ok(hits > 100, `${hits} intersections: the rays miss`);
  mesh.geometry.disposeBoundsTree();
  assert.equal(mesh.geometry.boundsTree, null);
}

test('first hit, FrontSide, world matrix', () => check(THREE.FrontSide, false, true));
test('all hits, DoubleSide', () => check(THREE.DoubleSide, false, false));
test('all hits, BackSide, near and far', () => check(THREE.BackSide, false, false, 0.8, 1.3));
test('first hit with near and far', () => check(THREE.DoubleSide, false, true, 0.8, 1.1));
test('groups with a material array, first and all hits', async () => {
  await check(null, true, true);
  await check(null, true, false);
});

test('a mixed scene: a mesh with a tree, a plain mesh, and one after disposeBoundsTree (three\'s own raycast, no recursion)', async () => {
  THREE.BufferGeometry.prototype.computeBoundsTree = computeBoundsTree;
  THREE.BufferGeometry.prototype.disposeBoundsTree = disposeBoundsTree;
  const treed = setup(THREE.FrontSide, false);
  const floor = new THREE.Mesh(new THREE.PlaneGeometry(20, 20).rotateX(-Math.PI / 2), new THREE.MeshBasicMaterial({ side: THREE.DoubleSide }));
  floor.position.y = -2.5;
  floor.updateMatrixWorld(true);
  const disposed = setup(THREE.DoubleSide, false);
  disposed.mesh.position.x += 0.02;
  disposed.mesh.updateMatrixWorld(true);
  treed.mesh.geometry.computeBoundsTree();
  disposed.mesh.geometry.computeBoundsTree();
  disposed.mesh.geometry.disposeBoundsTree();
  const objects = [treed.mesh, floor, disposed.mesh];
  const raycaster = new THREE.Raycaster();
  let counts = [0, 0, 0];
  try {
    for (const [i, [o, d]] of worldRays(treed.mesh, treed.positions, 300, 21).entries()) {
      raycaster.set(o, d);
      THREE.Mesh.prototype.raycast = plain;
      const expected = raycaster.intersectObjects(objects, false);
      THREE.Mesh.prototype.raycast = acceleratedRaycast;
      const got = raycaster.intersectObjects(objects, false);
      assert.equal(got.length, expected.length, `ray ${i}`);
      for (let k = 0; k < got.length; k++) {
        assert.equal(got[k].object, expected[k].object, `ray ${i}, hit ${k}`);
        assert.ok(Math.abs(got[k].distance - expected[k].distance) <= 1e-5 * expected[k].distance, `ray ${i}, hit ${k}`);
        counts[objects.indexOf(got[k].object)]++;
      }
    }
  } finally {
    THREE.Mesh.prototype.raycast = plain;
  }
  assert.ok(counts.every((c) => c > 20), `hits per mesh ${counts}`);
});
