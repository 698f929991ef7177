"""kdray against a numpy brute force (every ray against every triangle, in float64) on random
meshes: closest hits, occlusion, crossing counts and every hit, in both modes, both layouts and
both kinds of leaves.

A ray that passes within rounding of a triangle's edge may be given either answer, so each ray is
checked against two sets of the brute force: the triangles it hits with a margin (``strict``: it
must hit them) and those it hits within a tolerance (``loose``: it may hit only them)."""

import numpy as np
import pytest

import kdray
from conftest import brute_force, plane_hits, random_mesh, random_rays

EPS = 1e-5


def margins(vertices, faces, origins, directions, tmin=0.0, tmax=np.inf):
    """Which triangles each ray hits with a margin (strict), within a tolerance (loose), and
    the t of every ray–plane pair."""
    t, u, v = plane_hits(vertices, faces, origins, directions)
    inside_by = np.minimum(np.minimum(u, v), 1 - u - v)
    slack = EPS * (1 + np.abs(t))
    with np.errstate(invalid="ignore"):
        strict = (inside_by > EPS) & (t > tmin + slack) & (t < tmax - slack)
        loose = (inside_by > -EPS) & (t > tmin - slack) & (t < tmax + slack)
    return strict, loose, t


@pytest.mark.parametrize("watertight", [False, True])
@pytest.mark.parametrize(
    "options",
    [{}, {"layout": "nodes"}, {"leaves": "list"}, {"quality": "high"},
     {"quality": "high", "leaves": "list"}],
)
def test_intersect_and_occluded_match_brute_force(rng, watertight, options):
    for trial in range(3):
        vertices, faces = random_mesh(rng, n_tris=200 + 100 * trial)
        scene = kdray.Scene(vertices, faces, watertight=watertight, **options)
        origins, directions = random_rays(rng, 2000)
        strict, loose, _ = margins(vertices, faces, origins, directions)
        t_all, u_all, v_all = brute_force(vertices, faces, origins, directions)
        hits = scene.intersect(origins, directions)
        hit = hits.prim >= 0
        rows = np.arange(len(origins))
        # Every ray that surely hits is hit; every hit is a triangle the ray may hit.
        assert np.all(hit[strict.any(axis=1)])
        assert np.all(~hit[~loose.any(axis=1)])
        assert np.all(loose[rows[hit], hits.prim[hit]])
        # The hit is the nearest: its t is the brute force's for that triangle, and no triangle
        # surely hit is nearer.
        t_brute = t_all[rows[hit], hits.prim[hit]]
        np.testing.assert_allclose(hits.t[hit], t_brute, rtol=1e-4, atol=1e-5)
        nearest_strict = np.where(strict, t_all, np.inf).min(axis=1)
        assert np.all(hits.t[hit] <= nearest_strict[hit] * (1 + 1e-4) + 1e-5)
        np.testing.assert_allclose(hits.u[hit], u_all[rows[hit], hits.prim[hit]], atol=1e-3)
        np.testing.assert_allclose(hits.v[hit], v_all[rows[hit], hits.prim[hit]], atol=1e-3)
        assert np.all(np.isinf(hits.t[~hit])) and np.all(hits.t[~hit] > 0)
        # Nearly every ray gets the brute force's own nearest triangle.
        brute_prim = np.where(np.isfinite(t_all).any(axis=1), np.argmin(t_all, axis=1), -1)
        assert np.mean(brute_prim == hits.prim) > 0.99
        assert hit.sum() > 200, "the rays should hit the mesh often"
        occluded = scene.occluded(origins, directions)
        assert np.all(occluded[strict.any(axis=1)])
        assert np.all(~occluded[~loose.any(axis=1)])


def test_intervals_and_unnormalized_directions(rng):
    vertices, faces = random_mesh(rng)
    scene = kdray.Scene(vertices, faces)
    origins, directions = random_rays(rng, 3000)
    tmin = rng.uniform(0.0, 1.0, len(origins)).astype(np.float32)
    tmax = (tmin + rng.uniform(0.0, 2.0, len(origins))).astype(np.float32)
    strict, loose, _ = margins(vertices, faces, origins, directions, tmin[:, None], tmax[:, None])
    hits = scene.intersect(origins, directions, tmin, tmax)
    hit = hits.prim >= 0
    assert np.all(hit[strict.any(axis=1)]) and np.all(~hit[~loose.any(axis=1)])
    assert np.all((hits.t[hit] > tmin[hit]) & (hits.t[hit] < tmax[hit]))
    # The same rays with directions scaled by 1e-3 to 1e3: t in units of the direction.
    scale = (10.0 ** rng.uniform(-3, 3, len(origins))).astype(np.float32)
    scaled = directions * scale[:, None]
    again = scene.intersect(origins, scaled, tmin / scale, tmax / scale, points=True)
    same = again.prim == hits.prim
    assert same.mean() > 0.999
    np.testing.assert_allclose(again.t[same & hit] * scale[same & hit], hits.t[same & hit], rtol=1e-5)
    np.testing.assert_allclose(
        again.points[same & hit],
        origins[same & hit] + hits.t[same & hit, None] * directions[same & hit],
        rtol=1e-4, atol=1e-5,
    )


def test_points_and_normals(rng):
    vertices, faces = random_mesh(rng)
    scene = kdray.Scene(vertices, faces)
    origins, directions = random_rays(rng, 1000)
    hits = scene.intersect(origins, directions, points=True, normals=True)
    hit = hits.prim >= 0
    tri = vertices.astype(np.float64)[faces[hits.prim[hit]]]
    on_plane = tri[:, 0] + hits.u[hit, None] * (tri[:, 1] - tri[:, 0]) + hits.v[hit, None] * (tri[:, 2] - tri[:, 0])
    np.testing.assert_allclose(hits.points[hit], on_plane, atol=1e-4)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    np.testing.assert_allclose(hits.normals[hit], n, atol=1e-4)
    assert np.isnan(hits.points[~hit]).all() and np.isnan(hits.normals[~hit]).all()
    assert scene.intersect(origins, directions).points is None


def test_counts_and_every_hit_match_brute_force(rng):
    vertices, faces = random_mesh(rng, n_tris=400)
    scene = kdray.Scene(vertices, faces)
    origins, directions = random_rays(rng, 2000)
    strict, loose, plane_t = margins(vertices, faces, origins, directions)
    counts = scene.count_intersections(origins, directions)
    assert counts.dtype == np.int64
    assert np.all(counts >= strict.sum(axis=1)) and np.all(counts <= loose.sum(axis=1))
    assert np.mean(counts == strict.sum(axis=1)) > 0.99
    every = scene.intersect_all(origins, directions)
    assert np.array_equal(np.bincount(every.ray, minlength=len(origins)), counts)
    assert np.all(loose[every.ray, every.prim])
    np.testing.assert_allclose(every.t, plane_t[every.ray, every.prim], rtol=1e-4, atol=1e-5)
    # Sorted by ray, then along it.
    assert np.all(np.diff(every.ray) >= 0)
    same_ray = np.diff(every.ray) == 0
    assert np.all(np.diff(every.t)[same_ray] >= 0)
    # Every triangle surely crossed is listed.
    want = set(zip(*np.nonzero(strict)))
    got = set(zip(every.ray.tolist(), every.prim.tolist()))
    assert want <= got
