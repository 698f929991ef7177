"""What the process-pool tests run in their workers (a module of its own, so that a spawned
worker imports it by name): the scene arrives once, through the pool's initializer, and each task
traces a chunk of rays with it on the worker's one thread."""

import os

scene = None


def receive(s):
    global scene
    scene = s


def closest(chunk):
    """`chunk`: (origins, directions); the closest hits' t, prim, u, v and this process's id."""
    o, d = chunk
    h = scene.intersect(o, d, threads=1)
    return h.t, h.prim, h.u, h.v, os.getpid()


def occluded(chunk):
    o, d = chunk
    return scene.occluded(o, d, threads=1)


def contains(points):
    return scene.contains(points, threads=1)
