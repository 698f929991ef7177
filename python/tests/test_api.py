"""The API's promises: a batch equals single calls, answers do not depend on threads, shapes
broadcast as numpy's do, files and bytes round-trip, dtypes are converted (or not) as
documented."""

import math
import threading

import numpy as np
import pytest

import kdray
from conftest import random_mesh, random_rays, tetrahedron


@pytest.fixture
def mesh_and_rays(rng):
    vertices, faces = random_mesh(rng, n_tris=500)
    origins, directions = random_rays(rng, 20000)
    return vertices, faces, origins, directions


def test_a_batch_equals_single_calls(mesh_and_rays):
    vertices, faces, origins, directions = mesh_and_rays
    scene = kdray.Scene(vertices, faces)
    batch = scene.intersect(origins, directions, normals=True)
    occluded = scene.occluded(origins, directions)
    counts = scene.count_intersections(origins, directions)
    for i in range(0, len(origins), 97):
        one = scene.intersect(origins[i], directions[i], normals=True)
        assert one.t.shape == () and one.normals.shape == (3,)
        assert one.t == batch.t[i] and one.prim == batch.prim[i]
        assert one.u == batch.u[i] and one.v == batch.v[i]
        np.testing.assert_array_equal(one.normals, batch.normals[i])
        t, prim, u, v = scene.raycast(origins[i].tolist(), directions[i])
        assert (t, prim, u, v) == (batch.t[i], batch.prim[i], batch.u[i], batch.v[i])
        assert type(t) is float and type(prim) is int
        assert scene.occluded(origins[i], directions[i]) == occluded[i]
        assert scene.count_intersections(origins[i], directions[i]) == counts[i]
        every = scene.intersect_all(origins[i], directions[i])
        assert len(every.ray) == counts[i] and np.all(every.ray == 0)
    # Occlusion agrees with the closest hit.
    np.testing.assert_array_equal(occluded, batch.prim >= 0)


@pytest.mark.parametrize("watertight", [False, True])
def test_answers_do_not_depend_on_threads(mesh_and_rays, watertight):
    vertices, faces, origins, directions = mesh_and_rays
    scenes = [kdray.Scene(vertices, faces, watertight=watertight, threads=k) for k in (1, 2, 3)]
    # The build is the same tree on any number of threads.
    assert scenes[0].to_bytes()[128:] == scenes[1].to_bytes()[128:]
    assert scenes[0].info["nodes"] == scenes[2].info["nodes"]
    want = scenes[0].intersect(origins, directions, threads=1, points=True)
    for scene in scenes:
        for threads in (None, 1, 2, 5):
            got = scene.intersect(origins, directions, threads=threads, points=True)
            for a, b in zip(want, got):
                np.testing.assert_array_equal(a, b)
            np.testing.assert_array_equal(
                scene.occluded(origins, directions, threads=threads), want.prim >= 0
            )
    counts = scenes[0].count_intersections(origins, directions, threads=1)
    every = scenes[0].intersect_all(origins, directions, threads=1)
    contains = scenes[0].contains(origins, threads=1)
    for threads in (None, 2, 7):
        np.testing.assert_array_equal(
            scenes[0].count_intersections(origins, directions, threads=threads), counts
        )
        for a, b in zip(scenes[0].intersect_all(origins, directions, threads=threads), every):
            np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(scenes[0].contains(origins, threads=threads), contains)


def test_calls_from_python_threads_at_once(mesh_and_rays):
    """The GIL is released during a batch: several Python threads trace one scene at once."""
    vertices, faces, origins, directions = mesh_and_rays
    scene = kdray.Scene(vertices, faces)
    want = scene.intersect(origins, directions).t
    results = [None] * 4

    def work(k):
        results[k] = scene.intersect(origins, directions, threads=1).t

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        np.testing.assert_array_equal(r, want)


def test_shapes_broadcast(rng):
    vertices, faces = tetrahedron()
    scene = kdray.Scene(vertices, faces)
    # One origin, a (4, 5) grid of directions: answers of shape (4, 5).
    d = rng.normal(size=(4, 5, 3))
    hits = scene.intersect([0.1, 0.1, 0.1], d, points=True, normals=True)
    assert hits.t.shape == (4, 5) and hits.prim.shape == (4, 5)
    assert hits.points.shape == (4, 5, 3) and hits.normals.shape == (4, 5, 3)
    assert np.all(hits.prim >= 0), "every ray from inside leaves through a face"
    flat = scene.intersect(np.broadcast_to([0.1, 0.1, 0.1], (20, 3)), d.reshape(20, 3))
    np.testing.assert_array_equal(flat.t, hits.t.reshape(20))
    # tmax per ray broadcasts too: nothing within 1e-3.
    assert not scene.occluded([0.1, 0.1, 0.1], d, 0.0, np.full((4, 1), 1e-3)).any()
    assert scene.count_intersections([0.1, 0.1, 0.1], d).shape == (4, 5)
    assert scene.contains(np.zeros((2, 3, 3)) + 0.1).shape == (2, 3)
    assert scene.contains([0.1, 0.1, 0.1]).shape == ()
    # An empty batch.
    empty = scene.intersect(np.zeros((0, 3)), np.zeros((0, 3)))
    assert empty.t.shape == (0,) and empty.prim.dtype == np.int64
    assert scene.intersect_all(np.zeros((0, 3)), [0, 0, 1]).ray.shape == (0,)


def test_dtypes(rng):
    vertices, faces = random_mesh(rng)
    # float64, int32 faces, lists, Fortran order: the same scene.
    a = kdray.Scene(vertices, faces)
    b = kdray.Scene(vertices.astype(np.float64), faces.astype(np.int32))
    c = kdray.Scene(np.asfortranarray(vertices).tolist(), faces.astype(np.uint16).tolist())
    assert a.to_bytes()[128:] == b.to_bytes()[128:] == c.to_bytes()[128:]
    origins, directions = random_rays(rng, 500)
    want = a.intersect(origins, directions)
    got = a.intersect(origins.astype(np.float64), np.asfortranarray(directions))
    np.testing.assert_array_equal(want.t, got.t)
    assert want.t.dtype == np.float32 and want.u.dtype == np.float32
    # Non-contiguous views (every other ray) are read as the rays they hold.
    strided = a.intersect(origins[::2], directions[::2])
    np.testing.assert_array_equal(strided.t, want.t[::2])
    # Without faces: every 3 vertices a triangle.
    soup = kdray.Scene(vertices[faces].reshape(-1, 3))
    np.testing.assert_array_equal(soup.intersect(origins, directions).prim, want.prim)


def test_files_and_bytes_round_trip(tmp_path, rng):
    vertices, faces = random_mesh(rng)
    scene = kdray.Scene(vertices, faces, layout="nodes", leaves="list")
    info = scene.info
    assert info["triangles"] == len(faces) and info["layout"] == "nodes"
    assert kdray.Scene(vertices, faces).info["layout"] == "wide"
    assert info["leaves"] == "list" and info["bytes"] == len(scene.to_bytes())
    lo, hi = info["bounds"]
    np.testing.assert_allclose(lo, vertices[np.unique(faces)].min(axis=0))
    np.testing.assert_allclose(hi, vertices[np.unique(faces)].max(axis=0))
    assert "triangles" in repr(scene)
    path = tmp_path / "mesh.kdt"
    scene.save(path)
    loaded = kdray.Scene.load(path)
    copied = kdray.Scene.from_bytes(scene.to_bytes())
    assert path.read_bytes() == scene.to_bytes() == loaded.to_bytes() == copied.to_bytes()
    origins, directions = random_rays(rng, 500)
    want = scene.intersect(origins, directions)
    for other in (loaded, copied):
        for a, b in zip(want, other.intersect(origins, directions)):
            np.testing.assert_array_equal(a, b)
    assert kdray.Scene.from_bytes(bytearray(scene.to_bytes())).info == info


def test_mesh_files_load_and_build(tmp_path):
    vertices, faces = tetrahedron()
    obj = tmp_path / "tetra.obj"
    obj.write_text(
        "".join(f"v {x} {y} {z}\n" for x, y, z in vertices)
        + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces)
    )
    tri = tmp_path / "tetra.tri"
    tri.write_bytes(np.uint32(len(faces)).tobytes() + vertices[faces].astype("<f4").tobytes())
    want = kdray.Scene(vertices, faces).contains([[0.1, 0.1, 0.1], [1, 1, 1]])
    for path in (obj, tri, str(tri)):
        scene = kdray.Scene.load(path, leaves="list", threads=1)
        assert scene.info["triangles"] == 4
        np.testing.assert_array_equal(scene.contains([[0.1, 0.1, 0.1], [1, 1, 1]]), want)


def test_qualities_build_different_trees_that_answer_alike(rng):
    # 3,000 triangles: `fast` bins the nodes of 32 triangles and more, so its tree differs from
    # `high`'s (the exact sweep everywhere); both find the same nearest hits.
    vertices, faces = random_mesh(rng, n_tris=3000)
    origins, directions = random_rays(rng, 5000)

    def tree(scene):
        # The file's words but the build time (header word 22, information only) and the
        # checksum over all words (24 and 25).
        words = np.frombuffer(scene.to_bytes(), "<u4")
        return np.delete(words, [22, 24, 25]).tobytes()

    fast = kdray.Scene(vertices, faces)  # the default
    high = kdray.Scene(vertices, faces, quality="high")
    assert tree(fast) == tree(kdray.Scene(vertices, faces, quality="fast"))
    assert tree(fast) != tree(high)
    a, b = fast.intersect(origins, directions), high.intersect(origins, directions)
    assert (a.prim >= 0).sum() > 1000, "the rays should hit the mesh often"
    np.testing.assert_array_equal(a.t, b.t)
    assert np.mean(a.prim == b.prim) > 0.999


def test_watertight_mode_is_the_scenes(rng):
    vertices, faces = random_mesh(rng)
    origins, directions = random_rays(rng, 2000)
    fast = kdray.Scene(vertices, faces)
    tight = kdray.Scene(vertices, faces, watertight=True)
    assert not fast.watertight and tight.watertight
    a, b = fast.intersect(origins, directions), tight.intersect(origins, directions)
    same = a.prim == b.prim
    assert same.mean() > 0.99
    np.testing.assert_allclose(a.t[same & (a.prim >= 0)], b.t[same & (a.prim >= 0)], rtol=1e-5)
    assert math.isinf(kdray.Scene(vertices, faces).intersect([9, 9, 9], [1, 0, 0]).t)


@pytest.mark.parametrize(
    "options", [{}, {"layout": "nodes"}, {"leaves": "list"}, {"watertight": True}]
)
def test_prim_is_the_faces_row_on_a_mesh_of_many_triangles(options):
    """The tree stores triangles in its leaves' order, not the mesh's; every answer names the
    row of ``faces``. A ray at the centre of each of an icosphere's 1,280 triangles, along its
    inward normal, hits that triangle: ``prim`` is its row, in ``intersect``, ``raycast`` and
    ``intersect_all``."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=3)
    v = np.asarray(sphere.vertices, dtype=np.float32)
    f = np.asarray(sphere.faces)
    assert len(f) == 1280
    scene = kdray.Scene(v, f, **options)
    tri = v[f].astype(np.float64)
    centre = tri.mean(axis=1)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    origins = (centre + normal).astype(np.float32)
    directions = (-normal).astype(np.float32)
    rows = np.arange(len(f))
    np.testing.assert_array_equal(scene.intersect(origins, directions).prim, rows)
    for i in range(0, len(f), 97):
        assert scene.raycast(origins[i], directions[i])[1] == i
    every = scene.intersect_all(origins[::97], directions[::97])
    for k, i in enumerate(rows[::97]):
        mine = every.ray == k
        assert every.prim[mine][np.argmin(every.t[mine])] == i


def test_version_is_the_packages():
    import pathlib
    import re

    pyproject = (pathlib.Path(__file__).parents[1] / "pyproject.toml").read_text()
    assert kdray.__version__ == re.search(r'^version = "(.*)"', pyproject, re.M).group(1)


def test_stubs_name_the_build_options_values():
    """The stub types ``layout``, ``leaves`` and ``quality`` as the ``Literal`` of the values
    the package accepts, in every signature that takes them."""
    import ast
    import pathlib

    stub = ast.parse((pathlib.Path(kdray.__file__).parent / "__init__.pyi").read_text())
    aliases = {
        node.targets[0].id: node.value
        for node in stub.body
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name)
    }

    def literal(annotation):
        if isinstance(annotation, ast.Name):
            annotation = aliases[annotation.id]
        assert isinstance(annotation, ast.Subscript) and ast.unparse(annotation.value) == "Literal"
        return {e.value for e in ast.walk(annotation.slice) if isinstance(e, ast.Constant)}

    scene = next(n for n in stub.body if isinstance(n, ast.ClassDef) and n.name == "Scene")
    checked = 0
    for fn in (n for n in scene.body if isinstance(n, ast.FunctionDef)):
        for arg in fn.args.kwonlyargs:
            if arg.arg in kdray._BUILD_OPTIONS:
                assert literal(arg.annotation) == set(kdray._BUILD_OPTIONS[arg.arg]), (fn.name, arg.arg)
                checked += 1
    assert checked == 6
