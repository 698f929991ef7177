"""Issue 39, item 6: under an address-space limit (`RLIMIT_AS`), calls whose memory is set by
their input raise MemoryError and leave the process working. Before, `intersect` of 120 M rays,
`count_intersections` of 250 M, `intersect_all` of many crossings and a build of 4 M triangles
ended the interpreter with SIGABRT (Rust's allocator aborts on failure)."""

import pytest

from child import run

# Each case: a child that limits its address space to what it uses plus `room`, then asks for
# more; prints "ok" once the MemoryError was raised and a small call answered right after it.
PRELUDE = """
import resource
import numpy as np, kdray
scene = kdray.Scene(layers(4))
o = np.array([0.25, 0.25, -1], np.float32)
d = np.array([0, 0, 1], np.float32)
def works():
    assert (scene.count_intersections(np.tile(o, (5000, 1)), d) == 4).all()  # on the pool
    assert scene.intersect(o, d).t == 1
    assert len(scene.intersect_all(o, d).ray) == 4
works()  # the pools and their threads' memory exist before the limit
def vm():
    with open("/proc/self/status") as f:
        return next(int(l.split()[1]) << 10 for l in f if l.startswith("VmSize"))
def limit(room):
    lim = vm() + room
    resource.setrlimit(resource.RLIMIT_AS, (lim, lim))
def expect_memory_error(call, *words):
    try:
        call()
    except MemoryError as e:
        for w in words:
            assert w in str(e), (w, str(e))
    else:
        raise AssertionError("no MemoryError")
    works()
    print("ok")
"""

CASES = {
    # 120 M rays: 480 MB of tmin fit; 2.4 GB of answers do not.
    "intersect": """
        limit(1 << 30)
        tmin = np.zeros(120_000_000, np.float32)
        expect_memory_error(lambda: scene.intersect(o, d, tmin), "intersect")
    """,
    "count_intersections": """
        limit(1 << 30)
        tmin = np.zeros(200_000_000, np.float32)
        expect_memory_error(lambda: scene.count_intersections(o, d, tmin), "count_intersections")
    """,
    "occluded": """
        limit(1 << 30)
        tmin = np.zeros(240_000_000, np.float32)
        expect_memory_error(lambda: scene.occluded(o, d, tmin), "occluded")
    """,
    # 2,000 layers × 20,000 rays: 40 M crossings, 640 MB kept per ray, past 64 MB of room.
    "intersect_all": """
        big = kdray.Scene(layers(2000))
        limit(64 << 20)
        tmin = np.zeros(20_000, np.float32)
        expect_memory_error(lambda: big.intersect_all(o, d, tmin), "intersect_all")
    """,
    # 4 M triangles: 144 MB of vertices, a 2 GB build.
    "build": """
        limit(1 << 30)
        v = np.random.default_rng(1).random((12_000_000, 3), np.float32)
        expect_memory_error(lambda: kdray.Scene(v), "build of 4000000 triangles")
    """,
    "contains": """
        limit(300 << 20)
        p = np.zeros((1, 3), np.float32)
        expect_memory_error(lambda: scene.contains(np.broadcast_to(p, (300_000_000, 3))))
    """,
}


@pytest.mark.parametrize("call", sorted(CASES))
def test_memory_limits_raise_memory_error_and_the_process_goes_on(call):
    out = run(PRELUDE + __import__("textwrap").dedent(CASES[call]), timeout=300)
    assert out.strip().endswith("ok"), out
