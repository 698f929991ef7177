#!/usr/bin/env bash
# Builds the npm package's two WebAssembly modules (module/: the host library's builder and the
# core's traversal) into dist/, and dist/inline.js, the same bytes as base64 for the default entry.
#   dist/kdray_scalar.wasm    no SIMD: every engine with WebAssembly (Safari before 16.4 too)
#   dist/kdray_simd128.wasm   -C target-feature=+simd128: wide's f32x4 packets on WASM SIMD
# Reproducible: the paths compiled into the modules are remapped (no home or checkout path), no
# time is recorded, and Cargo.lock pins every crate; the same toolchain gives the same bytes
# (`build.sh --check` rebuilds into a temporary folder and compares with dist/). After a shipping
# build (with LTO, not CI's) scripts/sizes.mjs writes the README's size figures.
# CARGO_TARGET_DIR is respected (default: target/ under the repository root, js/ in it).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
out="$here/dist"
check=no
if [[ "${1:-}" == "--check" ]]; then
  check=yes
  out=$(mktemp -d)
  trap 'rm -rf "$out"' EXIT
fi
rustup target add wasm32-unknown-unknown >/dev/null 2>&1 || true
mkdir -p "$out"
base="${CARGO_TARGET_DIR:-$root/target}/js"
cargo_home="${CARGO_HOME:-$HOME/.cargo}"
remap="--remap-path-prefix=$root=/kdray --remap-path-prefix=$cargo_home=/cargo"
for variant in scalar simd128; do
  flags="$remap"
  [[ $variant == simd128 ]] && flags="$flags -C target-feature=+simd128"
  dir="$base/wasm-$variant"
  RUSTFLAGS="$flags" CARGO_TARGET_DIR="$dir" \
    cargo build --quiet --locked --release --target wasm32-unknown-unknown \
    --manifest-path "$here/module/Cargo.toml"
  cp "$dir/wasm32-unknown-unknown/release/kdray_js.wasm" "$out/kdray_$variant.wasm"
done
node "$here/scripts/inline.mjs" "$out"
if [[ $check == yes ]]; then
  for f in kdray_scalar.wasm kdray_simd128.wasm inline.js; do
    cmp "$out/$f" "$here/dist/$f" || { echo "build.sh: dist/$f differs from a fresh build" >&2; exit 1; }
  done
  echo "build.sh: dist/ is what this source builds"
else
  ls -l "$out"/kdray_*.wasm "$out"/inline.js | awk '{print $NF, $5, "bytes"}'
  # The README's size figures, from a shipping build only (CI builds without LTO: larger).
  if [[ "${CARGO_PROFILE_RELEASE_LTO:-}" != off ]]; then
    node "$here/scripts/sizes.mjs"
  fi
fi
