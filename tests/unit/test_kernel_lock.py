"""Two processes that need one kernel at once compile it once (irtlang.compile.specialize.kernel_lock).

Before the lock, two processes starting from an empty cache (a local cluster's workers, the test suite's two
workers, two runs started together) both compiled the kernel, each for minutes.  Now the second waits for the
first's lock and loads the cached code.  The check is Numba's own count for the kernel's entry point: over the
two processes, one cache miss (a compile) and one cache hit.  Without the lock both processes miss."""
import json
import os
import subprocess
import sys

import pytest

SCENE = """UNITS MM
WAVELENGTHS 550 NM
SEED 3
SURFACE
  PLANE Z 10 RECT 5 5
OBJECT screen
  INTERFACE ABSORB
  DETECTOR PIXELS 8 8
GRID RECT Z 0 -4 4 -4 4 20 20
SOURCE DIRECTION 0 0 1
FLUX TOTAL 1 W
TRACE
"""

CHILD = """
import json, sys
from irtlang.cli import main
assert main(["run", sys.argv[1], "--out", sys.argv[2], "--quiet"]) == 0
import irtlang.compile.specialize as sp
(m,) = sp._loaded.values()
st = m.trace_batch.stats
print(json.dumps([sum(st.cache_hits.values()), sum(st.cache_misses.values())]))
"""


@pytest.mark.slow
def test_two_processes_compile_a_kernel_once(tmp_path):
    script = tmp_path / "plane.inr"
    script.write_text(SCENE)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "IRT_DISK_CACHE": "0"}
    env.pop("IRT_KERNEL_FEATURES", None)
    procs = [subprocess.Popen([sys.executable, "-c", CHILD, str(script), str(tmp_path / f"out{k}")], env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for k in range(2)]
    counts = []
    for p in procs:
        out, err = p.communicate(timeout=900)
        assert p.returncode == 0, err[-2000:]
        counts.append(json.loads(out.strip().splitlines()[-1]))
    hits = sum(c[0] for c in counts)
    misses = sum(c[1] for c in counts)
    assert (hits, misses) == (1, 1), counts
