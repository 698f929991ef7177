"""kdray's Python package against Open3D's RaycastingScene and embreex on the same meshes and
rays, one and two threads, and against the native `kdray trace` on the same rays.

    python bench/peers.py --kdray target/release/kdray data/bunny.tri data/dragon.tri

For each mesh (a `.tri`, as `scripts/fetch-meshes.sh` writes them), `kdray build` and
`kdray rays` make the benchmark protocol's ray sets (docs/BENCHMARKS.md: primary rays of a
1024×1024 pinhole camera in 2×4 tiles, loose framing, and their cosine-weighted diffuse bounces);
every tracer gets those rays. Figures: Mrays/s (median of `--repeat` rounds, the tracers taking
turns in each round), the build's seconds (Open3D and Embree build at their first query: a
one-ray query is included), and `contains` on a million points (kdray's `contains`, Open3D's
`compute_occupancy`, trimesh's `contains` with embreex, which it uses when installed) — points
uniform in the mesh's box. The hits are compared ray by ray (the share of rays whose triangle
equals kdray's). Prints a Markdown table.

Peers are optional (pip install open3d embreex trimesh rtree); a missing one is a "—".
embreex traces on one thread (it calls rtcIntersect1 in a loop), so it has no two-thread figure.
"""

import argparse
import os
import statistics
import subprocess
import tempfile
import time

import numpy as np

import kdray


def read_tri(path):
    with open(path, "rb") as f:
        n = int(np.frombuffer(f.read(4), "<u4")[0])
        tris = np.frombuffer(f.read(36 * n), "<f4").reshape(n, 3, 3)
    return tris


def read_rays(path):
    r = np.fromfile(path, "<f4").reshape(-1, 8)
    return (
        np.ascontiguousarray(r[:, 0:3]),
        np.ascontiguousarray(r[:, 3:6]),
        np.ascontiguousarray(r[:, 6]),
        np.ascontiguousarray(r[:, 7]),
    )


def timed(f):
    start = time.perf_counter()
    out = f()
    return time.perf_counter() - start, out


class Kdray:
    name = "kdray (Python)"

    def __init__(self, tris, threads):
        self.threads = threads
        n = len(tris)
        self.build_s, self.scene = timed(
            lambda: kdray.Scene(tris.reshape(-1, 3), threads=threads)
        )
        assert self.scene.info["triangles"] == n

    def trace(self, o, d, lo, hi):
        return self.scene.intersect(o, d, lo, hi, threads=self.threads).prim

    def contains(self, p):
        return self.scene.contains(p, threads=self.threads)


class Open3D:
    name = "Open3D RaycastingScene"

    def __init__(self, tris, threads):
        import open3d as o3d

        self.o3d = o3d
        self.threads = threads
        v = o3d.core.Tensor(np.ascontiguousarray(tris.reshape(-1, 3)))
        f = o3d.core.Tensor(np.arange(3 * len(tris), dtype=np.uint32).reshape(-1, 3))

        def build():
            scene = o3d.t.geometry.RaycastingScene(nthreads=threads)
            scene.add_triangles(v, f)
            scene.cast_rays(o3d.core.Tensor(np.array([[0, 0, 0, 0, 0, 1]], np.float32)))
            return scene

        self.build_s, self.scene = timed(build)

    def trace(self, o, d, lo, hi):
        # Open3D has no per-ray interval: the origin moves to tmin (the diffuse rays' offset off
        # the surface they leave); tmax is inf in the protocol's rays.
        o = (o + lo[:, None] * d).astype(np.float32)
        rays = self.o3d.core.Tensor(np.ascontiguousarray(np.concatenate([o, d], axis=1)))
        ids = self.scene.cast_rays(rays, nthreads=self.threads)["primitive_ids"].numpy()
        return np.where(ids == self.scene.INVALID_ID, -1, ids.astype(np.int64))

    def contains(self, p):
        q = self.o3d.core.Tensor(p)
        return self.scene.compute_occupancy(q, nthreads=self.threads).numpy() > 0.5


class Embreex:
    name = "embreex (Embree 4)"

    def __init__(self, tris, threads):
        from embreex import rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh

        def build():
            scene = rtcs.EmbreeScene()
            TriangleMesh(scene, np.ascontiguousarray(tris))
            scene.run(np.zeros((1, 3), np.float32), np.array([[0, 0, 1]], np.float32))
            return scene

        self.build_s, self.scene = timed(build)

    def trace(self, o, d, lo, hi):
        # embreex's run takes no interval: the origin moves to tmin, as for Open3D.
        o = (o + lo[:, None] * d).astype(np.float32)
        return self.scene.run(o, d).astype(np.int64)

    def contains(self, p):
        return None


def peers(threads):
    out = [Kdray]
    for peer in (Open3D, Embreex):
        try:
            __import__({Open3D: "open3d", Embreex: "embreex"}[peer])
        except ImportError:
            continue
        if peer is Embreex and threads != 1:
            continue
        out.append(peer)
    return out


def trimesh_contains(tris, points):
    try:
        import trimesh
        from trimesh.ray import ray_pyembree
    except ImportError:
        return None
    mesh = trimesh.Trimesh(tris.reshape(-1, 3), np.arange(3 * len(tris)).reshape(-1, 3), process=False)
    mesh.ray = ray_pyembree.RayMeshIntersector(mesh)
    return timed(lambda: mesh.contains(points))


def native(kdray_bin, kdt, rays, threads, repeat):
    """`kdray trace`'s Mrays/s on the same rays: the faster of its two fast ways, packets of 8
    consecutive rays and the stream API with 8-wide packets (the package picks between the two
    by the rays' coherence: python/src/closest.rs)."""
    best = 0.0
    for flags in (["--packet", "8"], ["--stream", "--packet", "8"]):
        with tempfile.TemporaryDirectory() as tmp:
            out = subprocess.run(
                [kdray_bin, "trace", kdt, "--rays", rays, "--out", os.path.join(tmp, "hits.bin"),
                 "--threads", str(threads), "--repeat", str(repeat), *flags],
                check=True, capture_output=True, text=True,
            ).stdout
        best = max(best, float(out.split("mrays_s=")[1].split()[0]))
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("meshes", nargs="+", help=".tri files")
    ap.add_argument("--kdray", default="kdray", help="the kdray command (for rays and trace)")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--points", type=int, default=1_000_000)
    args = ap.parse_args()
    rows = []
    for mesh in args.meshes:
        name = os.path.basename(mesh).split(".")[0]
        tris = read_tri(mesh)
        with tempfile.TemporaryDirectory() as tmp:
            kdt = os.path.join(tmp, "m.kdt")
            subprocess.run([args.kdray, "build", mesh, "-o", kdt], check=True, capture_output=True)
            sets = {}
            for kind in ("primary", "diffuse"):
                path = os.path.join(tmp, kind + ".bin")
                subprocess.run([args.kdray, "rays", kdt, "-o", path, "--kind", kind],
                               check=True, capture_output=True)
                sets[kind] = (path, read_rays(path))
            lo, hi = tris.reshape(-1, 3).min(axis=0), tris.reshape(-1, 3).max(axis=0)
            points = np.random.default_rng(7).uniform(lo, hi, (args.points, 3)).astype(np.float32)
            for threads in map(int, args.threads.split(",")):
                tracers = [p(tris, threads) for p in peers(threads)]
                for kind, (path, rays) in sets.items():
                    times = {t.name: [] for t in tracers}
                    answers = {}
                    for _ in range(args.repeat):
                        for t in tracers:
                            s, answers[t.name] = timed(lambda: t.trace(*rays))
                            times[t.name].append(s)
                    ref = answers[Kdray.name]
                    for t in tracers:
                        rows.append(dict(
                            mesh=name, triangles=len(tris), threads=threads, what=f"{kind} rays ({len(ref):,})",
                            tracer=t.name, mrays=len(ref) / statistics.median(times[t.name]) / 1e6,
                            same=float(np.mean(answers[t.name] == ref)), build=t.build_s,
                        ))
                    rows.append(dict(
                        mesh=name, triangles=len(tris), threads=threads, what=f"{kind} rays ({len(ref):,})",
                        tracer="kdray trace (native, the faster of --packet 8 and --stream --packet 8)",
                        mrays=native(args.kdray, kdt, path, threads, args.repeat), same=None, build=None,
                    ))
                # contains on a million points.
                ref = None
                for t in tracers:
                    s, got = timed(lambda: t.contains(points))
                    if got is None:
                        continue
                    ref = got if ref is None else ref
                    rows.append(dict(mesh=name, triangles=len(tris), threads=threads,
                                     what=f"contains ({args.points:,} points)", tracer=t.name,
                                     mrays=args.points / s / 1e6, same=float(np.mean(got == ref)), build=None))
                if threads == 1:
                    tm = trimesh_contains(tris, points)
                    if tm is not None:
                        rows.append(dict(mesh=name, triangles=len(tris), threads=threads,
                                         what=f"contains ({args.points:,} points)", tracer="trimesh contains (embreex)",
                                         mrays=args.points / tm[0] / 1e6, same=float(np.mean(tm[1] == ref)), build=None))
    print("| mesh | threads | query | tracer | M/s | same answer as kdray | build s |")
    print("|---|---:|---|---|---:|---:|---:|")
    for r in rows:
        same = "" if r["same"] is None else f"{100 * r['same']:.2f} %"
        build = "" if r["build"] is None else f"{r['build']:.2f}"
        print(f"| {r['mesh']} ({r['triangles']:,}) | {r['threads']} | {r['what']} | {r['tracer']} | "
              f"{r['mrays']:.2f} | {same} | {build} |")


if __name__ == "__main__":
    main()
