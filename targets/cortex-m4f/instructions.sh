#!/usr/bin/env bash
# Instructions per ray of the firmware's render, under QEMU. QEMU's wall-clock speed says nothing
# about a Cortex-M4F's (it translates the code for the host CPU, and models no cycle timing nor a
# DWT cycle counter), so this counts instructions instead: `-icount shift=0` advances QEMU's
# virtual clock by exactly 1 ns per executed instruction, and the firmware built with the `ticks`
# feature reads SysTick (core clock, 25 MHz on mps2-an386: 40 ns, so 40 instructions a tick)
# around each row's render. The rays the render traces (camera, bounce and shadow) are counted by
# the WASM module's kd_accumulate, which follows the same paths bit for bit.
#
#   targets/cortex-m4f/instructions.sh [SCENE.toml]     (default: host/scenes/default.toml)
#
# KDRAY_FW_SIZE (default 32x32) and KDRAY_FW_SPP (default 2) as for run.sh, KDRAY_FW_FEATURES the
# variant (default: mixed any-camera). Prints one line:
#   cortex-m4f-instructions scene= size= spp= ticks= instructions= rays= instructions_per_ray=
#   qemu_wall_s= qemu_rays_per_s=
# (the last two are QEMU's own speed on this machine, for scale only).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
scene="$(realpath "${1:-$root/host/scenes/default.toml}")"
export KDRAY_FW_SIZE="${KDRAY_FW_SIZE:-32x32}"
export KDRAY_FW_SPP="${KDRAY_FW_SPP:-2}"
features="${KDRAY_FW_FEATURES:-mixed any-camera}"
die() { echo "instructions.sh: error: $*" >&2; exit 1; }
command -v qemu-system-arm >/dev/null || die "qemu-system-arm is not installed (run.sh installs it)"
command -v node >/dev/null || die "node is not installed"

base="${CARGO_TARGET_DIR:-$root/target}"
cd "$root"
cargo build --quiet -p kdray
kdray="$base/debug/kdray"
export KDRAY_FW_SCENE="$base/targets/cortex-m4f-ticks-scene"
mkdir -p "$KDRAY_FW_SCENE"
"$kdray" build "$scene" -o "$KDRAY_FW_SCENE/scene.kdt" --description "$KDRAY_FW_SCENE/scene.kdr" >/dev/null

cd "$here"
fw_target="$base/targets/cortex-m4f-ticks"
CARGO_TARGET_DIR="$fw_target" cargo build --quiet --release --no-default-features --features "$features ticks"
elf="$fw_target/thumbv7em-none-eabihf/release/kdray-cortex-m4f"
start=$(date +%s.%N)
out=$(timeout 900 qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic -icount shift=0 \
  -semihosting-config enable=on,target=native -kernel "$elf") || die "the firmware failed: $out"
wall=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { print b - a }')
ticks=$(sed -n 's/^ticks=\([0-9]*\).*/\1/p' <<<"$out")
[[ -n $ticks ]] || die "the firmware printed no ticks= line: $out"

bash "$root/targets/wasm/build.sh" >/dev/null
rays_line=$(node "$root/targets/wasm/bench/count-rays.mjs" "$root/targets/wasm/out/kdray_wasm_scalar.wasm" \
  "$KDRAY_FW_SCENE/scene.kdt" "$KDRAY_FW_SCENE/scene.kdr" "$KDRAY_FW_SIZE" "$KDRAY_FW_SPP")
rays=$(sed -n 's/^rays=\([0-9]*\).*/\1/p' <<<"$rays_line")
[[ -n $rays && $rays -gt 0 ]] || die "no ray count: $rays_line"

instructions=$((ticks * 40))
awk -v s="$(basename "$scene" .toml)" -v size="$KDRAY_FW_SIZE" -v spp="$KDRAY_FW_SPP" -v t="$ticks" \
  -v i="$instructions" -v r="$rays" -v w="$wall" 'BEGIN {
    printf "cortex-m4f-instructions scene=%s size=%s spp=%s ticks=%d instructions=%d rays=%d instructions_per_ray=%.0f qemu_wall_s=%.2f qemu_rays_per_s=%.0f\n",
      s, size, spp, t, i, r, i / r, w, r / w }'
