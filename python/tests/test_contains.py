"""``contains`` is exact on points whose rays pass through the vertices and edges of closed
meshes (tests/closed_meshes.py), where ray parity that counts a shared edge twice or not at all
goes wrong; and it agrees with a sphere's and a tetrahedron's truth on random points."""

import numpy as np
import pytest

import kdray
from closed_meshes import cases, octahedron
from conftest import tetrahedron


@pytest.mark.parametrize("case", cases(), ids=lambda c: c[0])
@pytest.mark.parametrize("options", [{}, {"leaves": "list", "layout": "nodes"}])
def test_contains_is_exact_through_vertices_and_edges(case, options):
    name, vertices, faces, points, truth = case
    assert len(points) > 100 and 0.1 < truth.mean() < 0.9
    scene = kdray.Scene(vertices, faces, **options)
    got = scene.contains(points)
    wrong = np.flatnonzero(got != truth)
    assert len(wrong) == 0, f"{name}: {len(wrong)} wrong, e.g. {points[wrong[:5]].tolist()}"
    # The crossing counts behind it: from outside the box, 0 or 2; from inside, 1.
    counts = scene.count_intersections(points, kdray.CONTAINS_DIRECTION)
    assert np.array_equal(counts % 2 == 1, truth)
    assert set(np.unique(counts)) <= {0, 1, 2}


def test_contains_on_random_points(rng):
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=3)
    scene = kdray.Scene(sphere.vertices, sphere.faces)
    points = rng.uniform(-1.2, 1.2, (20000, 3))
    r = np.linalg.norm(points, axis=1)
    clear = (r < 0.98) | (r > 1.0)  # the mesh lies between radius 0.98 and 1
    np.testing.assert_array_equal(scene.contains(points)[clear], r[clear] < 0.99)
    v, f = tetrahedron()
    p = rng.uniform(-0.5, 1.5, (20000, 3)).astype(np.float32)
    inside = np.all(p > 0, axis=1) & (p.sum(axis=1) < 1)
    np.testing.assert_array_equal(kdray.Scene(v, f).contains(p), inside)


def test_crossings_through_a_vertex_count_once():
    """Rays through the octahedron's apex and along its axes: one crossing at each vertex, not
    one per triangle around it (4)."""
    v, f, _, _ = octahedron()
    scene = kdray.Scene(v, f)
    # From (-9, 0, 0) along +x: through the vertices (-4, 0, 0) and (4, 0, 0).
    every = scene.intersect_all([-9, 0, 0], [1, 0, 0])
    assert every.t.tolist() == [5.0, 13.0]
    assert scene.count_intersections([[-9, 0, 0], [0, -9, 0], [0, 0, -9]], np.eye(3)).tolist() == [2, 2, 2]


def stacked_quads(n):
    """`n` unit squares (two triangles each, sharing a diagonal) in the planes z = 0 … n − 1."""
    z = np.repeat(np.arange(n, dtype=np.float32), 4)
    xy = np.tile(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32), (n, 1))
    vertices = np.column_stack([xy, z])
    base = 4 * np.arange(n)[:, None]
    faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]]).astype(np.int64)
    return vertices, faces


@pytest.mark.parametrize("n", [1, 100, 2000])
def test_every_stacked_quad_is_crossed_once(rng, n):
    """Rays along z through `n` stacked squares cross each exactly once, also through the shared
    diagonal and the corners (one walk collects all of them; issue 38)."""
    v, f = stacked_quads(n)
    scene = kdray.Scene(v, f)
    inside = rng.uniform(0.01, 0.99, (200, 2))
    seams = np.array([[0.5, 0.5], [0.25, 0.25], [0.0, 0.0], [1.0, 1.0], [0.0, 0.5], [0.5, 1.0]])
    xy = np.vstack([inside, seams])
    origins = np.column_stack([xy, np.full(len(xy), -1.0)])
    counts = scene.count_intersections(origins, [0, 0, 1])
    # Inside and through the diagonal: n each. On the squares' outline the count is that of a ray
    # moved by an infinitesimal step (simulation of simplicity): n or 0, never another number.
    assert counts[: len(inside) + 2].tolist() == [n] * (len(inside) + 2)
    assert set(counts[len(inside) + 2 :].tolist()) <= {0, n}
    every = scene.intersect_all(origins[:3], [0, 0, 1])
    assert len(every.t) == 3 * n
    for r in range(3):
        t = every.t[every.ray == r]
        np.testing.assert_array_equal(t, np.arange(n, dtype=np.float32) + 1)
