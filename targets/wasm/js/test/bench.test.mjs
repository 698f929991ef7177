// The benchmark scripts run as their headers say (one round, the bunny): a change to a module
// they import (bench/meshes.mjs once lost the `bunny` that build.mjs called) fails here rather
// than on the next person to measure. Timings are not checked: only that each script finishes
// and prints its table with a row for the bunny.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { fileURLToPath } from 'node:url';

const here = fileURLToPath(new URL('..', import.meta.url));
const run = (script, ...args) =>
  execFileSync(process.execPath, [`bench/${script}`, ...args], { cwd: here, encoding: 'utf8', timeout: 120_000 });

test('bench/build.mjs builds the bunny with both qualities and both peers', () => {
  const out = run('build.mjs', '--rounds', '1', '--meshes', 'bunny');
  assert.match(out, /^\| mesh \| kdray fast ms \|/m);
  assert.match(out, /^\| bunny \(3,674 tris\) \| [\d.]+ \| [\d.]+ \| [\d.]+ \| [\d.]+ \|/m);
});

test('bench/bench.mjs traces the bunny against three-mesh-bvh', () => {
  const out = run('bench.mjs', '--rounds', '1', '--meshes', 'bunny', '--leaves', 'groups');
  assert.match(out, /bunny/);
  assert.match(out, /^\|.*\|$/m);
});

test('bench/instances.mjs casts a small scene of many meshes against three-mesh-bvh', () => {
  const out = run('instances.mjs', '--rounds', '1', '--rays', '20', '--meshes', '50', '--instances', '200');
  // The same first hits on every ray (the scene is kdray's and three-mesh-bvh's alike).
  assert.match(out, /^\| intersectObject\(scene\) \| [\d.]+ \| [\d.]+ \| [\d.]+× \| 20\/20 /m);
  assert.match(out, /^moving 200 instances, then intersectObject\(scene\): [\d.]+ ms/m);
});
