"""`scene.intersect` against the native `kdray trace` on the same tree, rays and threads, the two
taking turns (A/B), for the issue's target: a batch within 10 % of the native throughput.

    python bench/native_ab.py --kdray target/release/kdray data/bunny.tri data/dragon.tri

For each mesh, `kdray build` writes the tree once (the command line's defaults; a `.kdt` given
instead is used as it is) and the package loads that `.kdt` (`Scene.load`), so both trace the
same tree; `kdray rays` writes the benchmark protocol's primary and diffuse rays
(docs/BENCHMARKS.md). Each round runs `kdray trace --repeat K` (its `trace_ms`: the best of K,
without file I/O) for each way of tracing given to `--native` (default: consecutive packets, and
the stream), and K calls of `scene.intersect` on the same arrays (the best of K, the whole call:
the Python layer, checks, tracing, the answers' arrays), the package before the native runs in
one round and after them in the next; `--python` adds another build of the package (another
virtual environment's), timed in its own process in the same rounds. Printed: the medians over
the rounds, the package's ratio to the fastest native way (1.00 = equal) and the median of the
per-round ratios, and the ratio of the best times over all rounds (this VM has phases of
seconds in which everything runs up to 1.8× slower, native and package alike; the best of many
alternating runs is the figure those phases touch least). The answers are compared ray by ray
with the last native hits file (the triangle, and `t` to 1e-6 relative).
"""

import argparse
import os
import statistics
import subprocess
import tempfile
import time

import numpy as np

import kdray


def read_rays(path):
    r = np.fromfile(path, "<f4").reshape(-1, 8)
    return (
        np.ascontiguousarray(r[:, 0:3]),
        np.ascontiguousarray(r[:, 3:6]),
        np.ascontiguousarray(r[:, 6]),
        np.ascontiguousarray(r[:, 7]),
    )


def native(args, flags, kdt, rays, out, threads):
    line = subprocess.run(
        [args.kdray, "trace", kdt, "--rays", rays, "--out", out, "--threads", str(threads),
         "--repeat", str(args.repeat), *flags.split()],
        check=True, capture_output=True, text=True,
    ).stdout
    keys = dict(kv.split("=", 1) for kv in line.split() if "=" in kv)
    return float(keys["trace_ms"]) / 1e3, keys


def package(scene, rays, threads, repeat):
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        hits = scene.intersect(*rays, threads=threads)
        best = min(best, time.perf_counter() - start)
    return best, hits


class Worker:
    """Another Python (another build of the package, e.g. an older one in its own virtual
    environment) timing `scene.intersect` in a process of its own, on request: this file run
    with `--worker`, commands on stdin."""

    def __init__(self, python):
        self.python = python
        self.p = subprocess.Popen([python, os.path.abspath(__file__), "--worker", "-"],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def ask(self, *words):
        self.p.stdin.write(" ".join(map(str, words)) + "\n")
        self.p.stdin.flush()
        return self.p.stdout.readline().split()

    def close(self):
        self.p.stdin.close()
        self.p.wait()


def worker():
    scene = rays = None
    for line in iter(input_line, None):
        cmd, *args = line.split()
        if cmd == "load":
            scene = kdray.Scene.load(args[0])
            print(getattr(kdray, "ISA", "?"), flush=True)
        elif cmd == "rays":
            rays = read_rays(args[0])
            print("ok", flush=True)
        elif cmd == "run":
            s, _ = package(scene, rays, int(args[0]), int(args[1]))
            print(s, flush=True)


def input_line():
    try:
        return input()
    except EOFError:
        return None


def same_answers(hits, path):
    h = np.fromfile(path, "<u4").reshape(-1, 4)
    prim = np.where(h[:, 1] == 0xFFFFFFFF, -1, h[:, 1].astype(np.int64))
    t = h[:, 0].view("<f4")
    same_prim = np.mean(prim == hits.prim)
    both = np.isfinite(t) & np.isfinite(hits.t)
    t_ok = np.allclose(hits.t[both], t[both], rtol=1e-6, atol=0) and np.array_equal(
        np.isfinite(t), np.isfinite(hits.t))
    return same_prim, t_ok


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("meshes", nargs="*", help="meshes (.tri, .ply, ...) or .kdt trees")
    ap.add_argument("--kdray", default="kdray", help="the kdray command")
    ap.add_argument("--native", default="--packet 8;--stream --packet 8",
                    help="kdray trace's tracing flags, ';' between ways to run it, each timed "
                         "in every round; the ratio is against the fastest (default: %(default)s)")
    ap.add_argument("--build", default="", help="kdray build's flags (default: its defaults)")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--kinds", default="primary,diffuse")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs in a round")
    ap.add_argument("--python", action="append", default=[],
                    help="also time the package of this Python (another build, in its own "
                         "virtual environment), in the same rounds")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        return worker()
    isa = subprocess.run([args.kdray, "--version"], capture_output=True, text=True).stdout.strip()
    print(f"native: {isa}; package: isa={kdray.ISA}; native flags: {args.native}; "
          f"load average {os.getloadavg()[0]:.1f}")
    ways = [w.strip() for w in args.native.split(";")]
    others = [Worker(p) for p in args.python]
    print("| mesh | threads | rays | " + " | ".join(f"native `{w}`" for w in ways)
          + "".join(f" | package ({w.python})" for w in others)
          + " | package | package ÷ fastest native (ratio of medians) | median of per-round "
          "ratios | ratio of the bests | same triangle |")
    print("|---|---:|---|" + "---:|" * (len(ways) + len(others) + 5))
    for mesh in args.meshes:
        name = os.path.basename(mesh).split(".")[0]
        with tempfile.TemporaryDirectory() as tmp:
            kdt = os.path.join(tmp, "m.kdt")
            if mesh.endswith(".kdt"):
                kdt = mesh
            else:
                subprocess.run([args.kdray, "build", mesh, "-o", kdt, *args.build.split()],
                               check=True, capture_output=True)
            scene = kdray.Scene.load(kdt)
            for w in others:
                w.ask("load", kdt)
            for kind in args.kinds.split(","):
                path = os.path.join(tmp, kind + ".bin")
                subprocess.run([args.kdray, "rays", kdt, "-o", path, "--kind", kind],
                               check=True, capture_output=True)
                rays = read_rays(path)
                for w in others:
                    w.ask("rays", path)
                n = len(rays[0])
                out = os.path.join(tmp, "hits.bin")
                for threads in map(int, args.threads.split(",")):
                    package(scene, rays, threads, 1)  # warm: the pool, the thread's buffers
                    for w in others:
                        w.ask("run", threads, 1)
                    nat = {w: [] for w in ways}
                    pkg = []
                    old = {w.python: [] for w in others}
                    for r in range(args.rounds):
                        if r % 2 == 1:
                            s, hits = package(scene, rays, threads, args.repeat)
                            pkg.append(s)
                        for w in others:
                            old[w.python].append(float(w.ask("run", threads, args.repeat)[0]))
                        for w in ways:
                            nat[w].append(native(args, w, kdt, path, out, threads)[0])
                        if r % 2 == 0:
                            s, hits = package(scene, rays, threads, args.repeat)
                            pkg.append(s)
                    same, t_ok = same_answers(hits, out)
                    best = min(ways, key=lambda w: statistics.median(nat[w]))
                    mn, mp = statistics.median(nat[best]), statistics.median(pkg)
                    ratios = statistics.median(
                        min(nat[w][r] for w in ways) / pkg[r] for r in range(args.rounds))
                    bests = min(min(nat[w]) for w in ways) / min(pkg)
                    cells = " | ".join(f"{n / statistics.median(nat[w]) / 1e6:.2f}" for w in ways)
                    cells += "".join(f" | {n / statistics.median(old[w.python]) / 1e6:.2f}"
                                     for w in others)
                    print(f"| {name} | {threads} | {kind} ({n:,}) | {cells} | {n / mp / 1e6:.2f} | "
                          f"{mn / mp:.3f} | {ratios:.3f} | {bests:.3f} | "
                          f"{100 * same:.3f} %{'' if t_ok else ' (t differs)'} |", flush=True)
    for w in others:
        w.close()
    print(f"load average at the end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
