#!/usr/bin/env bash
# The WASM throughput table (README, "Throughput on the targets"): rays per second, one thread, on
# the same rays and the same mesh for
#   native 1 / native 4   `kdray trace --packet 1|4` (the default portable build: SSE2 on x86-64,
#                         the same 128-bit width as WASM SIMD)
#   wasm scalar           the module built without simd128, scalar walk, in Node
#   wasm simd128          the module built with simd128, 4-wide packets, in Node
#                         (both `build.sh --profile speed`: opt-level 3, LTO)
#   three-mesh-bvh        MeshBVH.raycastFirst (closest hit, DoubleSide, SAH build) in Node
# Each round runs every engine once in turn (best of --repeat inside a run); the table shows the
# median over rounds, so that a shared, loaded machine disturbs all engines alike. Every engine's
# hits are compared with native 4-wide's (`compare-hits.mjs`).
#
#   targets/wasm/bench/throughput.sh [--rounds N] [--repeat N] [--kind primary|diffuse] [MESH...]
#
# MESH: stems in data/ (default: bunny dragon; scripts/fetch-meshes.sh fetches them). Needs node,
# `npm ci` in targets/wasm, cargo with wasm32-unknown-unknown. KDRAY=path uses that host binary.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
wasm=$(cd "$here/.." && pwd)
root=$(cd "$here/../../.." && pwd)
die() { echo "throughput: error: $*" >&2; exit 1; }

rounds=3 repeat=3 kind=primary meshes=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --rounds) rounds=$2; shift 2 ;;
    --repeat) repeat=$2; shift 2 ;;
    --kind) kind=$2; shift 2 ;;
    -*) die "unknown option $1" ;;
    *) meshes+=("$1"); shift ;;
  esac
done
[[ ${#meshes[@]} -gt 0 ]] || meshes=(bunny dragon)
data=${KDRAY_DATA:-$root/data}
for m in "${meshes[@]}"; do
  [[ -f $data/$m.ply && -f $data/$m.tri ]] || die "missing $data/$m.{ply,tri}: run scripts/fetch-meshes.sh"
done
[[ -d $wasm/node_modules/three-mesh-bvh ]] || die "run 'npm ci' in $wasm first"

if [[ -z ${KDRAY:-} ]]; then
  cargo build --release -q -p kdray --manifest-path "$root/Cargo.toml"
  KDRAY=${CARGO_TARGET_DIR:-$root/target}/release/kdray
fi
bash "$wasm/build.sh" --profile speed >/dev/null
scalar=$wasm/out/speed/kdray_wasm_scalar.wasm simd=$wasm/out/speed/kdray_wasm_simd128.wasm
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

engines=(native-1 native-4 wasm-scalar wasm-simd128 three-mesh-bvh)
# run ENGINE MESH: prints the run's Mrays/s and leaves its hits in $work/MESH-ENGINE.hits
run() {
  local e=$1 m=$2 out
  local kdt=$work/$m.kdt rays=$work/$m.rays hits=$work/$m-$1.hits
  case $e in
    native-1) out=$("$KDRAY" trace "$kdt" --rays "$rays" --out "$hits" --packet 1 --threads 1 --repeat "$repeat") ;;
    native-4) out=$("$KDRAY" trace "$kdt" --rays "$rays" --out "$hits" --packet 4 --threads 1 --repeat "$repeat") ;;
    wasm-scalar) out=$(node "$here/wasm-trace.mjs" "$scalar" "$kdt" "$rays" --packet 1 --repeat "$repeat" --hits "$hits") ;;
    wasm-simd128) out=$(node "$here/wasm-trace.mjs" "$simd" "$kdt" "$rays" --packet 4 --repeat "$repeat" --hits "$hits") ;;
    three-mesh-bvh) out=$(node "$here/three-mesh-bvh.mjs" "$data/$m.tri" "$rays" --repeat "$repeat" --hits "$hits") ;;
  esac
  sed -n 's/.*mrays_s=\([0-9.]*\).*/\1/p' <<<"$out"
}

median() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }

echo "machine: $(grep -m1 '^model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg); node $(node --version); $rounds rounds, best of $repeat per run, one thread, $kind rays"
table="| mesh | triangles | rays | native 1 | native 4 | WASM scalar | WASM simd128 4-wide | three-mesh-bvh | WASM simd128 / three-mesh-bvh |"$'\n'
table+="|---|---:|---:|---:|---:|---:|---:|---:|---:|"$'\n'
for m in "${meshes[@]}"; do
  "$KDRAY" build "$data/$m.ply" -o "$work/$m.kdt" >/dev/null
  "$KDRAY" rays "$work/$m.kdt" -o "$work/$m.rays" --kind "$kind" >/dev/null
  declare -A runs=()
  for ((r = 1; r <= rounds; r++)); do
    for e in "${engines[@]}"; do
      runs[$e]+="$(run "$e" "$m") "
    done
  done
  declare -A med=()
  for e in "${engines[@]}"; do
    med[$e]=$(tr ' ' '\n' <<<"${runs[$e]}" | grep . | median)
    printf '%s %s: Mrays/s per round: %s median %s; hits vs native 4: %s\n' "$m" "$e" "${runs[$e]}" "${med[$e]}" \
      "$(node "$here/compare-hits.mjs" "$work/$m-native-4.hits" "$work/$m-$e.hits" --prims)"
  done
  tris=$(od -An -tu4 -N4 "$data/$m.tri" | tr -d ' ')
  nrays=$(( $(stat -c %s "$work/$m.rays") / 32 ))
  ratio=$(awk -v a="${med[wasm-simd128]}" -v b="${med[three-mesh-bvh]}" 'BEGIN {printf "%.1f×", a / b}')
  table+="| $m | $tris | $nrays | ${med[native-1]} | ${med[native-4]} | ${med[wasm-scalar]} | ${med[wasm-simd128]} | ${med[three-mesh-bvh]} | $ratio |"$'\n'
  unset runs med
done
echo
echo "Mrays/s, median of $rounds rounds:"
printf '%s' "$table"
