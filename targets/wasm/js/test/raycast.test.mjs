// raycast against three.js's own brute-force Mesh.raycast and three-mesh-bvh, on seeded random
// triangle soups and the bunny; raycastMany against raycast.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import * as THREE from 'three';
import { MeshBVH } from 'three-mesh-bvh';
import { Scene } from '../src/index.js';
import { bunny, soup, rays } from './meshes.mjs';

function threeMesh(positions, indices) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  if (indices) g.setIndex(new THREE.BufferAttribute(indices, 1));
  return new THREE.Mesh(g, new THREE.MeshBasicMaterial({ side: THREE.DoubleSide }));
}

// First hit: the same face, or the same distance within 1e-5 relative (two triangles the ray
// meets at one point, where f32 and f64 arithmetic may choose differently); a miss is a miss.
function agree(a, b, what) {
  if (a === null || b === null) {
    assert.equal(a === null, b === null, `${what}: one hit (${JSON.stringify(a ?? b)}), the other missed`);
    return;
  }
  if (a.faceIndex === b.faceIndex) {
    assert.ok(Math.abs(a.distance - b.distance) <= 1e-5 * b.distance, `${what}: face ${a.faceIndex} at ${a.distance} vs ${b.distance}`);
  } else {
    assert.ok(Math.abs(a.distance - b.distance) <= 1e-5 * b.distance, `${what}: face ${a.faceIndex} at ${a.distance} vs face ${b.faceIndex} at ${b.distance}`);
  }
}

function compare(positions, indices, n, seed, options) {
  return async () => {
    const scene = await Scene.build(positions, indices, options);
    const mesh = threeMesh(positions, indices);
    // three-mesh-bvh reorders the index it is given in place: its own copy.
    const bvh = new MeshBVH(threeMesh(positions.slice(), indices?.slice()).geometry);
    const rs = rays(positions, n, seed);
    const raycaster = new THREE.Raycaster();
    let hits = 0;
    for (let i = 0; i < n; i++) {
      const r = rs.subarray(8 * i, 8 * i + 8);
      const ours = scene.raycast(r.subarray(0, 3), r.subarray(3, 6));
      raycaster.set(new THREE.Vector3(r[0], r[1], r[2]), new THREE.Vector3(r[3], r[4], r[5]));
      const brute = raycaster.intersectObject(mesh, false)[0] ?? null;
      agree(ours, brute, `ray ${i} against Mesh.raycast`);
      const peer = bvh.raycastFirst(raycaster.ray, THREE.DoubleSide) ?? null;
      agree(ours, peer, `ray ${i} against three-mesh-bvh`);
      if (ours) {
        hits++;
        // The point and barycentrics describe the same place.
        assert.ok(Math.abs(ours.point[0] - brute.point.x) <= 1e-4 * (1 + Math.abs(brute.point.x)));
      }
    }
    assert.ok(hits > n / 4, `only ${hits} of ${n} rays hit: the rays miss the mesh`);
    scene.dispose();
  };
}

test('random soup, non-indexed, agrees with Mesh.raycast and three-mesh-bvh', compare(soup(400, 1), undefined, 1500, 2));
test('random soup, watertight mode', compare(soup(400, 3), undefined, 1500, 4, { watertight: true }));
test('random soup, binary nodes only', compare(soup(2000, 5, 0.05), undefined, 1500, 6, { layout: 'nodes' }));
test('bunny, indexed', compare(bunny().positions, bunny().indices, 3000, 7));
test('bunny, watertight', compare(bunny().positions, bunny().indices, 1500, 8, { watertight: true }));
test('bunny, index-list leaves', compare(bunny().positions, bunny().indices, 1500, 14, { leaves: 'list' }));
test('random soup, index-list leaves, watertight', compare(soup(400, 15), undefined, 1500, 16, { leaves: 'list', watertight: true }));

// Triangle groups and index lists (the default) are two trees over the same triangles, tested by
// the same arithmetic lane by lane: every ray meets its first triangle at the same t in both,
// and where they name different faces, both faces lie at that t (a tie: the other tree reached
// the other one first).
test('group and index-list leaves give the same hits', async () => {
  const { positions, indices } = bunny();
  const n = 4000;
  const rs = rays(positions, n, 17);
  for (const watertight of [false, true]) {
    const groups = await Scene.build(positions, indices, { watertight, leaves: 'groups' });
    const list = await Scene.build(positions, indices, { watertight });
    assert.ok(groups.toBytes().length > list.toBytes().length, 'groups store triangles inline');
    const [hg, hl] = [groups.raycastMany(rs), list.raycastMany(rs)];
    const [fg, fl] = [new Uint32Array(hg.buffer), new Uint32Array(hl.buffer)];
    let ties = 0;
    for (let i = 0; i < n; i++) {
      const o = rs.subarray(8 * i, 8 * i + 3), d = rs.subarray(8 * i + 3, 8 * i + 6);
      assert.equal(hg[4 * i], hl[4 * i], `ray ${i}: t (raycastMany, watertight=${watertight})`);
      const [a, b] = [groups.raycast(o, d), list.raycast(o, d)];
      assert.equal(a?.distance, b?.distance, `ray ${i}: t (raycast)`);
      for (const [x, y] of [[fg[4 * i + 1], fl[4 * i + 1]], [a?.faceIndex, b?.faceIndex]]) {
        if (x === y) continue;
        ties++;
        const at = list.intersectAll(o, d).filter((h) => h.distance === a.distance).map((h) => h.faceIndex);
        assert.ok(at.includes(x) && at.includes(y), `ray ${i}: faces ${x} and ${y} are not both at t = ${a.distance}`);
      }
    }
    assert.ok(ties < n / 100, `${ties} ties in ${n} rays`);
    groups.dispose();
    list.dispose();
  }
});

test('raycastMany equals raycast, ray by ray', async () => {
  const { positions, indices } = bunny();
  for (const watertight of [false, true]) {
    const scene = await Scene.build(positions, indices, { watertight });
    const n = 5000;
    const rs = rays(positions, n, 9);
    // Some rays with a near/far window and some from inside the box.
    for (let i = 0; i < n; i += 7) { rs[8 * i + 6] = 1; rs[8 * i + 7] = 20; }
    const hits = new Float32Array(4 * n);
    assert.equal(scene.raycastMany(rs, hits), hits);
    const face = new Uint32Array(hits.buffer);
    let hit = 0;
    for (let i = 0; i < n; i++) {
      const r = rs.subarray(8 * i, 8 * i + 8);
      const one = scene.raycast(r.subarray(0, 3), r.subarray(3, 6), r[6], r[7]);
      if (one === null) {
        assert.equal(hits[4 * i], Infinity, `ray ${i}`);
        assert.equal(face[4 * i + 1], 0xffffffff, `ray ${i}`);
      } else {
        hit++;
        assert.equal(hits[4 * i], Math.fround(one.distance), `ray ${i}: t`);
        // Two triangles at exactly that t: a packet may report either (the core's stream).
        if (face[4 * i + 1] === one.faceIndex) {
          assert.equal(hits[4 * i + 2], one.u, `ray ${i}: u`);
          assert.equal(hits[4 * i + 3], one.v, `ray ${i}: v`);
        }
      }
    }
    assert.ok(hit > n / 4);
    // Again into the same buffer: the same answers; a returned array when none is passed.
    const again = scene.raycastMany(rs);
    assert.deepEqual(again, hits);
    scene.dispose();
  }
});

test('occluded agrees with raycast', async () => {
  const { positions, indices } = bunny();
  const scene = await Scene.build(positions, indices);
  const rs = rays(positions, 2000, 10);
  for (let i = 0; i < 2000; i++) {
    const r = rs.subarray(8 * i, 8 * i + 8);
    const hit = scene.raycast(r.subarray(0, 3), r.subarray(3, 6));
    assert.equal(scene.occluded(r.subarray(0, 3), r.subarray(3, 6)), hit !== null, `ray ${i}`);
    if (hit) {
      // Short of the hit: nothing in the way (the closest hit is the first thing on the ray).
      assert.equal(scene.occluded(r.subarray(0, 3), r.subarray(3, 6), 0, hit.distance * 0.999), false, `ray ${i} short`);
    }
  }
});

test('toBytes and fromBytes round-trip', async () => {
  const { positions, indices } = bunny();
  const a = await Scene.build(positions, indices);
  const bytes = a.toBytes();
  const b = await Scene.fromBytes(bytes);
  assert.deepEqual(b.toBytes(), bytes);
  const rs = rays(positions, 500, 11);
  assert.deepEqual(b.raycastMany(rs), a.raycastMany(rs));
  assert.equal(a.info.triangles, 3674);
});

test('a scene answers the same after another build grows the memory', async () => {
  const { positions, indices } = bunny();
  const scene = await Scene.build(positions, indices);
  const rs = rays(positions, 300, 12);
  const cast = () => Array.from({ length: 300 }, (_, i) => scene.raycast(rs.subarray(8 * i, 8 * i + 3), rs.subarray(8 * i + 3, 8 * i + 6)));
  const before = cast();
  assert.ok(before.some((h) => h !== null));
  // 20,000 small triangles need more memory than the module holds after the bunny (2.9 MB, then
  // 9.4 MB when this was written): it grows, and the views of the old memory are detached.
  const big = soup(20000, 13, 0.01);
  const other = await Scene.build(big);
  assert.deepEqual(cast(), before);
  other.dispose();
});

// The tree stores triangles in its leaves' order, not the mesh's; every answer names the mesh's
// triangle. A ray at the centre of each of an icosphere's 1,280 triangles, along its inward
// normal, hits that triangle: faceIndex is its index in raycast, raycastMany and intersectAll,
// with and without indices, in both modes and both kinds of leaves.
test('faceIndex is the mesh\'s triangle on a mesh of many triangles', async () => {
  const soupPositions = new Float32Array(new THREE.IcosahedronGeometry(1, 7).attributes.position.array);
  const n = soupPositions.length / 9;
  assert.equal(n, 1280);
  const indexed = { positions: soupPositions, indices: Uint32Array.from({ length: 3 * n }, (_, i) => i) };
  const many = new Float32Array(8 * n);
  const centre = new THREE.Vector3();
  const normal = new THREE.Vector3();
  for (let i = 0; i < n; i++) {
    const [a, b, c] = [0, 1, 2].map((k) => new THREE.Vector3().fromArray(soupPositions, 9 * i + 3 * k));
    centre.copy(a).add(b).add(c).divideScalar(3);
    normal.subVectors(b, a).cross(new THREE.Vector3().subVectors(c, a)).normalize();
    many.set([centre.x + normal.x, centre.y + normal.y, centre.z + normal.z, -normal.x, -normal.y, -normal.z, 0, Infinity], 8 * i);
  }
  for (const options of [{}, { leaves: 'list' }, { watertight: true }, { layout: 'nodes' }]) {
    for (const scene of [await Scene.build(soupPositions, options), await Scene.build(indexed.positions, indexed.indices, options)]) {
      const hits = scene.raycastMany(many, new Float32Array(4 * n));
      const faces = new Uint32Array(hits.buffer, hits.byteOffset, hits.length);
      for (let i = 0; i < n; i++) {
        assert.equal(faces[4 * i + 1], i, `${JSON.stringify(options)}: raycastMany, ray ${i}`);
        if (i % 97 === 0) {
          const o = many.subarray(8 * i, 8 * i + 3);
          const d = many.subarray(8 * i + 3, 8 * i + 6);
          assert.equal(scene.raycast(o, d)?.faceIndex, i, `${JSON.stringify(options)}: raycast, ray ${i}`);
          assert.equal(scene.intersectAll(o, d).sort((p, q) => p.distance - q.distance)[0].faceIndex, i, `${JSON.stringify(options)}: intersectAll, ray ${i}`);
        }
      }
      scene.dispose();
    }
  }
});
