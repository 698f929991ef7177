// Hostile calls on the package (issue 29): sizes that would wrap as i32 arguments, pointers past
// 2 GiB, scenes dropped without dispose(), short directions in fast mode, and what three.js users
// pass as indices. Each leaves every scene answering as before.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { setFlagsFromString } from 'node:v8';
import { runInNewContext } from 'node:vm';
import * as THREE from 'three';
import { Scene } from '../src/index.js';
import { moduleMemory } from '../src/core.js';
import { buildInWorker } from '../src/worker.js';
import { bunny, rays } from './meshes.mjs';

const square = () => new Float32Array([0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]);
const squareIdx = () => new Uint32Array([0, 1, 2, 0, 2, 3]);

// A Float32Array that reports `length` floats without holding them: the size checks read the
// length before anything else, so a 2²⁷-ray call needs no 4 GiB array to test.
function claiming(length) {
  return new (class extends Float32Array { get length() { return length; } })(8);
}

test('raycastMany: a ray count whose buffers pass 4 GiB is refused before the call, and the scene answers as before', async () => {
  const { positions, indices } = bunny();
  const scene = await Scene.build(positions, indices);
  const r = rays(positions, 1000, 7);
  const before = scene.raycastMany(r).slice();
  for (const n of [2 ** 27, 2 ** 26, 89478486]) { // 32·2²⁷ wraps to 0, 16·2²⁷ to -2³¹; 48·89478486 > 2³²
    const error = (() => { try { scene.raycastMany(claiming(8 * n), claiming(4 * n)); } catch (e) { return e; } })();
    assert.deepEqual(scene.raycastMany(r), before, `after ${n} rays`);
    assert.deepEqual(scene.raycastMany(r.subarray(0, 800)), before.subarray(0, 400));
    assert.ok(error instanceof Error && error.message.includes(`${n} rays`) && /4 GiB/.test(error.message), `${n} rays: ${error}`);
  }
  const other = await Scene.build(square(), squareIdx());
  assert.equal(other.raycast([0.25, 0.5, 1], [0, 0, -1]).distance, 1);
});

test('pointers past 2 GiB of module memory are read unsigned', async () => {
  const { positions, indices } = bunny();
  const scene = await Scene.build(positions, indices);
  const bytes = scene.toBytes();
  const r = rays(positions, 400_000, 3); // 19 MB of buffers: more than any free block below
  const expected = scene.raycastMany(r).slice();
  scene.dispose();
  // Grow the memory past 2 GiB (pages never touched stay virtual): the allocator's next blocks
  // lie above 2³¹, where an i32 export's result reads negative.
  const memory = moduleMemory();
  memory.grow(Math.ceil((2 ** 31 + 2 ** 20 - memory.buffer.byteLength) / 65536));
  const again = await Scene.fromBytes(bytes);
  assert.deepEqual(again.raycastMany(r), expected);
  assert.deepEqual(again.toBytes(), bytes);
  const built = await Scene.build(positions, indices);
  assert.deepEqual(built.raycastMany(r), expected);
  assert.equal(again.info.triangles, 3674);
  again.dispose();
  built.dispose();
});

test('scenes dropped without dispose() free their raycastMany buffers when collected', async () => {
  setFlagsFromString('--expose-gc');
  const gc = runInNewContext('gc');
  const r = new Float32Array(8 * 50_000); // 2.4 MB of buffers in the module a scene (rays of no direction: misses, fast)
  const keep = await Scene.build(square(), squareIdx());
  const start = moduleMemory().buffer.byteLength;
  const grown = [];
  for (let round = 0; round < 8; round++) {
    for (let i = 0; i < 25; i++) {
      const s = await Scene.build(square(), squareIdx());
      s.raycastMany(r);
    }
    gc();
    await new Promise((resolve) => setTimeout(resolve, 10)); // the registry's callbacks run
    grown.push((moduleMemory().buffer.byteLength - start) / 2 ** 20);
  }
  // 200 scenes × 2.4 MB would be 480 MB; freed, the memory stops growing after the first rounds.
  assert.ok(grown.at(-1) < 64, `module memory grown by ${grown} MiB`);
  assert.equal(keep.raycast([0.25, 0.5, 1], [0, 0, -1]).distance, 1);
});

test('fast mode: short and long directions hit, with distances in lengths of the direction', async () => {
  const scene = await Scene.build(square(), squareIdx());
  for (const k of [1e-7, 1e-20, 1e-35, 1e20]) {
    const d = [0, 0, -k];
    const hit = scene.raycast([0.25, 0.5, 1], d);
    assert.ok(hit, `direction ${d}`);
    assert.ok(Math.abs(hit.distance * k - 1) < 1e-6, `distance ${hit.distance} for ${d}`);
    assert.equal(hit.faceIndex, 1);
    assert.ok(Math.abs(hit.point[2]) < 1e-6);
    assert.equal(scene.occluded([0.25, 0.5, 1], d), true);
    assert.equal(scene.occluded([0.25, 0.5, 1], d, 0, 0.5 / k), false);
    assert.equal(scene.crossings([0.25, 0.5, 1], d), 1);
    assert.ok(Math.abs(scene.intersectAll([0.25, 0.5, 1], d)[0].distance * k - 1) < 1e-6);
    const hits = scene.raycastMany(new Float32Array([0.75, 0.25, 1, 0, 0, -k, 0, Infinity, 0.75, 0.25, 1, 0, 0, -k, 0, 0.5 / k]));
    assert.ok(Math.abs(hits[0] * k - 1) < 1e-6, `raycastMany distance ${hits[0]} for ${d}`);
    assert.equal(hits[4], Infinity, 'far is in lengths of the direction too');
  }
});

test('indices: Uint16Array, Array and BufferAttribute build what Uint32Array does; anything else throws naming it', async () => {
  const { positions, indices } = bunny();
  const r = rays(positions, 1000, 11);
  const expected = (await Scene.build(positions, indices)).raycastMany(r);
  const geometry = new THREE.BufferGeometry();
  geometry.setIndex(new THREE.BufferAttribute(Uint16Array.from(indices), 1));
  for (const idx of [Uint16Array.from(indices), Array.from(indices), geometry.index, new THREE.BufferAttribute(indices, 1)]) {
    const s = await Scene.build(positions, idx);
    assert.equal(s.info.triangles, 3674, idx.constructor.name);
    assert.deepEqual(s.raycastMany(r), expected, idx.constructor.name);
  }
  const tri = new Float32Array(9);
  await assert.rejects(Scene.build(tri, new Int8Array(3)), /indices must be a Uint32Array, Uint16Array, Array or three.js BufferAttribute \(or omitted\), not a Int8Array/);
  await assert.rejects(Scene.build(tri, [0, 1, -1]), /indices\[2\] is number -1/);
  await assert.rejects(Scene.build(tri, [0, 1.5, 2]), /indices\[1\] is number 1.5/);
  await assert.rejects(Scene.build(tri, 'abc'), /indices must be/);
  await assert.rejects(Scene.build(tri, [0, 1, 2], 'watertight'), /options must be an object/);
  await assert.rejects(Scene.build(tri, { watertigth: true }), /unknown option "watertigth" for Scene.build: the options are watertight, layout, leaves, quality/);
  await assert.rejects(Scene.build(tri, undefined, { watertight: 'yes' }), /options.watertight must be true or false/);
  const bytes = (await Scene.build(tri)).toBytes();
  await assert.rejects(Scene.fromBytes(bytes, { watertigth: true }), /unknown option "watertigth" for Scene.fromBytes/);
  await assert.rejects(Scene.fromBytes(bytes, { leaves: 'list' }), /leaves applies to Scene.build/);
  assert.equal((await Scene.fromBytes(bytes, { watertight: true })).watertight, true);
});

test('buildInWorker takes the indices Scene.build takes', async () => {
  const { positions, indices } = bunny();
  const r = rays(positions, 500, 5);
  const expected = (await Scene.build(positions, indices)).raycastMany(r);
  const { scene } = await buildInWorker(positions, Uint16Array.from(indices));
  assert.deepEqual(scene.raycastMany(r), expected);
  await assert.rejects(buildInWorker(positions, indices, { leaf: 'list' }), /unknown option "leaf"/);
});

// Issue 39, item 12: null options and intervals that are not numbers were taken for defaults or
// for 0 (`raycast(o, d, 0, null)` missed every ray: far = 0).
test('options and intervals of the wrong type or value are refused, naming them', async () => {
  const scene = await Scene.build(square(), squareIdx());
  try {
    for (const options of [{ quality: null }, { layout: null }, { leaves: null }, { watertight: null },
      { watertight: 'false' }, { quality: 'slow' }, { layout: 1 }]) {
      const [key] = Object.keys(options);
      assert.throws(() => Scene.buildSync(square(), squareIdx(), options),
        (e) => e instanceof TypeError && e.message.includes(key), JSON.stringify(options));
    }
    const o = [0.75, 0.25, 1];
    const d = [0, 0, -1];
    for (const [near, far, kind] of [[0, null, TypeError], [null, 5, TypeError], ['0', 5, TypeError],
      [0, '5', TypeError], [0n, 5, TypeError], [0, NaN, RangeError], [NaN, 5, RangeError]]) {
      const name = typeof near !== 'number' || Number.isNaN(near) ? 'near' : 'far';
      for (const call of ['raycast', 'occluded', 'intersectAll', 'crossings']) {
        assert.throws(() => scene[call](o, d, near, far),
          (e) => e instanceof kind && e.message.includes(name), `${call}(o, d, ${String(near)}, ${String(far)})`);
      }
    }
    // and the scene answers as before
    assert.equal(scene.raycast(o, d, 0, 5).distance, 1);
    assert.equal(scene.raycast(o, d).faceIndex, 0);
    assert.equal(scene.crossings(o, d, 0, Infinity), 1);
  } finally {
    scene.dispose();
  }
});
