#!/usr/bin/env bash
# Builds kdray for its constrained targets and checks that each renders what the host renders:
#   cortex-m4f      the firmware under QEMU (targets/cortex-m4f/run.sh)
#   wasm-node       the WASM module under Node (targets/wasm/run.sh)
#   wasm-chromium   the page in headless Chromium (targets/wasm/page.sh test)
#   npm-kdray       the npm package: node --test suite, npm pack + install (targets/wasm/js/test.sh)
# Prints one line per target with its checksum and whether it matches the host, and exits
# non-zero if any target fails or does not match.
#
# Installs what is missing: the rustup targets, and (as root, through apt-get) qemu-system-arm,
# chromium, nodejs and npm; `npm ci` in targets/wasm (package-lock.json is committed).
#
#   scripts/targets.sh [--no-install]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
install=yes
[[ ${1:-} == --no-install ]] && install=no

step() { printf '\n== targets: %s\n' "$*"; }
die() { echo "targets: error: $*" >&2; exit 1; }

step "tools"
missing_rust=()
for t in thumbv7em-none-eabihf wasm32-unknown-unknown; do
  rustup target list --installed | grep -qx "$t" || missing_rust+=("$t")
done
if [[ ${#missing_rust[@]} -gt 0 ]]; then
  [[ $install == yes ]] || die "missing rustup targets: ${missing_rust[*]}"
  rustup target add "${missing_rust[@]}"
fi
missing_apt=()
command -v qemu-system-arm >/dev/null || missing_apt+=(qemu-system-arm)
command -v chromium >/dev/null || missing_apt+=(chromium)
command -v node >/dev/null || missing_apt+=(nodejs)
command -v npm >/dev/null || missing_apt+=(npm)
if [[ ${#missing_apt[@]} -gt 0 ]]; then
  [[ $install == yes ]] || die "missing: ${missing_apt[*]} (Debian packages)"
  sudo=()
  [[ $(id -u) -eq 0 ]] || sudo=(sudo)
  "${sudo[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing_apt[@]}" >/dev/null
fi
# npm ci when node_modules is missing or older than the lock file.
if [[ ! -d targets/wasm/node_modules || targets/wasm/package-lock.json -nt targets/wasm/node_modules ]]; then
  [[ $install == yes ]] || die "run 'npm ci' in targets/wasm"
  (cd targets/wasm && npm ci --no-audit --no-fund --loglevel=error)
fi
echo "qemu: $(qemu-system-arm --version | head -1); chromium: $(chromium --version 2>/dev/null | head -1); node: $(node --version)"

# The debug build: `cargo test` (in .ci/run) has built it already, and the targets' renders are small.
step "host binary"
cargo build -q -p kdray
export KDRAY=${CARGO_TARGET_DIR:-$root/target}/debug/kdray

# run NAME COMMAND...: runs a target's check, keeps its output, and remembers its result line
# (the line starting with NAME) or a failure line.
lines=()
status=0
run() {
  local name=$1 log
  shift
  step "$name: $*"
  log=$(mktemp)
  if "$@" 2>&1 | tee "$log"; then
    :
  else
    status=1
  fi
  local line
  line=$(grep -E "^$name " "$log" | grep -E 'match=' | head -1 || true)
  if [[ -z $line ]]; then
    line="$name match=no (no result line; see the output above)"
    status=1
  fi
  grep -q 'match=yes' <<<"$line" || status=1
  lines+=("$line")
  rm -f "$log"
}

run cortex-m4f bash targets/cortex-m4f/run.sh
run wasm-node bash targets/wasm/run.sh
# The page with the size build run.sh has just made (the same code as the speed build the page
# serves by default; saves two LTO builds).
run wasm-chromium env KDRAY_PAGE_PROFILE=release bash targets/wasm/page.sh test
# The npm package `kdray` (targets/wasm/js): its module, node --test suite and pack-and-install test.
run npm-kdray bash targets/wasm/js/test.sh

# The targets' crates are outside the workspace (.ci/run's fmt and clippy do not see them).
step "targets' crates: fmt and clippy (targets/lint.sh)"
bash targets/lint.sh || { echo "targets/lint.sh failed" >&2; status=1; }

step "summary"
printf '%s\n' "${lines[@]}"
if [[ $status -ne 0 ]]; then
  echo "targets: a target failed or does not match the host" >&2
fi
exit $status
