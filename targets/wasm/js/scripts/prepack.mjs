// npm pack's (and npm publish's) first step: the tarball needs dist/ — the two modules and
// inline.js, which build.sh makes from module/ (Rust) and which git does not hold. When they are
// missing this builds them (bash build.sh: cargo and rustup, about 5 minutes) or, without
// cargo, stops with what to do, so that `npm pack` never makes a tarball whose import fails.
import { existsSync } from 'node:fs';
import { execFileSync } from 'node:child_process';
import { fileURLToPath } from 'node:url';
import { join } from 'node:path';

const here = fileURLToPath(new URL('..', import.meta.url));
const needed = ['kdray_scalar.wasm', 'kdray_simd128.wasm', 'inline.js'].map((f) => join('dist', f));
const missing = needed.filter((f) => !existsSync(join(here, f)));
if (missing.length > 0) {
  const haveCargo = (() => { try { execFileSync('cargo', ['--version'], { stdio: 'ignore' }); return true; } catch { return false; } })();
  if (!haveCargo) {
    console.error(`kdray prepack: ${missing.join(', ')} missing, and cargo is not installed to build them.\n`
      + 'Install Rust (https://rustup.rs), then run `bash build.sh` here (about 5 minutes) and `npm pack` again.');
    process.exit(1);
  }
  console.error(`kdray prepack: ${missing.join(', ')} missing: building them (bash build.sh, about 5 minutes)`);
  execFileSync('bash', [join(here, 'build.sh')], { stdio: 'inherit' });
}
