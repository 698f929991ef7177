#!/usr/bin/env python3
"""Fails on documentation that points nowhere, so that the repository stands alone.

Every tracked text file (sources, scripts, docs) is searched for
  - a Markdown file it names (`docs/BUILD.md`, `../README.md`), and
  - a path into the repository's folders (`core/src/format/mod.rs`, `host/scenes/dragon.toml`),
and each must exist, relative to the repository's root or to the naming file's folder. Names
built at run time (`$root/README.md`, `{name}.md`), paths git ignores (`data/`, `target/`,
`fuzz/corpus/`) and another project's files cited as such (wide's `tests/simd_float.rs`) are not
checked; a package's paths may be written from its own folder (`scripts/prepack.mjs` in
targets/wasm/js/). A document that is not in the repository
at all (a design note kept elsewhere) fails by name, wherever it is mentioned.

    python3 scripts/doc-refs.py   # exit 1 and one line per dangling reference, FILE:LINE: PATH
"""
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Files that are not documentation or code: meshes, pictures, data.
BINARY = re.compile(r"\.(png|jpg|ply|gz|kdt|kdr|bin|exr|csv|lock|tri|tgz|wasm|ico)$")
# Documents that lived outside the repository; a reader cannot follow a reference to them.
OUTSIDE = re.compile(r"\b(DESIGN\.md|NOTES\.md)|/work/shared")
TOP = "core|host|docs|scripts|benches|tests|fuzz|targets|python|\\.ci"
# A Markdown file, or a path into one of the top folders with an extension; not preceded by a
# character that makes it part of a larger name or of a variable (`$root/...`, `${x}/...`).
REF = re.compile(
    r"(?<![\w$}/.{-])((?:\.\./)*(?:(?:" + TOP + r")/[\w./-]*\.[A-Za-z0-9]+|[\w.-]+(?:/[\w.-]+)*\.md))\b"
)
IGNORED = re.compile(r"(^|/)(data|target|node_modules|dist|pkg|\.venv|\.cargo)/")


def main() -> int:
    files = subprocess.run(
        ["git", "ls-files", "-z"], cwd=ROOT, check=True, capture_output=True
    ).stdout.decode().split("\0")
    me = os.path.relpath(os.path.abspath(__file__), ROOT)
    bad = []
    for path in files:
        if not path or path == me or BINARY.search(path):
            continue
        full = os.path.join(ROOT, path)
        if not os.path.isfile(full):
            continue
        try:
            text = open(full, encoding="utf-8").read()
        except UnicodeDecodeError:
            continue
        here = os.path.dirname(path)
        for n, line in enumerate(text.splitlines(), 1):
            for m in OUTSIDE.finditer(line):
                bad.append(f"{path}:{n}: {m.group(0)} (not in the repository)")
            for m in REF.finditer(line):
                ref = m.group(1).rstrip(".")
                if IGNORED.search(ref) or "*" in ref:
                    continue
                if any(
                    os.path.exists(os.path.normpath(os.path.join(ROOT, base, ref)))
                    for base in ("", here)
                ):
                    continue
                # A package's own folders, named from inside it (`scripts/prepack.mjs` in
                # targets/wasm/js/), and paths written from a folder further down.
                tail = "/" + re.sub(r"^(\.\./)+", "", ref)
                if any(("/" + f).endswith(tail) for f in files):
                    continue
                # Another project's file, cited as `wide's `tests/simd_float.rs``.
                if re.search(r"\w's `$", line[: m.start()]):
                    continue
                # Outputs of scripts, under ignored folders (fuzz/corpus/).
                if subprocess.run(["git", "check-ignore", "-q", ref], cwd=ROOT).returncode == 0:
                    continue
                bad.append(f"{path}:{n}: {ref}")
    for b in bad:
        print(b)
    if bad:
        print(f"doc-refs: {len(bad)} references to files that do not exist", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
