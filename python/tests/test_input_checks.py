"""Issue 39, items 10, 12 and 13: unaligned arrays, option types and values, and messages."""

import math
import os

import numpy as np
import pytest

import kdray
import kdray.trimesh
from conftest import tetrahedron

V, F = tetrahedron()


def unaligned(a):
    """`a`'s values in an array at an odd byte offset of a buffer, as `np.frombuffer` of a
    binary PLY's bytes gives them: C-contiguous, not aligned."""
    raw = b"\0" + np.ascontiguousarray(a).tobytes()
    out = np.frombuffer(raw, dtype=a.dtype, offset=1).reshape(a.shape)
    assert out.flags.c_contiguous and not out.flags.aligned
    return out


# Item 10: refused as "not C-contiguous" before.
def test_unaligned_arrays_are_accepted():
    scene = kdray.Scene(unaligned(V), unaligned(F.astype(np.int64)))
    ref = kdray.Scene(V, F)
    o = np.array([[0.1, 0.1, -1], [0.2, 0.1, 2]], np.float32)
    d = np.array([[0, 0, 1], [0, 0, -1]], np.float32)
    assert scene.intersect(o, d).prim.tolist() == ref.intersect(o, d).prim.tolist()
    hits = scene.intersect(unaligned(o), unaligned(d), unaligned(np.zeros(2, np.float32)))
    assert hits.prim.tolist() == ref.intersect(o, d).prim.tolist()
    p = np.array([[0.1, 0.1, 0.1], [2, 2, 2]], np.float32)
    assert scene.contains(unaligned(p)).tolist() == [True, False]
    assert scene.count_intersections(unaligned(o), d).tolist() == [2, 2]


# Item 12: strings and numbers taken for True before; threads=True taken for 1.
@pytest.mark.parametrize("value", ["false", "no", 1, 0, None, [True]])
def test_yes_no_options_must_be_bools(value):
    with pytest.raises(TypeError, match="watertight must be True or False"):
        kdray.Scene(V, F, watertight=value)
    scene = kdray.Scene(V, F)
    with pytest.raises(TypeError, match="points must be True or False"):
        scene.intersect([0, 0, -1], [0, 0, 1], points=value)
    with pytest.raises(TypeError, match="normals must be True or False"):
        scene.intersect([0, 0, -1], [0, 0, 1], normals=value)
    with pytest.raises(TypeError, match="watertight must be True or False"):
        kdray.Scene.from_bytes(scene.to_bytes(), watertight=value)
    assert kdray.Scene(V, F, watertight=np.bool_(True)).watertight is True


def test_threads_must_be_an_int_not_a_bool():
    for value in (True, False, np.bool_(True), 2.0, "2"):
        with pytest.raises(TypeError, match="threads must be an int or None"):
            kdray.Scene(V, F, threads=value)


def test_build_options_are_refused_for_a_kdt(tmp_path):
    path = os.fspath(tmp_path / "t.kdt")
    kdray.Scene(V, F).save(path)
    for opts in ({"layout": "nodes"}, {"leaves": "list"}, {"quality": "high"}):
        with pytest.raises(ValueError, match="build options apply to mesh files"):
            kdray.Scene.load(path, **opts)
    with pytest.raises(ValueError, match="it must be one of"):
        kdray.Scene.load(path, layout="oops")
    assert kdray.Scene.load(path).info["triangles"] == 4


# Item 13.
@pytest.mark.parametrize("faces", [[], np.zeros((0, 3)), np.zeros((0,))])
def test_an_empty_faces_list_says_no_triangles(faces):
    with pytest.raises(ValueError, match="the mesh has no triangles"):
        kdray.Scene(V, faces)


@pytest.mark.parametrize("tmin, word", [(-1e39, "-1e+39"), (np.array([0.0, 1e39]), "tmin[1] is 1e+39")])
def test_values_past_float32_are_named_as_given(tmin, word):
    scene = kdray.Scene(V, F)
    with pytest.raises(ValueError, match=r"past float32's range") as e:
        scene.intersect([[0, 0, -1], [0, 0, -2]], [0, 0, 1], tmin)
    assert word in str(e.value) and "inf" not in str(e.value)
    with pytest.raises(ValueError, match=r"origins\[1, 2\] is -1e\+300"):
        scene.intersect(np.array([[0, 0, -1], [0, 0, -1e300]]), [0, 0, 1])
    with pytest.raises(ValueError, match=r"vertices\[4, 0\] is 1e\+40"):
        kdray.Scene(np.vstack([V.astype(np.float64), [[1e40, 0, 0]]]), F)
    # tmax past float32's range is no bound, as +inf
    assert scene.intersect([0.1, 0.1, -1], [0, 0, 1], 0.0, 1e39).prim == 0
    # and one ray as Python numbers
    with pytest.raises(ValueError, match=r"tmin is -1e\+39: past float32's range"):
        scene.raycast([0.1, 0.1, -1], [0, 0, 1], -1e39)
    with pytest.raises(ValueError, match=r"origin is \[0.1, 0.1, -1e\+39\]: past"):
        scene.raycast([0.1, 0.1, -1e39], [0, 0, 1])
    assert scene.raycast([0.1, 0.1, -1], [0, 0, 1], 0.0, 1e39)[1] == 0


class _Mesh:
    def __init__(self, v, f):
        self.vertices, self.faces = v.astype(np.float64), f

    def __hash__(self):
        return 1


def test_the_trimesh_adapter_answers_a_miss_for_a_zero_direction():
    r = kdray.trimesh.RayMeshIntersector(_Mesh(V, F))
    o = np.array([[0.1, 0.1, -1], [0.1, 0.1, -1]])
    d = np.array([[0, 0, 1], [0, 0, 0]])
    assert r.intersects_first(o, d).tolist() == [0, -1]
    assert r.intersects_any(o, d).tolist() == [True, False]
    tri, ray = r.intersects_id(o, d)
    assert set(ray.tolist()) == {0}
    tri, ray = r.intersects_id(o, d, multiple_hits=False)
    assert ray.tolist() == [0]
    loc, ray, tri = r.intersects_location(o, d)
    assert set(ray.tolist()) == {0} and len(loc) == len(ray)
