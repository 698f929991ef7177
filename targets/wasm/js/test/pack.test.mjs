// `npm pack` makes a tarball that installs in an empty folder (no network: the package has no
// dependencies; three is an optional peer) and runs the README's first example there.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { mkdtempSync, readFileSync, writeFileSync, rmSync, existsSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';

const pkg = join(dirname(fileURLToPath(import.meta.url)), '..');

test('npm pack, install in an empty folder, run the README example', { timeout: 120_000 }, () => {
  const dir = mkdtempSync(join(tmpdir(), 'kdray-pack-'));
  try {
    const npm = (args, cwd) => execFileSync('npm', [...args, '--no-audit', '--no-fund', '--loglevel=error'], { cwd, encoding: 'utf8' });
    const [packed] = JSON.parse(npm(['pack', '--json', '--pack-destination', dir], pkg));
    const files = packed.files.map((f) => f.path).sort();
    for (const f of ['dist/inline.js', 'dist/kdray_scalar.wasm', 'dist/kdray_simd128.wasm', 'src/index.js', 'src/three.js', 'types/index.d.ts', 'README.md', 'package.json']) {
      assert.ok(files.includes(f), `the tarball lacks ${f}`);
    }
    assert.ok(!files.some((f) => f.startsWith('module/') || f.startsWith('test/')), `sources or tests packed: ${files}`);
    const app = join(dir, 'app');
    execFileSync('mkdir', [app]);
    writeFileSync(join(app, 'package.json'), JSON.stringify({ name: 'app', private: true, type: 'module' }));
    npm(['install', '--offline', join(dir, packed.filename)], app);
    assert.ok(existsSync(join(app, 'node_modules/kdray/dist/kdray_simd128.wasm')));
    // The README's first ```js block, as written.
    const readme = readFileSync(join(pkg, 'README.md'), 'utf8');
    const example = readme.match(/```js\n([\s\S]*?)```/)[1];
    writeFileSync(join(app, 'example.mjs'), example);
    const out = execFileSync('node', ['example.mjs'], { cwd: app, encoding: 'utf8' });
    // The README says what it prints: the lines after "prints:".
    const expected = readme.match(/prints:\n```\n([\s\S]*?)```/)[1];
    assert.equal(out, expected);
    // The .wasm files are exported for those who stream them.
    const resolved = execFileSync('node', ['--input-type=module', '-e', "console.log(import.meta.resolve('kdray/kdray_scalar.wasm'))"], { cwd: app, encoding: 'utf8' });
    assert.match(resolved, /node_modules\/kdray\/dist\/kdray_scalar\.wasm/);
  } finally {
    rmSync(dir, { recursive: true, force: true });
  }
});
