"""Rays/s of the Cassegrain traced from a script (irtlang's non-sequential kernel) against the hand-written
sequential Numba kernel of the same geometry, measured in one run on the same machine.

Run: ``python -m benchmarks.bench_trace [--rays N] [--repeat K]`` (also part of ``python -m benchmarks``).
Both are warmed up (compiled) first; each timing is the best of K repeats.
"""
from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = """
WAVELENGTHS 550 NM
SEED 7
spacing_delta = 0
INCLUDE '{cass}'
GRID DISK Z 1200 150 RAYS {n} RANDOM
SOURCE DIRECTION 0 0 -1
FLUX TOTAL 1 W
LEVEL 10
HALT 0
TRACE
"""


def scene_for(n: int):
    from irtlang.lang.diagnostics import Source
    from irtlang.lang.interp import Interpreter

    it = Interpreter(check_only=True)
    it.include_stack = [ROOT / "benchmarks" / "bench.inr"]
    it.run_source(Source("bench.inr", SCRIPT.format(cass=ROOT / "benchmarks" / "cassegrain_plain.inr", n=n)))
    assert not it.diags, it.diags.items
    trace = [s for s in it.steps if s.kind == "TRACE"][0]
    return trace.scene, it


def run(n: int = 2_000_000, repeat: int = 3, quick: bool = False) -> dict:
    if quick:
        n, repeat = 200_000, 1
    from irtlang.tracer import Progress, run_trace

    from .handwritten import trace_cassegrain

    scene, it = scene_for(n)
    g = lambda k: it.lookup(k).value  # noqa: E731
    spacing = g("spacing") * 1e-3
    c1 = 1 / (g("R1") * 1e-3)
    c2 = 1 / (g("R2") * 1e-3)
    args = (7, 1.2, 0.15, c1, -1.0, 0.04, 0.15, spacing, c2, g("K2"), 0.02, spacing + 1e-3, 0.022, -0.3, 0.010752, 1024)
    nth = numba.get_num_threads()
    quiet = Progress(0, enabled=False)
    # warm up both
    run_trace(scene_for(20000)[0], seed=7, level=10, halt=0.0, progress=quiet)
    img = np.zeros((nth, 1024, 1024))
    trace_cassegrain(20000, *args, img)
    t_irt, t_hand = [], []
    res = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = run_trace(scene, seed=7, level=10, halt=0.0, progress=quiet)
        t_irt.append(time.perf_counter() - t0)
        img = np.zeros((nth, 1024, 1024))
        t0 = time.perf_counter()
        trace_cassegrain(n, *args, img)
        hand = img.sum(0)
        t_hand.append(time.perf_counter() - t0)
    irt_img = res.images["fpa"][0][0]
    out = {"rays": n, "threads": nth, "irtlang_s": min(t_irt), "hand_s": min(t_hand),
           "irtlang_Mrays_s": n / min(t_irt) / 1e6, "hand_Mrays_s": n / min(t_hand) / 1e6,
           "ratio": min(t_hand) / min(t_irt), "flux_irt": float(irt_img.sum()), "flux_hand": float(hand.sum())}
    return out


def report(r: dict) -> str:
    return "\n".join([
        "## Telescope trace: script vs hand-written kernel",
        "",
        f"Cassegrain of benchmarks/cassegrain_plain.inr, {r['rays']:,} rays, {r['threads']} threads, best of the repeats.",
        "",
        "| tracer | time (s) | Mrays/s | ratio to hand-written |",
        "|---|---|---|---|",
        f"| irtlang (script, non-sequential) | {r['irtlang_s']:.3f} | {r['irtlang_Mrays_s']:.2f} | {r['ratio']:.2f}x |",
        f"| hand-written Numba (sequential) | {r['hand_s']:.3f} | {r['hand_Mrays_s']:.2f} | 1.00x |",
        "",
        f"Flux on the focal plane: irtlang {r['flux_irt']:.6f} W, hand-written {r['flux_hand']:.6f} W "
        "(same geometry, same Philox source numbers).",
        "",
    ])


def readme_rows(r: dict) -> list:
    return [("telescope trace, irtlang vs hand-written Numba kernel (same run)",
             f"{r['irtlang_Mrays_s']:.2f} vs {r['hand_Mrays_s']:.2f} Mrays/s = {r['ratio']:.2f}x ({r['threads']} threads)",
             ">= 0.8x and >= 20 Mrays/s")]


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--rays", type=int, default=2_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    r = run(a.rays, a.repeat)
    print(report(r))
    return r


if __name__ == "__main__":
    main()
