"""A scene's pickle round trip against its build (issue 43: at most 10 % of `kdray.Scene(v, f)`
with the default options, the same answers).

    python bench/pickle_round_trip.py data/dragon.tri --rounds 5

Needs the meshes (scripts/fetch-meshes.sh; `.tri` files, read as bench/first_answer.py reads
them). Each round, in turn: the build (`kdray.Scene(v, f)`, every core), then each way a scene
travels, once:

- **out of band**: `pickle.dumps(scene, protocol=5, buffer_callback=...)` then `pickle.loads`
  with those buffers (what Dask does; in this process the buffer is the tree's own memory, kept
  in place by the receiver and validated);
- **writable copy**: the same pickle, its buffer first copied into a `bytearray` (untimed), as a
  transport delivers it to another process (Dask's frames): the receiver must copy it, then
  validate;
- **in band**: protocol 5 without a `buffer_callback` (the words copied into the pickle);
- **protocol 4**: the words as `bytes` in the pickle;
- **deepcopy**: `copy.deepcopy` (shares the tree: no pickle).

Printed: medians over the rounds, wall and CPU (this process's, every thread: steadier than the
wall on a shared machine), in milliseconds and as a share of the build's median, and the
machine's load before and after. Every received scene is checked against the original on
100,000 random rays (closest hits, ray by ray) once.
"""

import argparse
import copy
import os
import pickle
import statistics
import time

import numpy as np

import kdray
from first_answer import random_rays, read_tri


def out_of_band(scene):
    buffers = []
    data = pickle.dumps(scene, protocol=5, buffer_callback=buffers.append)
    return pickle.loads(data, buffers=buffers)


def prepared_writable(scene):
    """The pickle and its buffer as another process receives them: writable memory of its own."""
    buffers = []
    data = pickle.dumps(scene, protocol=5, buffer_callback=buffers.append)
    return data, [bytearray(b.raw()) for b in buffers]


WAYS = {
    "out of band": out_of_band,
    "in band": lambda s: pickle.loads(pickle.dumps(s, protocol=5)),
    "protocol 4": lambda s: pickle.loads(pickle.dumps(s, protocol=4)),
    "deepcopy": copy.deepcopy,
}


def load():
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh", help="a .tri file")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    print(f"kdray {kdray.ISA}; {args.mesh}; load before: {load()}")
    v, f = read_tri(args.mesh)
    o, d = random_rays(v, 100_000)
    times = {"build": [], "writable copy": [], **{k: [] for k in WAYS}}
    cpu = {k: [] for k in times}

    def clock(name, f):
        start, c = time.perf_counter(), time.process_time()
        r = f()
        times[name].append(time.perf_counter() - start)
        cpu[name].append(time.process_time() - c)
        return r

    for round_ in range(args.rounds):
        scene = clock("build", lambda: kdray.Scene(v, f))
        data, buffers = prepared_writable(scene)
        back = clock("writable copy", lambda: pickle.loads(data, buffers=buffers))
        received = {"writable copy": back}
        del data, buffers
        for name, way in WAYS.items():
            received[name] = clock(name, lambda: way(scene))
        if round_ == 0:
            want = scene.intersect(o, d)
            for name, r in received.items():
                got = r.intersect(o, d)
                assert all(np.array_equal(a, b) for a, b in zip(got[:4], want[:4])), name
        del received, back, scene
    build, build_cpu = statistics.median(times["build"]), statistics.median(cpu["build"])
    print(f"{len(f):,} triangles; medians of {args.rounds} rounds")
    print(f"{'':>14} {'wall ms':>8} {'of the build':>13} {'CPU ms':>8} {'of the build':>13}")
    for name, ts in times.items():
        t, c = statistics.median(ts), statistics.median(cpu[name])
        print(f"{name:>14} {t * 1e3:>8.1f} {t / build:>13.1%} {c * 1e3:>8.1f} {c / build_cpu:>13.1%}")
    print(f"load after: {load()}")


if __name__ == "__main__":
    main()
