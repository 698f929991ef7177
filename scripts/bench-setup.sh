#!/usr/bin/env bash
# Prepares a machine for kdray's benchmarks:
#   1. installs Embree 3 (Debian/Ubuntu package `libembree-dev`) unless it is already there, for
#      the `embree` feature of kdray-benches;
#   2. fetches and converts the benchmark meshes into data/ (scripts/fetch-meshes.sh).
#
# Usage: scripts/bench-setup.sh [--no-meshes]
# Runs apt-get through sudo when not root. Elsewhere, install Embree 3 by other means and point
# EMBREE_DIR at it (benches/build.rs searches $EMBREE_DIR/lib and checks $EMBREE_DIR/include).
set -euo pipefail

die() {
    echo "bench-setup: error: $*" >&2
    exit 1
}

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
meshes=1
for arg in "$@"; do
    case $arg in
    --no-meshes) meshes=0 ;;
    -h | --help)
        sed -n '2,10p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
        exit 0
        ;;
    *) die "unknown argument '$arg' (try --help)" ;;
    esac
done

embree_installed() {
    if [[ -n ${EMBREE_DIR:-} ]]; then
        [[ -f $EMBREE_DIR/include/embree3/rtcore.h ]] && compgen -G "$EMBREE_DIR/lib/libembree3.so*" >/dev/null
    else
        [[ -f /usr/include/embree3/rtcore.h ]] && ldconfig -p 2>/dev/null | grep -q 'libembree3\.so'
    fi
}

if embree_installed; then
    echo "bench-setup: Embree 3 already installed"
else
    command -v apt-get >/dev/null ||
        die "Embree 3 is missing and there is no apt-get; install Embree 3 and set EMBREE_DIR"
    sudo=()
    if [[ $(id -u) -ne 0 ]]; then
        command -v sudo >/dev/null || die "installing libembree-dev needs root (no sudo found)"
        sudo=(sudo)
    fi
    echo "bench-setup: installing libembree-dev" >&2
    "${sudo[@]}" apt-get update -q || die "apt-get update failed"
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends libembree-dev ||
        die "apt-get install libembree-dev failed"
    embree_installed || die "libembree-dev installed, but embree3/rtcore.h or libembree3.so is still missing"
fi
version=$(sed -n 's/^#define RTC_VERSION_STRING "\(.*\)"/\1/p' "${EMBREE_DIR:-/usr}/include/embree3/rtcore_config.h")
[[ $version == 3.* ]] || die "found Embree '$version', the benches need Embree 3"
echo "bench-setup: Embree $version"

if [[ $meshes -eq 1 ]]; then
    "$root/scripts/fetch-meshes.sh"
fi
echo "bench-setup: done; run e.g. 'cargo test -p kdray-benches --features embree'"
