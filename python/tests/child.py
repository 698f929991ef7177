"""Running a test's code in a Python process of its own: for what may kill or hang a process
(fork, memory limits, signals), so that a failure is reported, not suffered by pytest."""

import os
import subprocess
import sys
import textwrap

HERE = os.path.dirname(os.path.abspath(__file__))

# Stacked layers of large triangles, which every ray along +z from below crosses: as many
# crossings per ray as layers, for work as long or answers as large as a test needs.
LAYERS = """
import numpy as np
def layers(k):
    z = np.arange(k, dtype=np.float32)
    tri = np.array([[-1, -1, 0], [3, -1, 0], [-1, 3, 0]], dtype=np.float32)
    v = np.repeat(tri[None], k, axis=0)
    v[:, :, 2] = z[:, None]
    return v.reshape(-1, 3)
"""


def run(code: str, timeout: float = 120.0) -> str:
    """Runs `code` (dedented, after LAYERS) in a new interpreter; returns its standard output.
    Fails the test, with the child's output, if it exits other than 0, dies of a signal, or is
    still running after `timeout` seconds (then killed: a hang is a failure, not a wait)."""
    src = LAYERS + textwrap.dedent(code)
    try:
        p = subprocess.run(
            [sys.executable, "-c", src],
            capture_output=True,
            text=True,
            timeout=timeout,
            cwd=HERE,
        )
    except subprocess.TimeoutExpired as e:
        raise AssertionError(
            f"the child was still running after {timeout} s (killed)\n"
            f"stdout: {e.stdout}\nstderr: {e.stderr}"
        ) from None
    assert p.returncode == 0, (
        f"the child exited with {p.returncode}\nstdout: {p.stdout}\nstderr: {p.stderr[-3000:]}"
    )
    return p.stdout
