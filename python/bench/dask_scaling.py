"""Dask throughput: one worker process against two, each with one thread, on random rays against
a mesh (issue 43's target: two workers ≥ 1.8× one on 10⁷ rays), the overhead a chunk costs, and
the pickle round trip of the scene against its build.

    python bench/dask_scaling.py data/dragon.ply            # 10⁷ rays, chunks of 10⁵, 2.5·10⁵, 10⁶
    python bench/dask_scaling.py data/dragon.ply --rays 1e6 --chunks 1e5 --rounds 2   # quick

Needs `pip install ./python[dask]` and the meshes (scripts/fetch-meshes.sh).

- Build: `kdray.Scene.load(mesh)` with the default options and every core, the median of
  `--rounds` (and the SAH builder's share, the tree header's `build_ms`). Pickle: `pickle.dumps(scene, protocol=5)` then `pickle.loads`, out of band (a
  `buffer_callback`, as Dask pickles) and in band, the median of 5; its ratio to the build.
- Rays: origins uniform in the mesh's box grown 1.5× about its centre, directions uniform on the
  sphere, two `(n, 3)` dask arrays as in the README's recipe (no strided copies in the tasks),
  made on the workers, chunk `i` on worker `i mod w` (seeded by chunk: the same rays in every
  run; placed evenly, so that no worker waits for another's last chunks or fetches its rays),
  kept there (`persist`) before the clock starts: what is timed is tracing, the scheduler and
  the answers.
- Each round, for each chunk size, in turn: the same chunks traced in this process one after
  another with `threads=1` (**local**); on a `LocalCluster` of one worker process (**1 w**) and of
  two (**2 w**), `threads_per_worker=1`, the closest hits (t, prim, u, v) of every chunk
  `map_blocks`-ed and persisted on the workers (answers as dask arrays, not gathered); also this
  process with `threads=2` over the whole batch (**local 2 t**: what two cores give without Dask,
  the reference for this machine's load). Printed: medians over the rounds. The cluster runs
  with Dask's background work turned down (`QUIET`: no statistical profiler, slower timers;
  `--dask-defaults` keeps Dask's).
- Overhead a chunk: a worker's wall time outside the traced calls (w × wall − the compute time
  of the tasks, Dask's task stream: scheduling, moving and storing chunks), per chunk and as a
  share of the tasks' time; also (1 w − local) / chunks. Speed-up: 1 w / 2 w. On a machine
  shared with other work these wall times mostly measure the others; the CPU time that a run
  costs all its processes (this one: the client, the scheduler and the nannies; the workers),
  less the CPU time of the same tracing in this process (**local**, one thread), is the
  overhead that does not depend on them: **CPU over** a chunk. With w workers on w cores, that
  CPU is taken from the tracing.
- The scene reaches each worker once (`client.scatter(..., broadcast=True)`: pickle, transfer,
  validation), timed apart; the answers of one run are compared with the local ones, ray by ray.

The machine's load (`os.getloadavg`) is printed before and after: timings on a shared machine are
noisy; rerun on a quiet one for figures to quote.
"""

import argparse
import logging
import os
import pickle
import platform
import statistics
import subprocess
import time

import numpy as np

import kdray

HIT = np.dtype([("t", "f4"), ("prim", "i8"), ("u", "f4"), ("v", "f4")])

# Dask's background work, which two workers on two cores pay out of the tracing: an idle
# two-worker LocalCluster took 9.3 % of a core with its defaults, 4.2 % with the event loops'
# tick at 1 s (20 ms by default: it only measures how long the loop was blocked), 1.6 % with the
# system and memory monitors at 5 s and 1 s too (100 and 500 ms by default: the dashboard's
# figures, the memory limits' checks); the profiler samples every thread's stack every 10 ms
# while tasks run (half a worker's event-loop time in a run).
QUIET = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "1s",
}


def make_rays(index, size, lo, hi):
    """Chunk `index` of the rays: origins and directions, (size, 3) float32 each."""
    rng = np.random.default_rng([43, int(index)])
    centre, half = (lo + hi) / 2, (hi - lo) / 2 * 1.5
    o = rng.uniform(centre - half, centre + half, (size, 3))
    d = rng.normal(size=(size, 3))
    return o.astype(np.float32), d.astype(np.float32)


def rays_part(index, part, size, lo, hi):
    return make_rays(index, size, lo, hi)[part]


def placed_rays(client, k, size, lo, hi):
    """The origins and directions as dask arrays of k chunks, chunk i made and kept on worker
    i mod w."""
    import dask.array as da

    workers = sorted(client.scheduler_info()["workers"])
    parts = []
    for part in (0, 1):
        futures = [
            client.submit(rays_part, i, part, size, lo, hi, workers=[workers[i % len(workers)]],
                          allow_other_workers=False, pure=False)
            for i in range(k)
        ]
        parts.append(da.concatenate([
            da.from_delayed(f, (size, 3), dtype=np.float32) for f in futures
        ]).rechunk(((size,) * k, 3)))
    return parts


def closest(o, d, scene):
    h = scene.intersect(o, d, threads=1)
    out = np.empty(len(o), HIT)
    out["t"], out["prim"], out["u"], out["v"] = h.t, h.prim, h.u, h.v
    return out


def cpu_seconds():
    """The CPU time of this process and its children (a LocalCluster's workers)."""
    import psutil

    me = psutil.Process()
    total = 0.0
    for p in [me] + me.children(recursive=True):
        try:
            t = p.cpu_times()
        except psutil.NoSuchProcess:
            continue
        total += t.user + t.system
    return total


def median_time(f, k):
    times = []
    for _ in range(k):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def settle(client, x):
    """Waits until `x`'s chunks are computed on `client`'s workers (two clients live here: the
    one of `x`, not a default)."""
    from dask.distributed import futures_of, wait

    with client.as_current():
        wait(futures_of(x))


def cpu_model():
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        return next(l.split(":", 1)[1].strip() for l in out.splitlines() if "Model name" in l)
    except (OSError, StopIteration):
        return platform.processor()


def load():
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh")
    ap.add_argument("--rays", type=float, default=1e7)
    ap.add_argument("--chunks", default="1e5,2.5e5,1e6", help="chunk sizes, comma-separated")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--dask-defaults", action="store_true",
                    help="keep Dask's profiler and timers as they are (see QUIET)")
    args = ap.parse_args()

    import dask.array as da
    from dask.distributed import Client, LocalCluster, get_task_stream

    n = int(args.rays)
    sizes = [int(float(s)) for s in args.chunks.split(",")]
    print(f"cpu: {cpu_model()}, {os.cpu_count()} logical cores; load before: {load()}")
    print(f"kdray {kdray.ISA}; mesh {args.mesh}; {n:,} rays; chunks {sizes}")

    builds = []
    for _ in range(args.rounds):
        start = time.perf_counter()
        scene = kdray.Scene.load(args.mesh)
        builds.append(time.perf_counter() - start)
    build = statistics.median(builds)
    info = scene.info
    builder = info["build_ms"] / 1e3  # the SAH builder alone, as the tree's header records it
    print(f"scene: {info['triangles']:,} triangles, {info['bytes'] / 2**20:.1f} MiB tree; "
          f"build (load + build, every core) {build * 1e3:.0f} ms median, of which the "
          f"builder {builder * 1e3:.0f} ms (the last)")

    def out_of_band():
        buffers = []
        data = pickle.dumps(scene, protocol=5, buffer_callback=buffers.append)
        return pickle.loads(data, buffers=buffers)

    def in_band():
        return pickle.loads(pickle.dumps(scene, protocol=5))

    for name, f in (("out of band", out_of_band), ("in band", in_band)):
        t = median_time(f, 5)
        print(f"pickle round trip, {name}: {t * 1e3:.1f} ms = {t / build:.1%} of the build, "
              f"{t / builder:.1%} of the builder")
    back = out_of_band()
    lo, hi = (np.array(b, np.float32) for b in info["bounds"])
    probe = make_rays(2**32, 100_000, lo, hi)
    assert np.array_equal(closest(*probe, back), closest(*probe, scene))

    if not args.dask_defaults:
        import dask

        dask.config.set(QUIET)
    clusters = {}
    for w in (1, 2):
        cluster = LocalCluster(n_workers=w, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
        client = Client(cluster, set_as_default=False)
        client.wait_for_workers(w)  # a broadcast reaches only the workers already there
        start = time.perf_counter()
        remote = client.scatter(scene, broadcast=True)  # returns once the workers hold it
        scatter = time.perf_counter() - start
        print(f"{w} worker(s): scene scattered (pickle, transfer, validation) in "
              f"{scatter * 1e3:.0f} ms")
        clusters[w] = (cluster, client, remote)

    results = {}
    for size in sizes:
        k = -(-n // size)
        rays = {}
        for w, (_, client, _) in clusters.items():
            rays[w] = client.persist(placed_rays(client, k, size, lo, hi))
            settle(client, rays[w])
        local_rays = [make_rays(i, size, lo, hi) for i in range(k)]
        times = {"local": [], "1 w": [], "2 w": [], "local 2 t": [], "1 w tasks": [],
                 "2 w tasks": [], "local cpu": [], "1 w cpu": [], "2 w cpu": []}
        for round_ in range(args.rounds):
            start, cpu = time.perf_counter(), time.process_time()
            local = [closest(o, d, scene) for o, d in local_rays]
            times["local"].append(time.perf_counter() - start)
            times["local cpu"].append(time.process_time() - cpu)
            for w, (_, client, remote) in clusters.items():
                # A new name each run: the same graph again would find its answers computed.
                name = f"closest-{size}-{w}-{round_}"
                hits = da.map_blocks(
                    closest, *rays[w], scene=remote, drop_axis=1, dtype=HIT, name=name
                )
                with get_task_stream(client=client) as stream:
                    start, cpu = time.perf_counter(), cpu_seconds()
                    hits = client.persist(hits)
                    settle(client, hits)
                    wall = time.perf_counter() - start
                    times[f"{w} w cpu"].append(cpu_seconds() - cpu)
                times[f"{w} w"].append(wall)
                # The workers' time in `closest` itself; the rest of w × wall is the overhead.
                inside = sum(
                    s["stop"] - s["start"]
                    for task in stream.data
                    for s in task["startstops"]
                    if s["action"] == "compute"
                )
                times[f"{w} w tasks"].append(inside)
                if round_ == 0:
                    got = client.compute(hits, sync=True)
                    assert np.array_equal(got, np.concatenate(local)), "answers differ"
                del hits
            whole = [np.concatenate(part) for part in zip(*local_rays)]
            start = time.perf_counter()
            scene.intersect(*whole, threads=2)
            times["local 2 t"].append(time.perf_counter() - start)
            del whole
        med = {key: statistics.median(v) for key, v in times.items()}
        results[size] = (k, med)
        del rays, local_rays
        print(f"  chunk {size:>9,}: done (load {load()})")

    print()
    print("local: this process, threads=1; 1 w, 2 w: LocalCluster wall time; 2w/1w: the "
          "speed-up; local 2 t: this process's threads=2 speed-up; overhead: a worker's time "
          "outside the traced calls (w × wall − the tasks' compute time), a chunk and as a share "
          "of the tasks' time; vs local: 1 w − local, a chunk; CPU over: the CPU time of all the "
          "run's processes less local's, a chunk")
    print(f"{'chunk':>10} {'chunks':>6} {'local s':>8} {'1 w s':>7} {'2 w s':>7} "
          f"{'2w/1w':>6} {'local 2 t':>9} {'overhead 1 w':>20} {'overhead 2 w':>20} "
          f"{'vs local':>9} {'CPU over 1 w':>12} {'CPU over 2 w':>12} {'Mrays/s 2 w':>11}")
    for size, (k, m) in results.items():
        cols = []
        for w in (1, 2):
            over = w * m[f"{w} w"] - m[f"{w} w tasks"]
            cols.append(f"{over / k * 1e3:>8.2f} ms {over / m[f'{w} w tasks']:>7.1%}")
        print(f"{size:>10,} {k:>6} {m['local']:>8.2f} {m['1 w']:>7.2f} {m['2 w']:>7.2f} "
              f"{m['1 w'] / m['2 w']:>5.2f}× {m['local'] / m['local 2 t']:>8.2f}× "
              f"{cols[0]:>20} {cols[1]:>20} "
              f"{(m['1 w'] - m['local']) / k * 1e3:>6.2f} ms "
              f"{(m['1 w cpu'] - m['local cpu']) / k * 1e3:>9.1f} ms "
              f"{(m['2 w cpu'] - m['local cpu']) / k * 1e3:>9.1f} ms {n / m['2 w'] / 1e6:>11.2f}")
    print(f"load after: {load()}")
    for cluster, client, _ in clusters.values():
        client.close()
        cluster.close()


if __name__ == "__main__":
    main()
