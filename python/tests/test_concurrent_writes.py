"""Issue 39, item 9: another Python thread writing a mesh's arrays while it is being built (the
GIL is released during the build) gets a scene or a ValueError, never a PanicException (a
BaseException that `except Exception` does not catch). Before, a face index checked in range
and then read again could be out of range by then: Rust panicked indexing the vertices."""

import threading

import numpy as np

import kdray


def test_writing_faces_and_vertices_during_builds_never_panics():
    rng = np.random.default_rng(39)
    n = 100_000
    v = rng.random((3 * n, 3)).astype(np.float32)
    f = np.arange(3 * n, dtype=np.int64).reshape(n, 3)
    stop = threading.Event()

    def writer():
        # Flip the last face between in range and far out of range, and the last vertex
        # between finite and NaN, as fast as the GIL lets it: a check of the whole array and a
        # second read of it (the build) then see them differently about as often as not.
        last, good = f[n - 1, 1], v[3 * n - 1, 0]
        while not stop.is_set():
            f[n - 1, 1] = 10**12
            v[3 * n - 1, 0] = np.nan
            f[n - 1, 1] = last
            v[3 * n - 1, 0] = good

    t = threading.Thread(target=writer)
    t.start()
    outcomes = set()
    try:
        for _ in range(20):
            try:
                kdray.Scene(v, f, quality="fast")
                outcomes.add("built")
            except ValueError as e:
                assert "faces[" in str(e) or "vertices[" in str(e), e
                outcomes.add("refused")
    finally:
        stop.set()
        t.join()
    assert outcomes <= {"built", "refused"}
