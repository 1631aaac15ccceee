"""Run every benchmark in one run and write benchmarks/REPORT.md and the README's performance table.

    python -m benchmarks [--quick] [--only NAME ...]

Each benchmark module has ``run(quick: bool) -> dict``, ``report(dict) -> markdown`` and optionally
``readme_rows(dict) -> list of (benchmark, result, target)`` for the README table.  Ratios are measured against
baselines run in the same process, on the same machine, in the same run.
"""
from __future__ import annotations

import argparse
import datetime as dt
import importlib
import os
import platform
import re
import sys
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent
MODULES = ["bench_trace", "bench_importance", "bench_cluster"]
MARK_START = "<!-- perf-table:start -->"
MARK_END = "<!-- perf-table:end -->"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks")
    ap.add_argument("--quick", action="store_true", help="fewer rays (a smoke run)")
    ap.add_argument("--only", nargs="*", help="run only these modules")
    a = ap.parse_args(argv)
    import numba

    head = [f"# Benchmarks", "", f"Run {dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M UTC} on {platform.machine()}, "
            f"{os.cpu_count()} CPUs, {numba.get_num_threads()} Numba threads, Python {platform.python_version()}, "
            f"numba {numba.__version__}{' (quick)' if a.quick else ''}.", ""]
    body, rows = [], []
    for name in a.only or MODULES:
        try:
            mod = importlib.import_module(f"benchmarks.{name}")
        except ImportError as e:
            body += [f"## {name}", "", f"not run: {e}", ""]
            continue
        try:
            r = mod.run(quick=a.quick) if "quick" in mod.run.__code__.co_varnames else mod.run()
            body.append(mod.report(r))
            if hasattr(mod, "readme_rows"):
                rows += mod.readme_rows(r)
        except Exception as e:  # a failing benchmark is reported, the others still run
            body += [f"## {name}", "", f"failed: {type(e).__name__}: {e}", "", "```", traceback.format_exc(), "```", ""]
    (HERE / "REPORT.md").write_text("\n".join(head + body) + "\n")
    readme = HERE.parent / "README.md"
    if rows and readme.exists():
        table = ["| benchmark | result | target |", "|---|---|---|"] + [f"| {b} | {r} | {t} |" for b, r, t in rows]
        text = readme.read_text()
        block = MARK_START + "\n" + "\n".join(table) + "\n" + MARK_END
        if MARK_START in text:
            text = re.sub(re.escape(MARK_START) + ".*?" + re.escape(MARK_END), block, text, flags=re.S)
        else:
            text += "\n## Performance\n\nMeasured by `python -m benchmarks` (full report: `benchmarks/REPORT.md`).\n\n" + block + "\n"
        readme.write_text(text)
    print("\n".join(head + body))
    return 0


if __name__ == "__main__":
    sys.exit(main())
