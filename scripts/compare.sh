#!/usr/bin/env bash
# Runs the whole side-by-side comparison of DESIGN.md's benchmark protocol and prints one table
# per mesh: kdray scalar / 4-wide / 8-wide, the bvh crate, and Embree 3 (rtcIntersect1/8/1M) on the
# same rays, one thread, median of --repeat runs.
#
# Builds with AVX2/FMA (-C target-cpu=native) into target/native so the baseline build in
# target/ stays untouched. Usage: scripts/compare.sh [MESH...] [--repeat N]
set -euo pipefail
cd "$(dirname "$0")/.."
meshes=() ; args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --repeat|--size) args+=("$1" "$2"); shift 2 ;;
    *) meshes+=("$1"); shift ;;
  esac
done
[ ${#meshes[@]} -gt 0 ] || meshes=(data/dragon.ply data/bunny.ply)
for m in "${meshes[@]}"; do
  [ -f "$m" ] || { echo "missing $m: run scripts/fetch-meshes.sh" >&2; exit 1; }
done
features=()
if pkg-config --exists embree3 2>/dev/null || [ -f /usr/include/embree3/rtcore.h ]; then
  features=(--features embree)
else
  echo "Embree 3 not installed (scripts/bench-setup.sh installs it): comparing without it" >&2
fi
RUSTFLAGS="${RUSTFLAGS:-} -C target-cpu=native" CARGO_TARGET_DIR=target/native \
  cargo build --release -q -p kdray-benches "${features[@]}" --bin compare
grep -m1 '^model name' /proc/cpuinfo || true
for m in "${meshes[@]}"; do
  target/native/release/compare "$m" "${args[@]}"
  echo
done
