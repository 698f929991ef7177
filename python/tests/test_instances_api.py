"""kdray.Instances as a user meets it: meshes added, moved and removed (ids stable, answers those
of a scene built afresh), shared Scenes, pickling, the errors for bad transforms and rays, an
empty scene, and kdray.trimesh.instances on a trimesh.Scene (against a brute force over its
meshes placed by its graph)."""

import copy
import pickle

import numpy as np
import pytest

import kdray
from conftest import brute_force, random_mesh, tetrahedron


def same(a, b):
    return all(np.array_equal(x, y) for x, y in zip(a[:6], b[:6]))


def shifted(x, y=0.0, z=0.0):
    m = np.eye(4)
    m[:3, 3] = x, y, z
    return m


@pytest.fixture
def rays(rng):
    o = rng.uniform(-4, 4, (3000, 3)).astype(np.float32)
    d = rng.uniform(-1, 1, (3000, 3)).astype(np.float32) - o / 4
    return o, (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


def test_add_move_remove_answer_as_a_scene_built_afresh(rng, rays):
    a, b, c = (random_mesh(rng, n_tris=100) for _ in range(3))
    scene = kdray.Instances([a, b], [shifted(-1.5), None])
    assert scene.add_mesh(c, np.stack([shifted(1.5), shifted(0, 2)])) == 2
    assert scene.geometry_ids == [0, 1, 2] and len(scene) == 4
    two = np.stack([shifted(1.5), shifted(0, 2)])
    fresh = kdray.Instances([a, b, c], [shifted(-1.5), None, two])
    assert same(scene.intersect(*rays), fresh.intersect(*rays))
    scene.set_transforms(1, np.stack([shifted(0, 0, 1), shifted(0, 0, -1), shifted(2, 2, 2)]))
    fresh = kdray.Instances(
        [a, b, c],
        [shifted(-1.5), np.stack([shifted(0, 0, 1), shifted(0, 0, -1), shifted(2, 2, 2)]),
         np.stack([shifted(1.5), shifted(0, 2)])],
    )
    assert same(scene.intersect(*rays), fresh.intersect(*rays))
    assert scene.intersect(*rays).instance_id.max() == 2
    scene.remove_mesh(0)
    assert scene.geometry_ids == [1, 2]
    hits = scene.intersect(*rays)
    assert set(np.unique(hits.geometry_id)) <= {-1, 1, 2}
    assert scene.add_mesh(a) == 3  # ids are never reused
    np.testing.assert_array_equal(scene.transforms(3), np.eye(4)[None])
    np.testing.assert_array_equal(scene.transforms(2)[1], shifted(0, 2))
    with pytest.raises(KeyError, match="no geometry 0"):
        scene.set_transforms(0, None)


def test_a_scene_is_shared_not_rebuilt_and_its_origin_is_kept(rng, rays):
    v, f = random_mesh(rng, n_tris=100)
    v = (np.round(v * 1024) / 1024).astype(np.float32)  # v + 1000 exact in float32
    far = kdray.Scene(v + np.float32(1000), f, origin="auto")  # built around its centre
    near = kdray.Scene(v, f)
    scene = kdray.Instances([near, far], [None, shifted(-1000, -1000, -1000)])
    assert scene.mesh(0) is near
    hits = scene.intersect(*rays)
    alone = near.intersect(*rays)
    # The far copy, moved back, lies on the near one: the same t (but for rounding in other
    # coordinates) wherever the near one alone is hit.
    hit = alone.prim >= 0
    np.testing.assert_allclose(hits.t[hit], alone.t[hit], rtol=1e-5, atol=1e-5)
    assert np.mean((hits.prim >= 0) == hit) > 0.99


def test_pickle_and_copy_answer_the_same(rng, rays):
    meshes = [random_mesh(rng, n_tris=80) for _ in range(3)]
    scene = kdray.Instances(meshes, [shifted(-1), None, np.stack([shifted(1), shifted(0, 1)])],
                            watertight=True)
    scene.remove_mesh(1)
    want = scene.intersect(*rays)
    for protocol in (2, 5):
        back = pickle.loads(pickle.dumps(scene, protocol=protocol))
        assert back.geometry_ids == [0, 2] and back.watertight
        assert same(back.intersect(*rays), want)
        assert back.add_mesh(meshes[1]) == 3
    for other in (copy.copy(scene), copy.deepcopy(scene)):
        assert same(other.intersect(*rays), want)
    with pytest.raises(ValueError, match="pickled kdray.Instances"):
        kdray._instances._restore([0], [], [], 1, False)


@pytest.mark.parametrize(
    "transform, message",
    [
        (np.zeros((4, 4)), "geometry 0, instance 0: the last row"),
        (np.diag([1.0, 1.0, 0.0, 1.0]), "geometry 0, instance 0: the transform is singular"),
        (np.array([[1, 2, 3, 0], [2, 4, 6.000001, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]]),
         "singular"),
        (np.diag([1.0, np.nan, 1.0, 1.0]), "instance 0: the transform is not finite"),
        (shifted(np.inf), "not finite"),
        (np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0.5, 1.0]]), "projective"),
        (shifted(1e39), "past float32's range"),
        (np.diag([3e38, 3e38, 3e38, 1.0]) + shifted(3e38) - np.eye(4), "beyond float32's range"),
        (np.eye(3), r"shape \(4, 4\), \(3, 4\)"),
        (np.eye(4)[None, None], "shape"),
    ],
)
def test_bad_transforms_are_value_errors_naming_the_instance(transform, message):
    mesh = tetrahedron()
    with pytest.raises(ValueError, match=message):
        kdray.Instances([mesh], [transform])
    scene = kdray.Instances([mesh, mesh])
    stacked = transform.shape == (4, 4)  # placed second, after the identity
    second = message.replace("geometry 0", "geometry 1")
    with pytest.raises(ValueError, match=second.replace("instance 0", "instance 1")
                       if stacked else second):
        scene.set_transforms(1, np.stack([np.eye(4), transform]) if stacked else transform)
    # Nothing changed.
    np.testing.assert_array_equal(scene.transforms(1), np.eye(4)[None])
    assert scene.raycast((0.1, 0.1, 5), (0, 0, -1))[4] in (0, 1)


def test_moving_every_placement_refits_and_answers_as_a_scene_built_afresh(rng):
    """The same placements moved (set_transforms with as many) refit the top level: the same
    answers as a scene built afresh with the new placements, frame after frame; a bad transform
    then is refused naming it, and changes nothing."""
    mesh, other = random_mesh(rng, n_tris=60), random_mesh(rng, n_tris=40)
    # 12 x 12 placements, apart (the random meshes fit in 2 units), so no two tie on a ray.
    grid = [(x, y) for x in range(12) for y in range(12)]

    def field(frame):
        m = np.stack([shifted(3.0 * x + 0.1 * frame, 3.0 * y, 0.05 * frame * x) for x, y in grid])
        turn = 0.2 * frame
        m[:, 0, :2] = [np.cos(turn), -np.sin(turn)]
        m[:, 1, :2] = [np.sin(turn), np.cos(turn)]
        return m

    o = np.column_stack([rng.uniform(-2, 36, 5000), rng.uniform(-2, 36, 5000),
                         np.full(5000, 6.0)]).astype(np.float32)
    d = np.tile(np.float32([0.05, -0.03, -1.0]), (5000, 1))
    scene = kdray.Instances([other, mesh], [shifted(-5), field(0)])
    for frame in range(1, 4):
        scene.set_transforms(1, field(frame))
        fresh = kdray.Instances([other, mesh], [shifted(-5), field(frame)])
        got = scene.intersect(o, d)
        assert same(got, fresh.intersect(o, d))
        assert (got.geometry_id == 1).sum() > 200
        assert np.array_equal(scene.occluded(o, d), fresh.occluded(o, d))
    before = scene.intersect(o, d)
    bad = field(5)
    bad[37, :3, :3] = 0.0
    with pytest.raises(ValueError, match="geometry 1, instance 37: the transform is singular"):
        scene.set_transforms(1, bad)
    assert same(scene.intersect(o, d), before)
    np.testing.assert_array_equal(scene.transforms(1)[:, :3], field(3)[:, :3].astype(np.float32))


def test_bad_arguments(rays):
    mesh = tetrahedron()
    with pytest.raises(TypeError, match="must hold numbers"):
        kdray.Instances([mesh], [np.array([["a"] * 4] * 4)])
    with pytest.raises(ValueError, match="2 entries of transforms for 1 meshes"):
        kdray.Instances([mesh], [None, None])
    with pytest.raises(TypeError, match="a mesh must be a kdray.Scene"):
        kdray.Instances([np.zeros((3, 3))])
    with pytest.raises(TypeError, match="geometry_id must be an int"):
        kdray.Instances([mesh]).remove_mesh("0")
    scene = kdray.Instances([mesh])
    with pytest.raises(ValueError, match=r"origins\[1\] is"):
        scene.intersect([[0, 0, 0], [np.nan, 0, 0]], [1, 0, 0])
    with pytest.raises(ValueError, match=r"directions\[0\] is zero"):
        scene.occluded([0, 0, 0], [0, 0, 0])
    with pytest.raises(ValueError, match="tmin"):
        scene.raycast((0, 0, 0), (1, 0, 0), tmin=np.inf)
    with pytest.raises(TypeError, match="origin must be 3 numbers"):
        scene.raycast((0, 0), (1, 0, 0))


def test_a_scene_without_placements_misses_and_still_checks_rays(rays):
    scene = kdray.Instances([tetrahedron()], [np.zeros((0, 4, 4))])
    assert len(scene) == 0 and scene.info["bounds"] is None
    hits = scene.intersect(*rays, points=True)
    assert np.all(np.isinf(hits.t)) and np.all(hits.geometry_id == -1)
    assert hits.points.shape == (3000, 3) and not scene.occluded(*rays).any()
    assert scene.raycast((0, 0, 5), (0, 0, -1)) == (np.inf, -1, 0.0, 0.0, -1, -1)
    with pytest.raises(ValueError, match=r"directions\[0\] is zero"):
        scene.intersect([0, 0, 0], [0, 0, 0])
    scene.set_transforms(0, None)
    assert scene.raycast((0.1, 0.1, 5), (0, 0, -1))[4:] == (0, 0)


def test_trimesh_scene(rng):
    trimesh = pytest.importorskip("trimesh")
    import kdray.trimesh

    scene = trimesh.Scene()
    box, ball = trimesh.creation.box(), trimesh.creation.icosphere(subdivisions=2)
    scene.add_geometry(box, geom_name="box", node_name="box-a")
    turned = trimesh.transformations.rotation_matrix(0.3, [1, 1, 0]) @ shifted(2)
    scene.add_geometry(ball, geom_name="ball", node_name="ball-a", transform=turned)
    for k, name in enumerate(["box-b", "box-c"]):
        m = trimesh.transformations.rotation_matrix(0.5 + k, [0, 1, 1])
        m[:3, :3] *= 0.5 * (k + 1)
        m[:3, 3] = (-2, k, 1)
        scene.graph.update(frame_to=name, geometry="box", matrix=m)
    scene.add_geometry(trimesh.PointCloud(rng.random((5, 3))), geom_name="dots")
    found = kdray.trimesh.instances(scene)
    assert found.geometry_names == ["box", "ball"]
    assert sorted(found.node_names[0]) == ["box-a", "box-b", "box-c"]
    assert found.node_names[1] == ["ball-a"] and len(found.instances) == 4
    # The brute force over trimesh's own world meshes, one per node.
    nodes = [(g, i, n) for g, names in enumerate(found.node_names) for i, n in enumerate(names)]
    tris, label = [], []
    for g, i, n in nodes:
        m, name = scene.graph[n]
        mesh = scene.geometry[name]
        tris.append(trimesh.transform_points(mesh.vertices, m)[mesh.faces])
        label += [(g, i, p) for p in range(len(mesh.faces))]
    tris = np.concatenate(tris)
    o = rng.uniform(-4, 4, (2000, 3))
    d = rng.uniform(-1, 1, (2000, 3)) - o / 3
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t_all, _, _ = brute_force(tris.reshape(-1, 3), np.arange(3 * len(tris)).reshape(-1, 3), o, d)
    nearest = np.argmin(t_all, axis=1)
    hit_brute = np.isfinite(t_all.min(axis=1))
    hits = found.instances.intersect(o, d)
    assert np.mean((hits.prim >= 0) == hit_brute) > 0.99 and hit_brute.sum() > 300
    both = np.flatnonzero((hits.prim >= 0) & hit_brute)
    ours = list(zip(hits.geometry_id[both], hits.instance_id[both], hits.prim[both]))
    theirs = [label[k] for k in nearest[both]]
    assert np.mean([a == b for a, b in zip(ours, theirs)]) > 0.99
    np.testing.assert_allclose(hits.t[both], t_all[both, nearest[both]], rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("call", ["intersect", "occluded"])
def test_ctrl_c_stops_a_long_batch(call):
    """As test_interrupt.py for Scene: a call that would run for hours (2,000 placements of one
    triangle, all on one spot, whose boxes every ray enters and whose triangle it misses) stops
    with KeyboardInterrupt, and the scene goes on answering."""
    from child import run

    out = run(
        f"""
        import os, signal, threading
        import numpy as np, kdray
        tri = ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
        scene = kdray.Instances([tri], [np.tile(np.eye(4), (2000, 1, 1))])
        o = np.broadcast_to(np.float32([0.9, 0.9, -1]), (5_000_000, 3))  # 10¹⁰ bottom walks
        d = np.float32([0, 0, 1])
        threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT)).start()
        answered = False
        try:
            scene.{call}(o, d)
            answered = True
        except KeyboardInterrupt:
            print("interrupted")
        assert not answered
        assert scene.raycast((0.2, 0.2, -1), (0, 0, 1))[0] == 1.0
        print("ok")
        """,
        timeout=120,
    )
    assert "interrupted" in out and out.strip().endswith("ok"), out


def test_memory_limits_raise_memory_error():
    """As test_memory.py for Scene: under an address-space limit, a batch whose answers do not
    fit raises MemoryError naming the call, and the scene goes on answering."""
    from child import run

    out = run(
        """
        import resource
        import numpy as np, kdray
        scene = kdray.Instances([(layers(4), None)], [np.tile(np.eye(4), (3, 1, 1))])
        o = np.array([0.25, 0.25, -1], np.float32)
        d = np.array([0, 0, 1], np.float32)
        assert scene.intersect(np.tile(o, (5000, 1)), d).t.max() == 1  # pools exist
        with open("/proc/self/status") as f:
            vm = next(int(l.split()[1]) << 10 for l in f if l.startswith("VmSize"))
        resource.setrlimit(resource.RLIMIT_AS, (vm + (1 << 30), vm + (1 << 30)))
        tmin = np.zeros(40_000_000, np.float32)  # 160 MB fit; 2 GB of answers do not
        try:
            scene.intersect(o, d, tmin)
            raise AssertionError("no MemoryError")
        except MemoryError as e:
            assert "intersect" in str(e), str(e)
        assert scene.raycast(o, d)[0] == 1.0
        print("ok")
        """,
        timeout=300,
    )
    assert out.strip().endswith("ok"), out
