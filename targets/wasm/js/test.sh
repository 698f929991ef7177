#!/usr/bin/env bash
# The npm package's checks, as scripts/targets.sh runs them: builds both modules (build.sh),
# installs the test dependencies (npm ci: three, three-mesh-bvh, pinned by package-lock.json),
# runs the module's Rust unit tests and the node --test suite (against three.js and
# three-mesh-bvh, scenes of many meshes and whole hierarchies with InstancedMesh and BatchedMesh,
# bad input, crossings, the worker, out of memory on a memory-limited module,
# random call sequences, the README's ES-module examples against the .d.ts (tsc --noEmit,
# strict, with @types/three), and the README's install section — npm pack, install in an empty
# folder, the examples as ES module and CommonJS — on the modules just built), then the example page in headless Chromium (example/browser-test.mjs). Prints
#   npm-kdray tests=N pass=N fail=N page=yes|no|skipped match=yes|no
# and exits 1 on any failure. CARGO_TARGET_DIR is respected.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
cd "$here"
# In CI the modules are built without LTO and with parallel codegen: the tests check behaviour,
# not bytes, and the two single-unit LTO builds took ~11 min of CI's 30 (build.sh alone, without
# CI set, makes the shipped modules with the manifest's profile).
if [[ "${CI:-}" == true ]]; then
  export CARGO_PROFILE_RELEASE_LTO=off CARGO_PROFILE_RELEASE_CODEGEN_UNITS=16
fi
bash build.sh >/dev/null
CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}/js/host" \
  cargo test --quiet --locked --manifest-path module/Cargo.toml 2>&1 | grep -E "test result|FAILED|panicked" >&2
if [[ ! -d node_modules || package-lock.json -nt node_modules ]]; then
  npm ci --no-audit --no-fund --loglevel=error
fi
log=$(mktemp)
trap 'rm -f "$log"' EXIT
status=0
node --test --test-reporter=tap test/ >"$log" 2>&1 || status=1
grep -E "^(not ok|# (tests|pass|fail))" "$log" >&2 || true
[[ $status == 0 ]] || cat "$log" >&2
count() { sed -n "s/^# $1 \([0-9]*\)/\1/p" "$log" | tail -1; }
# The example page in headless Chromium (playwright-core from targets/wasm's npm ci, Debian's
# chromium: scripts/targets.sh installs both).
page=skipped
if [[ -x /usr/bin/chromium && -d ../node_modules/playwright-core ]]; then
  if node example/browser-test.mjs >&2; then page=yes; else page=no; status=1; fi
fi
match=$([[ $status == 0 ]] && echo yes || echo no)
echo "npm-kdray tests=$(count tests) pass=$(count pass) fail=$(count fail) page=$page match=$match"
exit $status
