"""The trimesh adapter: trimesh's own intersector (``trimesh.ray.ray_triangle``, pure numpy)
and kdray's on the same meshes and rays — the same answers, the same return types and shapes,
and ``mesh.ray = ...`` as the whole switch."""

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")
from trimesh.ray import ray_triangle  # noqa: E402

import kdray.trimesh  # noqa: E402


def meshes():
    yield "icosphere", trimesh.creation.icosphere(subdivisions=3)
    yield "torus", trimesh.creation.torus(major_radius=1.0, minor_radius=0.3)
    yield "box", trimesh.creation.box()


def rays(rng, n=1000):
    o = rng.uniform(-3, 3, (n, 3))
    d = rng.uniform(-0.6, 0.6, (n, 3)) - o
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


def same_kind(a, b):
    """Same type, dtype kind and shape (or both tuples of such)."""
    if isinstance(a, tuple) or isinstance(b, tuple):
        assert isinstance(a, tuple) and isinstance(b, tuple) and len(a) == len(b)
        for x, y in zip(a, b):
            same_kind(x, y)
        return
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype.kind == b.dtype.kind, (a.dtype, b.dtype)
    assert a.ndim == b.ndim and a.shape[1:] == b.shape[1:], (a.shape, b.shape)


@pytest.mark.parametrize("name, mesh", list(meshes()), ids=lambda x: x if isinstance(x, str) else "")
def test_the_adapter_answers_as_trimesh(name, mesh, rng):
    theirs = ray_triangle.RayMeshIntersector(mesh)
    ours = kdray.trimesh.RayMeshIntersector(mesh)
    o, d = rays(rng)

    first_t, first_k = theirs.intersects_first(o, d), ours.intersects_first(o, d)
    same_kind(first_t, first_k)
    assert first_k.shape == (len(o),)
    # The same first triangle for nearly every ray (they may differ on a shared edge).
    assert np.mean(first_t == first_k) > 0.995
    np.testing.assert_array_equal(first_t >= 0, first_k >= 0)

    any_t, any_k = theirs.intersects_any(o, d), ours.intersects_any(o, d)
    same_kind(any_t, any_k)
    np.testing.assert_array_equal(any_t, any_k)

    for multiple in (True, False):
        id_t = theirs.intersects_id(o, d, multiple_hits=multiple)
        id_k = ours.intersects_id(o, d, multiple_hits=multiple)
        same_kind(id_t, id_k)
        loc_t = theirs.intersects_location(o, d, multiple_hits=multiple)
        loc_k = ours.intersects_location(o, d, multiple_hits=multiple)
        same_kind(loc_t, loc_k)
        assert loc_k[0].shape == (len(loc_k[1]), 3) and loc_k[0].dtype == np.float64
        # The same (ray, triangle) pairs, up to rays through shared edges.
        pairs_t = set(zip(id_t[1].tolist(), id_t[0].tolist()))
        pairs_k = set(zip(id_k[1].tolist(), id_k[0].tolist()))
        assert len(pairs_t ^ pairs_k) <= 0.005 * len(pairs_t) + 2
        # The locations lie on the triangles reported, along the rays.
        locations, index_ray, index_tri = loc_k
        tri = mesh.triangles[index_tri]
        n = mesh.face_normals[index_tri]
        np.testing.assert_allclose(np.sum((locations - tri[:, 0]) * n, axis=1), 0, atol=1e-5)
        along = locations - o[index_ray]
        np.testing.assert_allclose(np.cross(along, d[index_ray]), 0, atol=1e-5)
        id_loc = ours.intersects_id(o, d, return_locations=True, multiple_hits=multiple)
        same_kind(id_loc, theirs.intersects_id(o, d, return_locations=True, multiple_hits=multiple))

    points = rng.uniform(-1.5, 1.5, (2000, 3))
    c_t, c_k = theirs.contains_points(points), ours.contains_points(points)
    same_kind(c_t, c_k)
    np.testing.assert_array_equal(c_t, c_k)


def test_mesh_ray_is_the_whole_switch(rng):
    mesh = trimesh.creation.icosphere(subdivisions=2)
    want = mesh.contains([[0, 0, 0], [0, 0, 2]])
    mesh.ray = kdray.trimesh.RayMeshIntersector(mesh)
    assert mesh.contains([[0, 0, 0], [0, 0, 2]]).tolist() == want.tolist() == [True, False]
    o, d = rays(rng, 100)
    assert mesh.ray.intersects_first(o, d).shape == (100,)
    # A changed mesh is traced as it is now.
    first = mesh.ray.scene
    mesh.vertices = mesh.vertices * 2
    assert mesh.ray.scene is not first
    assert mesh.ray.contains_points([[0, 0, 1.5]]).tolist() == [True]


def test_the_adapter_refuses_bad_rays():
    mesh = trimesh.creation.box()
    ray = kdray.trimesh.RayMeshIntersector(mesh)
    with pytest.raises(ValueError, match="ray_origins"):
        ray.intersects_first([[0, 0]], [[0, 0, 1]])
    with pytest.raises(ValueError, match="ray_directions"):
        ray.intersects_any([[0, 0, 0]], [[0, 0, 1], [0, 1, 0]])
    with pytest.raises(ValueError, match="points"):
        ray.contains_points([1, 2, 3])
