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
await init(limitedModule(LIMIT_MIB));

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

test('memory full to the byte: every call answers or throws an Error, and then every scene answers as before', async () => {
  const before = await scenes();
  const tiny = (await Scene.build(new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0]))).toBytes();
  // Fill the memory with scenes' raycastMany buffers, halving the size at each refusal, until
  // not even a 1-triangle scene loads: an allocation that cannot fail gracefully then traps,
  // and the package starts the module again with every scene reloaded.
  const fillers = [];
  let full;
  for (let n = 2 ** 20; n >= 1 && !full;) {
    let s;
    try {
      s = Scene.fromBytesSync(tiny);
    } catch (e) {
      full = e;
      break;
    }
    try {
      s.raycastMany(new Float32Array(8 * n));
      fillers.push(s);
    } catch (e) {
      assert.ok(!(e instanceof WebAssembly.RuntimeError), e.stack);
      s.dispose();
      n = Math.floor(n / 2);
    }
  }
  assert.ok(full instanceof Error && !(full instanceof WebAssembly.RuntimeError) && /out of memory/.test(full.message), `${full}`);
  const { scene, r } = before[0];
  for (const call of [
    () => scene.raycast(r.subarray(0, 3), r.subarray(3, 6)), () => scene.intersectAll(r.subarray(0, 3), r.subarray(3, 6)),
    () => scene.crossings(r.subarray(0, 3), r.subarray(3, 6)), () => scene.contains([0, 0, 0]), () => scene.occluded(r.subarray(0, 3), r.subarray(3, 6)),
    () => scene.info, () => scene.toBytes(), () => scene.raycastMany(r), () => Scene.fromBytesSync(tiny), () => Scene.buildSync(new Float32Array(9)),
  ]) {
    try {
      call();
    } catch (e) {
      assert.ok(!(e instanceof WebAssembly.RuntimeError) && /^kdray: /.test(e.message), e.stack);
    }
  }
  stillAnswer(before);
  for (const f of fillers) f.dispose();
  stillAnswer(before);
  assert.equal((await Scene.fromBytes(tiny)).info.triangles, 1);
});
