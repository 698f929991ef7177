// The README's install section, as written, in an empty folder: `npm pack` in the package's
// folder, then `npm init -y` and `npm install` of the tarball in a new project (the folder's
// name replaced by a temporary one; no network: the package has no dependencies, three is an
// optional peer). There the README's examples run as written and print what it says: the first
// example as an ES module (example.mjs), the CommonJS one in the CommonJS project `npm init -y`
// makes (example.js, require), and the kdray/core one (init from import.meta.resolve's file:
// URLs) — and init from a plain path and from bytes.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { mkdtempSync, readFileSync, writeFileSync, rmSync, existsSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';

const pkg = join(dirname(fileURLToPath(import.meta.url)), '..');
const root = join(pkg, '../../..');
const readme = readFileSync(join(pkg, 'README.md'), 'utf8');
const version = JSON.parse(readFileSync(join(pkg, 'package.json'), 'utf8')).version;

// The fenced blocks of `lang` in the README's section `heading`, or after the text `after`.
function blocks(lang, { heading, after }) {
  let text = readme;
  if (heading) text = text.split(`\n## ${heading}\n`)[1].split('\n## ')[0];
  if (after) text = text.slice(text.indexOf(after));
  return [...text.matchAll(new RegExp('```' + lang + '\\n([\\s\\S]*?)```', 'g'))].map((m) => m[1]);
}

test('the README\'s install section, as written, in an empty folder; its examples there', { timeout: 180_000 }, () => {
  const dir = mkdtempSync(join(tmpdir(), 'kdray-pack-'));
  const app = join(dir, 'my-app');
  const tarball = join(pkg, `kdray-${version}.tgz`);
  try {
    // As a reader pasting the blocks into one terminal runs them, and scripts/doc-commands.sh
    // too: one shell, from the repository's folder, a `cd` holding for the commands after it.
    const commands = blocks('sh', { heading: 'Install' }).join('').split('\n').filter((l) => l && !l.startsWith('#'));
    assert.equal(commands.length, 3, `the install section's commands: ${commands}`);
    const script = commands.map((c) => c.replaceAll('/tmp/my-app', app)).join('\n');
    const env = { ...process.env, npm_config_offline: 'true', npm_config_audit: 'false', npm_config_fund: 'false', npm_config_loglevel: 'error' };
    execFileSync('bash', ['-euo', 'pipefail', '-c', script], { cwd: root, env, encoding: 'utf8' });
    const files = execFileSync('tar', ['-tzf', tarball], { encoding: 'utf8' }).split('\n').filter(Boolean).map((f) => f.replace(/^package\//, ''));
    for (const f of ['dist/inline.js', 'dist/kdray_scalar.wasm', 'dist/kdray_simd128.wasm', 'src/index.js', 'src/args.js', 'src/three.js', 'types/index.d.ts', 'README.md', 'package.json']) {
      assert.ok(files.includes(f), `the tarball lacks ${f}`);
    }
    assert.ok(!files.some((f) => /^(module|test|bench|scripts)\//.test(f)), `sources, tests or scripts packed: ${files}`);
    assert.ok(existsSync(join(app, 'node_modules/kdray/dist/kdray_simd128.wasm')));
    assert.equal(JSON.parse(readFileSync(join(app, 'package.json'), 'utf8')).type ?? 'commonjs', 'commonjs');
    const node = (file, text) => {
      writeFileSync(join(app, file), text);
      return execFileSync('node', [file], { cwd: app, encoding: 'utf8' });
    };
    // The first example, saved as example.mjs as the README says; it prints what follows it.
    const [first] = blocks('js', {});
    assert.equal(node('example.mjs', first), readme.match(/prints:\n```\n([\s\S]*?)```/)[1]);
    // CommonJS: require('kdray') in example.js — where Node's require loads ES modules (20.19,
    // 22.12); before, the README's alternative, import() in CommonJS.
    const [cjs] = blocks('js', { after: 'In a CommonJS project' });
    const required = "const { Scene } = require('kdray');";
    assert.ok(cjs.startsWith(required), cjs);
    const imported = `import('kdray').then(({ Scene }) => {\n${cjs.slice(required.length)}});\n`;
    assert.equal(node('example.js', process.features.require_module ? cjs : imported), '1\n');
    // kdray/core from import.meta.resolve's URLs, as written; then from a path and from bytes.
    const [core] = blocks('js', { after: 'import `kdray/core`' });
    assert.match(core, /import\.meta\.resolve/);
    assert.equal(node('core.mjs', core), '1\n');
    const wasm = join(app, 'node_modules/kdray/dist/kdray_scalar.wasm');
    const fromPath = core.replace(/await init\([\s\S]*?\);/, `await init(${JSON.stringify(wasm)});`);
    assert.equal(node('core-path.mjs', fromPath), '1\n');
    const fromBytes = `import { readFileSync } from 'node:fs';\n${core.replace(/await init\([\s\S]*?\);/, `await init(readFileSync(${JSON.stringify(wasm)}));`)}`;
    assert.equal(node('core-bytes.mjs', fromBytes), '1\n');
    // The .wasm files are exported for those who load them.
    const resolved = execFileSync('node', ['--input-type=module', '-e', "console.log(import.meta.resolve('kdray/kdray_scalar.wasm'))"], { cwd: app, encoding: 'utf8' });
    assert.match(resolved, /node_modules\/kdray\/dist\/kdray_scalar\.wasm/);
  } finally {
    rmSync(dir, { recursive: true, force: true });
    rmSync(tarball, { force: true });
  }
});

test('npm pack without dist/ and without cargo stops with what to do', () => {
  const dir = mkdtempSync(join(tmpdir(), 'kdray-prepack-'));
  try {
    execFileSync('cp', ['-r', join(pkg, 'package.json'), join(pkg, 'scripts'), dir]);
    // A PATH with node but no cargo.
    const bin = join(dir, 'bin');
    execFileSync('mkdir', [bin]);
    execFileSync('ln', ['-s', process.execPath, join(bin, 'node')]);
    let error;
    try {
      execFileSync(process.execPath, ['scripts/prepack.mjs'], { cwd: dir, env: { PATH: bin }, encoding: 'utf8', stdio: 'pipe' });
    } catch (e) {
      error = e;
    }
    assert.ok(error, 'prepack succeeded without dist/');
    assert.match(error.stderr, /dist\/kdray_scalar\.wasm, dist\/kdray_simd128\.wasm, dist\/inline\.js missing, and cargo is not installed/);
    assert.match(error.stderr, /bash build\.sh/);
  } finally {
    rmSync(dir, { recursive: true, force: true });
  }
});
