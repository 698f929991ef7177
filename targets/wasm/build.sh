#!/usr/bin/env bash
# Builds the WASM module twice — scalar, and with simd128 (the 4-wide packets on WASM SIMD) — into
# targets/wasm/out/kdray_wasm_{scalar,simd128}.wasm.
#   build.sh                  the size profile: opt-level "z", LTO (the bytes table)
#   build.sh --profile speed  opt-level 3, LTO, into out/speed/ (for throughput)
# Extra cargo arguments (e.g. --no-default-features --features "triangles pinhole") are passed on.
# CARGO_TARGET_DIR is respected (default: target/ here); KDRAY_WASM_OUT overrides the output folder.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
cd "$here"
profile=release
out="$here/out"
if [[ "${1:-}" == "--profile" ]]; then
  profile="$2"
  out="$here/out/$2"
  shift 2
fi
rustup target add wasm32-unknown-unknown >/dev/null 2>&1 || true
out="${KDRAY_WASM_OUT:-$out}"
mkdir -p "$out"
base="${CARGO_TARGET_DIR:-$here/target}"
# cargo's progress bar on a terminal (a first build takes minutes), quiet in logs.
quiet=(--quiet)
[[ -t 2 ]] && quiet=()
for variant in scalar simd128; do
  flags=""
  [[ $variant == simd128 ]] && flags="-C target-feature=+simd128"
  dir="$base/wasm-$variant"
  RUSTFLAGS="$flags" CARGO_TARGET_DIR="$dir" \
    cargo build "${quiet[@]}" --profile "$profile" --target wasm32-unknown-unknown "$@"
  cp "$dir/wasm32-unknown-unknown/$profile/kdray_wasm.wasm" "$out/kdray_wasm_$variant.wasm"
done
ls -l "$out"/kdray_wasm_*.wasm | awk '{print $NF, $5, "bytes"}'
