"""The two walks behind ``intersect`` (python/src/closest.rs): rays that come in coherent packets
as given — a camera's tiles — are traced as packets of consecutive rays (``kdray trace
--packet 8``), other rays through the core's ray stream (``kdray trace --stream``). Either way the
answers are the single-ray walk's; rays are checked as they are traced, and a refused batch says
what the checks before tracing said; directions of unit length are traced as given."""

import numpy as np
import pytest

import kdray
from conftest import brute_force, random_mesh, random_rays
from test_brute_force import margins


def camera_rays(width, height, eye=(0.2, -0.3, 3.0)):
    """A pinhole's rays towards the origin, 60° field of view, in 4×2 pixel tiles (8 consecutive
    rays are one tile, as ``kdray rays`` orders them), unit float32 directions."""
    eye = np.asarray(eye, np.float64)
    forward = -eye / np.linalg.norm(eye)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half = np.tan(np.radians(30.0))
    ty, tx, y, x = np.meshgrid(
        np.arange(height // 2), np.arange(width // 4), np.arange(2), np.arange(4), indexing="ij"
    )
    px = (4 * tx + x + 0.5) / width * 2 - 1
    py = 1 - (2 * ty + y + 0.5) / height * 2
    d = forward + half * (px[..., None] * right + py[..., None] * up)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    directions = d.reshape(-1, 3).astype(np.float32)
    origins = np.broadcast_to(eye.astype(np.float32), directions.shape).copy()
    return origins, directions


@pytest.fixture
def scene_and_mesh(rng):
    vertices, faces = random_mesh(rng, n_tris=600)
    return kdray.Scene(vertices, faces), vertices, faces


@pytest.mark.parametrize("watertight", [False, True])
def test_camera_tiles_and_shuffled_rays_give_the_same_answers(rng, watertight):
    vertices, faces = random_mesh(rng, n_tris=600)
    scene = kdray.Scene(vertices, faces, watertight=watertight)
    origins, directions = camera_rays(256, 128)
    tiles = scene.intersect(origins, directions, points=True)
    # The same rays out of order: no run of 8 shares an octant by chance, so the stream traces
    # them (and its packets are other groups of rays).
    order = rng.permutation(len(origins))
    shuffled = scene.intersect(origins[order], directions[order], points=True)
    for a, b in zip(tiles, shuffled):
        if a is not None:
            np.testing.assert_array_equal(a[order], b)
    # And one at a time: the single-ray walk.
    for i in range(0, len(origins), 331):
        assert scene.raycast(origins[i], directions[i]) == (
            tiles.t[i], tiles.prim[i], tiles.u[i], tiles.v[i])
    hit = tiles.prim >= 0
    assert 0.1 < hit.mean() < 0.95, "the camera should see the mesh and around it"


def test_camera_tiles_match_brute_force(scene_and_mesh):
    scene, vertices, faces = scene_and_mesh
    origins, directions = camera_rays(64, 64)
    hits = scene.intersect(origins, directions)
    strict, loose, _ = margins(vertices, faces, origins, directions)
    t_all, _, _ = brute_force(vertices, faces, origins, directions)
    hit = hits.prim >= 0
    rows = np.arange(len(origins))
    assert np.all(hit[strict.any(axis=1)]) and np.all(~hit[~loose.any(axis=1)])
    assert np.all(loose[rows[hit], hits.prim[hit]])
    np.testing.assert_allclose(hits.t[hit], t_all[rows[hit], hits.prim[hit]], rtol=1e-4, atol=1e-5)


def test_a_batch_of_tiles_then_scattered_rays(rng, scene_and_mesh):
    # One piece of the batch switches from packets to the stream part way.
    scene = scene_and_mesh[0]
    o1, d1 = camera_rays(64, 32)
    o2, d2 = random_rays(rng, 3000)
    origins, directions = np.concatenate([o1, o2]), np.concatenate([d1, d2])
    both = scene.intersect(origins, directions)
    apart = [scene.intersect(o1, d1), scene.intersect(o2, d2)]
    for k, field in enumerate(both):
        if field is not None:
            np.testing.assert_array_equal(field, np.concatenate([apart[0][k], apart[1][k]]))


@pytest.mark.parametrize("threads", [1, 2])
def test_a_bad_ray_deep_in_a_batch_is_named_as_before_tracing(scene_and_mesh, threads):
    scene = scene_and_mesh[0]
    origins, directions = camera_rays(256, 256)
    n = len(origins)
    tmax = np.full(n, np.inf, np.float32)
    # Two problems: the checks name the origins' first, wherever the other is.
    tmax[1000] = np.nan
    bad = origins.copy()
    bad[n - 5, 1] = np.inf
    with pytest.raises(ValueError, match=rf"origins\[{n - 5}\] is \(.*inf.*\)"):
        scene.intersect(bad, directions, 0.0, tmax, threads=threads)
    with pytest.raises(ValueError, match=r"tmax\[1000\] is nan"):
        scene.intersect(origins, directions, 0.0, tmax, threads=threads)
    zero = directions.copy()
    zero[40000] = 0.0
    with pytest.raises(ValueError, match=r"directions\[40000\] is zero"):
        scene.intersect(origins, zero, threads=threads)
    tmin = np.zeros(n, np.float32)
    tmin[n - 1] = 1.0
    with pytest.raises(ValueError, match=rf"ray {n - 1}: tmin 1 is above tmax 0.5"):
        scene.intersect(origins, directions, tmin, 0.5, threads=threads)
    # The scene still works.
    assert scene.intersect(origins[:10], directions[:10]).t.shape == (10,)


@pytest.mark.parametrize("stretch", [2.0**-22, 2.0**-16, 1.0])
def test_t_is_in_units_of_the_direction_near_unit_length(scene_and_mesh, stretch):
    # A direction whose squared length is within 2^-20 of 1 (stretch 2^-22) is traced as it is,
    # as `kdray trace` traces it, `t` not rescaled; one further from unit length (2^-16, and
    # twice as long) is normalized and `t` scaled back. Either way `t` is in units of the
    # direction given.
    scene = scene_and_mesh[0]
    origins, directions = camera_rays(64, 64)
    longer = (directions * (1 + stretch)).astype(np.float32)
    a, b = scene.intersect(origins, directions), scene.intersect(origins, longer)
    same = (a.prim == b.prim) & (a.prim >= 0)
    assert np.mean(a.prim == b.prim) > 0.999 and same.sum() > 500
    scale = np.linalg.norm(longer.astype(np.float64), axis=1) / np.linalg.norm(
        directions.astype(np.float64), axis=1)
    # (Rounding: a few units in the last place, more on grazing rays; a missed rescaling by
    # 1 + 2^-16 would be 1.5e-5.)
    np.testing.assert_allclose(b.t[same] * scale[same], a.t[same], rtol=5e-6)


def test_packets_read_from_broadcast_rows_and_mixed_lengths_match_single_rays(scene_and_mesh):
    # The packet path reads each packet from the arrays into lanes: one origin and one tmin/tmax
    # for every ray (broadcast, not copied), every third packet's directions stretched (converted
    # ray by ray then) and one ray's in another packet, and a batch that ends part way through a
    # packet. Each answer is the single-ray walk's on the same ray.
    scene = scene_and_mesh[0]
    origins, directions = camera_rays(64, 32)
    directions = directions[:-3].copy()
    for k in range(0, len(directions), 24):
        directions[k:k + 8] *= np.float32(2.0)
    directions[13] *= np.float32(3.0)
    tmin, tmax = np.float32(0.5), np.float32(40.0)
    hits = scene.intersect(origins[0], directions, tmin, tmax)
    assert hits.t.shape == (len(directions),) and (hits.prim >= 0).mean() > 0.1
    for i in list(range(0, len(directions), 37)) + [len(directions) - 1]:
        assert scene.raycast(origins[0], directions[i], tmin, tmax) == (
            hits.t[i], hits.prim[i], hits.u[i], hits.v[i])
    rows = np.broadcast_to(origins[0], directions.shape).copy()
    full = scene.intersect(rows, directions, np.full(len(rows), tmin), np.full(len(rows), tmax))
    for a, b in zip(hits, full):
        if a is not None:
            np.testing.assert_array_equal(a, b)


def test_the_build_names_its_instruction_set():
    assert kdray.ISA in {"avx512f", "avx2+fma", "avx2", "avx", "sse4.1", "sse2", "neon", "scalar"}


@pytest.mark.parametrize("length", [1e-30, 1e-37, 2e-38, 1e-38, 1e-40, 1e-45])
def test_a_hit_has_a_finite_t_whatever_the_directions_length(length):
    # Issue 39: a direction of length 1e-38 reported triangle 0 at t = inf (and NaN points). A
    # hit's t, in lengths of the direction, is finite; a hit that would lie past f32's range is
    # a miss.
    vertices = np.array([[-1, -1, 0], [3, -1, 0], [-1, 3, 0]], np.float32)
    scene = kdray.Scene(vertices, np.array([[0, 1, 2]], np.uint32))
    origin = np.array([0, 0, 1], np.float32)
    hit = scene.intersect(origin, np.array([0, 0, -length], np.float32), points=True)
    assert hit.prim < 0 or (np.isfinite(hit.t) and np.all(np.isfinite(hit.points)))
    if length >= 1e-37:
        assert hit.prim == 0
        np.testing.assert_allclose(hit.t, 1 / np.float64(np.float32(length)), rtol=1e-6)
