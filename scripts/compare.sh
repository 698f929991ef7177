#!/usr/bin/env bash
# Runs the whole side-by-side comparison of the benchmark protocol (docs/BENCHMARKS.md) and prints, per mesh and
# per camera framing (loose: the bounding sphere in a 45° field of view; tight: the mesh's projected
# bounds fill the image), a table of kdray scalar / 4-wide / 8-wide / stream, the bvh crate, and
# Embree 3 (rtcIntersect1/8/1M) on the same rays, one thread, median of --repeat runs, the share
# of primary rays that hit the mesh, and per kind of ray a summary line: kdray's best row against
# Embree's best row and their ratio.
#
# Builds for AVX2 + FMA (-C target-cpu=x86-64-v3, the protocol's ISA, also on machines with
# AVX-512; KDRAY_CPU=native or another CPU name overrides it) into $CARGO_TARGET_DIR/KDRAY_CPU
# (default target/x86-64-v3), so the baseline build stays untouched. kdray's rows come from three
# trees: index lists in nodes ("kdray"), `kdray build --leaves groups --layout nodes` ("kdray
# groups") and the same grouped tree with its wide section, `--leaves groups --layout wide`
# ("kdray wide", what `kdray trace` builds by default). Meshes default to the dragon and the
# bunny in $KDRAY_DATA (default data/), where scripts/fetch-meshes.sh puts them.
#
# Usage: scripts/compare.sh [MESH...] [--repeat N] [--size WxH]
# Exit codes: 0 done, 1 a missing mesh or a failed build or run, 2 a usage error.
set -euo pipefail
cd "$(dirname "$0")/.."
usage() { sed -n 's/^# Usage: /Usage: /p' "$0"; }
die_usage() { echo "compare.sh: $*" >&2; usage >&2; exit 2; }
meshes=() ; args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --repeat|--size)
      [ $# -ge 2 ] || die_usage "$1 needs a value"
      args+=("$1" "$2"); shift 2 ;;
    -h|--help) usage; exit 0 ;;
    -*) die_usage "unknown option '$1'" ;;
    *) meshes+=("$1"); shift ;;
  esac
done
data=${KDRAY_DATA:-data}
[ ${#meshes[@]} -gt 0 ] || meshes=("$data/dragon.ply" "$data/bunny.ply")
for m in "${meshes[@]}"; do
  [ -f "$m" ] || { echo "missing $m: run scripts/fetch-meshes.sh" >&2; exit 1; }
done
features=()
if pkg-config --exists embree3 2>/dev/null || [ -f /usr/include/embree3/rtcore.h ]; then
  features=(--features embree)
else
  echo "Embree 3 not installed (scripts/bench-setup.sh installs it): comparing without it" >&2
fi
cpu=${KDRAY_CPU:-x86-64-v3}
target=${CARGO_TARGET_DIR:-target}/$cpu
RUSTFLAGS="${RUSTFLAGS:-} -C target-cpu=$cpu" CARGO_TARGET_DIR=$target \
  cargo build --release -q -p kdray-benches "${features[@]}" --bin compare
# The machine, for the figures: the CPU's model, its cores, and (per mesh, below) the instruction
# set kdray was built for next to the CPU's own.
model=$(sed -n 's/^model name[[:space:]]*: *//p' /proc/cpuinfo 2>/dev/null | head -1)
[ -n "$model" ] || model=$(sysctl -n machdep.cpu.brand_string 2>/dev/null || true)
echo "machine: ${model:-unknown CPU}, $(nproc 2>/dev/null || echo '?') cores; kdray built with -C target-cpu=$cpu"

for m in "${meshes[@]}"; do
  "$target/release/compare" "$m" "${args[@]}"
  echo
done
