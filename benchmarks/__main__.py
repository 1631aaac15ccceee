"""Run every benchmark in one run and write benchmarks/REPORT.md and the README's performance table.

    python -m benchmarks [--quick] [--only NAME ...] [--out DIR] [--no-readme]

Each benchmark module has ``run(quick: bool[, out: Path]) -> dict`` (``out``: where its PNG plots go, next to
REPORT.md), ``report(dict) -> markdown`` and optionally ``readme_rows(dict) -> list of (benchmark, result,
target)`` for the README table.  Ratios are measured against baselines run in the same process, on the same
machine, in the same run.  The peers (optiland, Mitsuba 3) are optional: ``pip install ".[bench]"``; a
benchmark whose peer is absent says so in the report instead of failing.
"""
from __future__ import annotations

import argparse
import datetime as dt
import importlib
import inspect
import os
import platform
import re
import sys
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent
MODULES = ["bench_trace", "bench_optiland", "bench_importance", "bench_mitsuba", "bench_cluster", "bench_startup",
           "bench_memory", "bench_earth", "bench_defocus", "bench_polarization"]
MARK_START = "<!-- perf-table:start -->"
MARK_END = "<!-- perf-table:end -->"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks")
    ap.add_argument("--quick", action="store_true", help="fewer rays (a smoke run)")
    ap.add_argument("--only", nargs="*", choices=MODULES, metavar="NAME", help=f"run only these: {', '.join(MODULES)}")
    ap.add_argument("--out", type=Path, default=HERE, help="folder for REPORT.md and the plots (default benchmarks/)")
    ap.add_argument("--no-readme", action="store_true",
                    help="leave the README's performance table alone (always so with --only)")
    a = ap.parse_args(argv)
    import numba

    from ._common import PEERS, peer_version

    out = a.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    peers = {k: peer_version(v) for k, v in PEERS.items()}
    head = [f"# Benchmarks", "", f"Run {dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M UTC} on {platform.machine()}, "
            f"{os.cpu_count()} CPUs, {numba.get_num_threads()} Numba threads, Python {platform.python_version()}, "
            f"numba {numba.__version__}{' (quick)' if a.quick else ''}; peers: "
            + ", ".join(f"{k} {v}" if v else f"{k} **absent** (pip install \".[bench]\")" for k, v in peers.items())
            + ".  Command: `python -m benchmarks" + (" --quick" if a.quick else "")
            + (f" --only {' '.join(a.only)}" if a.only else "") + "`.", "",
            "Timings are best-of-N wall times on whatever machine ran this; on a shared machine (other jobs on the "
            "same cores) they are noisy, so every ratio is taken against a baseline measured in the same run.", ""]
    body, rows = [], []
    for name in a.only or MODULES:
        t0 = time.perf_counter()
        try:
            mod = importlib.import_module(f"benchmarks.{name}")
        except ImportError as e:
            body += [f"## {name}", "", f"not run: {e}", ""]
            continue
        try:
            kw = {}
            names = inspect.signature(mod.run).parameters
            if "quick" in names:
                kw["quick"] = a.quick
            if "out" in names:
                kw["out"] = out
            r = mod.run(**kw)
            body.append(mod.report(r))
            body.append(f"<sub>{name}: {time.perf_counter() - t0:.0f} s</sub>\n")
            if hasattr(mod, "readme_rows"):
                rows += mod.readme_rows(r)
        except Exception as e:  # a failing benchmark is reported, the others still run
            body += [f"## {name}", "", f"failed: {type(e).__name__}: {e}", "", "```", traceback.format_exc(), "```", ""]
        print(f"benchmarks: {name} done ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
    (out / "REPORT.md").write_text("\n".join(head + body) + "\n")
    readme = HERE.parent / "README.md"
    if rows and readme.exists() and not a.no_readme and not a.only:   # --only: a partial run leaves the README alone
        table = ["| benchmark | result | target |", "|---|---|---|"] + [f"| {b} | {r} | {t} |" for b, r, t in rows]
        text = readme.read_text()
        block = MARK_START + "\n" + "\n".join(table) + "\n" + MARK_END
        if MARK_START in text:
            text = re.sub(re.escape(MARK_START) + ".*?" + re.escape(MARK_END), lambda m: block, text, flags=re.S)
        else:
            text += "\n## Performance\n\nMeasured by `python -m benchmarks` (full report: `benchmarks/REPORT.md`).\n\n" + block + "\n"
        readme.write_text(text)
    print("\n".join(head + body))
    return 0


if __name__ == "__main__":
    sys.exit(main())
