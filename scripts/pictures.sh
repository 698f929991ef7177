#!/usr/bin/env bash
# Renders the pictures of the documentation that come from a scene — docs/default.png (the
# built-in default scene, README) and the example scenes' pictures (docs/SCENE.md, "Example
# scenes") — at the settings of their scene files, so that they show what the renderer makes today.
# A render depends only on the scene, the settings and the seed (not on the thread count, the
# machine or its instruction set: the kernels use no FMA), so the same code gives the same bytes.
#
#   scripts/pictures.sh           # writes them into docs/ (after a change that moves pixels)
#   scripts/pictures.sh --check   # renders them into a scratch folder and compares byte for byte
#                                 # with docs/; exit 1 naming each picture that differs (CI)
#
# Uses $KDRAY when set, else target/release/kdray (built first if cargo has anything to do).
# The plots (converge-*.png, accuracy.png) are measurements of time and are not re-rendered.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
check=no
case ${1:-} in
  "") ;;
  --check) check=yes ;;
  -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  *) echo "pictures: unknown argument '$1' (see --help)" >&2; exit 2 ;;
esac

if [[ -n ${KDRAY:-} ]]; then
  kdray=$KDRAY
else
  cargo build --release --quiet -p kdray
  kdray=${CARGO_TARGET_DIR:-$root/target}/release/kdray
fi

# picture (in docs/) | scene file (empty: the built-in default scene)
pictures=(
  "default.png|"
  "bunny.png|host/scenes/bunny.toml"
  "fisheye.png|host/scenes/fisheye.toml"
  "fisheye-pinhole.png|host/scenes/fisheye-pinhole.toml"
  "parallel.png|host/scenes/parallel.toml"
  "parallel-pinhole.png|host/scenes/parallel-pinhole.toml"
  "thick_lens.png|host/scenes/thick_lens.toml"
  "lens_array.png|host/scenes/lens_array.toml"
  "instances.png|host/scenes/instances.toml"
)

out_dir=docs
if [[ $check == yes ]]; then
  out_dir=$(mktemp -d)
  trap 'rm -rf "$out_dir"' EXIT
fi
stale=()
for p in "${pictures[@]}"; do
  IFS='|' read -r name scene <<<"$p"
  args=(render)
  [[ -n $scene ]] && args+=("$scene")
  "$kdray" "${args[@]}" -o "$out_dir/$name" >/dev/null
  if [[ $check == yes ]] && ! cmp -s "$out_dir/$name" "docs/$name"; then
    stale+=("docs/$name")
  fi
  echo "pictures: $name${scene:+ ($scene)}"
done
if [[ ${#stale[@]} -gt 0 ]]; then
  echo "pictures: stale (differs from today's render): ${stale[*]}; run scripts/pictures.sh and commit them" >&2
  exit 1
fi
[[ $check == yes ]] && echo "pictures: every picture is today's render, byte for byte"
exit 0
