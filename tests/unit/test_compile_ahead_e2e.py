"""Compiling ahead, end to end, from an empty kernel cache (slow tier: two specialized kernels compile).

The check is Numba's own count for each kernel's entry point in the process that runs the script: a kernel
compiled by another process (irtlang.ahead's helper, or `irt warmup`) is a cache hit there, not a miss.  The
script (tests/unit/test_compile_ahead.py's SCRIPT) needs two kernels: a forward trace keeping ray records, and a
camera-side trace."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from test_compile_ahead import SCRIPT  # noqa: E402  (pytest puts this folder on the path)

ROOT = Path(__file__).resolve().parents[2]

CHILD = """
import json, sys
from irtlang.cli import main
assert main(["run", sys.argv[1], "--out", sys.argv[2], "--quiet"]) == 0
import irtlang.compile.specialize as sp
from irtlang.kernels import reduce
out = {}
for key, m in sp._loaded.items():
    st = m.trace_batch.stats
    out[key] = [sum(st.cache_hits.values()), sum(st.cache_misses.values())]
st = reduce.reduce_batch.stats
out["reduce"] = [sum(st.cache_hits.values()), sum(st.cache_misses.values())]
print(json.dumps(out))
"""


def _env(tmp_path, name):
    return dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / name), IRT_KERNEL_FEATURES="", PYTHONPATH=str(ROOT))


def _run(tmp_path, env, out):
    path = tmp_path / "three.inr"
    path.write_text(SCRIPT)
    r = subprocess.run([sys.executable, "-c", CHILD, str(path), str(tmp_path / out)], env=env, capture_output=True,
                       text=True, timeout=1800, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_a_runs_second_kernel_is_compiled_by_the_helper(tmp_path):
    """From an empty cache: the run compiles its first kernel (a miss) while the helper compiles the second,
    which the run then loads (a hit, no miss)."""
    counts = _run(tmp_path, _env(tmp_path, "nc"), "out")
    kernels = {k: v for k, v in counts.items() if k != "reduce"}
    assert len(kernels) == 2, counts
    misses = sorted(v[1] for v in kernels.values())
    hits = sorted(v[0] for v in kernels.values())
    assert misses == [0, 1] and hits == [0, 1], counts


@pytest.mark.slow
def test_after_irt_warmup_a_run_compiles_nothing(tmp_path):
    env = _env(tmp_path, "nc")
    path = tmp_path / "three.inr"
    path.write_text(SCRIPT)
    w = subprocess.run([sys.executable, "-m", "irtlang.cli", "warmup", str(path), "--jobs", "2"], env=env,
                       capture_output=True, text=True, timeout=1800, cwd=tmp_path)
    assert w.returncode == 0 and "0 already compiled, 2 compiled now (2 at once)" in w.stdout, w.stdout + w.stderr
    counts = _run(tmp_path, env, "out")
    assert all(v[1] == 0 for v in counts.values()), counts       # no compile: every kernel loaded
    assert all(v[0] == 1 for v in counts.values()), counts
