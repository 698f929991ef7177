#!/usr/bin/env bash
# Seeds the from_words fuzz corpus with small valid scenes built by the kdray CLI (a debug build:
# the scenes are small, and CI has that build already).
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p fuzz/corpus/from_words
cargo run -q -p kdray -- build host/scenes/default.toml -o fuzz/corpus/from_words/default.kdt --layout nodes
tmp=$(mktemp -d)
python3 - "$tmp/fan.tri" <<'PY'
import struct, sys
tris = []
for i in range(12):
    a = (i * 5 % 12) * 0.5
    tris.append([a, 0, 0, a + 1, 0, 0.3, a, 1, -0.2])
with open(sys.argv[1], "wb") as f:
    f.write(struct.pack("<I", len(tris)))
    for t in tris:
        f.write(struct.pack("<9f", *t))
PY
cargo run -q -p kdray -- build "$tmp/fan.tri" -o fuzz/corpus/from_words/fan.kdt --layout nodes --leaves list
# And with triangle groups (format v9).
cargo run -q -p kdray -- build "$tmp/fan.tri" -o fuzz/corpus/from_words/fan-groups.kdt --layout nodes --leaves groups
# And with wide nodes (format v10; `build`'s default layout), with lists and with groups.
cargo run -q -p kdray -- build host/scenes/default.toml -o fuzz/corpus/from_words/default-wide.kdt --layout wide
cargo run -q -p kdray -- build "$tmp/fan.tri" -o fuzz/corpus/from_words/fan-wide.kdt --leaves list --layout wide
cargo run -q -p kdray -- build "$tmp/fan.tri" -o fuzz/corpus/from_words/fan-wide-groups.kdt --leaves groups --layout wide
rm -rf "$tmp"
