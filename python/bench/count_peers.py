"""``count_intersections`` on stacked squares, where every ray crosses every square: kdray against
Open3D's ``RaycastingScene.count_intersections`` (when installed), crossings a second as the
number of squares grows. A count that walks once and keeps its crossings in a sorted list costs
about the same per crossing at 100 squares and at 2,000; one that looks each crossing up among
those found so far (kdray before issue 38) slows down in proportion to the crossings per ray.

    python bench/count_peers.py [--rays 1000] [--squares 100,2000] [--rounds 5] [--threads 1]

Each round times one call per tester, alternating them so that a busy machine slows both alike;
printed are the medians over the rounds, and whether the counts agree (Open3D's may differ on a
ray through the diagonal the two triangles of a square share; the rays here avoid it).
"""

import argparse
import os
import statistics
import time

import numpy as np

import kdray


def stacked_quads(n):
    """`n` unit squares (two triangles each) in the planes z = 0 … n − 1."""
    z = np.repeat(np.arange(n, dtype=np.float32), 4)
    xy = np.tile(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32), (n, 1))
    base = 4 * np.arange(n)[:, None]
    faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]]).astype(np.int32)
    return np.column_stack([xy, z]).astype(np.float32), faces


def testers(vertices, faces, origins, threads):
    """(name, count()) for kdray and, when installed, Open3D."""
    out = []
    scene = kdray.Scene(vertices, faces, threads=threads)
    out.append(("kdray", lambda: scene.count_intersections(origins, [0, 0, 1])))
    try:
        import open3d as o3d
    except ImportError:
        print("   (open3d is not installed: kdray only)")
        return out
    o3 = o3d.t.geometry.RaycastingScene(nthreads=threads)
    o3.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(faces.astype(np.uint32)))
    dirs = np.tile(np.float32([0, 0, 1]), (len(origins), 1))
    rays = o3d.core.Tensor(np.hstack([origins, dirs]).astype(np.float32))
    out.append(("open3d", lambda: o3.count_intersections(rays).numpy()))
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rays", type=int, default=1000)
    p.add_argument("--squares", default="100,2000")
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--threads", type=int, default=1)
    a = p.parse_args()
    rng = np.random.default_rng(38)
    # Off the diagonal x = y, where two triangles meet.
    xy = rng.uniform(0.01, 0.99, (a.rays, 2))
    xy = xy[np.abs(xy[:, 0] - xy[:, 1]) > 1e-3]
    origins = np.column_stack([xy, np.full(len(xy), -1.0)]).astype(np.float32)
    print(f"{len(origins)} rays, {a.threads} thread(s), "
          f"{os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}")
    for n in map(int, a.squares.split(",")):
        v, f = stacked_quads(n)
        ts = testers(v, f, origins, a.threads)
        times = {name: [] for name, _ in ts}
        counts = {}
        for _ in range(a.rounds):
            for name, run in ts:
                t0 = time.perf_counter()
                counts[name] = np.asarray(run())
                times[name].append(time.perf_counter() - t0)
        crossings = len(origins) * n
        for name, _ in ts:
            s = statistics.median(times[name])
            right = np.all(counts[name] == n)
            print(f"{n:6} squares  {name:7} {s:8.4f} s  {crossings / s / 1e6:7.2f} M crossings/s"
                  f"  counts exact: {right}")


if __name__ == "__main__":
    main()
