"""``contains`` against Open3D's ``RaycastingScene.compute_occupancy`` (when installed) on a closed
mesh: trimesh's icosphere (subdivision 7: 327,680 triangles, closed) and points uniform in its
box, about half of them inside. Times one call per tester per round, the testers taking turns so
that a busy machine slows both alike; prints the medians and whether the answers agree with the
sphere's (points within 1e-3 of the surface left out of that count: the mesh is not the sphere).

    python bench/contains_speed.py [--points 100000] [--subdivisions 7] [--rounds 7] [--threads 0]

``--threads 0``: every core (both libraries' default); ``--threads N``: the build and the
queries of both on N threads.
"""

import argparse
import os
import statistics
import time

import numpy as np
import trimesh

import kdray


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=100_000)
    p.add_argument("--subdivisions", type=int, default=7)
    p.add_argument("--rounds", type=int, default=7)
    p.add_argument("--threads", type=int, default=0)
    a = p.parse_args()
    mesh = trimesh.creation.icosphere(subdivisions=a.subdivisions)
    v = np.asarray(mesh.vertices, np.float32)
    f = np.asarray(mesh.faces, np.int32)
    pts = np.random.default_rng(38).uniform(-1, 1, (a.points, 3)).astype(np.float32)
    r = np.linalg.norm(pts.astype(np.float64), axis=1)
    clear = np.abs(r - 1) > 1e-3
    print(f"{len(f)} triangles, {len(pts)} points, threads {a.threads or 'all'}, "
          f"{os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}")
    testers = []
    scene = kdray.Scene(v, f, threads=a.threads or None)
    testers.append(("kdray contains", lambda: scene.contains(pts, threads=a.threads or None)))
    try:
        import open3d as o3d

        o3 = o3d.t.geometry.RaycastingScene(nthreads=a.threads)
        o3.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f.astype(np.uint32)))
        q = o3d.core.Tensor(pts)
        testers.append(("Open3D compute_occupancy",
                        lambda: o3.compute_occupancy(q, nthreads=a.threads).numpy() > 0.5))
        print(f"   Open3D {o3d.__version__}")
    except ImportError:
        print("   (open3d is not installed: kdray only)")
    times = {name: [] for name, _ in testers}
    answers = {}
    for name, run in testers:  # a first call each, untimed (lazy builds, page faults)
        answers[name] = np.asarray(run())
    for _ in range(a.rounds):
        for name, run in testers:
            t0 = time.perf_counter()
            answers[name] = np.asarray(run())
            times[name].append(time.perf_counter() - t0)
    for name, _ in testers:
        s = statistics.median(times[name])
        wrong = int(np.sum(answers[name][clear] != (r < 1)[clear]))
        print(f"{name:26} {s * 1e3:8.1f} ms (median of {a.rounds}; min {min(times[name]) * 1e3:.1f})"
              f"  wrong away from the surface: {wrong}")
    if len(testers) == 2:
        ratio = statistics.median(times["kdray contains"]) / statistics.median(
            times["Open3D compute_occupancy"])
        print(f"kdray / Open3D: {ratio:.2f}x")


if __name__ == "__main__":
    main()
