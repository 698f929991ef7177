"""The main README's Python example and python/README.md's (a process pool, a Dask cluster, a
scene of many meshes) run as written (scripts/doc-commands.sh runs only the shell blocks) and
print what they say."""

import contextlib
import importlib.util
import io
import os
import re
import subprocess
import sys

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


PACKAGE_README = os.path.join(os.path.dirname(__file__), "..", "README.md")


def package_blocks():
    text = open(PACKAGE_README, encoding="utf-8").read()
    return re.findall(r"```python\n(.*?)```", text, re.S)


def run_script(block, tmp_path):
    """A block as the script it is (its workers are spawned: they import it as __main__)."""
    script = tmp_path / "example.py"
    script.write_text(block)
    done = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.splitlines()


def test_the_package_readme_has_its_examples():
    blocks = package_blocks()
    assert len(blocks) == 3
    assert "ProcessPoolExecutor" in blocks[0] and "LocalCluster" in blocks[1]
    assert "kdray.Instances" in blocks[2]


def test_the_process_pool_example_runs(tmp_path):
    assert run_script(package_blocks()[0], tmp_path) == ["True"]


@pytest.mark.skipif(
    importlib.util.find_spec("distributed") is None, reason="pip install ./python[dask]"
)
def test_the_dask_recipe_runs(tmp_path):
    assert run_script(package_blocks()[1], tmp_path) == ["True True True"]


def test_the_instances_example_runs(tmp_path):
    assert run_script(package_blocks()[2], tmp_path) == ["True True"]
