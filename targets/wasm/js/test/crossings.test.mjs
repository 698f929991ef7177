// intersectAll / crossings in watertight mode: exact on shared edges and vertices, so parity
// tells inside from outside of a closed mesh even for rays aimed exactly at them.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Scene } from '../src/index.js';
import { bunny, rng } from './meshes.mjs';

// A closed icosphere (subdivided icosahedron), indexed: vertices shared exactly.
function icosphere(levels) {
  const t = (1 + Math.sqrt(5)) / 2;
  let v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]];
  let f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]];
  const norm = (p) => { const l = Math.hypot(...p); return p.map((x) => x / l); };
  v = v.map(norm);
  for (let l = 0; l < levels; l++) {
    const mid = new Map();
    const m = (a, b) => {
      const k = a < b ? `${a},${b}` : `${b},${a}`;
      if (!mid.has(k)) { v.push(norm(v[a].map((x, i) => (x + v[b][i]) / 2))); mid.set(k, v.length - 1); }
      return mid.get(k);
    };
    f = f.flatMap(([a, b, c]) => { const ab = m(a, b), bc = m(b, c), ca = m(c, a); return [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]; });
  }
  return { positions: Float32Array.from(v.flat()), indices: Uint32Array.from(f.flat()) };
}

// Points to aim at exactly: every vertex, and every edge's midpoint (as f32, on the edge up to
// rounding, which is the hard case: the ray grazes both triangles).
function targets({ positions, indices }) {
  const out = [];
  const p = (i) => [positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]];
  for (let i = 0; i < positions.length / 3; i++) out.push(p(i));
  for (let f = 0; f < indices.length; f += 3) {
    for (let k = 0; k < 3; k++) {
      const a = p(indices[f + k]), b = p(indices[f + (k + 1) % 3]);
      out.push(a.map((x, i) => Math.fround((x + b[i]) / 2)));
    }
  }
  return out;
}

test('rays from inside a closed icosphere through its vertices and edges cross once', async () => {
  const mesh = icosphere(2);
  const scene = await Scene.build(mesh.positions, mesh.indices, { watertight: true });
  const r = rng(12);
  const origins = [[0, 0, 0], [0.1, -0.2, 0.05], [r() * 0.3, r() * 0.3, r() * 0.3]];
  let rays = 0;
  for (const o of origins) {
    for (const t of targets(mesh)) {
      const d = t.map((x, i) => x - o[i]);
      assert.equal(scene.crossings(o, d), 1, `from ${o} at ${t}`);
      rays++;
    }
  }
  assert.ok(rays > 1000);
});

test('rays from outside through vertices and edges cross an even number of times', async () => {
  const mesh = icosphere(2);
  const scene = await Scene.build(mesh.positions, mesh.indices, { watertight: true });
  for (const t of targets(mesh)) {
    for (const o of [[3, 0.5, 0.25], [-2, -2, 1]]) {
      const d = t.map((x, i) => x - o[i]);
      const all = scene.intersectAll(o, d);
      assert.equal(all.length % 2, 0, `from ${o} at ${t}: ${all.length}`);
      for (let i = 1; i < all.length; i++) assert.ok(all[i].distance >= all[i - 1].distance);
    }
  }
});

test('contains: inside and outside of the bunny agree with a second direction', async () => {
  const { positions, indices } = bunny();
  const scene = await Scene.build(positions, indices, { watertight: true });
  const r = rng(13);
  const { min, max } = scene.info.bounds;
  let inside = 0, agreeing = 0;
  const n = 300;
  for (let i = 0; i < n; i++) {
    const p = [0, 1, 2].map((k) => min[k] + r() * (max[k] - min[k]));
    const a = scene.crossings(p, [1, 0, 0]) % 2;
    const b = scene.crossings(p, [0, 1, 0]) % 2;
    inside += scene.contains(p);
    agreeing += a === b;
  }
  // The bunny from npm has holes in its base: parity may differ between directions there, so
  // this asks for broad agreement and a plausible inside fraction, not exactness.
  assert.ok(agreeing > 0.9 * n, `${agreeing} of ${n} agree`);
  assert.ok(inside > 0.05 * n && inside < 0.95 * n, `${inside} of ${n} inside`);
});

test('a cube: rays along its faces\' shared edges and through its corners', async () => {
  // 12 triangles, 8 shared vertices.
  const positions = new Float32Array([0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1]);
  const indices = new Uint32Array([0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4, 1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7]);
  const scene = await Scene.build(positions, indices, { watertight: true });
  // From the centre through each corner and each face diagonal's midpoint (on the shared edge).
  const c = [0.5, 0.5, 0.5];
  for (let i = 0; i < 8; i++) {
    const p = [positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]];
    assert.equal(scene.crossings(c, p.map((x, k) => x - c[k])), 1, `corner ${p}`);
  }
  for (const p of [[0.5, 0.5, 0], [0.5, 0.5, 1], [0, 0.5, 0.5], [1, 0.5, 0.5], [0.5, 0, 0.5], [0.5, 1, 0.5], [0.25, 0.25, 0]]) {
    assert.equal(scene.crossings(c, p.map((x, k) => x - c[k])), 1, `edge point ${p}`);
  }
  // Through the cube from outside, along a face diagonal in the plane z = 0.5: in and out.
  assert.equal(scene.crossings([-1, -1, 0.5], [1, 1, 0]), 2);
  assert.equal(scene.contains([0.5, 0.5, 0.5]), true);
  assert.equal(scene.contains([1.5, 0.5, 0.5]), false);
  // A ray along the x axis through the corner edge line y = 0, z = 0 (in the faces' planes):
  // touching, never a single crossing.
  assert.equal(scene.crossings([-1, 0, 0], [1, 0, 0]) % 2, 0);
});
