#!/usr/bin/env bash
# The builder's front (docs/BUILD.md, "The front"): for each mesh and builder setting of
# benches/src/front.rs, the instructions of the build (one thread; build, serialization with the
# wide section, opening) and of the single-ray walk a ray on three ray sets (the framing camera's
# primary rays, one diffuse bounce from their hits, random rays from points in the mesh's box),
# with the tree's bytes a triangle; then the plot docs/front.png and the table docs/front.tsv.
# Instructions, counted by callgrind on an x86-64-v3 build, do not depend on the machine's load;
# wall-clock figures for the chosen settings are `front`'s timed mode (docs/BUILD.md).
#
# Usage: scripts/front.sh [--size W] [--random N] [--only NAME,...] MESH...
#   e.g. scripts/front.sh data/bunny.tri data/dragon-2.tri data/dragon.tri   (needs: big meshes)
set -euo pipefail
cd "$(dirname "$0")/.."

opts=()
meshes=()
while [ $# -gt 0 ]; do
  case "$1" in
    --size|--random|--only)
      [ $# -ge 2 ] || { echo "front.sh: $1 needs a value" >&2; exit 2; }
      opts+=("$1" "$2"); shift 2 ;;
    -h|--help) sed -n 's/^# Usage: /Usage: /p;/^#   /p' "$0"; exit 0 ;;
    -*) echo "front.sh: unknown option '$1'" >&2; exit 2 ;;
    *) meshes+=("$1"); shift ;;
  esac
done
[ ${#meshes[@]} -gt 0 ] || { echo "front.sh: no mesh given" >&2; exit 2; }
command -v valgrind >/dev/null || { echo "front.sh: needs valgrind (apt-get install valgrind)" >&2; exit 1; }

cpu=x86-64-v3
target=${CARGO_TARGET_DIR:-target}/$cpu
RUSTFLAGS="${RUSTFLAGS:-} -C target-cpu=$cpu" CARGO_TARGET_DIR=$target \
  cargo build --release --locked -q -p kdray-benches --bin front
front=$target/release/front
names=$("$front" --list "${opts[@]}")

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
out=docs/front.tsv
printf 'mesh\tsetting\tbytes_per_tri\tbuild_instr_per_tri\tprimary_instr\tdiffuse_instr\trandom_instr\n' >"$work/front.tsv"
for mesh in "${meshes[@]}"; do
  for name in $names; do
    cg=$work/cg.out
    valgrind --tool=callgrind --callgrind-out-file="$cg" --collect-atstart=no \
      --toggle-collect='front::count_*' \
      "$front" "$mesh" --count --only "$name" "${opts[@]}" >"$work/line" 2>"$work/vg.log" ||
      { cat "$work/vg.log" >&2; echo "front.sh: valgrind failed on $mesh $name" >&2; exit 1; }
    callgrind_annotate --inclusive=yes --threshold=100 "$cg" >"$work/ann" 2>/dev/null
    # inclusive instructions of one counting function
    of() { awk -v f="front.rs:front::count_$1 " 'index($0, f) { gsub(",", "", $1); print $1; exit }' "$work/ann"; }
    read -r m s bytes tris np nd nr <"$work/line"
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$m" "$s" "$bytes" \
      "$(python3 -c "print(round($(of build)/$tris))")" \
      "$(python3 -c "print(round($(of primary)/$np))")" \
      "$(python3 -c "print(round($(of diffuse)/$nd))")" \
      "$(python3 -c "print(round($(of random)/$nr))")" | tee -a "$work/front.tsv"
  done
done
cp "$work/front.tsv" "$out"
"$front" --plot "$out" --png docs/front.png
echo "front.sh: wrote $out and docs/front.png"
