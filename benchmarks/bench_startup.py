"""Start-up: the wall time of a whole ``irt run`` process on a small script, cold (an empty Numba cache) and warm.

Run: ``python -m benchmarks.bench_startup [--script FILE] [--repeat K] [--quick]`` (also part of
``python -m benchmarks``); ``python -m benchmarks.bench_startup --examples [NAME ...]``: the first run of every
runnable example (or those named), each from its own empty Numba cache, against issue 18's 45 s (about 15 min
for all of them; not part of ``python -m benchmarks``).

The process is ``python -c "from irtlang.cli import main; ..." run SCRIPT --out TMP`` with this interpreter and
the working tree first on the path (the same code as the ``irt`` entry point, without a shell wrapper).  Cold: a
fresh, empty NUMBA_CACHE_DIR (Python's own bytecode caches stay warm).  Warm: the same cache again, best (and
median) of K runs.  Also reported: the bare interpreter's start-up and the slowest imports of a warm run
(``python -X importtime``).
"""
from __future__ import annotations

import argparse
import re
import statistics
import tempfile
import time
from pathlib import Path

from ._common import ROOT, python_child

SCRIPT = ROOT / "examples_scripts" / "paraboloid_focus.inr"
RUN = "import sys; from irtlang.cli import main; sys.exit(main())"
TARGET_WARM = 1.5


def _run_once(script: Path, cache: str, out: str, importtime: bool = False, env: dict | None = None
              ) -> tuple[float, object]:
    code = RUN
    args = ["run", str(script), "--out", out]
    t0 = time.perf_counter()
    if importtime:
        import os
        import subprocess
        import sys

        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=str(ROOT))
        p = subprocess.run([sys.executable, "-X", "importtime", "-c", code, *args], capture_output=True, text=True,
                           env=env, cwd=ROOT, timeout=600)
    else:
        p = python_child(code, *args, env={"NUMBA_CACHE_DIR": cache, **(env or {})})
    t = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"irt run failed ({p.returncode}): {p.stderr[-400:]}")
    return t, p


def top_imports(stderr: str, k: int = 8) -> list:
    """The k top-level imports (not nested under another) with the largest cumulative time, in ms."""
    rows = []
    for line in stderr.splitlines():
        if not line.startswith("import time:") or "|" not in line:
            continue
        parts = line.split("|")
        try:
            cum = int(parts[1])
        except ValueError:
            continue
        name = parts[2]
        if name.startswith("  "):        # nested: indented under its importer
            continue
        rows.append((name.strip(), cum / 1e3))
    rows.sort(key=lambda x: -x[1])
    return rows[:k]


def run(quick: bool = False, repeat: int = 5, script: Path = SCRIPT, cold: bool | None = None) -> dict:
    """cold: also time a run on an empty Numba cache (it compiles the kernels: a minute or two); default: not
    with --quick."""
    cold = (not quick) if cold is None else cold
    if quick:
        repeat = 2
    script = Path(script)
    r = {"script": str(script.relative_to(ROOT)) if str(script).startswith(str(ROOT)) else str(script),
         "repeat": repeat}
    t0 = time.perf_counter()
    python_child("pass")
    r["python_s"] = min([time.perf_counter() - t0] + [_time_child("pass") for _ in range(2)])
    r["import_numba_s"] = min(_time_child("import numba") for _ in range(2))
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
        if cold:
            r["cold_s"], _ = _run_once(script, cache, out)
            # the same cold run with Numba's own compile passes (irtlang.kernels.numba_speedups off)
            with tempfile.TemporaryDirectory() as cache0:
                r["cold_plain_s"], _ = _run_once(script, cache0, out, env={"IRT_NUMBA_SPEEDUPS": "0"})
        else:
            _run_once(script, cache, out)
        # the same script without its PNG (SPOTS without a file name): what matplotlib's import and drawing cost
        noplot = Path(out) / "noplot.inr"
        noplot.write_text(re.sub(r"(SPOTS\s+\w+)\s+'[^']*\.png'", r"\1", script.read_text()))
        r["noplot_differs"] = noplot.read_text() != script.read_text()
        warm, warm_np = [], []
        for _ in range(repeat):   # interleaved: a shared machine's load drifts
            warm.append(_run_once(script, cache, out)[0])
            if r["noplot_differs"]:
                warm_np.append(_run_once(noplot, cache, out)[0])
        r["warm_best_s"], r["warm_median_s"] = min(warm), statistics.median(warm)
        if warm_np:
            r["noplot_best_s"], r["noplot_median_s"] = min(warm_np), statistics.median(warm_np)
        _, p = _run_once(script, cache, out, importtime=True)
        r["imports"] = top_imports(p.stderr)
    r["met"] = r["warm_best_s"] <= TARGET_WARM
    return r


#: the examples' settings for a first run that is not the whole job (the flagship's day: its first frame)
EXAMPLE_SETS = {"earth": ("hours=1",)}
TARGET_FIRST = 45.0


def runnable_examples() -> list:
    """examples_scripts/*.inr that a user runs: not those another example INCLUDEs (cassegrain.inr, ...), nor
    those that trace and load nothing (cassegrain_optics.inr, the bare mirrors that tests include)."""
    files = sorted((ROOT / "examples_scripts").glob("*.inr"))
    included = set()
    for f in files:
        included |= {Path(m).name for m in re.findall(r"^\s*INCLUDE\s+'([^']+)'", f.read_text(), flags=re.M)}
    return [f for f in files if f.name not in included
            and re.search(r"^\s*(TRACE|LOAD)\b", f.read_text(), flags=re.M)]


def examples_first_run(names=()) -> list:
    """Each runnable example's whole first `irt run` from an empty Numba cache (the data caches as they are),
    one at a time: [{"example", "s", "rc"}]."""
    out = []
    for f in runnable_examples():
        if names and f.stem not in names:
            continue
        args = ["run", str(f)] + [a for x in EXAMPLE_SETS.get(f.stem, ()) for a in ("--set", x)]
        with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as o:
            t0 = time.perf_counter()
            p = python_child(RUN, *args, "--out", o, env={"NUMBA_CACHE_DIR": cache}, timeout=1800)
            out.append({"example": f.stem, "settings": EXAMPLE_SETS.get(f.stem, ()), "rc": p.returncode,
                        "s": time.perf_counter() - t0})
    return out


def examples_report(rows: list) -> str:
    lines = ["## First runs of the examples", "",
             "Each runnable example's whole `irt run` from its own empty Numba cache (it compiles its kernels), one "
             f"at a time, against issue 18's {TARGET_FIRST:.0f} s:", "",
             "| example | first run | within 45 s |", "|---|---|---|"]
    for r in rows:
        sets = "".join(f" `--set {x}`" for x in r["settings"])
        t = f"{r['s']:.1f} s" if r["rc"] == 0 else f"failed (exit {r['rc']})"
        lines.append(f"| {r['example']}{sets} | {t} | {'yes' if r['rc'] == 0 and r['s'] <= TARGET_FIRST else 'no'} |")
    return "\n".join(lines + [""])


def _time_child(code: str) -> float:
    t0 = time.perf_counter()
    python_child(code)
    return time.perf_counter() - t0


def report(r: dict) -> str:
    cold = f"{r['cold_s']:.2f} s" if "cold_s" in r else "not measured (--quick or --no-cold)"
    lines = ["## Start-up: a whole `irt run` process", "",
             f"`irt run {r['script']}` (a paraboloid, 5,000 rays, spot diagram PNG, ledger CSV, detector .npy), the "
             f"wall time of the process.  The bare interpreter starts in {r['python_s']:.2f} s and `import numba` "
             f"takes {r['import_numba_s']:.2f} s on this machine.", "",
             "| run | wall time |", "|---|---|",
             f"| cold (empty NUMBA_CACHE_DIR: the kernels compile) | {cold} |"]
    if "cold_plain_s" in r:
        lines.append(f"| cold, with Numba's own compile passes (IRT_NUMBA_SPEEDUPS=0) | {r['cold_plain_s']:.2f} s "
                     f"({r['cold_plain_s'] / r['cold_s']:.2f}x the cold run above) |")
    lines += [f"| warm, best of {r['repeat']} | {r['warm_best_s']:.2f} s |",
              f"| warm, median of {r['repeat']} | {r['warm_median_s']:.2f} s |"]
    if "noplot_best_s" in r:
        lines.append(f"| warm, the same script without its spot-diagram PNG (no matplotlib), best / median | "
                     f"{r['noplot_best_s']:.2f} s / {r['noplot_median_s']:.2f} s |")
    lines += ["",
              f"Target: warm <= {TARGET_WARM} s: **{'met' if r['met'] else 'not met'}**.  What a warm run cannot "
              "avoid: the interpreter, numpy and numba (`import numba`, above), Numba's first-use set-up of its "
              "code generator when the cached kernel is loaded (about 0.4 s, numba.core.base.refresh), and "
              "matplotlib when a script writes a PNG.", "",
             "Slowest top-level imports of a warm run (`python -X importtime`, cumulative):", "",
             "| module | ms |", "|---|---|"]
    lines += [f"| {name} | {ms:.0f} |" for name, ms in r["imports"]]
    lines.append("")
    return "\n".join(lines)


def readme_rows(r: dict) -> list:
    cold = f"cold {r['cold_s']:.1f} s, " if "cold_s" in r else ""
    if "cold_plain_s" in r:
        cold += f"(without irtlang.kernels.numba_speedups {r['cold_plain_s']:.1f} s), "
    return [("start-up, `irt run examples_scripts/paraboloid_focus.inr` (whole process)",
             f"{cold}warm {r['warm_best_s']:.2f} s (best of {r['repeat']})", f"warm <= {TARGET_WARM} s")]


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--script", type=Path, default=SCRIPT)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--no-cold", action="store_true", help="skip the cold run (it compiles the kernels: minutes)")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--examples", nargs="*", default=None, metavar="NAME",
                    help="the first run of every runnable example (or those named), each from an empty cache")
    a = ap.parse_args(argv)
    if a.examples is not None:
        rows = examples_first_run(a.examples)
        print(examples_report(rows))
        return rows
    r = run(a.quick, a.repeat, a.script.resolve(), cold=False if a.no_cold else None)
    print(report(r))
    return r


if __name__ == "__main__":
    main()
