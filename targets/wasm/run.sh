#!/usr/bin/env bash
# Renders the default scene with the WASM module under Node, scalar and simd128 builds, and
# compares each with the host's render of the same scene (`kdray render --checksum`): the
# checksum of the linear pixels and every byte of the 8-bit image; then traces the scene's
# primary and diffuse benchmark rays (kd_trace, packets of 1, 4, 8) against `kdray trace`'s hits;
# and checks that a tree of triangle groups, which the module leaves out, is refused by name.
# Prints one line:
#   wasm-node scalar=yes simd128=yes trace=yes groups-refused=yes checksum=… host=… size=… spp=… match=yes|no
# and exits 1 unless both match. Usage: run.sh [SCENE.toml] (default: host/scenes/default.toml);
# KDRAY_WASM_SIZE (default 32x32) and KDRAY_WASM_SPP (default 4) set the image; KDRAY a host kdray
# binary to use instead of a debug build.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
scene="${1:-$root/host/scenes/default.toml}"
size="${KDRAY_WASM_SIZE:-32x32}"
spp="${KDRAY_WASM_SPP:-4}"
# Progress on stderr (stdout is the one result line): each step as it starts, and cargo's own
# progress bar while building when stderr is a terminal (the first builds take minutes).
say() { echo "wasm/run.sh: $*" >&2; }
quiet=(--quiet)
[[ -t 2 ]] && quiet=()
if ! command -v node >/dev/null; then
  say "node is not on the PATH: installing Debian's nodejs with apt-get (needs root)"
  apt-get update -qq && apt-get install -y -qq nodejs >/dev/null
fi

cd "$root"
# The host binary: $KDRAY when set (e.g. a release build from scripts/targets.sh), else a debug build.
if [[ -n "${KDRAY:-}" ]]; then
  kdray="$KDRAY"
else
  say "building the host kdray (debug; the first time takes minutes)"
  cargo build "${quiet[@]}" -p kdray
  kdray="${CARGO_TARGET_DIR:-$root/target}/debug/kdray"
fi
say "building the WASM modules, scalar and simd128 (the first time takes minutes)"
CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}/targets" "$here/build.sh" >/dev/null
say "rendering $scene at $size, $spp spp on the host and in each module under Node"

out="$here/out"
mkdir -p "$out"
"$kdray" build "$scene" -o "$out/scene.kdt" --description "$out/scene.kdr" >/dev/null
host_line=$("$kdray" render "$scene" --size "$size" --spp "$spp" --checksum -o "$out/host.png")
host_sum=$(sed -n 's/.*checksum=\([0-9a-f]*\).*/\1/p' <<<"$host_line")

status=0
results=""
sum=""
for variant in scalar simd128; do
  line=$(node "$here/compare.mjs" "$out/kdray_wasm_$variant.wasm" "$out/scene.kdt" \
    "$out/scene.kdr" "$out/host.png" "${size%x*}" "${size#*x}" "$spp" "$host_sum") || status=1
  echo "$line" >&2
  results+=" $variant=$(sed -n 's/.*match=\([a-z]*\).*/\1/p' <<<"$line")"
  sum=$(sed -n 's/.*checksum=\([0-9a-f]*\).*/\1/p' <<<"$line")
done
# kd_trace against `kdray trace`: primary and diffuse rays, every packet width, byte for byte.
say "tracing the primary and diffuse rays with kd_trace against kdray trace"
"$kdray" rays "$out/scene.kdt" -o "$out/primary.bin" --size "$size" >/dev/null
"$kdray" rays "$out/scene.kdt" -o "$out/diffuse.bin" --size "$size" --kind diffuse >/dev/null
trace=yes
for kind in primary diffuse; do
  "$kdray" trace "$out/scene.kdt" --rays "$out/$kind.bin" --out "$out/$kind-hits.bin" >/dev/null
  for variant in scalar simd128; do
    node "$here/trace-compare.mjs" "$out/kdray_wasm_$variant.wasm" "$out/scene.kdt" \
      "$out/$kind.bin" "$out/$kind-hits.bin" >&2 || { trace=no; status=1; }
  done
done
# A tree of triangle groups: the module, built without kdray-core's `groups` feature, refuses it
# and says how to rebuild it.
"$kdray" build "$root/host/scenes/meshes/bunny.ply.gz" --leaves groups -o "$out/groups.kdt" >/dev/null
groups=yes
for variant in scalar simd128; do
  node "$here/refusal.mjs" "$out/kdray_wasm_$variant.wasm" "$out/groups.kdt" \
    "triangle groups.*--leaves list" >&2 || { groups=no; status=1; }
done
match=$([[ $status == 0 ]] && echo yes || echo no)
echo "wasm-node$results trace=$trace groups-refused=$groups checksum=$sum host=$host_sum size=$size spp=$spp match=$match"
exit $status
