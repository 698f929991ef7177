"""Closed meshes with integer vertices, and points whose `+x` rays (the axis
``kdray.Scene.contains`` casts along: ``+x``, or ``−x`` on the same line from points nearer the
box's low x face) pass exactly through their vertices and edges, with the true answer for each
point. Used by tests/test_contains.py and bench/contains_peers.py.

Integer vertices make the points exact: a point ``v − (s, 0, 0)`` has ``v``'s y and z, so its
ray meets ``v``; a point whose (y, z) is the midpoint of an edge's (y, z) — a half-integer, exact
in float32 — has a ray that meets the edge (or runs along it, when the edge is parallel to x).
"""

import numpy as np


def outward(vertices, faces):
    """``faces`` of a convex mesh around the origin, each turned to face outward."""
    t = vertices.astype(np.float64)[faces]
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    inward = np.sum(n * t.mean(axis=1), axis=1) < 0
    faces = faces.copy()
    faces[inward] = faces[inward][:, ::-1]
    return faces


def octahedron(r=4):
    """The octahedron |x| + |y| + |z| = r (faces outward): vertices, faces, and the truth
    ``inside(points)``."""
    v = np.array(
        [[r, 0, 0], [-r, 0, 0], [0, r, 0], [0, -r, 0], [0, 0, r], [0, 0, -r]], dtype=np.float32
    )
    faces = [[ix, iy, iz] for ix in (0, 1) for iy in (2, 3) for iz in (4, 5)]
    return (
        v,
        outward(v, np.array(faces)),
        lambda p: np.abs(p).sum(axis=-1) < r,
        lambda p: np.abs(p).sum(axis=-1) == r,
    )


def box(n=4, r=4):
    """The cube [−r, r]³ with each face cut into n × n squares of two triangles (diagonals in
    alternating directions): vertices, faces, inside, on_surface."""
    grid = np.linspace(-r, r, n + 1)
    verts, index, faces = [], {}, []

    def vid(p):
        key = tuple(float(x) for x in p)
        if key not in index:
            index[key] = len(verts)
            verts.append(key)
        return index[key]

    for axis in range(3):
        for side in (-r, r):
            a, b = [k for k in range(3) if k != axis]
            for i in range(n):
                for j in range(n):
                    corners = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0] * 3
                        p[axis], p[a], p[b] = side, grid[i + di], grid[j + dj]
                        corners.append(vid(p))
                    q = corners if (i + j) % 2 == 0 else corners[1:] + corners[:1]
                    faces += [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    v = np.array(verts, dtype=np.float32)
    return (
        v,
        outward(v, np.array(faces)),
        lambda p: np.all(np.abs(p) < r, axis=-1),
        lambda p: np.all(np.abs(p) <= r, axis=-1) & np.any(np.abs(p) == r, axis=-1),
    )


def lattice_sphere(subdivisions=2, radius=1000):
    """trimesh's icosphere scaled to ``radius`` and rounded to integers (still closed: shared
    vertices stay shared). Only points well inside (|p| < 0.9 r) or well outside (|p| > 1.001 r:
    outside every vertex) are given, so the truth is |p| < r."""
    import trimesh

    mesh = trimesh.creation.icosphere(subdivisions=subdivisions)
    v = np.round(mesh.vertices * radius).astype(np.float32)
    return v, np.asarray(mesh.faces), lambda p: np.linalg.norm(p, axis=-1) < radius, None


def seam_points(vertices, faces, shifts, direction=(1.0, 0.0, 0.0)):
    """Points whose ray along ``direction`` passes through each vertex and each edge's
    midpoint: ``target − s·direction`` for every shift s. Along +x (the default) every
    coordinate is exact in float32; along another direction the points are rounded (to float64,
    then float32), so their rays pass within rounding of the targets."""
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    v = vertices.astype(np.float64)
    targets = np.concatenate([v, (v[edges[:, 0]] + v[edges[:, 1]]) / 2])
    d = np.asarray(direction, dtype=np.float64)
    pts = np.concatenate([targets - s * d for s in shifts])
    if tuple(direction) == (1.0, 0.0, 0.0):
        assert np.array_equal(pts.astype(np.float32).astype(np.float64), pts)
    return pts.astype(np.float32)


def meshes():
    """(name, vertices, faces, inside, clear, shifts): the meshes, their truth, which points
    have a clear answer (not on or too near the surface), and the shifts along the ray that put
    points inside and outside."""

    def off_surface(on_surface):
        return lambda p: ~on_surface(p)

    def sphere_clear(p):
        r = np.linalg.norm(p.astype(np.float64), axis=-1)
        return (r < 900) | (r > 1001)

    shifts = (-3, -1, 0.5, 1, 2, 3.5, 5, 7, 9)
    v, f, inside, on = octahedron()
    yield "octahedron", v, f, inside, off_surface(on), shifts
    v, f, inside, on = box()
    yield "box 4x4", v, f, inside, off_surface(on), shifts
    v, f, inside, _ = lattice_sphere()
    yield "lattice icosphere", v, f, inside, sphere_clear, (-500, -100, 150, 400, 900, 1500, 2500)


def cases(direction=(1.0, 0.0, 0.0)):
    """(name, vertices, faces, points, truth) for every mesh: the points aimed along
    ``direction`` at vertices and edges whose answer is clear."""
    out = []
    for name, v, f, inside, clear, shifts in meshes():
        p = seam_points(v, f, shifts, direction)
        keep = clear(p)
        out.append((name, v, f, p[keep], inside(p[keep])))
    return out
