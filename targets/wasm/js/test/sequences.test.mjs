// A property test of random sequences of package calls (issue 29): builds of random soups and of
// meshes too large for the module's memory (limited to 64 MiB, test/limited.mjs), raycast,
// raycastMany with random sizes up to past the memory, dispose, and fromBytes of mutated bytes.
// Every call either answers or throws an Error of the package's ("kdray: …"); nothing traps;
// and after every call each scene not disposed answers exactly as it did when it was made.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Scene, init } from '../src/streaming.js';
import { limitedModule } from './limited.mjs';
import { rng, soup, rays } from './meshes.mjs';

// KDRAY_SEQUENCES=seeds:steps runs others (e.g. 4-20:200); CI runs seeds 1-3, 80 calls each.
const [SEEDS, STEPS] = (() => {
  const [seeds = '1-3', steps = '80'] = (process.env.KDRAY_SEQUENCES ?? '').split(':').map((x) => x || undefined);
  const [a, b = a] = seeds.split('-').map(Number);
  return [Array.from({ length: b - a + 1 }, (_, i) => a + i), +steps];
})();

function packageError(e, step) {
  assert.ok(e instanceof Error && !(e instanceof WebAssembly.RuntimeError) && /^kdray: /.test(e.message), `step ${step}: ${e?.stack ?? e}`);
}

function answers(scene, r) {
  const first = scene.raycast(r.subarray(0, 3), r.subarray(3, 6));
  return { many: scene.raycastMany(r).slice(), first };
}

test('random call sequences: nothing traps, every live scene answers as before', { timeout: 3_600_000 }, async () => {
  await init(limitedModule(64));
  const tally = {};
  const count = (key) => { tally[key] = (tally[key] ?? 0) + 1; };
  for (const seed of SEEDS) {
    const random = rng(seed);
    const pick = (a) => a[Math.floor(random() * a.length)];
    const live = []; // { scene, r, expected }
    const add = (scene) => {
      const r = rays(soup(8, 99), 64, live.length + seed);
      live.push({ scene, r, expected: answers(scene, r) });
    };
    for (let step = 0; step < STEPS; step++) {
      const op = live.length === 0 ? 'build' : pick(['build', 'build', 'huge', 'raycast', 'many', 'many', 'dispose', 'mutated']);
      try {
        if (op === 'build') {
          const n = 1 + Math.floor(random() * 2000);
          add(await Scene.build(soup(n, step + 100 * seed), pick([undefined, { watertight: true }, { leaves: 'list' }, { layout: 'nodes' }])));
        } else if (op === 'huge') {
          // Copies of one triangle: tens of thousands build, hundreds of thousands do not. It
          // lies away from the rays (a ray through it would test every copy).
          const n = Math.floor(2 ** (14 + 7 * random()));
          const idx = new Uint32Array(3 * n).map((_, i) => i % 3);
          add(await Scene.build(new Float32Array([-50, -50, -50, -49, -50, -50, -50, -49, -50]), idx));
        } else if (op === 'raycast') {
          const { scene, r, expected } = pick(live);
          assert.deepEqual(scene.raycast(r.subarray(0, 3), r.subarray(3, 6)), expected.first);
        } else if (op === 'many') {
          // Sizes from 0 to 2²¹ rays (64 MiB: past the memory), the scene's own rays repeated.
          const { scene, r, expected } = pick(live);
          const n = random() < 0.1 ? 0 : Math.floor(2 ** (21 * random()));
          const batch = new Float32Array(8 * n);
          for (let i = 0; i < n; i += 64) batch.set(r.subarray(0, Math.min(8 * 64, 8 * (n - i))), 8 * i);
          const hits = scene.raycastMany(batch);
          for (let i = 0; i < n; i += 1 + Math.floor(n / 50)) {
            assert.deepEqual(hits.subarray(4 * i, 4 * i + 4), expected.many.subarray(4 * (i % 64), 4 * (i % 64) + 4));
          }
        } else if (op === 'dispose') {
          const i = Math.floor(random() * live.length);
          live[i].scene.dispose();
          live.splice(i, 1);
        } else if (op === 'mutated') {
          const bytes = pick(live).scene.toBytes();
          const kind = pick(['flip', 'truncate', 'splice']);
          let bad = bytes.slice();
          if (kind === 'flip') for (let k = 0; k < 1 + random() * 4; k++) bad[Math.floor(random() * bad.length)] ^= 1 << Math.floor(random() * 8);
          else if (kind === 'truncate') bad = bad.subarray(0, Math.floor(random() * bad.length));
          else bad = new Uint8Array([...bad.subarray(0, 64), ...bytes.subarray(Math.floor(random() * bytes.length))]);
          add(await Scene.fromBytes(bad)); // refused (the checksum), or loaded and queried
        }
        count(`${op} answered`);
      } catch (e) {
        if (e?.code === 'ERR_ASSERTION') throw e;
        packageError(e, `${seed}.${step} ${op}`);
        count(`${op} ${/out of memory|4 GiB/.test(e.message) ? 'out of memory' : 'refused'}`);
      }
      for (const { scene, r, expected } of live) assert.deepEqual(answers(scene, r), expected, `seed ${seed}, after step ${step} (${op})`);
    }
    for (const { scene } of live) scene.dispose();
  }
  // The sequences reached what they are for: builds and batches past the memory, bad bytes.
  for (const key of ['huge out of memory', 'huge answered', 'many out of memory', 'many answered', 'mutated refused', 'dispose answered']) {
    assert.ok(tally[key] > 0, `no "${key}" in ${JSON.stringify(tally)}`);
  }
});
