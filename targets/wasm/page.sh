#!/usr/bin/env bash
# The kdray page (targets/wasm/www/): stage it, serve it, or test it in headless Chromium.
#
#   targets/wasm/page.sh stage DIR          index.html, app.js, engine.js, both .wasm modules (the
#                                           speed build, build.sh --profile speed) and
#                                           scenes/ (every example scene whose meshes are present,
#                                           as .kdt + .kdr, listed in scenes/scenes.json) into DIR
#   targets/wasm/page.sh serve [PORT]       stage into a temporary folder and serve it on
#                                           http://127.0.0.1:PORT/ (default 8000) until Ctrl-C
#   targets/wasm/page.sh test [SCENE [FRAMES [WxH]]]
#                                           stage, render SCENE (default: default) on the host with
#                                           `kdray render --spp FRAMES --size WxH` (default 8, 128x96)
#                                           and check that the page's canvas after FRAMES frames has
#                                           the same pixels; prints `wasm-chromium … match=yes|no`
#                                           and a screenshot path; then gives the page's file
#                                           picker a file that is not a scene (must be refused)
#                                           and the scene's .kdt alone (must render framed);
#                                           exits 1 on a mismatch or a failure
#
# Needs cargo with the wasm32-unknown-unknown target, node, `npm ci` done in targets/wasm (the
# page test uses playwright-core) and Debian's `chromium` (scripts/targets.sh installs all of
# them). KDRAY=path/to/kdray uses that host binary instead of building one; KDRAY_PAGE_PROFILE=release
# stages the size build (build.sh without --profile) instead of the speed build.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)

die() { echo "page.sh: error: $*" >&2; exit 1; }

host_kdray() {
  if [[ -z ${KDRAY:-} ]]; then
    cargo build --release -q -p kdray --manifest-path "$root/Cargo.toml"
    KDRAY=${CARGO_TARGET_DIR:-$root/target}/release/kdray
  fi
  [[ -x $KDRAY ]] || die "no host binary at $KDRAY"
}

stage() {
  local out=$1
  host_kdray
  mkdir -p "$out/scenes"
  cp "$here/www/index.html" "$here/www/app.js" "$here/www/engine.js" "$out/"
  # The speed build (opt-level 3) by default: the page is about watching it render.
  # KDRAY_PAGE_PROFILE=release takes the size build (opt-level "z", what run.sh builds).
  local profile=${KDRAY_PAGE_PROFILE:-speed} mods=$here/out
  if [[ $profile == release ]]; then
    bash "$here/build.sh" >/dev/null
  else
    bash "$here/build.sh" --profile "$profile" >/dev/null
    mods=$here/out/$profile
  fi
  cp "$mods/kdray_wasm_scalar.wasm" "$mods/kdray_wasm_simd128.wasm" "$out/"
  local list=() toml name
  for toml in "$root"/host/scenes/*.toml; do
    name=$(basename "$toml" .toml)
    if ! "$KDRAY" build "$toml" -o "$out/scenes/$name.kdt" --description "$out/scenes/$name.kdr" >"$out/scenes/$name.log" 2>&1; then
      # Scenes whose meshes are not fetched (scripts/fetch-meshes.sh) are left out, not fatal.
      echo "page.sh: leaving out $name: $(tail -1 "$out/scenes/$name.log")" >&2
      continue
    fi
    list+=("{\"name\":\"$name\",\"kdt\":\"$name.kdt\",\"kdr\":\"$name.kdr\"}")
  done
  [[ ${#list[@]} -gt 0 ]] || die "no example scene could be built"
  (IFS=,; echo "[${list[*]}]") >"$out/scenes/scenes.json"
}

cmd=${1:-}
case $cmd in
  stage)
    [[ $# -eq 2 ]] || die "usage: page.sh stage DIR"
    stage "$2"
    echo "staged the page in $2"
    ;;
  serve)
    dir=$(mktemp -d)
    stage "$dir"
    exec node "$here/serve.mjs" "$dir" "${2:-8000}"
    ;;
  test)
    scene=${2:-default} frames=${3:-8} size=${4:-128x96}
    dir=$(mktemp -d)
    trap 'rm -rf "$dir"' EXIT
    stage "$dir/www"
    toml=$root/host/scenes/$scene.toml
    [[ -f $toml ]] || die "no scene $toml"
    "$KDRAY" render "$toml" -o "$dir/host.png" --spp "$frames" --size "$size" >/dev/null
    "$KDRAY" build "$toml" -o "$dir/bare.kdt" >/dev/null
    shot=${KDRAY_SCREENSHOT:-${TMPDIR:-/tmp}/kdray-page.png}
    node "$here/browser-test.mjs" --www "$dir/www" --reference "$dir/host.png" --scene "$scene" \
      --frames "$frames" --size "$size" --bare "$dir/bare.kdt" --screenshot "$shot"
    echo "page.sh: screenshot of the page: $shot"
    ;;
  *)
    die "usage: page.sh stage DIR | serve [PORT] | test [SCENE [FRAMES [WxH]]]"
    ;;
esac
