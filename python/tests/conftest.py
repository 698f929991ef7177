"""Shared meshes and a numpy brute force for the tests."""

import numpy as np
import pytest


def random_mesh(rng, n_tris=300, n_verts=400, scale=1.0):
    """A soup of random triangles in [-scale, scale]³ sharing vertices: (vertices, faces)."""
    vertices = rng.uniform(-scale, scale, (n_verts, 3)).astype(np.float32)
    # Small triangles (a vertex and two near neighbours in a random order) so that rays see
    # several layers, not a hairball.
    a = rng.integers(0, n_verts, n_tris)
    order = np.argsort(np.linalg.norm(vertices[:, None] - vertices[None], axis=2), axis=1)
    b = order[a, rng.integers(1, 6, n_tris)]
    c = order[a, rng.integers(6, 12, n_tris)]
    return vertices, np.stack([a, b, c], axis=1).astype(np.int64)


def random_rays(rng, n, scale=1.5):
    """Rays from random points in [-scale, scale]³ towards random points of [-0.5, 0.5]³."""
    origins = rng.uniform(-scale, scale, (n, 3)).astype(np.float32)
    targets = rng.uniform(-0.5, 0.5, (n, 3)).astype(np.float32)
    directions = targets - origins
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return origins, directions.astype(np.float32)


def plane_hits(vertices, faces, origins, directions):
    """Every ray against every triangle's plane, Möller–Trumbore in float64: the
    (n_rays, n_tris) matrices of t, u, v (NaN where the ray is parallel to the plane)."""
    tri = vertices.astype(np.float64)[faces]  # (m, 3, 3)
    o = origins.astype(np.float64)[:, None, :]
    d = directions.astype(np.float64)[:, None, :]
    e1 = (tri[:, 1] - tri[:, 0])[None]
    e2 = (tri[:, 2] - tri[:, 0])[None]
    p = np.cross(d, e2)
    det = np.sum(e1 * p, axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(np.abs(det) > 1e-12, 1.0 / det, np.nan)
        s = o - tri[None, :, 0]
        u = np.sum(s * p, axis=2) * inv
        q = np.cross(s, e1)
        v = np.sum(d * q, axis=2) * inv
        t = np.sum(e2 * q, axis=2) * inv
    return t, u, v


def brute_force(vertices, faces, origins, directions, tmin=0.0, tmax=np.inf):
    """The brute force's hits: (n_rays, n_tris) matrices of t (inf where the ray misses the
    triangle), u and v."""
    t, u, v = plane_hits(vertices, faces, origins, directions)
    with np.errstate(invalid="ignore"):
        hit = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > tmin) & (t < tmax)
    return np.where(hit, t, np.inf), u, v


def tetrahedron():
    """A closed tetrahedron, outward faces."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return v, f


@pytest.fixture
def rng():
    return np.random.default_rng(20261125)
