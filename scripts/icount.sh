#!/usr/bin/env bash
# Instructions per ray, counted by callgrind, for a fixed scene and fixed ray sets, against the
# committed baseline benches/icount/baseline.tsv. Counts do not depend on the machine's load, so
# this catches a slower walk or kernel that the timed comparisons, on a shared and noisy machine,
# let through (as the packet walks' 14-32 % loss on primary rays once went unnoticed).
#
# The scene is the bunny embedded in the host (host/scenes/meshes/bunny.ply.gz, 3,674 triangles),
# built three ways: index lists in nodes, groups in nodes, and groups with wide nodes (what
# `kdray trace` builds by default). The rays are `kdray rays` of that scene: primary rays of a
# 128x128 framing camera and one diffuse bounce from each primary hit. The `instances` rows trace
# host/scenes/instances.toml (101 bunnies under a top level: the two-level walk, single rays and
# 8-wide packets) with the primary rays of its own 128x128 framing camera. Each row traces one ray set
# through one tree one way (`--packet 1/4/8/16`, `--stream`), fast and watertight, on one thread,
# with callgrind counting only the functions that trace a share of the rays (`trace_scalar_in`,
# `trace_packets_in`, the core's `stream::intersect`; for instances `instances::trace_rays` and
# the trace command's `packets`): not the load, the build, the threads or
# the writing of the hits, and no call into the C library, whose routines differ by CPU.
#
# kdray is built with -C target-cpu=x86-64-v3 (AVX2 + FMA; valgrind cannot decode AVX-512), with
# the locked dependencies and this repository's toolchain, into $CARGO_TARGET_DIR/x86-64-v3 (the
# build scripts/compare.sh uses). The same sources then give the same counts on every machine.
#
# Usage: scripts/icount.sh [--update] [--tolerance PCT]
#   (no flag)   measure and compare: exit 1 if any row rose by more than PCT % (default 3) or a
#               row is missing from the baseline; falls are reported (update the baseline then)
#   --update    measure and write the baseline (commit it with the change that moves it)
# Needs valgrind (installed with apt-get when missing and the user may).
set -euo pipefail
cd "$(dirname "$0")/.."

update=0
tolerance=3
while [ $# -gt 0 ]; do
  case "$1" in
    --update) update=1; shift ;;
    --tolerance)
      [ $# -ge 2 ] || { echo "icount.sh: --tolerance needs a value" >&2; exit 2; }
      tolerance=$2; shift 2 ;;
    -h|--help) sed -n 's/^# Usage: /Usage: /p;/^#   /p' "$0"; exit 0 ;;
    *) echo "icount.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done

if ! command -v valgrind >/dev/null; then
  sudo=()
  [[ $(id -u) -eq 0 ]] || sudo=(sudo)
  "${sudo[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends valgrind >/dev/null
fi

baseline=benches/icount/baseline.tsv
cpu=x86-64-v3
target=${CARGO_TARGET_DIR:-target}/$cpu
RUSTFLAGS="${RUSTFLAGS:-} -C target-cpu=$cpu" CARGO_TARGET_DIR=$target \
  cargo build --release --locked -q -p kdray
kdray=$target/release/kdray

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mesh=host/scenes/meshes/bunny.ply.gz
"$kdray" build "$mesh" --quality high --leaves list --layout nodes -o "$work/list.kdt" >/dev/null
"$kdray" build "$mesh" --quality high --leaves groups --layout nodes -o "$work/groups.kdt" >/dev/null
"$kdray" build "$mesh" --quality high --leaves groups --layout wide -o "$work/wide.kdt" >/dev/null
"$kdray" rays "$work/list.kdt" --size 128x128 -o "$work/primary.bin" >/dev/null
"$kdray" rays "$work/list.kdt" --size 128x128 --kind diffuse -o "$work/diffuse.bin" >/dev/null
instances=host/scenes/instances.toml
"$kdray" rays "$instances" --size 128x128 -o "$work/instances-primary.bin" >/dev/null

# count TREE RAYS WAY MODE: instructions per ray of `kdray trace` in the tracing functions.
count() {
  local tree=$1 set=$2 way=$3 mode=$4 flags=()
  case $way in
    stream) flags=(--stream) ;;
    packet*) flags=(--packet "${way#packet}") ;;
  esac
  [ "$mode" = watertight ] && flags+=(--watertight)
  local out=$work/cg.out input=$work/$tree.kdt rays=$work/$set.bin
  [ "$tree" = instances ] && input=$instances rays=$work/instances-$set.bin
  valgrind --tool=callgrind --callgrind-out-file="$out" --collect-atstart=no \
    --toggle-collect='kdray::rays::trace_scalar_in' --toggle-collect='kdray::rays::trace_packets_in*' \
    --toggle-collect='kdray_core::traverse::stream::intersect' \
    --toggle-collect='kdray::instances::trace_rays' \
    --toggle-collect='kdray::commands::trace_instanced::packets*' \
    "$kdray" trace "$input" --rays "$rays" --out "$work/hits.bin" \
    --threads 1 "${flags[@]}" >/dev/null 2>"$work/vg.log" ||
    { cat "$work/vg.log" >&2; echo "icount.sh: valgrind failed on $tree $set $way $mode" >&2; exit 1; }
  local total n
  total=$(sed -n 's/^summary: *//p' "$out")
  n=$(($(stat -c %s "$rays") / 32))
  [ -n "$total" ] && [ "$total" -gt 0 ] ||
    { echo "icount.sh: callgrind counted nothing ($tree $set $way $mode)" >&2; exit 1; }
  awk -v t="$total" -v n="$n" 'BEGIN { printf "%.1f", t / n }'
}

rows=(
  "list primary packet1" "list primary packet4" "list primary packet8" "list primary packet16"
  "list diffuse packet1" "list diffuse packet4" "list diffuse packet8"
  "groups primary packet8" "groups diffuse packet8"
  "wide primary packet1" "wide primary stream" "wide diffuse packet1" "wide diffuse stream"
  "instances primary packet1" "instances primary packet8"
)
measured=$work/measured.tsv
printf 'tree\trays\tway\tmode\tinstructions_per_ray\n' >"$measured"
for row in "${rows[@]}"; do
  read -r tree set way <<<"$row"
  for mode in fast watertight; do
    printf '%s\t%s\t%s\t%s\t%s\n' "$tree" "$set" "$way" "$mode" "$(count "$tree" "$set" "$way" "$mode")" >>"$measured"
  done
done

if [ $update = 1 ]; then
  mkdir -p "$(dirname "$baseline")"
  cp "$measured" "$baseline"
  column -t "$baseline"
  echo "icount.sh: wrote $baseline"
  exit 0
fi
[ -f "$baseline" ] || { echo "icount.sh: no $baseline: run with --update" >&2; exit 1; }
# Join on the first four columns; print each row with its change, and fail past the tolerance.
awk -F'\t' -v tol="$tolerance" '
  NR == FNR { if (FNR > 1) base[$1 FS $2 FS $3 FS $4] = $5; next }
  FNR == 1 { printf "%-9s %-8s %-8s %-11s %10s %10s %8s\n", "tree", "rays", "way", "mode", "baseline", "now", "change"; next }
  {
    key = $1 FS $2 FS $3 FS $4
    if (!(key in base)) { printf "%-9s %-8s %-8s %-11s %10s %10.1f  not in the baseline\n", $1, $2, $3, $4, "-", $5; bad++; next }
    change = 100 * ($5 / base[key] - 1)
    flag = change > tol ? "  ROSE" : (change < -tol ? "  fell: update the baseline" : "")
    if (change > tol) bad++
    printf "%-9s %-8s %-8s %-11s %10.1f %10.1f %+7.2f%%%s\n", $1, $2, $3, $4, base[key], $5, change, flag
  }
  END {
    if (bad) { printf "icount.sh: %d row(s) rose by more than %s %% or are new (instructions per ray)\n", bad, tol; exit 1 }
    print "icount.sh: every row within " tol " % of the baseline or below it"
  }' "$baseline" "$measured"
