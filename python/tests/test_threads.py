"""Issue 39, item 7: `threads=` keeps a bounded number of threads. Before, a pool was kept for
every distinct `threads=k` for ever (813 OS threads after k = 1 … 40), and up to 4,096 threads
were accepted per call."""

import os

import numpy as np
import pytest

import kdray
from child import run


def test_distinct_thread_counts_do_not_pile_up_threads():
    out = run(
        """
        import os
        import numpy as np, kdray
        scene = kdray.Scene(layers(2))
        o = np.zeros((5000, 3), np.float32); o[:, 2] = -1
        d = np.array([0, 0, 1], np.float32)
        for k in range(1, min(40, kdray.MAX_THREADS) + 1):
            assert (scene.count_intersections(o, d, threads=k) == 2).all()
        # one pool of a thread a core, one for the last k (40): the others' threads have
        # ended (waited for until each ran its exit handler; the last ones may still be
        # leaving the kernel's thread list)
        print("threads", len(os.listdir("/proc/self/task")))
        """
    )
    threads = int(out.split()[-1])
    # 813 before; the main thread, a pool a core, one pool of 40, at most stragglers of the pool
    # of 39 (36 on 2 cores, measured)
    assert threads <= 1 + os.cpu_count() + 40 + 39, out


def test_thread_counts_past_the_cap_are_refused():
    scene = kdray.Scene([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    o, d = np.zeros((5000, 3)), [0, 0, 1]
    with pytest.raises(ValueError, match=f"threads={kdray.MAX_THREADS + 1}: it must be from 1"):
        scene.count_intersections(o, d, threads=kdray.MAX_THREADS + 1)
    with pytest.raises(ValueError, match="threads=0"):
        kdray.Scene([[0, 0, 0], [1, 0, 0], [0, 1, 0]], threads=0)
    assert kdray.MAX_THREADS == 16 * os.cpu_count()
    assert scene.count_intersections(o, d, threads=kdray.MAX_THREADS).shape == (5000,)
