"""Issue 39, item 5: a forked child (multiprocessing's `fork`, Linux's default before Python
3.13) traces and builds after its parent used the thread pools. Before, the pools' threads did
not survive the fork and the child's next batch waited for ever."""

from child import run


def test_a_forked_child_traces_after_the_parents_pools():
    out = run(
        """
        import os, time
        import numpy as np, kdray
        scene = kdray.Scene(layers(4))
        n = 20_000  # over 4,096 rays: the pool, not the calling thread
        o = np.zeros((n, 3), np.float32); o[:, :2] = 0.25; o[:, 2] = -1
        d = np.array([0, 0, 1], np.float32)
        assert (scene.count_intersections(o, d) == 4).all()          # a thread a core
        assert (scene.count_intersections(o, d, threads=3) == 4).all()  # threads=
        pid = os.fork()
        if pid == 0:
            code = 1
            try:
                ok = (scene.count_intersections(o, d) == 4).all()
                ok &= (scene.intersect(o, d, threads=3).t == 1).all()
                ok &= bool(scene.occluded(o, d).all())
                ok &= kdray.Scene(layers(3000)).info["triangles"] == 3000  # a parallel build
                code = 0 if ok else 1
            finally:
                os._exit(code)
        for _ in range(600):  # 60 s at most: a child still running then has hung
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                print("child", os.waitstatus_to_exitcode(status))
                break
            time.sleep(0.1)
        else:
            os.kill(pid, 9)
            os.waitpid(pid, 0)
            print("child hung")
        # and the parent's pools still work
        assert (scene.count_intersections(o, d, threads=3) == 4).all()
        """
    )
    assert "child 0" in out, out


def test_multiprocessing_fork_pool():
    out = run(
        """
        import multiprocessing as mp
        import numpy as np, kdray
        scene = kdray.Scene(layers(2))
        o = np.zeros((10_000, 3), np.float32); o[:, 2] = -1
        d = np.array([0, 0, 1], np.float32)
        def work(k):
            return int(scene.count_intersections(o, d, threads=2).sum())
        print("parent", work(0))
        with mp.get_context("fork").Pool(2) as pool:
            print("children", pool.map_async(work, range(4)).get(timeout=60))
        """
    )
    assert "parent 20000" in out and "children [20000, 20000, 20000, 20000]" in out, out
