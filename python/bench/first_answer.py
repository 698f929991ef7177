"""The first answer: a user's clock from their arrays to their results — the build plus N rays —
for kdray's default `Scene` against Open3D's `RaycastingScene`, N = 1, 1,000, 100,000 and
1,000,000 (the package README's end-to-end table).

    python bench/first_answer.py data/dragon.tri icosphere --rounds 5

Rays: origins uniform in the mesh's box, directions uniform on the sphere (seeded), the same
float32 arrays for both. Each round times, for every N, one whole kdray run (`Scene(v, f)` and
`intersect(o, d)`) and one whole Open3D run (`RaycastingScene()`, `add_triangles`,
`cast_rays`), taking turns (kdray first in odd rounds, Open3D first in even ones), both on all
cores (`threads=None`, Open3D's default). Printed: the medians over the rounds in ms, the ratio
kdray ÷ Open3D of the medians, and how many rays' triangles agree (Open3D's `primitive_ids`
against kdray's `prim`, both in input order; a few may differ where two triangles tie or a ray
grazes a seam). `.tri` files: `kdray build`'s input format (little-endian u32 count, then
9 float32 a triangle), as `scripts/fetch-meshes.sh` writes them.
"""
import argparse
import statistics
import time

import numpy as np

import kdray

NS = (1, 1_000, 100_000, 1_000_000)


def read_tri(path):
    with open(path, "rb") as f:
        n = int(np.frombuffer(f.read(4), "<u4")[0])
        tris = np.frombuffer(f.read(36 * n), "<f4").reshape(n, 3, 3)
    # shared vertices, as a user's mesh has them
    verts, faces = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
    return np.ascontiguousarray(verts, np.float32), np.ascontiguousarray(faces.reshape(n, 3), np.int32)


def icosphere(subdivisions=7):
    """trimesh's closed icosphere (subdivision 7: 327,680 triangles), as bench/contains_speed.py."""
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    return np.ascontiguousarray(m.vertices, np.float32), np.ascontiguousarray(m.faces, np.int32)


def random_rays(verts, n, seed=7):
    rng = np.random.default_rng(seed)
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    o = rng.uniform(lo, hi, (n, 3)).astype(np.float32)
    z = rng.uniform(-1, 1, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    r = np.sqrt(1 - z * z)
    d = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1).astype(np.float32)
    return o, d


def run_kdray(verts, faces, o, d, options):
    t = time.perf_counter()
    scene = kdray.Scene(verts, faces, **options)
    built = time.perf_counter() - t
    hits = scene.intersect(o, d)
    return time.perf_counter() - t, np.asarray(hits.prim), built


def run_open3d(o3d, verts, faces, o, d):
    t = time.perf_counter()
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(verts), o3d.core.Tensor(faces.astype(np.uint32)))
    rays = o3d.core.Tensor(np.ascontiguousarray(np.concatenate([o, d], axis=1)))
    ids = scene.cast_rays(rays)["primitive_ids"].numpy()
    return time.perf_counter() - t, ids


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("meshes", nargs="+", help=".tri files, or 'icosphere' (trimesh's, 327,680 triangles)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--leaves", choices=("list", "groups"), help="kdray's leaves (default: its default)")
    ap.add_argument("--quality", choices=("fast", "high"), help="kdray's quality (default: its default)")
    ap.add_argument("--ns", default=",".join(map(str, NS)), help="the counts of rays, comma-separated")
    args = ap.parse_args()
    options = {k: v for k, v in (("leaves", args.leaves), ("quality", args.quality)) if v}
    import open3d as o3d

    print(f"kdray {kdray.__version__} {options or '(defaults)'}, Open3D {o3d.__version__}")
    print("| mesh | N rays | kdray ms (of which Scene) | Open3D ms | kdray ÷ Open3D | same triangle |")
    print("|---|---:|---:|---:|---:|---:|")
    for path in args.meshes:
        verts, faces = icosphere() if path == "icosphere" else read_tri(path)
        for n in map(int, args.ns.split(",")):
            o, d = random_rays(verts, n)
            times = {"kdray": [], "open3d": [], "scene": []}
            answers = {}
            for r in range(args.rounds):
                order = ["kdray", "open3d"] if r % 2 == 0 else ["open3d", "kdray"]
                for who in order:
                    if who == "kdray":
                        s, answers[who], built = run_kdray(verts, faces, o, d, options)
                        times["scene"].append(built * 1e3)
                    else:
                        s, answers[who] = run_open3d(o3d, verts, faces, o, d)
                    times[who].append(s * 1e3)
            k, p = statistics.median(times["kdray"]), statistics.median(times["open3d"])
            miss = np.uint32(0xFFFFFFFF)
            a = answers["kdray"].astype(np.uint32)
            b = answers["open3d"].astype(np.uint32)
            same = float(np.mean((a == b) | ((a == miss) & (b == miss))))
            sc = statistics.median(times["scene"])
            print(f"| {path.split('/')[-1]} ({len(faces):,} tris) | {n:,} | {k:.1f} ({sc:.1f}) | {p:.1f} | "
                  f"{k / p:.2f} | {100 * same:.2f} % |", flush=True)


if __name__ == "__main__":
    main()
