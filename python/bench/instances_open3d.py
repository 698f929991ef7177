"""Scenes of many meshes: Open3D's `RaycastingScene` with 100 `add_triangles` meshes (world
space) and `cast_rays` (its `geometry_ids`), against kdray's two ways to answer the same
question, all on one thread (`threads=1`, Open3D's `nthreads=1`):

- `kdray.Instances(meshes)`: each mesh its own tree, placed by the identity under a top level
  (the two-level walk, `geometry_id` from the instance hit);
- `kdray.Instances(meshes, merge=True)`: one tree over every mesh's triangles, built on the
  first query, and its map from triangle to mesh (a search over the meshes' first triangles,
  timed with the rays).

    python bench/instances_open3d.py --rounds 5
    python bench/instances_open3d.py --mesh data/bunny.tri --count 100

Meshes: by default 100 of trimesh's primitives (icospheres of 1,280 and 5,120 triangles, tori,
capsules, cylinders), each scaled, rotated and placed at random in a 40-unit cube (seeded), baked
into world coordinates; with `--mesh`, that mesh (a `.tri`, as bench/first_answer.py reads it)
`--count` times, scaled to fit a cell of the cube and rotated. Rays: origins uniform in the
scene's box, directions uniform on the sphere (seeded), the same float32 arrays for all three.
`--aim`: directions towards random triangles' centres instead (most rays hit). Each round times
every contender's tracing (not its build) once, in turn, the order rotating with the round.
Printed: the medians of wall time (ms, M rays/s) and of the process's CPU time (what a loaded
machine distorts least: one thread each), Open3D ÷ kdray (above 1: kdray faster), and the
share of rays on which each kdray way and Open3D name the same mesh and the same triangle (both
miss, or both hit that one).
"""
import argparse
import resource
import statistics
import time

import numpy as np

import kdray

from first_answer import random_rays, read_tri


def rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def primitives(rng, count):
    import trimesh

    makers = [
        lambda: trimesh.creation.icosphere(subdivisions=3),
        lambda: trimesh.creation.icosphere(subdivisions=4),
        lambda: trimesh.creation.torus(major_radius=1.0, minor_radius=0.3),
        lambda: trimesh.creation.capsule(height=1.5, radius=0.5, count=[32, 32]),
        lambda: trimesh.creation.cylinder(radius=0.7, height=2.0, sections=64),
    ]
    return [makers[k % len(makers)]() for k in range(count)]


def scene_meshes(args, rng):
    """`count` meshes in world coordinates: [(vertices float32, faces int32)]."""
    if args.mesh:
        v, f = read_tri(args.mesh)
        v = (v - (v.min(axis=0) + v.max(axis=0)) / 2) / np.ptp(v, axis=0).max() * 3
        base = [(v, f)] * args.count
    else:
        base = [(np.asarray(m.vertices), np.asarray(m.faces)) for m in primitives(rng, args.count)]
    out = []
    for v, f in base:
        linear = rotation(rng) * rng.uniform(0.6, 1.6)
        placed = v.astype(np.float64) @ linear.T + rng.uniform(0, 40, 3)
        out.append((np.ascontiguousarray(placed, np.float32), np.ascontiguousarray(f, np.int32)))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mesh", help="a .tri file placed --count times (default: trimesh primitives)")
    ap.add_argument("--count", type=int, default=100)
    ap.add_argument("--rays", type=int, default=1_000_000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--aim", action="store_true",
                    help="rays towards random triangles' centres instead of random directions")
    ap.add_argument("--quality", choices=("fast", "high"), help="kdray's trees' (both ways)")
    ap.add_argument("--leaves", choices=("list", "groups"), help="kdray's trees' (both ways)")
    args = ap.parse_args()
    merged_options = {k: v for k, v in (("quality", args.quality), ("leaves", args.leaves)) if v}
    import open3d as o3d

    rng = np.random.default_rng(42)
    meshes = scene_meshes(args, rng)
    tris = sum(len(f) for _, f in meshes)
    verts = np.concatenate([v for v, _ in meshes])
    o, d = random_rays(verts, args.rays)
    if args.aim:
        centres = np.concatenate([v[f].mean(axis=1) for v, f in meshes])
        d = centres[np.random.default_rng(8).integers(0, len(centres), args.rays)] - o
        d = (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)
    print(f"kdray {kdray.__version__} (isa={kdray.ISA}), Open3D {o3d.__version__}: {len(meshes)} "
          f"meshes, {tris:,} triangles, {args.rays:,} rays "
          f"({'aimed at triangles' if args.aim else 'random'}), one thread")

    t0 = time.perf_counter()
    o3 = o3d.t.geometry.RaycastingScene()
    for v, f in meshes:
        o3.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f.astype(np.uint32)))
    rays = o3d.core.Tensor(np.ascontiguousarray(np.concatenate([o, d], axis=1)))
    o3.cast_rays(rays[:1], nthreads=1)  # Embree commits the scene on the first cast
    t1 = time.perf_counter()
    inst = kdray.Instances(meshes, threads=1, **merged_options)
    t2 = time.perf_counter()
    merged = kdray.Instances([inst.mesh(g) for g in inst.geometry_ids], merge=True, threads=1,
                             **merged_options)
    merged.raycast(o[0], d[0])  # builds the merged tree
    t3 = time.perf_counter()
    assert merged.info["merged"]
    print(f"builds (one thread): Open3D {1e3 * (t1 - t0):.0f} ms, Instances "
          f"{1e3 * (t2 - t1):.0f} ms, then merge=True's one tree {1e3 * (t3 - t2):.0f} ms "
          f"{merged_options or ''}")

    def open3d():
        r = o3.cast_rays(rays, nthreads=1)
        g = r["geometry_ids"].numpy().astype(np.int64)
        miss = g == o3.INVALID_ID
        prim = r["primitive_ids"].numpy().astype(np.int64)
        return np.where(miss, -1, g), np.where(miss, -1, prim)

    def instances():
        h = inst.intersect(o, d, threads=1)
        return h.geometry_id, h.prim

    def one_tree():
        h = merged.intersect(o, d, threads=1)
        return h.geometry_id, h.prim

    runs = {"Open3D": open3d, "Instances": instances, "Instances, merge=True": one_tree}
    times = {k: [] for k in runs}
    cpu_times = {k: [] for k in runs}
    answers = {}

    def cpu():
        r = resource.getrusage(resource.RUSAGE_SELF)
        return r.ru_utime + r.ru_stime

    for r in range(args.rounds):
        names = list(runs)
        for name in names[r % 3:] + names[: r % 3]:
            t, c = time.perf_counter(), cpu()
            answers[name] = runs[name]()
            times[name].append(time.perf_counter() - t)
            cpu_times[name].append(cpu() - c)
    g3, p3 = answers["Open3D"]
    base = statistics.median(times["Open3D"])
    base_cpu = statistics.median(cpu_times["Open3D"])
    print(f"rays that hit (Open3D): {100 * np.mean(g3 >= 0):.1f} %")
    print("| contender | wall ms | M rays/s | Open3D ÷ it | CPU ms | Open3D ÷ it (CPU) | "
          "same mesh and triangle as Open3D |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name in runs:
        s, c = statistics.median(times[name]), statistics.median(cpu_times[name])
        g, p = answers[name]
        same = np.mean((g == g3) & (p == p3))
        print(f"| {name} | {1e3 * s:.1f} | {args.rays / s / 1e6:.2f} | {base / s:.2f} | "
              f"{1e3 * c:.1f} | {base_cpu / c:.2f} | {100 * same:.2f} % |", flush=True)


if __name__ == "__main__":
    main()
