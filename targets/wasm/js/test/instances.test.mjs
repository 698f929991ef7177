// InstancedScene (a scene of many meshes) against references that do not use it: a brute-force
// f64 ray/triangle test over every instance's triangles carried to world space, and, where the
// transforms are translations exact in f32, the merged mesh's own walk, bit for bit. Then bad
// input, moving instances, disposing a mesh that a top level still places, and the README's
// examples.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Scene, InstancedScene } from '../src/index.js';
import { bunny, rays, rng, soup } from './meshes.mjs';
import { spawnSync } from 'node:child_process';
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

// A 3×4 row-major transform: rotation about a random axis, scales (negative ones mirror), shift.
function randomTransform(r) {
  const axis = [r() - 0.5, r() - 0.5, r() - 0.5];
  const len = Math.hypot(...axis);
  const [x, y, z] = axis.map((a) => a / len);
  const a = 2 * Math.PI * r(), c = Math.cos(a), s = Math.sin(a), k = 1 - c;
  const rot = [
    [c + x * x * k, x * y * k - z * s, x * z * k + y * s],
    [y * x * k + z * s, c + y * y * k, y * z * k - x * s],
    [z * x * k - y * s, z * y * k + x * s, c + z * z * k],
  ];
  const scale = [0, 1, 2].map(() => (0.5 + r()) * (r() < 0.3 ? -1 : 1));
  const t = [0, 1, 2].map(() => 4 * r() - 2);
  const out = [];
  for (let i = 0; i < 3; i++) out.push(rot[i][0] * scale[0], rot[i][1] * scale[1], rot[i][2] * scale[2], t[i]);
  return out;
}

function apply(m, p) {
  return [0, 1, 2].map((i) => m[4 * i] * p[0] + m[4 * i + 1] * p[1] + m[4 * i + 2] * p[2] + m[4 * i + 3]);
}

// Every triangle of every instance in world space (f64), with its mesh's face and the id.
function worldTriangles(meshes, placed) {
  const out = [];
  for (const { mesh, m, id } of placed) {
    const { positions, indices } = meshes[mesh];
    const n = indices ? indices.length / 3 : positions.length / 9;
    for (let f = 0; f < n; f++) {
      const v = [0, 1, 2].map((k) => {
        const i = indices ? indices[3 * f + k] : 3 * f + k;
        return apply(m, [positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]]);
      });
      out.push({ v, face: f, id });
    }
  }
  return out;
}

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];

// The two closest hits (t, triangle) of a ray, Möller–Trumbore in f64.
function bruteForce(tris, o, d) {
  let best = { t: Infinity, tri: null }, second = Infinity;
  for (const tri of tris) {
    const [a, b, c] = tri.v;
    const e1 = sub(b, a), e2 = sub(c, a);
    const p = cross(d, e2);
    const det = dot(e1, p);
    if (Math.abs(det) < 1e-12) continue;
    const s = sub(o, a);
    const u = dot(s, p) / det;
    if (u < 0 || u > 1) continue;
    const q = cross(s, e1);
    const v = dot(d, q) / det;
    if (v < 0 || u + v > 1) continue;
    const t = dot(e2, q) / det;
    if (t <= 0) continue;
    if (t < best.t) [second, best] = [best.t, { t, tri }];
    else if (t < second) second = t;
  }
  return { ...best, second };
}

test('closest hits over rotated, scaled and mirrored instances match a brute-force f64 reference', async () => {
  const b = bunny();
  const meshes = [b, { positions: soup(300, 5, 0.3), indices: null }];
  const scenes = [await Scene.build(b.positions, b.indices), await Scene.build(meshes[1].positions)];
  const world = new InstancedScene(scenes);
  const r = rng(11);
  // The bunny is about 10 across: scaled down to the soup's size.
  const placed = [];
  for (let i = 0; i < 12; i++) {
    const m = randomTransform(r);
    const mesh = i % 2;
    if (mesh === 0) for (const k of [0, 1, 2, 4, 5, 6, 8, 9, 10]) m[k] *= 0.15;
    placed.push({ mesh, m, id: 1000 + 7 * i });
  }
  const placedCount = world.setInstances({ meshes: placed.map((p) => p.mesh), transforms: placed.flatMap((p) => p.m), ids: placed.map((p) => p.id) });
  assert.equal(placedCount, 12);
  assert.equal(world.info.instances, 12);
  const tris = worldTriangles(meshes, placed.map((p) => ({ ...p, m: [...Float32Array.from(p.m)] })));
  const box = new Float32Array([-2.5, -2.5, -2.5, 2.5, -2.5, -2.5, -2.5, 2.5, 2.5]);
  const rs = rays(box, 300, 3);
  const many = world.raycastMany(rs);
  const ids = new Uint32Array(many.buffer);
  let hits = 0, compared = 0;
  for (let i = 0; i < 300; i++) {
    const o = [rs[8 * i], rs[8 * i + 1], rs[8 * i + 2]];
    const d = [rs[8 * i + 3], rs[8 * i + 4], rs[8 * i + 5]];
    const ref = bruteForce(tris, o, d);
    const hit = world.raycast(o, d);
    // Near-ties (a ray through an edge, or two surfaces within 1e-4) may go either way.
    if (ref.second - ref.t < 1e-4 * ref.t) continue;
    compared++;
    if (ref.tri === null) {
      assert.equal(hit, null, `ray ${i}: a hit where the reference misses`);
      assert.equal(many[5 * i], Infinity);
      continue;
    }
    hits++;
    assert.ok(hit, `ray ${i}: a miss where the reference hits at ${ref.t}`);
    // f32 rounding of coordinates up to ~14 from the origin: an absolute tolerance.
    assert.ok(Math.abs(hit.distance - ref.t) <= 1e-5 * (ref.t + 1), `ray ${i}: t ${hit.distance} vs ${ref.t}`);
    assert.equal(hit.id, ref.tri.id, `ray ${i}: instance id`);
    assert.equal(hit.faceIndex, ref.tri.face, `ray ${i}: face`);
    // The normal is the placed triangle's e1 × e2, unit.
    const n = cross(sub(ref.tri.v[1], ref.tri.v[0]), sub(ref.tri.v[2], ref.tri.v[0]));
    assert.ok(dot(n, hit.normal) / Math.hypot(...n) > 0.999, `ray ${i}: normal`);
    assert.deepEqual([many[5 * i], ids[5 * i + 1], ids[5 * i + 4]], [hit.distance, hit.faceIndex, hit.id], `ray ${i}: raycastMany`);
    assert.equal(world.occluded(o, d), true);
    assert.equal(world.occluded(o, d, 0, ref.t * 0.999), false, `ray ${i}: nothing before the closest hit`);
  }
  assert.ok(compared > 250 && hits > 80, `${compared} rays compared, ${hits} hits`);
  world.dispose();
  for (const s of scenes) s.dispose();
});

test('translations exact in f32: the same answers as the merged mesh, bit for bit', async () => {
  // Triangles on a 1/8 grid, copies shifted by whole numbers: every subtraction is exact, so the
  // instance walk's moved ray meets the same numbers as the merged mesh's.
  const r = rng(7);
  const grid = (x) => Math.round(x * 8) / 8;
  const meshes = [soup(200, 1, 0.5).map(grid), soup(50, 2, 0.8).map(grid)];
  const placed = [];
  const taken = new Set();
  while (placed.length < 20) {
    const shift = [0, 1, 2].map(() => Math.floor(6 * r()) - 3);
    if (taken.has(String(shift))) continue; // two copies in one place: either may win a tie
    taken.add(String(shift));
    placed.push({ mesh: placed.length % 3 === 0 ? 1 : 0, shift });
  }
  const merged = [];
  const faceOf = []; // merged face → [instance, face]
  placed.forEach(({ mesh, shift }, i) => {
    const p = meshes[mesh];
    for (let k = 0; k < p.length; k++) merged.push(p[k] + shift[k % 3]);
    for (let f = 0; f < p.length / 9; f++) faceOf.push([i, f]);
  });
  const scenes = await Promise.all(meshes.map((p) => Scene.build(p)));
  const world = new InstancedScene(scenes);
  world.setInstances({
    meshes: placed.map((p) => p.mesh),
    transforms: placed.flatMap(({ shift }) => [1, 0, 0, shift[0], 0, 1, 0, shift[1], 0, 0, 1, shift[2]]),
  });
  const whole = await Scene.build(Float32Array.from(merged));
  // Origins on a 1/1024 grid too, so that the origin moved into an instance is exact.
  const rs = rays(Float32Array.from(merged), 2000, 9);
  for (let i = 0; i < rs.length; i += 8) for (let k = 0; k < 3; k++) rs[i + k] = Math.round(rs[i + k] * 1024) / 1024;
  const a = world.raycastMany(rs);
  const b = whole.raycastMany(rs);
  const [ua, ub] = [new Uint32Array(a.buffer), new Uint32Array(b.buffer)];
  let hits = 0;
  for (let i = 0; i < 2000; i++) {
    if (ub[4 * i + 1] === 0xffffffff) {
      assert.equal(ua[5 * i + 4], 0xffffffff, `ray ${i}: a hit where the merged mesh misses`);
      continue;
    }
    hits++;
    const [inst, face] = faceOf[ub[4 * i + 1]];
    assert.deepEqual([ua[5 * i], ua[5 * i + 4], ua[5 * i + 1], ua[5 * i + 2], ua[5 * i + 3]],
      [ub[4 * i], inst, face, ub[4 * i + 2], ub[4 * i + 3]], `ray ${i}: t, instance, face, u, v bits`);
  }
  assert.ok(hits > 800, `${hits} hits`);
  world.dispose();
  whole.dispose();
  for (const s of scenes) s.dispose();
});

test('moving instances places them anew; a scale of 0 places nothing', async () => {
  const scene = await Scene.build(new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0]));
  const world = new InstancedScene([scene]);
  const at = (z) => [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, z];
  assert.equal(world.raycast([0.2, 0.2, 10], [0, 0, -1]), null, 'nothing placed yet');
  world.setInstances({ meshes: [0, 0], transforms: [...at(0), ...at(2)], ids: [5, 6] });
  assert.deepEqual([world.raycast([0.2, 0.2, 10], [0, 0, -1]).distance, world.raycast([0.2, 0.2, 10], [0, 0, -1]).id], [8, 6]);
  world.setInstances({ meshes: [0, 0], transforms: [...at(3), ...at(2)], ids: [5, 6] });
  assert.deepEqual([world.raycast([0.2, 0.2, 10], [0, 0, -1]).distance, world.raycast([0.2, 0.2, 10], [0, 0, -1]).id], [7, 5]);
  assert.equal(world.setInstances({ meshes: [0, 0], transforms: [...at(3).map((x, i) => (i === 11 ? 3 : 0)), ...at(2)] }), 1);
  assert.equal(world.raycast([0.2, 0.2, 10], [0, 0, -1]).id, 1, 'ids default to the index');
  // A direction of length 2: distances in its lengths.
  assert.equal(world.raycast([0.2, 0.2, 10], [0, 0, -2]).distance, 4);
  world.dispose();
  scene.dispose();
});

test('moving the same instances (a refit) answers as a top level placed afresh, frame after frame', async () => {
  const r = rng(42);
  const scene = await Scene.build(soup(120, 1, 0.5));
  // 15 × 15 instances a grid apart (the soup fits in a unit cube), turned and moved each frame.
  const field = (frame) => {
    const out = [];
    for (let k = 0; k < 225; k++) {
      const a = 0.3 * frame + 0.01 * k, c = Math.cos(a), s = Math.sin(a);
      out.push(c, -s, 0, 2.5 * (k % 15) + 0.1 * frame, s, c, 0, 2.5 * Math.floor(k / 15), 0, 0, 1, 0.05 * frame * (k % 7));
    }
    return out;
  };
  const rs = new Float32Array(8 * 3000);
  for (let i = 0; i < 3000; i++) rs.set([38 * r() - 1, 38 * r() - 1, 5, 0.05, -0.03, -1, 0, Infinity], 8 * i);
  const meshes = new Array(225).fill(0);
  const world = new InstancedScene([scene]);
  world.setInstances({ meshes, transforms: field(0) });
  let hits;
  for (let frame = 1; frame <= 3; frame++) {
    world.setInstances({ meshes, transforms: field(frame) });
    const fresh = new InstancedScene([scene]);
    fresh.setInstances({ meshes, transforms: field(frame) });
    const [a, b] = [world.raycastMany(rs), fresh.raycastMany(rs)];
    assert.deepEqual(new Uint32Array(a.buffer), new Uint32Array(b.buffer), `frame ${frame}: the same bits`);
    hits = a.filter((_, i) => i % 5 === 0 && Number.isFinite(a[i])).length;
    fresh.dispose();
  }
  assert.ok(hits > 300, `${hits} hits`);
  // A refused frame leaves the last one placed.
  const before = world.raycastMany(rs);
  const bad = field(4);
  bad[12 * 9 + 5] = NaN;
  assert.throws(() => world.setInstances({ meshes, transforms: bad }), /transforms\[113\] is NaN \(instance 9\)/);
  bad[12 * 9 + 5] = field(4)[12 * 9 + 5];
  bad[12 * 9 + 3] = 3.4028234e38; // finite, but the mesh's box moved there is not: refused by the refit
  assert.throws(() => world.setInstances({ meshes, transforms: bad }), /instance 9: transform carries the mesh beyond f32/);
  assert.deepEqual(world.raycastMany(rs), before);
  world.dispose();
  scene.dispose();
});

test('bad input is refused with the argument named; a disposed mesh stays placed until the top level goes', async () => {
  const scene = await Scene.build(new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0]));
  assert.throws(() => new InstancedScene(scene), /an Array of Scene/);
  assert.throws(() => new InstancedScene([scene, {}]), /meshes\[1\] is not a kdray Scene/);
  assert.throws(() => new InstancedScene([scene], { leaves: 'list' }), /options are \{ watertight \}/);
  const world = new InstancedScene([scene]);
  const id = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0];
  assert.throws(() => world.setInstances({ meshes: [0], transforms: id.map((x, i) => (i === 3 ? NaN : x)) }), /transforms\[3\] is NaN \(instance 0\)/);
  assert.throws(() => world.setInstances({ meshes: [0, 0], transforms: [...id, ...id.map((x, i) => (i === 7 ? Infinity : x))] }), /transforms\[19\] is Infinity \(instance 1\)/);
  assert.throws(() => world.setInstances({ meshes: [1], transforms: id }), /meshes\[0\] is 1/);
  assert.throws(() => world.setInstances({ meshes: [0], transforms: id.slice(1) }), /12 numbers an instance/);
  assert.throws(() => world.setInstances({ meshes: [0], transforms: id, ids: [-1] }), /ids\[0\] is -1/);
  assert.throws(() => world.setInstances({}), /needs meshes/);
  assert.throws(() => world.raycast([0, 0, 1], [0, 0, -1], NaN), /near is NaN/);
  assert.throws(() => world.raycastMany(new Float32Array(7)), /8 floats a ray/);
  world.setInstances({ meshes: [0], transforms: id });
  scene.dispose();
  assert.equal(world.raycast([0.2, 0.2, 1], [0, 0, -1]).distance, 1, 'the top level still holds the mesh');
  assert.throws(() => new InstancedScene([scene]), /meshes\[0\] was disposed/);
  world.dispose();
  assert.throws(() => world.raycast([0.2, 0.2, 1], [0, 0, -1]), /was disposed/);
});

test('the README\'s examples for scenes of many meshes run as written and print what it says', () => {
  const pkg = join(dirname(fileURLToPath(import.meta.url)), '..');
  const readme = readFileSync(join(pkg, 'README.md'), 'utf8');
  const section = readme.slice(readme.indexOf('## Scenes of many meshes'), readme.indexOf('## Building on a worker'));
  const [core, three] = [...section.matchAll(/```js\n([\s\S]*?)```/g)].map((m) => m[1]);
  const printed = section.match(/prints\n```\n([\s\S]*?)```/)[1];
  // Inside the package, so that `kdray` resolves to itself and `three` to its dev dependency.
  const dir = mkdtempSync(join(pkg, '.readme-instances-'));
  try {
    const run = (code) => {
      writeFileSync(join(dir, 'example.mjs'), code);
      const r = spawnSync(process.execPath, [join(dir, 'example.mjs')], { encoding: 'utf8' });
      assert.equal(r.status, 0, r.stderr);
      return r.stdout;
    };
    assert.equal(run(core), printed);
    // The ball (radius 1, 32 × 16 segments) is hit first, about 4 from the origin at z = 5.
    const [type, instanceId, batchId, distance] = run(three).trim().split(' ');
    assert.deepEqual([type, instanceId, batchId], ['Mesh', 'undefined', 'undefined']);
    assert.ok(Math.abs(+distance - 4) < 0.01, distance);
  } finally {
    rmSync(dir, { recursive: true, force: true });
  }
});
