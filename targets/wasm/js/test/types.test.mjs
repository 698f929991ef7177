// The README's examples against the package's .d.ts, as a TypeScript user compiles them: every
// ES-module example of the README (```js blocks with an `import`; the CommonJS one is plain
// JavaScript), and the API section's `Scene.build(positions, geometry.index)` with three.js's
// own types (@types/three), through `tsc --noEmit` in strict mode. The names an example takes
// from the reader's code (`mesh`, `raycaster`, `positions`, `indices`) are declared with their
// three.js or typed-array types. Skipped, saying so, where the dev dependencies are not installed.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import { existsSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const pkg = join(dirname(fileURLToPath(import.meta.url)), '..');
const tsc = join(pkg, 'node_modules/typescript/bin/tsc');
const readme = readFileSync(join(pkg, 'README.md'), 'utf8');

// What the examples take from the reader's code.
const free = {
  mesh: "declare const mesh: import('three').Mesh;",
  raycaster: "declare const raycaster: import('three').Raycaster;",
  positions: 'declare const positions: Float32Array;',
  indices: 'declare const indices: Uint32Array;',
};

function prelude(code) {
  return Object.entries(free)
    .filter(([name]) => new RegExp(`\\b${name}\\b`).test(code) && !new RegExp(`\\b(const|let|var)\\s+${name}\\b`).test(code))
    .map(([, decl]) => decl)
    .join('\n');
}

test('the README\'s ES-module examples and Scene.build(positions, geometry.index) pass tsc --noEmit --strict', { skip: !existsSync(tsc) || !existsSync(join(pkg, 'node_modules/@types/three')) ? 'npm ci first (typescript, @types/three)' : false, timeout: 120_000 }, () => {
  const examples = [...readme.matchAll(/```js\n([\s\S]*?)```/g)].map((m) => m[1]).filter((code) => /^import /m.test(code));
  assert.ok(examples.length >= 4, `the README's ES-module examples: ${examples.length}`);
  examples.push(`import * as THREE from 'three';
import { Scene } from 'kdray';
const geometry = new THREE.TorusKnotGeometry();
const scene = await Scene.build(geometry.attributes.position.array as Float32Array, geometry.index);
const noIndex = await Scene.build(new Float32Array(9), new THREE.BoxGeometry().toNonIndexed().index, { quality: 'high' });
scene.dispose(); noIndex.dispose();
`);
  // Inside the package, so that `kdray` resolves to itself (its exports' types) and `three` to
  // its dev dependency.
  const dir = mkdtempSync(join(pkg, '.tsc-readme-'));
  try {
    const files = examples.map((code, i) => {
      const file = `example${i}.mts`;
      writeFileSync(join(dir, file), `${prelude(code)}\n${code}\nexport {};\n`);
      return file;
    });
    writeFileSync(join(dir, 'tsconfig.json'), JSON.stringify({
      compilerOptions: {
        strict: true, noEmit: true, target: 'es2022', module: 'esnext', moduleResolution: 'bundler',
        lib: ['es2022', 'dom'], types: [], skipLibCheck: true,
      },
      files,
    }));
    const r = spawnSync(process.execPath, [tsc, '-p', dir], { encoding: 'utf8' });
    const bad = new Set([...r.stdout.matchAll(/example(\d+)\.mts/g)].map((m) => Number(m[1])));
    const shown = [...bad].map((i) => `example${i}.mts:\n${examples[i]}`).join('\n');
    assert.equal(r.status, 0, `tsc --noEmit rejects the README's examples:\n${r.stdout}${r.stderr}\n${shown}`);
  } finally {
    rmSync(dir, { recursive: true, force: true });
  }
});
