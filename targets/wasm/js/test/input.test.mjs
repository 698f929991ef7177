// Every bad input throws an Error with a message naming the problem; nothing traps or answers.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Scene } from '../src/index.js';
import { bunny } from './meshes.mjs';

const tri = () => new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0]);

async function refuses(make, pattern) {
  await assert.rejects(async () => make(), (e) => e instanceof Error && pattern.test(e.message), `expected ${pattern}`);
}

test('bad meshes', async () => {
  const nan = tri(); nan[4] = NaN;
  await refuses(() => Scene.build(nan), /positions\[4\] is NaN \(vertex 1\)/);
  const inf = tri(); inf[8] = -Infinity;
  await refuses(() => Scene.build(inf), /positions\[8\] is -Infinity/);
  await refuses(() => Scene.build(new Float32Array(8)), /8 floats, not a multiple of 3/);
  await refuses(() => Scene.build(new Float32Array(12)), /4 vertices, not a multiple of 3/);
  await refuses(() => Scene.build(tri(), new Uint32Array([0, 1, 3])), /indices\[2\] is 3, but positions holds only 3 vertices/);
  await refuses(() => Scene.build(tri(), new Uint32Array([0, 1])), /indices has 2 entries/);
  await refuses(() => Scene.build([0, 0, 0, 1, 0, 0, 0, 1, 0]), /positions must be a Float32Array/);
  await refuses(() => Scene.build(tri(), new Int8Array(3)), /indices must be a Uint32Array/);
  await refuses(() => Scene.build(new Float32Array([-3e38, 0, 0, 3e38, 0, 0, 0, 1, 0])), /overflow/);
  await refuses(() => Scene.build(tri(), { leaves: 'lists' }), /options.leaves must be 'groups' or 'list', not "lists"/);
  await refuses(() => Scene.build(tri(), undefined, { layout: 'blocks' }), /options.layout must be 'wide' or 'nodes', not "blocks"/);
  await refuses(() => Scene.build(tri(), undefined, { layout: 'blocked' }), /not "blocked" \('blocked' was retired: 'wide' replaces it\)/);
});

test('bad .kdt bytes', async () => {
  const { positions, indices } = bunny();
  const good = (await Scene.build(positions, indices)).toBytes();
  await refuses(() => Scene.fromBytes(good.subarray(0, good.length - 4)), /truncated/);
  await refuses(() => Scene.fromBytes(good.subarray(0, good.length - 1)), /whole number of 4-byte words/);
  await refuses(() => Scene.fromBytes(new Uint8Array(0)), /not a valid \.kdt/);
  await refuses(() => Scene.fromBytes(new TextEncoder().encode('hello world!')), /not a valid \.kdt/);
  // One flipped bit anywhere past the header: refused (the checksum, or the header's fields).
  for (const at of [8, 100, good.length >> 1, good.length - 5]) {
    const bad = good.slice();
    bad[at] ^= 0x10;
    await refuses(() => Scene.fromBytes(bad), /not a valid \.kdt/);
  }
  await refuses(() => Scene.fromBytes('scene.kdt'), /Uint8Array or ArrayBuffer/);
  // The good bytes still load, from an ArrayBuffer too.
  assert.equal((await Scene.fromBytes(good.buffer.slice(good.byteOffset, good.byteOffset + good.length))).info.triangles, 3674);
});

test('bad queries', async () => {
  const scene = await Scene.build(tri());
  assert.throws(() => scene.raycast([0, 0], [0, 0, 1]), /origin must have 3 numbers/);
  assert.throws(() => scene.raycast([0, 0, 0], null), /direction must be/);
  assert.throws(() => scene.raycastMany(new Float32Array(7)), /8 floats a ray/);
  assert.throws(() => scene.raycastMany(new Float32Array(16), new Float32Array(7)), /at least 8 floats/);
  assert.throws(() => scene.raycastMany([0, 0, 0, 0, 0, 1, 0, 1]), /Float32Array/);
  // NaN in a ray is a miss, not an error or a hit (the core's rule for non-finite rays).
  assert.equal(scene.raycast([NaN, 0.2, -1], [0, 0, 1]), null);
  assert.equal(scene.raycast([0.2, 0.2, -1], [0, 0, 0]), null);
  assert.ok(scene.raycast({ x: 0.2, y: 0.2, z: -1 }, { x: 0, y: 0, z: 1 }));
  scene.dispose();
  assert.throws(() => scene.raycast([0, 0, 0], [0, 0, 1]), /disposed/);
  assert.throws(() => scene.toBytes(), /disposed/);
  scene.dispose(); // twice: nothing happens
});

test('an empty mesh and degenerate triangles build, and nothing is hit', async () => {
  const empty = await Scene.build(new Float32Array(0));
  assert.equal(empty.raycast([0, 0, -1], [0, 0, 1]), null);
  const flat = await Scene.build(new Float32Array([0, 0, 0, 1, 1, 1, 2, 2, 2]));
  assert.equal(flat.raycast([1, 1, -1], [0, 0, 1]), null);
  assert.deepEqual(flat.intersectAll([1, 1, -1], [0, 0, 1]), []);
});
