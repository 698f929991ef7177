// options.quality: 'fast' (the default) and 'high' build two trees over the same triangles;
// both agree ray by ray with a brute-force walk over every triangle, the default is 'fast', the
// worker builds the tree Scene.build does, and anything else is refused naming the option.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Scene } from '../src/index.js';
import { buildInWorker } from '../src/worker.js';
import { bunny, soup, rays } from './meshes.mjs';

// The nearest t of every ray over every triangle (Möller–Trumbore in f64), Infinity on a miss.
function bruteForce(positions, indices, rs) {
  const n = rs.length / 8;
  const tris = indices ? indices.length / 3 : positions.length / 9;
  const v = (t, k) => { const i = indices ? indices[3 * t + k] : 3 * t + k; return [positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]]; };
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const out = new Float64Array(n).fill(Infinity);
  for (let t = 0; t < tris; t++) {
    const p0 = v(t, 0), e1 = sub(v(t, 1), p0), e2 = sub(v(t, 2), p0);
    for (let r = 0; r < n; r++) {
      const o = rs.subarray(8 * r, 8 * r + 3), d = rs.subarray(8 * r + 3, 8 * r + 6);
      const p = cross(d, e2), det = dot(e1, p);
      if (det === 0) continue;
      const s = sub(o, p0), u = dot(s, p) / det;
      if (u < 0 || u > 1) continue;
      const q = cross(s, e1), w = dot(d, q) / det;
      if (w < 0 || u + w > 1) continue;
      const dist = dot(e2, q) / det;
      if (dist > 0 && dist < out[r]) out[r] = dist;
    }
  }
  return out;
}

for (const [name, mesh] of [['the bunny', bunny()], ['a random soup', { positions: soup(3000, 21, 0.05) }]]) {
  test(`${name}: both qualities hit as brute force does`, async () => {
    const { positions, indices } = mesh;
    const n = 600;
    const rs = rays(positions, n, 22);
    const want = bruteForce(positions, indices, rs);
    const fast = await Scene.build(positions, indices, { quality: 'fast' });
    const high = await Scene.build(positions, indices, { quality: 'high' });
    assert.notDeepEqual(fast.toBytes(), high.toBytes(), 'the two qualities build different trees');
    let hits = 0;
    for (const scene of [fast, high]) {
      const got = scene.raycastMany(rs);
      for (let i = 0; i < n; i++) {
        if (want[i] === Infinity) {
          assert.equal(got[4 * i], Infinity, `ray ${i}: a miss`);
        } else {
          assert.ok(Math.abs(got[4 * i] - want[i]) <= 1e-5 * want[i], `ray ${i}: t ${got[4 * i]} vs ${want[i]}`);
          hits++;
        }
      }
      scene.dispose();
    }
    assert.ok(hits > n / 2, `only ${hits / 2} of ${n} rays hit`);
  });
}

test("the default quality is 'fast'", async () => {
  const { positions, indices } = bunny();
  const plain = (await Scene.build(positions, indices)).toBytes();
  assert.deepEqual(plain, (await Scene.build(positions, indices, { quality: 'fast' })).toBytes());
  assert.notDeepEqual(plain, (await Scene.build(positions, indices, { quality: 'high' })).toBytes());
  assert.deepEqual(plain, Scene.buildSync(positions, indices, { leaves: 'list', quality: undefined }).toBytes());
});

test('buildInWorker builds at the quality asked for', async () => {
  const { positions, indices } = bunny();
  for (const quality of ['high', 'fast']) {
    const { scene } = await buildInWorker(positions, indices, { quality });
    assert.deepEqual(scene.toBytes(), (await Scene.build(positions, indices, { quality })).toBytes(), quality);
  }
});

test('an unknown quality is refused, naming the option', async () => {
  const tri = new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0]);
  for (const quality of ['medium', 'HIGH', 1, true]) {
    const named = (e) => e instanceof TypeError && /options\.quality must be 'fast' or 'high', not /.test(e.message);
    await assert.rejects(Scene.build(tri, { quality }), named, String(quality));
    assert.throws(() => Scene.buildSync(tri, undefined, { quality }), named, String(quality));
    await assert.rejects(buildInWorker(tri, { quality }), named, String(quality));
  }
  const bytes = (await Scene.build(tri)).toBytes();
  await assert.rejects(Scene.fromBytes(bytes, { quality: 'high' }), /quality applies to Scene.build/);
});
