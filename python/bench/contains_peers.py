"""Inside/outside on points whose +x rays pass through the vertices and edges of closed meshes
(tests/closed_meshes.py): kdray's ``contains`` and the peers' answers side by side, as wrong
answers out of the points — aimed along each tester's own ray direction in turn (a point is hard
only for a tester whose ray meets a vertex or an edge).

    python bench/contains_peers.py

Peers, each where installed: trimesh's ``contains`` with its pure-numpy intersector
(``trimesh.ray.ray_triangle``) and with Embree (``ray_pyembree``, when embreex is installed),
and Open3D's ``RaycastingScene.compute_occupancy`` (its default, one ray per point, and
``nsamples=3``, a vote of three rays).
"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))

import kdray  # noqa: E402
from closed_meshes import cases  # noqa: E402


def peers(vertices, faces):
    """(name, contains(points)) for every peer installed."""
    out = []
    try:
        import trimesh
        from trimesh.ray import ray_triangle

        mesh = trimesh.Trimesh(vertices.astype(np.float64), faces, process=False)
        mesh.ray = ray_triangle.RayMeshIntersector(mesh)
        out.append(("trimesh (ray_triangle)", mesh.contains))
        try:
            from trimesh.ray import ray_pyembree

            em = trimesh.Trimesh(vertices.astype(np.float64), faces, process=False)
            em.ray = ray_pyembree.RayMeshIntersector(em)
            out.append(("trimesh (embreex)", em.contains))
        except (ImportError, ValueError):
            pass
    except ImportError:
        pass
    try:
        import open3d as o3d

        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(
            o3d.core.Tensor(vertices.astype(np.float32)), o3d.core.Tensor(faces.astype(np.uint32))
        )

        def occupancy(points, nsamples=1):
            q = o3d.core.Tensor(np.asarray(points, dtype=np.float32))
            return scene.compute_occupancy(q, nsamples=nsamples).numpy() > 0.5

        out.append(("Open3D compute_occupancy", occupancy))
        out.append(("Open3D compute_occupancy, nsamples=3", lambda p: occupancy(p, 3)))
    except ImportError:
        pass
    return out


# The rays each tester casts: kdray's +x; trimesh's fixed direction (trimesh/ray/ray_util.py,
# which also casts the opposite one); Open3D's (1, 1, 1) give or take 0.001 per component
# (RaycastingScene.cpp, VoteInsideOutside: its exact directions come from a seeded generator).
AIMS = {
    "+x (kdray's rays)": (1.0, 0.0, 0.0),
    "trimesh's direction": (0.4395064455, 0.617598629942, 0.652231566745),
    "(1, 1, 1) (Open3D's, ±0.001)": tuple(np.full(3, 1 / np.sqrt(3))),
}


def main():
    rows = []
    names = ["kdray contains"]
    for aim, direction in AIMS.items():
        for name, vertices, faces, points, truth in cases(direction):
            row = {"mesh": name, "aim": aim, "points": len(points)}
            kd = kdray.Scene(vertices, faces).contains(points)
            row["kdray contains"] = int(np.sum(kd != truth))
            for peer, contains in peers(vertices, faces):
                if peer not in names:
                    names.append(peer)
                row[peer] = int(np.sum(np.asarray(contains(points)) != truth))
            rows.append(row)
    print("| mesh | points aimed along | points | " + " | ".join(names) + " |")
    print("|---|---|---:|" + "---:|" * len(names))
    for row in rows:
        cells = [str(row.get(n, "—")) for n in names]
        print(f"| {row['mesh']} | {row['aim']} | {row['points']} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
