// Out of memory (issue 29): the module limited to 96 MiB (test/limited.mjs), builds (here and
// on a worker) and raycastMany calls too large for it. Each is an Error naming the size, and every scene built
// before still answers as it did; small builds and loads go on working.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Scene, init } from '../src/streaming.js';
import { buildInWorker } from '../src/worker.js';
import { limitedModule } from './limited.mjs';
import { bunny, rays } from './meshes.mjs';

const LIMIT_MIB = 96;

// Scenes, and what each answered when it was made.
async function scenes() {
  const { positions, indices } = bunny();
  const out = [];
  for (const options of [{}, { watertight: true }, { leaves: 'list' }]) {
    const scene = await Scene.build(positions, indices, options);
    const r = rays(positions, 300, out.length + 1);
    out.push({ scene, r, hits: scene.raycastMany(r).slice(), one: scene.raycast(r.subarray(0, 3), r.subarray(3, 6)) });
  }
  return out;
}

function stillAnswer(list) {
  for (const { scene, r, hits, one } of list) {
    assert.deepEqual(scene.raycastMany(r), hits);
    assert.deepEqual(scene.raycast(r.subarray(0, 3), r.subarray(3, 6)), one);
    assert.equal(scene.info.triangles, 3674);
  }
}

const outOfMemory = (what) => (e) => e instanceof Error && !(e instanceof WebAssembly.RuntimeError)
  && /out of memory/.test(e.message) && e.message.includes(what);

test('builds and ray batches past the memory limit fail with an Error; every other scene answers as before', async () => {
  await init(limitedModule(LIMIT_MIB));
  const before = await scenes();
  // 2²⁰ copies of one triangle: 12 MiB of indices fit, the build's working memory does not (a
  // trap in the builder's own instance, reported from its last failed allocation).
  const copies = new Uint32Array(3 * 2 ** 20).map((_, i) => i % 3);
  await assert.rejects(Scene.build(new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0]), copies), outOfMemory('building 1048576 triangles'));
  stillAnswer(before);
  // Input larger than the memory: refused when copied in.
  await assert.rejects(Scene.build(new Float32Array(9 * 4_000_000)), outOfMemory('the positions (144000000 bytes)'));
  stillAnswer(before);
  // 2²¹ rays: 96 MiB of buffers do not fit; 1,000,000 rays' buffers (48 MB) do, the stream's own
  // copies of the rays then do not.
  const { scene } = before[0];
  for (const n of [2 ** 21, 1_000_000]) {
    assert.throws(() => scene.raycastMany(new Float32Array(8 * n)), outOfMemory(`${n} rays`));
    stillAnswer(before);
  }
  // The worker builds with the same module: its out of memory is named too (was "unreachable").
  await assert.rejects(buildInWorker(new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0]), copies), /cannot build the mesh: out of memory building 1048576 triangles \(an allocation of \d+ bytes failed/);
  stillAnswer(before);
  // Scenes keep being made, and the ones from before keep answering.
  const after = await scenes();
  stillAnswer(before);
  stillAnswer(after);
  const loaded = await Scene.fromBytes(before[1].scene.toBytes(), { watertight: true });
  assert.deepEqual(loaded.raycastMany(before[1].r), before[1].hits);
  for (const { scene: s } of [...before, ...after]) s.dispose();
});
