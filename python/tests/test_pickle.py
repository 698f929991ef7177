"""A Scene travels: pickle (every protocol; protocol 5 with the words out of band, not copied
into the pickle), copy, deepcopy and a memory-mapped .kdt give scenes that answer bit for bit as
the original, without a rebuild; a truncated, damaged or malformed pickle is a ValueError that
names the problem, never a crash."""

import copy
import pickle

import numpy as np
import pytest

import kdray
from conftest import random_mesh, random_rays, tetrahedron


@pytest.fixture(scope="module")
def mesh():
    return random_mesh(np.random.default_rng(43), n_tris=2000, n_verts=1500)


@pytest.fixture(scope="module")
def scene(mesh):
    return kdray.Scene(*mesh, watertight=True)


def assert_same_answers(a, b):
    """Every query, ray by ray: the same bits."""
    o, d = random_rays(np.random.default_rng(7), 3000)
    ha, hb = a.intersect(o, d), b.intersect(o, d)
    for x, y in zip(ha[:4], hb[:4]):
        assert np.array_equal(x, y, equal_nan=True)
    assert np.array_equal(a.occluded(o, d), b.occluded(o, d))
    assert np.array_equal(a.count_intersections(o, d), b.count_intersections(o, d))
    assert np.array_equal(a.contains(o), b.contains(o))
    assert a.watertight == b.watertight
    assert np.array_equal(a.origin, b.origin) if a.origin is not None else b.origin is None
    assert a.to_bytes() == b.to_bytes()


@pytest.mark.parametrize("protocol", range(2, pickle.HIGHEST_PROTOCOL + 1))
def test_pickle_round_trip(scene, protocol):
    back = pickle.loads(pickle.dumps(scene, protocol=protocol))
    assert isinstance(back, kdray.Scene) and back._tree is not scene._tree
    assert_same_answers(scene, back)


def test_protocol_5_sends_the_words_out_of_band(scene):
    buffers = []
    data = pickle.dumps(scene, protocol=5, buffer_callback=buffers.append)
    assert len(buffers) == 1
    raw = buffers[0].raw()
    assert raw.nbytes == scene.info["bytes"] and raw.readonly
    assert len(data) < 200  # the words are not in the pickle
    # The buffer is the tree's memory, not a copy of it.
    words = np.frombuffer(raw, dtype=np.uint32)
    assert np.shares_memory(words, kdray._kdray.words(scene._tree))
    assert_same_answers(scene, pickle.loads(data, buffers=buffers))


def test_the_words_out_of_band_are_kept_in_place_and_validated(scene):
    """In the process that pickled it, the receiver keeps the tree's own (immutable) words where
    they are instead of copying them, and still validates them."""
    buffers = []
    data = pickle.dumps(scene, protocol=5, buffer_callback=buffers.append)
    back = pickle.loads(data, buffers=buffers)
    assert back._tree is not scene._tree
    assert np.shares_memory(kdray._kdray.words(back._tree), kdray._kdray.words(scene._tree))
    assert_same_answers(scene, back)
    from kdray._pickle import restore

    words = kdray._kdray.words(scene._tree)
    # In place too (64-byte aligned views of a tree's words), and refused: cut short, shifted.
    for part in (words[:-16], words[16:]):
        with pytest.raises(ValueError, match="a pickled kdray.Scene: not a valid kd-tree"):
            restore(pickle.PickleBuffer(part), False)


def test_writable_buffers_are_copied(scene):
    """Another process receives the words in writable memory (Dask's frames): the receiver
    copies them, so that changing that memory afterwards changes nothing."""
    buffers = []
    data = pickle.dumps(scene, protocol=5, buffer_callback=buffers.append)
    raw = bytearray(buffers[0].raw())
    back = pickle.loads(data, buffers=[raw])
    assert not np.shares_memory(kdray._kdray.words(back._tree), np.frombuffer(raw, np.uint8))
    raw[:] = bytes(len(raw))
    assert_same_answers(scene, back)


def test_the_words_view_is_read_only(scene):
    words = kdray._kdray.words(scene._tree)
    assert not words.flags.writeable
    with pytest.raises(ValueError):
        words[0] = 0
    with pytest.raises(ValueError):
        words.flags.writeable = True


def test_copy_and_deepcopy_share_the_immutable_tree(scene):
    for c in (copy.copy(scene), copy.deepcopy(scene)):
        assert c is not scene and c._tree is scene._tree
        assert_same_answers(scene, c)
        c.watertight = False  # the option is the copy's own
        assert scene.watertight
    # Inside a container too.
    [c] = copy.deepcopy([scene])
    assert c._tree is scene._tree


def test_mmap_load(scene, tmp_path):
    path = tmp_path / "scene.kdt"
    scene.save(path)
    mapped = kdray.Scene.load(path, mmap=True, watertight=True)
    assert_same_answers(scene, mapped)
    # A mapped scene pickles as its words, like any other.
    assert_same_answers(scene, pickle.loads(pickle.dumps(mapped, protocol=5)))
    # save() replaces the file (rename), which leaves the mapped scene's pages intact.
    kdray.Scene(*tetrahedron()).save(path)
    assert_same_answers(scene, mapped)
    assert kdray.Scene.load(path, mmap=True).info["triangles"] == 4


def test_mmap_refuses_what_is_not_a_tree(mesh, tmp_path):
    ply = tmp_path / "mesh.obj"
    ply.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(ValueError, match="mmap=True maps a saved tree"):
        kdray.Scene.load(ply, mmap=True)
    good = kdray.Scene(*mesh).to_bytes()
    for name, data, words in [
        ("empty.kdt", b"", "not a valid kd-tree"),
        ("odd.kdt", good[:-2], "not a whole number of 32-bit words"),
        ("short.kdt", good[:-4], "not a valid kd-tree"),
        ("flipped.kdt", good[:100] + bytes([good[100] ^ 1]) + good[101:], "checksum"),
    ]:
        (tmp_path / name).write_bytes(data)
        with pytest.raises(ValueError, match=words) as e:
            kdray.Scene.load(tmp_path / name, mmap=True)
        assert name in str(e.value)


def pickled(scene):
    """The pickle of `scene` (protocol 5, in band) and where its words lie in it."""
    data = pickle.dumps(scene, protocol=5)
    words = scene.to_bytes()
    at = data.index(words)
    return data, at, len(words)


def test_every_damaged_word_is_refused():
    """The tree's checksum catches a change in any one word; every word of a small tree, flipped
    in the pickle."""
    scene = kdray.Scene(*tetrahedron())
    data, at, size = pickled(scene)
    for i in range(at, at + size, 4):
        for bit in (0, 13, 31):
            bad = bytearray(data)
            bad[i + bit // 8] ^= 1 << (bit % 8)
            with pytest.raises(ValueError, match="a pickled kdray.Scene: not a valid kd-tree"):
                pickle.loads(bytes(bad))


def test_truncated_words_are_refused(scene):
    from kdray._pickle import restore

    words = scene.to_bytes()
    for n in [0, 4, 100, len(words) // 2, len(words) - 4]:
        with pytest.raises(ValueError, match="a pickled kdray.Scene: not a valid kd-tree"):
            restore(words[:n], False)
    with pytest.raises(ValueError, match="not a whole number of 4-byte words"):
        restore(words[:-1], False)


def test_a_truncated_pickle_stream_is_pickles_error(scene):
    """Cut short anywhere, the stream is refused by pickle itself before the scene sees it."""
    data, at, size = pickled(scene)
    for n in [1, at - 1, at + 7, at + size // 2, len(data) - 1]:
        with pytest.raises((pickle.UnpicklingError, EOFError, ValueError)):
            pickle.loads(data[:n])


@pytest.mark.parametrize(
    "data, watertight, words",
    [
        (None, False, "the tree is a NoneType, not bytes"),
        ("a string", False, "the tree is a str, not bytes"),
        (b"\0" * 64, False, "not a valid kd-tree"),
        (np.zeros((4, 4), np.uint32)[:, ::2], False, "not contiguous"),
        (b"", 1, "watertight is 1, not True or False"),
    ],
)
def test_malformed_arguments_are_refused(data, watertight, words):
    """A crafted pickle can call the restore function with anything."""
    from kdray._pickle import restore

    with pytest.raises(ValueError, match=words):
        restore(data, watertight)


@pytest.mark.parametrize(
    "origin, words",
    [
        ("auto", "origin is 'auto', not None or 3 floats"),
        ((1.0, 2.0), r"origin is \(1.0, 2.0\)"),
        ((1, 2, 3), r"origin is \(1, 2, 3\)"),
        ((1.0, 2.0, float("nan")), r"origin is \(1.0, 2.0, nan\): every coordinate must be"),
    ],
)
def test_malformed_origins_are_refused(origin, words):
    from kdray._pickle import restore

    data = kdray.Scene(*tetrahedron()).to_bytes()
    with pytest.raises(ValueError, match="a pickled kdray.Scene: " + words):
        restore(data, False, origin)


def test_the_origin_travels(mesh):
    v, f = mesh
    far = kdray.Scene(v.astype(np.float64) + 1e6, f, origin="auto")
    assert far.origin is not None
    for back in (pickle.loads(pickle.dumps(far, protocol=p)) for p in (2, 5)):
        assert back.origin.tolist() == far.origin.tolist()
        o, d = random_rays(np.random.default_rng(9), 500)
        o = o + 1e6
        assert np.array_equal(back.intersect(o, d).t, far.intersect(o, d).t)
    c = copy.deepcopy(far)
    assert c.origin.tolist() == far.origin.tolist()


def test_a_pickle_naming_the_restore_function_with_junk():
    """The same through pickle: a stream built by hand."""

    class Fake:
        def __reduce__(self):
            from kdray._pickle import restore

            return restore, (b"KDT?" * 16, False)

    with pytest.raises(ValueError, match="a pickled kdray.Scene"):
        pickle.loads(pickle.dumps(Fake()))



def test_unaligned_arrays_are_read(scene):
    """An array unpickled from a byte stream (Dask's, in band) may start at any byte: it is
    copied once onto its alignment, not refused."""
    o, d = random_rays(np.random.default_rng(8), 1000)
    raw = np.zeros(o.nbytes + 1, np.uint8)
    odd = raw[1:].view(np.float32).reshape(o.shape)
    odd[:] = o
    assert not odd.flags.aligned and odd.flags.c_contiguous
    assert np.array_equal(scene.intersect(odd, d).t, scene.intersect(o, d).t)
    assert np.array_equal(scene.contains(odd), scene.contains(o))
    v, f = tetrahedron()
    raw = np.zeros(f.size * 8 + 1, np.uint8)
    faces = raw[1:].view(np.int64).reshape(f.shape)
    faces[:] = f
    assert not faces.flags.aligned
    assert kdray.Scene(v, faces).contains([[0.1, 0.1, 0.1], [1, 1, 1]]).tolist() == [True, False]
