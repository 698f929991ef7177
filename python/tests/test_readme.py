"""The main README's Python example runs as written (scripts/doc-commands.sh runs only its shell
blocks) and prints what it says."""

import contextlib
import io
import os
import re

import pytest

README = os.path.join(os.path.dirname(__file__), "..", "..", "README.md")


def python_blocks():
    text = open(README, encoding="utf-8").read()
    section = text.split("## Python: the package `kdray`", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", section, re.S)


def test_the_readme_example_runs(tmp_path, monkeypatch):
    blocks = python_blocks()
    assert len(blocks) == 1
    lines = [l for l in blocks[0].splitlines() if l.strip()]
    assert len(lines) <= 12, "the README promises a short example"
    monkeypatch.chdir(tmp_path)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(blocks[0], "README.md", "exec"), {})
    printed = out.getvalue().splitlines()
    assert len(printed) == 3
    assert float(printed[1]) == pytest.approx(1 / 27, abs=0.002)
    assert printed[2] == "12"
    assert (tmp_path / "cube.kdt").exists()
