"""kdray.Instances against a numpy brute force over every placement (each mesh's triangles moved
into the world in float64, every ray against every one), with rotations, shears, mirrors and
scales from 1e-6 to 1e6; and, where the transforms are the identity or translations exact in
float32, bit for bit against one kdray.Scene over all the meshes' triangles.

As in test_brute_force.py, a ray passing within rounding of an edge may get either answer: each
ray is checked against the triangles it hits with a margin (it must hit one of them or nearer)
and those it hits within a tolerance (it may hit only those)."""

import numpy as np
import pytest

import kdray
from conftest import plane_hits, random_mesh

EPS = 1e-5


def world(meshes, transforms):
    """Every placement's triangles in world space (float64): vertices ``(3m, 3)``, faces, and
    per triangle its geometry id, instance id and index in its mesh."""
    verts, geometry, instance, prim = [], [], [], []
    for g, ((v, f), stack) in enumerate(zip(meshes, transforms)):
        for i, m in enumerate(np.asarray(stack, dtype=np.float64).reshape(-1, 4, 4)):
            tri = v.astype(np.float64)[f] @ m[:3, :3].T + m[:3, 3]
            verts.append(tri.reshape(-1, 3))
            geometry += [g] * len(f)
            instance += [i] * len(f)
            prim += list(range(len(f)))
    v = np.concatenate(verts)
    faces = np.arange(len(v)).reshape(-1, 3)
    return v, faces, np.array(geometry), np.array(instance), np.array(prim)


def margins(vertices, faces, origins, directions):
    """Which triangles each ray hits with a margin (strict), within a tolerance (loose), and
    every ray–plane ``t``; the slack on ``t`` is relative, so any scale is judged alike."""
    t, u, v = plane_hits(vertices, faces, origins, directions)
    inside_by = np.minimum(np.minimum(u, v), 1 - u - v)
    with np.errstate(invalid="ignore"):
        strict = (inside_by > EPS) & (t > EPS * np.abs(t))
        loose = (inside_by > -EPS) & (t > -EPS * np.abs(t))
    return strict, loose, t, u, v


def rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def affine(linear, translation):
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = linear, translation
    return m


def rays_through(rng, lo, hi, n):
    """Rays from random points of the box ``lo..hi`` grown by half, towards random points of
    it (float32, unit directions)."""
    size = hi - lo
    o = rng.uniform(lo - size / 2, hi + size / 2, (n, 3))
    d = rng.uniform(lo, hi, (n, 3)) - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return o.astype(np.float32), d.astype(np.float32)


def check_against_brute_force(scene, meshes, transforms, origins, directions, unit=1.0):
    """``unit``: the scene's size; the brute force runs on the world divided by it (its
    parallel test is absolute), and its ``t`` are multiplied back."""
    v, f, geometry, instance, prim = world(meshes, transforms)
    strict, loose, t_all, u_all, v_all = margins(v / unit, f, origins / unit, directions)
    t_all = t_all * unit
    hits = scene.intersect(origins, directions)
    hit = hits.prim >= 0
    assert np.array_equal(hit, hits.geometry_id >= 0) and np.array_equal(hit, hits.instance_id >= 0)
    assert np.all(hit[strict.any(axis=1)]) and np.all(~hit[~loose.any(axis=1)])
    # The world triangle each hit names: one the ray may hit, at the brute force's t, and none
    # surely hit lies nearer.
    key = {(g, i, p): k for k, (g, i, p) in enumerate(zip(geometry, instance, prim))}
    rows = np.flatnonzero(hit)
    k = np.array([key[(hits.geometry_id[r], hits.instance_id[r], hits.prim[r])] for r in rows])
    assert np.all(loose[rows, k])
    # Rounding is relative to the coordinates' magnitude (the scene's size), not to t.
    np.testing.assert_allclose(hits.t[rows], t_all[rows, k], rtol=1e-4, atol=1e-5 * unit)
    nearest = np.where(strict, t_all, np.inf).min(axis=1)
    assert np.all(hits.t[rows] <= nearest[rows] * (1 + 1e-4) + 1e-5 * unit)
    np.testing.assert_allclose(hits.u[rows], u_all[rows, k], atol=1e-3)
    np.testing.assert_allclose(hits.v[rows], v_all[rows, k], atol=1e-3)
    # Nearly every ray gets the brute force's own nearest triangle.
    ours = np.full(len(hit), -1)
    ours[rows] = k
    brute = np.where(loose.any(axis=1), np.argmin(np.where(loose, t_all, np.inf), axis=1), -1)
    assert np.mean(ours == brute) > 0.98
    occluded = scene.occluded(origins, directions)
    assert np.all(occluded[strict.any(axis=1)]) and np.all(~occluded[~loose.any(axis=1)])
    assert hit.sum() > len(hit) // 10, "the rays should hit often"
    return hits


@pytest.mark.parametrize("watertight", [False, True])
def test_rotations_shears_and_mirrors_match_brute_force(rng, watertight):
    meshes = [random_mesh(rng, n_tris=120, n_verts=150) for _ in range(3)]
    transforms = []
    for g in range(3):
        stack = [np.eye(4)]
        for _ in range(3):
            linear = rotation(rng) @ np.diag(rng.uniform(0.5, 2.0, 3))
            if rng.random() < 0.5:
                linear = linear @ np.diag([-1.0, 1.0, 1.0])  # a mirror
            linear[0, 1] += rng.uniform(-0.5, 0.5)  # a shear
            stack.append(affine(linear, rng.uniform(-2, 2, 3)))
        transforms.append(np.stack(stack))
    scene = kdray.Instances(meshes, transforms, watertight=watertight)
    assert len(scene) == 12 and scene.info["instances"] == 12
    origins, directions = rays_through(rng, np.full(3, -3.0), np.full(3, 3.0), 1500)
    check_against_brute_force(scene, meshes, transforms, origins, directions)


@pytest.mark.parametrize("scale", [1e-6, -1e-3, 1e3, -1e6])
def test_huge_tiny_and_negative_scales(rng, scale):
    """Every placement scaled by ``scale`` (negative: a point reflection), the rays with them:
    the answers scale with the scene."""
    meshes = [random_mesh(rng, n_tris=150, n_verts=200) for _ in range(2)]
    transforms = [
        np.stack([affine(scale * rotation(rng), scale * rng.uniform(-1, 1, 3)) for _ in range(2)])
        for _ in meshes
    ]
    scene = kdray.Instances(meshes, transforms)
    lo, hi = np.full(3, -2.0 * abs(scale)), np.full(3, 2.0 * abs(scale))
    origins, directions = rays_through(rng, lo, hi, 1500)
    hits = check_against_brute_force(scene, meshes, transforms, origins, directions, abs(scale))
    assert np.all(hits.t[hits.prim >= 0] < 10 * abs(scale))


def test_points_and_normals_are_the_world_triangles(rng):
    mesh = random_mesh(rng, n_tris=100, n_verts=120)
    mirror = affine(np.diag([-1.0, 2.0, 0.5]) @ rotation(rng), [0.5, 0, 0])
    scene = kdray.Instances([mesh], [np.stack([np.eye(4), mirror])])
    origins, directions = rays_through(rng, np.full(3, -2.0), np.full(3, 2.0), 1000)
    hits = scene.intersect(origins, directions, points=True, normals=True)
    hit = hits.prim >= 0
    expected = origins[hit] + hits.t[hit, None].astype(np.float64) * directions[hit]
    np.testing.assert_allclose(hits.points[hit], expected, rtol=1e-5, atol=1e-5)
    assert np.all(np.isnan(hits.points[~hit])) and np.all(np.isnan(hits.normals[~hit]))
    v, f, _, _, _ = world([mesh], [np.stack([np.eye(4), mirror])])
    k = hits.instance_id[hit] * len(mesh[1]) + hits.prim[hit]  # the world triangle hit
    tri = v[f[k]]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # e1 × e2 as placed
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    np.testing.assert_allclose(hits.normals[hit], n, atol=1e-4)


def grid_mesh(rng, n_tris):
    """Random triangles whose coordinates are multiples of 1/64 in [-2, 2]: exact in float32
    after any integer translation below 2^16."""
    v, f = random_mesh(rng, n_tris=n_tris, n_verts=n_tris + 50, scale=2.0)
    return (np.round(v * 64) / 64).astype(np.float32), f


@pytest.mark.parametrize("watertight", [False, True])
def test_identity_and_exact_translations_are_bit_identical_to_one_merged_scene(rng, watertight):
    meshes = [grid_mesh(rng, 200) for _ in range(4)]
    transforms = [None, affine(np.eye(3), [3, 0, 0]),
                  np.stack([affine(np.eye(3), [0, -3, 1]), affine(np.eye(3), [-2, 2, 2])]),
                  affine(np.eye(3), [1, 1, -3])]
    scene = kdray.Instances(meshes, transforms, watertight=watertight)
    placed = [np.eye(4)[None] if x is None else x for x in transforms]
    v, f, geometry, instance, prim = world(meshes, placed)
    assert np.array_equal(v.astype(np.float32), v)  # the sums are exact in float32
    merged = kdray.Scene(v.astype(np.float32), f, watertight=watertight)
    # Origins on a grid of 2^-12 too, so that moving them into a placement is exact.
    origins, directions = rays_through(rng, np.full(3, -5.0), np.full(3, 5.0), 20000)
    origins = (np.round(origins * 4096) / 4096).astype(np.float32)
    # Unit directions and directions of other lengths (traced normalized, t scaled back).
    lengths = np.where(rng.random(len(directions)) < 0.3, rng.uniform(0.1, 10, len(directions)), 1)
    directions = (directions * lengths[:, None]).astype(np.float32)
    ours, theirs = scene.intersect(origins, directions), merged.intersect(origins, directions)
    assert np.array_equal(ours.t.view(np.uint32), theirs.t.view(np.uint32))
    hit = theirs.prim >= 0
    assert hit.sum() > 5000
    assert np.array_equal(ours.prim >= 0, hit)
    # Our triangle's index in the merged mesh, beside the one the merged walk named.
    index = {key: k for k, key in enumerate(zip(geometry, instance, prim))}
    named = np.array([index[key] for key in zip(ours.geometry_id[hit], ours.instance_id[hit],
                                                 ours.prim[hit])])
    same = named == theirs.prim[hit]
    # Where the two walks name different triangles, ours is hit at that same t too: a tie
    # (a ray through an edge the two share), which either walk may take, as the wide walk's
    # parts of one leaf and another tree's leaves meet them in other orders
    # (tests/tests/instances.rs checks the same of the core).
    assert (~same).sum() < hit.sum() / 200
    for ray, k in zip(np.flatnonzero(hit)[~same], named[~same]):
        alone = kdray.Scene(v[f[k]].astype(np.float32), watertight=watertight)
        t = alone.intersect(origins[ray], directions[ray]).t
        assert t.view(np.uint32) == ours.t[ray].view(np.uint32), f"ray {ray}: not a tie"
    both = np.flatnonzero(hit)[same]
    assert np.array_equal(ours.u[both].view(np.uint32), theirs.u[both].view(np.uint32))
    assert np.array_equal(ours.v[both].view(np.uint32), theirs.v[both].view(np.uint32))
    assert np.array_equal(scene.occluded(origins, directions), merged.occluded(origins, directions))
    # One ray at a time, as the batches.
    for r in range(0, 20000, 997):
        one = scene.raycast(origins[r], directions[r])
        assert np.float32(one[0]).view(np.uint32) == ours.t[r].view(np.uint32)
        assert one[1:] == (ours.prim[r], ours.u[r], ours.v[r], ours.geometry_id[r],
                           ours.instance_id[r])


def test_threads_and_batch_sizes_give_the_same_answers(rng):
    meshes = [random_mesh(rng, n_tris=150) for _ in range(3)]
    transforms = [np.stack([affine(rotation(rng), rng.uniform(-2, 2, 3)) for _ in range(4)])
                  for _ in meshes]
    scene = kdray.Instances(meshes, transforms)
    origins, directions = rays_through(rng, np.full(3, -3.0), np.full(3, 3.0), 50000)
    every = scene.intersect(origins, directions)
    one = scene.intersect(origins, directions, threads=1)
    for x, y in zip(every[:6], one[:6]):
        assert np.array_equal(x, y)
    for k in (0, 49000):
        part = scene.intersect(origins[k:k + 1000], directions[k:k + 1000])  # on this thread
        for x, y in zip(part[:6], every[:6]):
            assert np.array_equal(x, y[k:k + 1000])
    assert np.array_equal(scene.occluded(origins, directions, threads=1),
                          scene.occluded(origins, directions))
    # Python threads sharing the scene (each call releases the GIL), chunk by chunk.
    from concurrent.futures import ThreadPoolExecutor

    chunks = np.array_split(np.arange(len(origins)), 8)
    with ThreadPoolExecutor(4) as pool:
        parts = list(pool.map(lambda c: scene.intersect(origins[c], directions[c], threads=1),
                              chunks))
    for k, field in enumerate(every[:6]):
        assert np.array_equal(np.concatenate([p[k] for p in parts]), field)


@pytest.mark.parametrize("watertight", [False, True])
def test_merge_answers_as_the_two_level_walk_bit_for_bit(rng, watertight):
    """``merge=True``: one tree over every mesh placed once by the identity (a mesh given as a
    Scene whose tree stores its triangles out of input order among them), the same answers as
    the two-level walk; other placements fall back to the walk."""
    meshes = [random_mesh(rng, n_tris=150) for _ in range(3)]
    meshes[1] = kdray.Scene(*meshes[1], leaves="groups", quality="high")
    walk = kdray.Instances(meshes, watertight=watertight)
    merged = kdray.Instances(meshes, watertight=watertight, merge=True)
    assert merged.info["merged"] and not walk.info["merged"]
    origins, directions = rays_through(rng, np.full(3, -1.5), np.full(3, 1.5), 20000)
    directions[::3] *= 3.0  # some not of unit length

    def agree():
        a = walk.intersect(origins, directions, points=True, normals=True)
        b = merged.intersect(origins, directions, points=True, normals=True)
        for x, y in zip(a[:6], b[:6]):
            assert np.array_equal(x, y)
        grid = merged.intersect(origins.reshape(100, -1, 3), directions.reshape(100, -1, 3))
        for x, y in zip(grid[:6], b[:6]):
            assert x.shape == (100, 200) and np.array_equal(x.ravel(), y)
        np.testing.assert_allclose(a.points, b.points, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(a.normals, b.normals, atol=1e-6)
        assert np.array_equal(walk.occluded(origins, directions),
                              merged.occluded(origins, directions))
        for r in range(0, len(origins), 1999):
            assert walk.raycast(origins[r], directions[r]) == merged.raycast(origins[r],
                                                                             directions[r])
        return a

    assert (agree().geometry_id >= 0).sum() > 5000
    turned = affine(rotation(rng), [0.5, 0, 0])
    for scene in (walk, merged):
        scene.set_transforms(2, turned)
    assert not merged.info["merged"]
    agree()
    small = random_mesh(rng, n_tris=50)
    for scene in (walk, merged):
        scene.remove_mesh(2)
        scene.add_mesh(small)
    assert merged.info["merged"] and merged.geometry_ids == [0, 1, 3]
    agree()


def test_merged_ids_refuse_ranges_that_do_not_ascend_from_zero():
    """The merged answers' naming refuses mesh ranges it cannot search, and names a triangle
    by its mesh and its index there."""
    ids = np.array([7, 9], dtype=np.int64)
    for first in ([1, 2, 3], [0, 3, 2], [0, 3]):
        with pytest.raises(ValueError, match="ascend from 0"):
            kdray._kdray.merged_ids(np.zeros(2, dtype=np.int64),
                                    np.array(first, dtype=np.int64), ids)
    prim = np.array([-1, 0, 2, 3, 4], dtype=np.int64)
    g, i = kdray._kdray.merged_ids(prim, np.array([0, 3, 5], dtype=np.int64), ids)
    assert prim.tolist() == [-1, 0, 2, 0, 1]
    assert g.tolist() == [-1, 7, 7, 9, 9] and i.tolist() == [-1, 0, 0, 0, 0]
