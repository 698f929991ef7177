"""The same scene in a concurrent.futures.ProcessPoolExecutor, a multiprocessing.Pool (spawned
workers: each gets the scene once, pickled, through the pool's initializer) and a thread pool (no
copy: the calls release the GIL): every answer equals the single in-process call's, ray by ray."""

import multiprocessing
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest

import kdray
import pool_work
from conftest import random_mesh, random_rays


@pytest.fixture(scope="module")
def scene():
    return kdray.Scene(*random_mesh(np.random.default_rng(5), n_tris=2000, n_verts=1500))


@pytest.fixture(scope="module")
def rays():
    return random_rays(np.random.default_rng(6), 20_000)


def chunks(o, d, k=8):
    return list(zip(np.array_split(o, k), np.array_split(d, k)))


def check(scene, rays, closest, occluded, contains):
    o, d = rays
    want = scene.intersect(o, d)
    for got, w in zip(closest, want[:4]):
        assert np.array_equal(got, w)
    assert np.array_equal(occluded, scene.occluded(o, d))
    assert np.array_equal(contains, scene.contains(o))


def test_process_pool_executor(scene, rays):
    o, d = rays
    spawn = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(
        2, mp_context=spawn, initializer=pool_work.receive, initargs=(scene,)
    ) as pool:
        parts = list(pool.map(pool_work.closest, chunks(o, d)))
        occ = np.concatenate(list(pool.map(pool_work.occluded, chunks(o, d))))
        inside = np.concatenate(list(pool.map(pool_work.contains, np.array_split(o, 8))))
    closest = [np.concatenate([p[k] for p in parts]) for k in range(4)]
    check(scene, rays, closest, occ, inside)
    assert all(p[4] != multiprocessing.current_process().pid for p in parts)


def test_multiprocessing_pool(scene, rays):
    o, d = rays
    with multiprocessing.get_context("spawn").Pool(
        2, initializer=pool_work.receive, initargs=(scene,)
    ) as pool:
        parts = pool.map(pool_work.closest, chunks(o, d))
        occ = np.concatenate(pool.map(pool_work.occluded, chunks(o, d)))
        inside = np.concatenate(pool.map(pool_work.contains, np.array_split(o, 8)))
    closest = [np.concatenate([p[k] for p in parts]) for k in range(4)]
    check(scene, rays, closest, occ, inside)


def test_thread_pool_shares_the_scene(scene, rays):
    o, d = rays

    def closest(c):
        h = scene.intersect(*c, threads=1)
        return h.t, h.prim, h.u, h.v

    with ThreadPoolExecutor(4) as pool:
        parts = list(pool.map(closest, chunks(o, d)))
        occ = np.concatenate(list(pool.map(lambda c: scene.occluded(*c, threads=1), chunks(o, d))))
        inside = np.concatenate(
            list(pool.map(lambda p: scene.contains(p, threads=1), np.array_split(o, 8)))
        )
    closest = [np.concatenate([p[k] for p in parts]) for k in range(4)]
    check(scene, rays, closest, occ, inside)
