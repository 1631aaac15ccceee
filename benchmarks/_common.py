"""Helpers shared by the benchmark modules: paths, peers, robust timing, time-to-error, plots, child processes."""
from __future__ import annotations

import importlib.util
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HERE = ROOT / "benchmarks"
PEERS = {"optiland": "optiland", "mitsuba": "mitsuba"}


def peer_version(name: str) -> str | None:
    """The installed version of an optional peer (pip install ".[bench]"), or None when it is absent."""
    if importlib.util.find_spec(name) is None:
        return None
    try:
        from importlib.metadata import version

        return version(name)
    except Exception:  # pragma: no cover - installed without metadata
        return "unknown version"


def best_time(fn, repeat: int) -> tuple[float, object]:
    """Best wall time of `repeat` calls of fn() (the machine is shared: the minimum is the robust statistic) and
    the last result."""
    ts, res = [], None
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        res = fn()
        ts.append(time.perf_counter() - t0)
    return min(ts), res


def time_to_error(points, target: float) -> tuple[float | None, str]:
    """Time at which an error-against-time series reaches `target`.

    points: (time, error) pairs of runs of growing size.  Returns (time, how): "measured" interpolates (log-log)
    between the last run above the target and the first run at or below it after which every run stays below;
    "extrapolated" fits error = c t^-1/2 (Monte Carlo) to the largest run when none reached the target; None when
    there is nothing to go on."""
    pts = sorted((t, e) for t, e in points if t > 0 and e > 0 and math.isfinite(e))
    if not pts:
        return None, "no data"
    below = [e <= target for _, e in pts]
    k = None
    for i in range(len(pts)):
        if all(below[i:]):
            k = i
            break
    if k is None:
        t, e = pts[-1]
        return t * (e / target) ** 2, "extrapolated"
    if k == 0:
        t, e = pts[0]
        return t, "measured (first run already below; an upper bound)"
    (t0, e0), (t1, e1) = pts[k - 1], pts[k]
    if e1 >= e0:
        return t1, "measured"
    f = math.log(e0 / target) / math.log(e0 / e1)
    return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0))), "measured"


def plt():
    """matplotlib.pyplot on the Agg backend (imported only when a benchmark draws)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as p

    return p


def python_child(code: str, *args, env=None, timeout=600, cwd=None) -> subprocess.CompletedProcess:
    """Run `python -c code args...` with this interpreter and the working tree first on the path."""
    e = dict(os.environ)
    e["PYTHONPATH"] = str(ROOT) + (os.pathsep + e["PYTHONPATH"] if e.get("PYTHONPATH") else "")
    if env:
        e.update(env)
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True, env=e,
                          timeout=timeout, cwd=cwd or ROOT)


def last_json(stdout: str):
    """The last line of a child's stdout that parses as JSON."""
    for line in reversed(stdout.strip().splitlines()):
        try:
            return json.loads(line)
        except ValueError:
            continue
    raise ValueError("no JSON result in the child's output")


def fmt_time(t: float | None) -> str:
    if t is None:
        return "-"
    return f"{t * 1e3:.1f} ms" if t < 1 else f"{t:.2f} s"
