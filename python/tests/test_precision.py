"""Issue 39, item 14: float64 data far from the origin (UTM-like coordinates, 5·10⁶, where
float32's spacing is 0.5) traced around an `origin` the package subtracts in float64 gets the
float64 answers; without one, rays hit or miss otherwise (the rounding the docs describe)."""

import numpy as np

import kdray
import kdray.trimesh
from conftest import brute_force

X0 = np.array([5.0e6, 4.2e6, 120.0])  # metres, as UTM easting and northing


def far_mesh(rng):
    """400 small triangles (about 0.5 m) scattered over 10 m × 10 m at X0, in float64."""
    centres = rng.uniform(0, 10, (400, 3)) * [1, 1, 0]
    v = (centres[:, None, :] + rng.uniform(-0.5, 0.5, (400, 3, 3)) * [1, 1, 0.1]).reshape(-1, 3)
    return v + X0, np.arange(1200).reshape(400, 3)


def rays_and_reference(rng, v, f):
    """Rays straight down onto the mesh from 5 m above, float64, and the float64 brute force's
    closest triangles and crossings; rays within 1e-4 m (barycentric) of an edge are left out: they are the
    rounding's, whatever the origin."""
    o = np.column_stack([rng.uniform(0, 10, (3000, 2)), np.full(3000, 5.0)]) + X0
    d = np.array([[0.0, 0.0, -1.0]]).repeat(3000, axis=0)
    t, u, w = brute_force(v - X0, f, o - X0, d)  # translating in float64 is exact enough here
    closest = np.where(np.isfinite(t).any(axis=1), np.argmin(t, axis=1), -1)
    margin = np.minimum(np.minimum(u, w), 1 - u - w)
    near_edge = (np.abs(margin) < 1e-4 * 1 / 0.3).any(axis=1)
    return o, d, closest, ~near_edge, np.isfinite(t).sum(axis=1)


def test_an_origin_gives_the_float64_answers_far_from_zero():
    rng = np.random.default_rng(14)
    v, f = far_mesh(rng)
    o, d, ref, clear, crossings = rays_and_reference(rng, v, f)
    assert (ref[clear] >= 0).sum() > 300  # enough hits to tell
    plain = kdray.Scene(v, f).intersect(o, d).prim
    for origin in ("auto", X0, X0 + [3.0, -2.0, 1.0]):
        scene = kdray.Scene(v, f, origin=origin)
        hits = scene.intersect(o, d, points=True)
        assert (hits.prim[clear] == ref[clear]).all(), origin
        hit = hits.prim >= 0
        # points in the caller's coordinates, float64
        assert hits.points.dtype == np.float64
        assert np.allclose(hits.points[hit][:, :2], o[hit][:, :2], atol=1e-3)
        assert (scene.count_intersections(o, d)[clear] == crossings[clear]).all()
        assert (scene.occluded(o, d)[clear] == (ref[clear] >= 0)).all()
        assert np.allclose(np.array(scene.info["bounds"]), [v.min(0), v.max(0)], atol=1e-3)
        one = scene.raycast(o[0], d[0])
        assert one[1] == hits.prim[0]
    # Without an origin the mesh and rays are rounded by up to 0.25 m: many rays disagree.
    assert (plain[clear] != ref[clear]).sum() > 100


def test_a_saved_tree_takes_its_origin_back():
    rng = np.random.default_rng(15)
    v, f = far_mesh(rng)
    o, d, ref, clear, _ = rays_and_reference(rng, v, f)
    scene = kdray.Scene(v, f, origin="auto")
    again = kdray.Scene.from_bytes(scene.to_bytes(), origin=scene.origin)
    assert (again.intersect(o, d).prim == scene.intersect(o, d).prim).all()


class _Mesh:
    def __init__(self, v, f):
        self.vertices, self.faces = v, f

    def __hash__(self):
        return 2


def test_the_trimesh_adapter_recentres_float64_meshes():
    rng = np.random.default_rng(16)
    v, f = far_mesh(rng)
    o, d, ref, clear, _ = rays_and_reference(rng, v, f)
    r = kdray.trimesh.RayMeshIntersector(_Mesh(v, f))
    assert (r.intersects_first(o, d)[clear] == ref[clear]).all()
