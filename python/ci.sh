#!/usr/bin/env bash
# The Python package's checks (.ci/run calls this): rustfmt and clippy on its crate (its own
# workspace, which the main one's lints do not see), then the wheel built by `pip install
# ./python[dask]` — maturin, fetched by pip as the build backend — into a fresh virtual
# environment with numpy, Dask (the optional group `dask`: the recipe's test runs a two-process
# LocalCluster), pytest, trimesh and rtree (trimesh's own intersector needs it) from PyPI, then
# pytest on python/tests and the docstrings' examples. Among the tests, those of issue 39 run
# child interpreters (python/tests/child.py) that fork after using the pools, limit their
# address space (RLIMIT_AS), send themselves SIGINT during hours of work, and write a mesh's
# arrays from another thread during builds: each bounded, none passing or failing on time.
#
#   bash python/ci.sh
#
# The extension is built in $CARGO_TARGET_DIR (default: target/python at the repository's top,
# git-ignored), kept between runs so that a second run rebuilds only what changed. The virtual
# environment is made afresh each time, in target/python-venv. Needs python3 (≥ 3.9) with venv,
# and Rust.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

python=${PYTHON:-python3}
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$root/target/python}

echo "-- rustfmt, clippy (python/)"
cargo fmt --manifest-path python/Cargo.toml --check
cargo clippy --manifest-path python/Cargo.toml --all-targets -- -D warnings

echo "-- a fresh virtual environment: pip install ./python[dask]"
venv=$root/target/python-venv
rm -rf "$venv"
"$python" -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --upgrade pip
start=$(date +%s)
"$venv/bin/python" -m pip install --quiet "./python[dask]"
echo "   built and installed in $(($(date +%s) - start)) s"
"$venv/bin/python" -m pip install --quiet numpy pytest trimesh rtree

echo "-- pytest (python/tests, and the docstrings' examples)"
# From outside the source tree, so that `import kdray` is the installed wheel, not python/kdray.
cd "$root/target"
# pytest exits 5 when it collects nothing: under `set -e` that fails this script, as it should.
"$venv/bin/python" -m pytest -q -p no:cacheprovider "$root/python/tests"
"$venv/bin/python" -m pytest -q -p no:cacheprovider --doctest-modules --pyargs kdray kdray.trimesh
