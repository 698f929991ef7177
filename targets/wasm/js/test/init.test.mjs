// Loading the module, one rule (README, "Loading the module"): from the default entry the
// synchronous calls compile the module on first use, as kdray/three's computeBoundsTree does;
// from kdray/core, which carries no module, a call before `await init(source)` throws saying so.
// Each case in a fresh process, where nothing has loaded the module yet.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { fileURLToPath } from 'node:url';

const src = fileURLToPath(new URL('../src/', import.meta.url));
const run = (code) => execFileSync(process.execPath, ['--input-type=module', '-e', code], { cwd: src, encoding: 'utf8', stdio: 'pipe' });
const tri = 'new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0])';

test('the default entry: Scene.buildSync and fromBytesSync without init()', () => {
  const out = run(`import { Scene, moduleVariant } from './index.js';
    const s = Scene.buildSync(${tri});
    const again = Scene.fromBytesSync(s.toBytes());
    console.log(moduleVariant(), s.raycast([0.25, 0.25, 1], [0, 0, -1]).distance, again.info.triangles);`);
  assert.equal(out, 'simd128 1 1\n');
  assert.equal(run(`import { Scene } from './index.js'; console.log(Scene.fromBytesSync(Scene.buildSync(${tri}).toBytes()).info.triangles);`), '1\n');
});

test('kdray/core: a synchronous call before init(source) throws saying so', () => {
  assert.throws(() => run(`import { Scene } from './streaming.js'; Scene.buildSync(${tri});`), /await init\(source\)` first \(kdray\/core\)/);
});
