// Writes the package README's size figures — the two modules, dist/inline.js, and the tarball
// packed and unpacked (npm pack --dry-run) — between its `<!-- sizes -->` and `<!-- /sizes -->`
// marks, so that they are measured by the build, not typed. build.sh runs it after a shipping
// build (not after CI's, whose modules are built without LTO and are larger).
import { readFileSync, statSync, writeFileSync } from 'node:fs';
import { execFileSync } from 'node:child_process';
import { fileURLToPath } from 'node:url';
import { join } from 'node:path';

const here = fileURLToPath(new URL('..', import.meta.url));
const mb = (bytes) => `${(bytes / 1e6).toFixed(2)} MB`;
const size = (f) => statSync(join(here, 'dist', f)).size;
const [packed] = JSON.parse(execFileSync('npm', ['pack', '--dry-run', '--json', '--ignore-scripts', '--loglevel=error'], { cwd: here, encoding: 'utf8' }));
const text = `${mb(size('inline.js'))} of base64 in \`dist/inline.js\` (both modules: ${mb(size('kdray_scalar.wasm'))} scalar, `
  + `${mb(size('kdray_simd128.wasm'))} simd128; only one is compiled); the tarball is ${mb(packed.size)} packed, `
  + `${mb(packed.unpackedSize)} unpacked`;
const readme = join(here, 'README.md');
const old = readFileSync(readme, 'utf8');
const marked = /<!-- sizes -->[\s\S]*?<!-- \/sizes -->/;
if (!marked.test(old)) throw new Error('README.md has no <!-- sizes --> … <!-- /sizes --> marks');
writeFileSync(readme, old.replace(marked, `<!-- sizes -->${text}<!-- /sizes -->`));
console.log(`README.md: ${text}`);
