"""Dask on a two-process LocalCluster: the scene broadcast to both workers once, rays as dask
arrays chunked by rows, map_blocks calling intersect, occluded and contains; every answer equals
the single in-process call's, ray by ray. (Throughput: python/bench/dask_scaling.py.)"""

import logging
import pickle

import numpy as np
import pytest

import kdray
from conftest import random_mesh, random_rays

da = pytest.importorskip("dask.array", reason="pip install ./python[dask]")
distributed = pytest.importorskip("dask.distributed", reason="pip install ./python[dask]")

HIT = np.dtype([("t", "f4"), ("prim", "i8"), ("u", "f4"), ("v", "f4")])


def closest(o, d, scene):
    h = scene.intersect(o, d, threads=1)
    out = np.empty(len(o), HIT)
    out["t"], out["prim"], out["u"], out["v"] = h.t, h.prim, h.u, h.v
    return out


def closest_of_rows(rays, scene):
    """A block of (k, 8) rays: origin, direction, tmin, tmax."""
    return scene.intersect(rays[:, 0:3], rays[:, 3:6], rays[:, 6], rays[:, 7], threads=1).t


def occluded(o, d, scene):
    return scene.occluded(o, d, threads=1)


def contains(p, scene):
    return scene.contains(p, threads=1)


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        silence_logs=logging.ERROR,
    ) as cluster, distributed.Client(cluster) as client:
        client.wait_for_workers(2)  # a broadcast reaches only the workers already there
        yield client


@pytest.fixture(scope="module")
def scene():
    return kdray.Scene(*random_mesh(np.random.default_rng(11), n_tris=3000, n_verts=2000))


@pytest.fixture(scope="module")
def remote(client, scene):
    """The scene on both workers, sent once for the module (scattering the same scene again
    while the previous future is being released can lose it: a Dask race, not kdray's)."""
    future = client.scatter(scene, broadcast=True)
    assert len(client.who_has([future])[future.key]) == 2  # on both workers
    return future


def test_every_answer_equals_the_single_call(client, scene, remote):
    o, d = random_rays(np.random.default_rng(12), 40_000)
    do = da.from_array(o, chunks=(5_000, 3))
    dd = da.from_array(d, chunks=(5_000, 3))

    hits = da.map_blocks(closest, do, dd, scene=remote, drop_axis=1, dtype=HIT)
    shadow = da.map_blocks(occluded, do, dd, scene=remote, drop_axis=1, dtype=bool)
    inside = da.map_blocks(contains, do, scene=remote, drop_axis=1, dtype=bool)
    assert isinstance(hits, da.Array) and hits.numblocks == (8,)
    hits, shadow, inside = client.compute([hits, shadow, inside], sync=True)

    want = scene.intersect(o, d)
    for field in HIT.names:
        assert np.array_equal(hits[field], getattr(want, field)), field
    assert np.array_equal(shadow, scene.occluded(o, d))
    assert np.array_equal(inside, scene.contains(o))


def test_rays_as_one_array_of_rows(scene, remote):
    rng = np.random.default_rng(13)
    o, d = random_rays(rng, 20_000)
    tmin = rng.uniform(0, 0.5, (len(o), 1)).astype(np.float32)
    tmax = tmin + rng.uniform(0, 3, (len(o), 1)).astype(np.float32)
    rays = np.hstack([o, d, tmin, tmax])
    t = da.from_array(rays, chunks=(4_000, 8)).map_blocks(
        closest_of_rows, scene=remote, drop_axis=1, dtype=np.float32
    )
    want = scene.intersect(o, d, tmin[:, 0], tmax[:, 0]).t
    assert np.array_equal(t.compute(), want)


def test_a_damaged_pickle_is_refused_on_the_worker(client):
    """Bad input across the boundary: a pickled scene with a flipped bit, unpickled on a worker,
    is a ValueError there (raised again here), and the worker lives on."""
    scene = kdray.Scene(*random_mesh(np.random.default_rng(14)))
    data = bytearray(pickle.dumps(scene, protocol=5))
    data[data.index(scene.to_bytes()) + 200] ^= 4
    future = client.submit(pickle.loads, bytes(data), pure=False)
    with pytest.raises(ValueError, match="a pickled kdray.Scene: not a valid kd-tree"):
        future.result()
    assert len(client.scheduler_info()["workers"]) == 2
