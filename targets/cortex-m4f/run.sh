#!/usr/bin/env bash
# Builds a scene on the host, embeds it in the Cortex-M4F firmware, runs the firmware under
# `qemu-system-arm -machine mps2-an386`, renders the same scene on the host, and compares the two
# checksums of the linear pixels. Prints one line:
#   cortex-m4f checksum=… host=… size=32x32 spp=2 match=yes|no
# and exits 1 unless they match.
# Usage: run.sh [SCENE.toml] (default: host/scenes/default.toml). KDRAY_FW_SIZE (default 32x32),
# KDRAY_FW_SPP (default 2) set the image; KDRAY_FW_FEATURES (e.g. "triangles pinhole") the
# firmware variant (default: mixed, any camera); KDRAY a host kdray binary to use instead of a
# debug build. Installs the Rust target and QEMU when missing.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
scene="$(realpath "${1:-$root/host/scenes/default.toml}")"
export KDRAY_FW_SIZE="${KDRAY_FW_SIZE:-32x32}"
export KDRAY_FW_SPP="${KDRAY_FW_SPP:-2}"
features="${KDRAY_FW_FEATURES:-}"

rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 || true
if ! command -v qemu-system-arm >/dev/null; then
  apt-get update -qq && apt-get install -y -qq qemu-system-arm >/dev/null
fi

base="${CARGO_TARGET_DIR:-$root/target}"
cd "$root"
# The host binary: $KDRAY when set (e.g. a release build from scripts/targets.sh), else a debug build.
if [[ -n "${KDRAY:-}" ]]; then
  kdray="$KDRAY"
else
  cargo build --quiet -p kdray
  kdray="${CARGO_TARGET_DIR:-$root/target}/debug/kdray"
fi

# The scene is built now, from the scene file: the firmware never embeds a stale binary.
export KDRAY_FW_SCENE="$base/targets/cortex-m4f-scene"
mkdir -p "$KDRAY_FW_SCENE"
"$kdray" build "$scene" -o "$KDRAY_FW_SCENE/scene.kdt" --description "$KDRAY_FW_SCENE/scene.kdr" >/dev/null

cd "$here"
fw_target="$base/targets/cortex-m4f"
args=(--quiet --release)
if [[ -n "$features" ]]; then
  args+=(--no-default-features --features "$features")
fi
CARGO_TARGET_DIR="$fw_target" cargo build "${args[@]}"
elf="$fw_target/thumbv7em-none-eabihf/release/kdray-cortex-m4f"

fw_line=$(timeout 900 qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic \
  -semihosting-config enable=on,target=native -kernel "$elf") || {
  echo "$fw_line" >&2
  echo "cortex-m4f checksum=none host=none match=no (the firmware failed)"
  exit 1
}
echo "firmware: $fw_line" >&2
fw_sum=$(sed -n 's/.*checksum=\([0-9a-f]*\).*/\1/p' <<<"$fw_line")

host_line=$("$kdray" render "$scene" --size "$KDRAY_FW_SIZE" --spp "$KDRAY_FW_SPP" --checksum \
  -o "$KDRAY_FW_SCENE/host.png")
host_sum=$(sed -n 's/.*checksum=\([0-9a-f]*\).*/\1/p' <<<"$host_line")

match=$([[ -n "$fw_sum" && "$fw_sum" == "$host_sum" ]] && echo yes || echo no)
echo "cortex-m4f checksum=$fw_sum host=$host_sum size=$KDRAY_FW_SIZE spp=$KDRAY_FW_SPP match=$match"
[[ $match == yes ]]
