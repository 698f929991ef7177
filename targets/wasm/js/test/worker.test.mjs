// kdray/worker: the tree built on a worker is the tree built here, byte for byte; a refusal in
// the worker comes back as the same Error.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { buildInWorker } from '../src/worker.js';
import { Scene } from '../src/index.js';
import { bunny } from './meshes.mjs';

test('buildInWorker gives the same tree as Scene.build', async () => {
  const { positions, indices } = bunny();
  const { scene, bytes } = await buildInWorker(positions, indices);
  const here = await Scene.build(positions, indices);
  assert.deepEqual(scene.toBytes(), here.toBytes());
  assert.deepEqual(new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength), here.toBytes());
  assert.equal(positions.length, 3 * 1839, 'the caller keeps its positions');
  assert.deepEqual(scene.raycast([0, 5, 20], [0, 0, -1]), here.raycast([0, 5, 20], [0, 0, -1]));
});

test('buildInWorker passes the build options', async () => {
  const { positions, indices } = bunny();
  const options = { leaves: 'list', layout: 'nodes' };
  const { scene } = await buildInWorker(positions, indices, options);
  assert.deepEqual(scene.toBytes(), (await Scene.build(positions, indices, options)).toBytes());
  assert.notDeepEqual(scene.toBytes(), (await Scene.build(positions, indices)).toBytes());
  await assert.rejects(buildInWorker(positions, indices, { leaves: 'lists' }), /options.leaves must be/);
});

test('a refusal in the worker is an Error here', async () => {
  await assert.rejects(buildInWorker(new Float32Array([0, 0, NaN, 1, 0, 0, 0, 1, 0])), /positions\[2\] is NaN/);
});
