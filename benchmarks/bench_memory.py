"""Peak memory against the ray count of an image run: the maximum resident set size of a whole ``irt run``
process tracing the benchmark Cassegrain into its 1024 x 1024 focal-plane image (no per-ray records).

Run: ``python -m benchmarks.bench_memory [--quick]`` (also part of ``python -m benchmarks``).

Each point is a fresh ``irt run`` (this interpreter, the working tree's code, the warm Numba cache) started by a
small wrapper process that reports ``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss`` after it ends, so a point is
the peak of that one process.  Two sources: random points (GRID DISK ... RANDOM: each ray's start is drawn from
its id) and the regular lattice (GRID DISK without RANDOM: the lattice points are computed before the trace).
"""
from __future__ import annotations

import argparse
import json
import math
import tempfile
from pathlib import Path

from ._common import HERE, ROOT, last_json, plt, python_child

SCRIPT = """WAVELENGTHS 550 NM
SEED 7
spacing_delta = 0
INCLUDE '{cass}'
GRID DISK Z 1200 150 RAYS {n}{rnd}
SOURCE DIRECTION 0 0 -1
FLUX TOTAL 1 W
LEVEL 10
HALT 0
TRACE
EXPORT fpa 'fpa.npy'
"""
WRAP = """import json, resource, subprocess, sys, time
t0 = time.perf_counter()
p = subprocess.run([sys.executable, '-c', 'import sys; from irtlang.cli import main; sys.exit(main())', 'run',
                    sys.argv[1], '--out', sys.argv[2]], capture_output=True, text=True)
t = time.perf_counter() - t0
print(json.dumps({'rc': p.returncode, 's': t, 'maxrss_kb': resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss,
                  'err': p.stderr[-300:]}))
"""
FLAT = 1.10          # "flat": the largest peak at most 10 % above the smallest over the sweep


def peak(n: int, lattice: bool, workdir: Path) -> dict:
    script = workdir / f"mem_{n}_{'lat' if lattice else 'rnd'}.inr"
    script.write_text(SCRIPT.format(cass=HERE / "cassegrain_plain.inr", n=n, rnd="" if lattice else " RANDOM"))
    p = python_child(WRAP, script, workdir / "out", timeout=1200)
    r = last_json(p.stdout)
    if r["rc"] != 0:
        raise RuntimeError(f"irt run failed: {r['err']}")
    return {"rays": n, "s": r["s"], "mb": r["maxrss_kb"] / 1024.0}


def run(quick: bool = False, out=None) -> dict:
    out = Path(HERE if out is None else out)
    ns = [10_000, 100_000, 1_000_000] if quick else [10_000, 100_000, 1_000_000, 10_000_000]
    r = {"series": {}}
    with tempfile.TemporaryDirectory() as td:
        wd = Path(td)
        peak(10_000, False, wd)     # make sure the kernel is compiled and cached first
        for lattice in (False, True):
            key = "lattice GRID" if lattice else "RANDOM GRID"
            r["series"][key] = [peak(n, lattice, wd) for n in ns]
    for key, pts in r["series"].items():
        mbs = [q["mb"] for q in pts]
        r.setdefault("growth", {})[key] = max(mbs) / min(mbs)
        q0, q1 = pts[0], pts[-1]
        r.setdefault("per_ray", {})[key] = (q1["mb"] - q0["mb"]) * 2 ** 20 / (q1["rays"] - q0["rays"])
    p = plt()
    fig, ax = p.subplots(figsize=(5.6, 3.8), dpi=110)
    for key, pts in r["series"].items():
        ax.semilogx([q["rays"] for q in pts], [q["mb"] for q in pts], "o-", label=key)
    ax.set_xlabel("rays")
    ax.set_ylabel("peak RSS of the irt run process (MB)")
    ax.set_title("Cassegrain image run: peak memory against rays", fontsize=9)
    ax.set_ylim(bottom=0)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "bench_memory.png")
    p.close(fig)
    r["plot"] = "bench_memory.png"
    return r


def report(r: dict) -> str:
    keys = list(r["series"])
    pts0 = r["series"][keys[0]]
    lines = ["## Peak memory against rays (image run)", "",
             "`irt run` of the benchmark Cassegrain (1024 x 1024 detector, EXPORT of the image, no per-ray records); "
             "peak RSS of the whole process (`getrusage(RUSAGE_CHILDREN)` in a wrapper), one fresh process per "
             "point, warm Numba cache.", "",
             "| rays | " + " | ".join(f"{k}: peak RSS (MB) | {k}: wall (s)" for k in keys) + " |",
             "|---|" + "---|---|" * len(keys)]
    for i, q in enumerate(pts0):
        cells = []
        for k in keys:
            x = r["series"][k][i]
            cells += [f"{x['mb']:.0f}", f"{x['s']:.1f}"]
        lines.append(f"| {q['rays']:,} | " + " | ".join(cells) + " |")
    lines.append("")
    for k in keys:
        g = r["growth"][k]
        lines.append(f"* {k}: largest / smallest peak {g:.2f} ({r['per_ray'][k]:.1f} bytes per extra ray): "
                     f"{'flat' if g <= FLAT else 'not flat'} (target: flat in rays, here within {FLAT - 1:.0%}).")
    lines += ["", "Neither source stores its start points: a random grid draws each from the ray's id, a lattice "
                  "GRID DISK keeps one row table (O(sqrt(rays)) entries, irtlang.compile.pack.disk_lattice_rows) and "
                  "finds a ray's row by bisection.  Images stream into their tallies; nothing per ray is kept.", "",
              f"![peak memory]({r['plot']})", ""]
    return "\n".join(lines)


def readme_rows(r: dict) -> list:
    rnd = r["series"]["RANDOM GRID"]
    lat = r["series"]["lattice GRID"]
    return [("peak memory of an image run against rays (whole `irt run` process)",
             f"RANDOM grid {rnd[0]['mb']:.0f} -> {rnd[-1]['mb']:.0f} MB, lattice {lat[0]['mb']:.0f} -> "
             f"{lat[-1]['mb']:.0f} MB for {rnd[0]['rays']:.0e} -> {rnd[-1]['rays']:.0e} rays", "flat in rays")]


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args(argv)
    r = run(a.quick)
    print(report(r))
    return r


if __name__ == "__main__":
    main()
