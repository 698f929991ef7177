"""Every kind of bad input raises ValueError or TypeError naming the argument and the problem
(or FileNotFoundError for a missing file), and leaves the scene working."""

import math

import numpy as np
import pytest

import kdray
from conftest import tetrahedron

V, F = tetrahedron()


@pytest.fixture(scope="module")
def scene():
    return kdray.Scene(V, F)


def raises(kind, *words):
    """pytest.raises(kind) whose message holds every word."""

    class Check:
        def __enter__(self):
            self.ctx = pytest.raises(kind)
            self.info = self.ctx.__enter__()
            return self.info

        def __exit__(self, *exc):
            done = self.ctx.__exit__(*exc)
            msg = str(self.info.value)
            for w in words:
                assert w in msg, f"{w!r} not in {msg!r}"
            return done

    return Check()


@pytest.mark.parametrize(
    "vertices, faces, kind, words",
    [
        (np.where(np.arange(12).reshape(4, 3) == 7, np.nan, V), F, ValueError, ["vertices[2, 1]", "nan", "finite"]),
        (np.where(np.arange(12).reshape(4, 3) == 3, np.inf, V), F, ValueError, ["vertices[1, 0]", "inf"]),
        (V.astype(np.float64) * 1e39, F, ValueError, ["vertices[1, 0]", "float32"]),
        (V[:, :2], F, ValueError, ["vertices", "(N, 3)", "(4, 2)"]),
        (V.ravel(), F, ValueError, ["vertices", "(12,)"]),
        (V.astype(str), F, TypeError, ["vertices", "numbers"]),
        (V.astype(complex), F, TypeError, ["vertices", "complex"]),
        (V > 0, F, TypeError, ["vertices", "bool"]),
        (V, F + 1, ValueError, ["faces[", "4", "holds 4 vertices"]),
        (V, F - 1, ValueError, ["faces[0, 0] is -1"]),
        (V, F.astype(np.float64), TypeError, ["faces", "integers", "float64"]),
        (V, F[:, :2], ValueError, ["faces", "(M, 3)", "(4, 2)"]),
        (V, np.full((1, 3), 2**64 - 1, dtype=np.uint64), ValueError, ["faces", "18446744073709551615"]),
        (V, np.zeros((0, 3), dtype=np.int64), ValueError, ["no triangles"]),
        (V, None, ValueError, ["4 vertices", "not a multiple of 3"]),
        (np.array([[-3e38, 0, 0], [3e38, 0, 0], [0, 1, 0]], dtype=np.float32), None, ValueError, ["triangle 0", "overflow"]),
    ],
)
def test_bad_meshes(vertices, faces, kind, words):
    with raises(kind, *words):
        kdray.Scene(vertices, faces)


def test_bad_build_options():
    with raises(TypeError, "unknown build option 'leaf'"):
        kdray.Scene(V, F, leaf="groups")
    with raises(ValueError, "layout='tiles'", "'wide'", "'nodes'"):
        kdray.Scene(V, F, layout="tiles")
    with raises(ValueError, "layout='blocked'", "retired", "'wide'"):
        kdray.Scene(V, F, layout="blocked")
    with raises(ValueError, "quality='best'", "'fast'", "'high'"):
        kdray.Scene(V, F, quality="best")
    with raises(ValueError, "threads=0"):
        kdray.Scene(V, F, threads=0)
    with raises(TypeError, "threads", "float"):
        kdray.Scene(V, F, threads=1.5)
    with raises(TypeError, "threads", "str"):
        kdray.Scene(V, F, threads="2")


def test_bad_files(tmp_path, scene):
    with raises(FileNotFoundError, "missing.kdt"):
        kdray.Scene.load(tmp_path / "missing.kdt")
    good = scene.to_bytes()
    truncated = tmp_path / "truncated.kdt"
    truncated.write_bytes(good[:-6])
    with raises(ValueError, "truncated.kdt", "whole number"):
        kdray.Scene.load(truncated)
    short = tmp_path / "short.kdt"
    short.write_bytes(good[:-8])
    with raises(ValueError, "short.kdt"):
        kdray.Scene.load(short)
    flipped = bytearray(good)
    flipped[len(good) // 2] ^= 1
    damaged = tmp_path / "damaged.kdt"
    damaged.write_bytes(flipped)
    with raises(ValueError, "damaged.kdt"):
        kdray.Scene.load(damaged)
    with raises(ValueError, "data", "whole number", "truncated"):
        kdray.Scene.from_bytes(good[:-2])
    with raises(ValueError, "data"):
        kdray.Scene.from_bytes(bytes(flipped))
    with raises(ValueError, "data"):
        kdray.Scene.from_bytes(b"")
    with raises(TypeError, "data", "bytes", "str"):
        kdray.Scene.from_bytes("KDRY")
    stl = tmp_path / "mesh.stl"
    stl.write_bytes(b"solid")
    with raises(ValueError, "mesh.stl"):
        kdray.Scene.load(stl)
    bad_obj = tmp_path / "bad.obj"
    bad_obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    with raises(ValueError, "bad.obj"):
        kdray.Scene.load(bad_obj)
    with raises(ValueError, str(tmp_path)):
        scene.save(tmp_path)
    with raises(TypeError, "path"):
        kdray.Scene.load(3.5)


RAY_O = np.array([[0.1, 0.1, -1.0], [0.2, 0.2, -1.0]], dtype=np.float32)
RAY_D = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]], dtype=np.float32)


def nan_at(a, i, j, value=np.nan):
    a = a.copy()
    a[i, j] = value
    return a


@pytest.mark.parametrize("method", ["intersect", "occluded", "count_intersections", "intersect_all"])
@pytest.mark.parametrize(
    "args, kind, words",
    [
        ((nan_at(RAY_O, 1, 2), RAY_D), ValueError, ["origins[1]", "nan", "finite"]),
        ((RAY_O, nan_at(RAY_D, 0, 1, np.inf)), ValueError, ["directions[0]", "inf"]),
        ((RAY_O, nan_at(RAY_D, 1, 2, 0.0)), ValueError, ["directions[1] is zero"]),
        ((RAY_O, RAY_D, np.nan), ValueError, ["tmin[0]", "nan", "finite"]),
        ((RAY_O, RAY_D, [0.0, -np.inf]), ValueError, ["tmin[1]", "-inf"]),
        ((RAY_O, RAY_D, 0.0, [1.0, np.nan]), ValueError, ["tmax[1]", "nan"]),
        ((RAY_O, RAY_D, 0.0, -np.inf), ValueError, ["tmax[0]", "-inf"]),
        ((RAY_O, RAY_D, 2.0, 1.0), ValueError, ["ray 0", "tmin 2 is above tmax 1"]),
        ((RAY_O[:, :2], RAY_D), ValueError, ["origins", "(..., 3)", "(2, 2)"]),
        ((RAY_O, RAY_D[:1].ravel()[:2]), ValueError, ["directions", "(2,)"]),
        ((np.zeros((3, 3)), RAY_D), ValueError, ["(3, 3)", "(2, 3)", "broadcast"]),
        ((RAY_O, RAY_D, np.zeros(3)), ValueError, ["tmin (3,)", "broadcast"]),
        ((RAY_O.astype(str), RAY_D), TypeError, ["origins", "numbers"]),
        ((None, RAY_D), TypeError, ["origins", "object"]),
        ((RAY_O, RAY_D, "0"), TypeError, ["tmin"]),
    ],
)
def test_bad_rays(scene, method, args, kind, words):
    with raises(kind, *words):
        getattr(scene, method)(*args)
    # The scene still works.
    assert scene.count_intersections(RAY_O, RAY_D).tolist() == [2, 2]


def test_bad_single_rays(scene):
    with raises(ValueError, "origin is (0.1, nan, 0)", "finite"):
        scene.raycast((0.1, np.nan, 0), (0, 0, 1))
    with raises(ValueError, "direction is zero"):
        scene.raycast((0.1, 0.1, -1), (0, 0, 0))
    with raises(ValueError, "tmin 3 is above tmax 1"):
        scene.raycast((0.1, 0.1, -1), (0, 0, 1), 3.0, 1.0)
    with raises(TypeError, "origin", "3 numbers"):
        scene.raycast((0.1, 0.1), (0, 0, 1))
    with raises(TypeError, "direction", "3 numbers"):
        scene.raycast((0.1, 0.1, 0), "up")
    with raises(TypeError, "tmax", "number"):
        scene.raycast((0.1, 0.1, 0), (0, 0, 1), 0.0, "far")
    assert scene.raycast((0.1, 0.1, -1), (0, 0, 1))[1] >= 0


def test_bad_call_options(scene):
    with raises(ValueError, "threads=-1"):
        scene.intersect(RAY_O, RAY_D, threads=-1)
    with raises(TypeError, "threads"):
        scene.contains(RAY_O, threads="all")
    with pytest.raises(TypeError):
        scene.intersect(RAY_O, RAY_D, 0.0, 1.0, 5)  # threads is keyword-only


@pytest.mark.parametrize(
    "points, kind, words",
    [
        (nan_at(RAY_O, 1, 0), ValueError, ["points[1]", "nan", "finite"]),
        (nan_at(RAY_O, 0, 2, -np.inf), ValueError, ["points[0]", "-inf"]),
        (RAY_O[:, :2], ValueError, ["points", "(..., 3)"]),
        (np.float32(1.0), ValueError, ["points", "()"]),
        ([["a", "b", "c"]], TypeError, ["points"]),
    ],
)
def test_bad_points(scene, points, kind, words):
    with raises(kind, *words):
        scene.contains(points)


def test_spheres_are_refused(tmp_path):
    toml = tmp_path / "spheres.toml"
    toml.write_text(
        '[camera]\nkind = "pinhole"\neye = [0, 0, 5]\ntarget = [0, 0, 0]\n\n'
        '[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\n'
    )
    with pytest.raises(ValueError, match="sphere"):
        kdray.Scene.load(toml)


def test_misses_are_inf_and_minus_one(scene):
    hits = scene.intersect([5.0, 5.0, 5.0], [1.0, 0.0, 0.0])
    assert math.isinf(hits.t) and hits.prim == -1 and hits.u == 0 and hits.v == 0
