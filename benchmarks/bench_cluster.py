"""Speed-up of a trace split over a local Dask cluster (irtlang.cluster) against the in-process run, measured in
one run on the same machine with the same scene (the Cassegrain of benchmarks/bench_trace.py).

Run: ``python -m benchmarks.bench_cluster [--rays N] [--repeat K] [--workers 1 2] [--quick]`` (also part of
``python -m benchmarks``; needs ``pip install "irtlang[cluster]"``).

The in-process run uses every Numba thread of this process.  A local cluster of W workers gives each worker
process cores // W Numba threads (irtlang.cluster.connect), so every configuration uses the same cores: on one
machine the cluster can at best match the in-process run; the point is the overhead (scatter, per-unit
round trips, in-order reduction on the client) that a cluster of several machines pays for its extra cores.
Each configuration is warmed up first (the workers load the compiled kernel from the Numba cache, timed as
"first trace"); its K repeats alternate with in-process runs (a shared machine's load drifts) and its
speed-up is the best in-process time over the best cluster time of those; every cluster run is checked
bitwise against the in-process ledger and image.
"""
from __future__ import annotations

import argparse
import time

import numba


def run(n: int = 4_000_000, repeat: int = 2, quick: bool = False, workers=(1, 2), batch: int = 1 << 16) -> dict:
    if quick:
        n, repeat = 400_000, 1
    from irtlang.cluster import DaskRunner, close_client, connect, default_threads
    from irtlang.tracer import Progress, run_trace

    from .bench_trace import scene_for

    scene, _ = scene_for(n)
    small, _ = scene_for(20_000)
    quiet = lambda: Progress(0, enabled=False)  # noqa: E731

    def trace(sc, runner=None, batch=batch):
        return run_trace(sc, seed=7, level=10, halt=0.0, batch=batch, runner=runner, progress=quiet())

    trace(small)   # compile (or load) the kernel here
    t_in, ref = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        ref = trace(scene)
        t_in.append(time.perf_counter() - t0)
    out = {"rays": n, "batch": batch, "units": -(-n // batch), "threads": numba.get_num_threads(),
           "in_process_s": min(t_in), "clusters": []}
    for w in workers:
        t0 = time.perf_counter()
        client = connect(workers=w)
        t_start = time.perf_counter() - t0
        try:
            runner = DaskRunner(client)
            t0 = time.perf_counter()
            trace(small, runner, batch=1024)   # 20 units: every worker loads the kernel
            t_first = time.perf_counter() - t0
            ts, tin, res = [], [], None
            for _ in range(repeat):   # interleaved with in-process runs: a machine's load drifts
                t0 = time.perf_counter()
                res = trace(scene, runner)
                ts.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                trace(scene)
                tin.append(time.perf_counter() - t0)
        finally:
            t0 = time.perf_counter()
            close_client(client)
            t_close = time.perf_counter() - t0
        same = (res.ledger.tobytes() == ref.ledger.tobytes()
                and all(res.images[k][0].tobytes() == ref.images[k][0].tobytes() for k in ref.images))
        out["clusters"].append({"workers": w, "threads_per_worker": default_threads(w), "start_s": t_start,
                                "first_s": t_first, "close_s": t_close, "trace_s": min(ts),
                                "in_process_s": min(tin), "speedup": min(tin) / min(ts), "bitwise_same": same})
    return out


def report(r: dict) -> str:
    rows = [f"| in-process | {r['threads']} Numba threads | {r['in_process_s']:.3f} | "
            f"{r['rays'] / r['in_process_s'] / 1e6:.2f} | 1.00x | - | - |"]
    for c in r["clusters"]:
        rows.append(f"| LocalCluster, {c['workers']} worker{'s' if c['workers'] > 1 else ''} | "
                    f"{c['threads_per_worker']} Numba thread{'s' if c['threads_per_worker'] > 1 else ''} each | "
                    f"{c['trace_s']:.3f} | {r['rays'] / c['trace_s'] / 1e6:.2f} | {c['speedup']:.2f}x "
                    f"(in-process {c['in_process_s']:.3f} s) | "
                    f"{c['start_s']:.1f} s + {c['first_s']:.1f} s | {'yes' if c['bitwise_same'] else 'NO'} |")
    return "\n".join([
        "## Trace on a local Dask cluster",
        "",
        f"Cassegrain of benchmarks/bench_trace.py, {r['rays']:,} rays in {r['units']} units of {r['batch']:,}, "
        "best of the repeats (each cluster row against the in-process runs interleaved with it); the same cores "
        "in every row.",
        "",
        "| run | threads | time (s) | Mrays/s | speed-up | cluster start + first trace | bitwise same |",
        "|---|---|---|---|---|---|---|",
        *rows,
        "",
    ])


def readme_rows(r: dict) -> list:
    s = ", ".join(f"{c['workers']} worker{'s' if c['workers'] > 1 else ''} {c['speedup']:.2f}x"
                  for c in r["clusters"])
    return [("local Dask cluster vs in-process (same cores, bitwise same result)", s,
             "~1x on one machine (overhead only)")]


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--rays", type=int, default=4_000_000)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args(argv)
    r = run(a.rays, a.repeat, a.quick, tuple(a.workers))
    print(report(r))
    return r


if __name__ == "__main__":
    main()
