#!/usr/bin/env bash
# Format and clippy checks of the target crates (each is its own workspace, so the workspace's
# `cargo fmt --all` and `cargo clippy --workspace` do not see them): every feature variant that
# scripts/target-bytes.sh measures, firmware for thumbv7em-none-eabihf, the module for
# wasm32-unknown-unknown with and without simd128. CARGO_TARGET_DIR and KDRAY (a host kdray
# binary, else a debug build) are respected.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
base="${CARGO_TARGET_DIR:-$root/target}"
rustup target add thumbv7em-none-eabihf wasm32-unknown-unknown >/dev/null 2>&1 || true
cd "$root"
if [[ -n "${KDRAY:-}" ]]; then
  kdray="$KDRAY"
else
  cargo build --quiet -p kdray
  kdray="$base/debug/kdray"
fi
# The firmware embeds a scene at compile time: give it one.
export KDRAY_FW_SCENE="$base/targets/lint-scene"
mkdir -p "$KDRAY_FW_SCENE"
"$kdray" build host/scenes/default.toml -o "$KDRAY_FW_SCENE/scene.kdt" \
  --description "$KDRAY_FW_SCENE/scene.kdr" >/dev/null

variants=("mixed any-camera" "triangles pinhole" "spheres pinhole")
(
  cd targets/cortex-m4f
  cargo fmt --check
  for f in "${variants[@]}"; do
    CARGO_TARGET_DIR="$base/targets/cortex-m4f" \
      cargo clippy --quiet --release --no-default-features --features "$f" -- -D warnings
  done
)
(
  cd targets/wasm
  cargo fmt --check
  for flags in "" "-C target-feature=+simd128"; do
    for f in "${variants[@]}"; do
      RUSTFLAGS="$flags" CARGO_TARGET_DIR="$base/targets/wasm-lint${flags:+-simd128}" \
        cargo clippy --quiet --release --target wasm32-unknown-unknown \
        --no-default-features --features "$f" -- -D warnings
    done
  done
)
(
  # The npm package's module (builder + traversal): wasm32, and its unit tests on the host.
  cd targets/wasm/js/module
  cargo fmt --check
  CARGO_TARGET_DIR="$base/js/lint" \
    cargo clippy --quiet --release --target wasm32-unknown-unknown -- -D warnings
  CARGO_TARGET_DIR="$base/js/host" cargo clippy --quiet --all-targets -- -D warnings
)
echo "targets lint: ok"
