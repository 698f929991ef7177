// Watertight mode on long geometry through the package (issue 39): rays from inside a closed box of
// L×1×1, at sin 1e-2 … 1e-5 to its long walls, must all hit it at the exact exit distance, through
// raycast (one ray) and raycastMany (the stream: packets for coherent runs, single rays for the
// rest). The core's walks have the same test over more meshes (tests/tests/stiff_long.rs).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Scene } from '../src/index.js';
import { rng } from './meshes.mjs';

const FACES = [
  0, 2, 1, 0, 3, 2, // z = 0
  4, 5, 6, 4, 6, 7, // z = 1
  0, 1, 5, 0, 5, 4, // y = 0
  3, 7, 6, 3, 6, 2, // y = 1
  0, 4, 7, 0, 7, 3, // x = 0
  1, 2, 6, 1, 6, 5, // x = L
];

function longBox(length) {
  const corners = [
    [0, 0, 0], [length, 0, 0], [length, 1, 0], [0, 1, 0],
    [0, 0, 1], [length, 0, 1], [length, 1, 1], [0, 1, 1],
  ];
  return new Float32Array(corners.flat());
}

// n rays from inside the box as float32 (origin, direction) with their exact exit distances.
function grazingRays(length, n, seed) {
  const next = rng(seed);
  const rays = [];
  for (let i = 0; i < n; i++) {
    const o = Float32Array.from([length * (0.3 + 0.4 * next()), 0.2 + 0.6 * next(), 0.2 + 0.6 * next()]);
    const sine = 10 ** (-5 + 3 * next());
    const wall = Math.floor(4 * next());
    const d = [(next() < 0.5 ? 1 : -1) * Math.sqrt(1 - sine * sine), 0, 0];
    d[1 + (wall % 2)] = (wall < 2 ? 1 : -1) * sine;
    const dir = Float32Array.from(d);
    const hi = [length, 1, 1];
    let exit = Infinity;
    for (let k = 0; k < 3; k++) {
      if (dir[k] > 0) exit = Math.min(exit, (hi[k] - o[k]) / dir[k]);
      if (dir[k] < 0) exit = Math.min(exit, (0 - o[k]) / dir[k]);
    }
    rays.push({ o, dir, exit });
  }
  return rays;
}

for (const length of [1e4, 1e5, 1e6]) {
  test(`watertight rays do not escape a box of length ${length}`, async () => {
    const scene = await Scene.build(longBox(length), new Uint32Array(FACES), { watertight: true });
    const rays = grazingRays(length, 256, 39 + length);
    const packed = new Float32Array(8 * rays.length);
    rays.forEach((r, i) => packed.set([...r.o, ...r.dir, 0, Infinity], 8 * i));
    const many = scene.raycastMany(packed);
    const faces = new Uint32Array(many.buffer, many.byteOffset, many.length);
    rays.forEach((r, i) => {
      const one = scene.raycast(r.o, r.dir);
      assert.ok(one !== null, `L = ${length}: ray ${i} escaped (raycast)`);
      assert.ok(Math.abs(one.distance - r.exit) <= 1e-4 * r.exit, `L = ${length}: raycast t ${one.distance}, exact ${r.exit}`);
      assert.notEqual(faces[4 * i + 1], 0xffffffff, `L = ${length}: ray ${i} escaped (raycastMany)`);
      assert.ok(Math.abs(many[4 * i] - r.exit) <= 1e-4 * r.exit, `L = ${length}: raycastMany t ${many[4 * i]}, exact ${r.exit}`);
    });
    scene.dispose?.();
  });
}
