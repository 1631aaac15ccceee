"""Reproducibility: the same script gives bitwise identical ledgers, images and ray records for any thread
count and any batch size (counter-based random numbers keyed by ray and event; tallies per chunk of ray ids,
reduced in id order)."""
import hashlib
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import ledger_gap, trace_file  # noqa: E402

SCENE = """SYSTEM NEW
UNITS MM
WAVELENGTHS 450 650 NM
SEED 99
MEDIUM glass INDEX 1.5 1.48 ABSORB 0.01
COATING lossy REFLECT 0.5 TRANSMIT 0.3
SURFACE
  SPHERE 0 0 0 10
OBJECT ball
  INTERFACE TRANSMIT AIR glass
SURFACE
  PLANE Z -20 RECT 15 15
OBJECT screen
  DETECTOR PIXELS 33 31
SURFACE
  PLANE Z 25 DISK 30
OBJECT top
  INTERFACE COATING lossy AIR AIR
LEVEL 30
HALT 0.01
GRID DISK Z 20 9 RAYS 5000 RANDOM
SOURCE DIRECTION 0.05 0 -1
FLUX TOTAL 1 W
EMITTING DISK Z 24 3 RAYS 1500 CONE 40
FLUX TOTAL 0.5 W
TRACE
"""


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    p = tmp_path_factory.mktemp("det") / "det.inr"
    p.write_text(SCENE)
    return p


def _digest(res) -> dict:
    out = {"ledger": res.ledger.tobytes(), "ledger_sq": res.ledger_sq.tobytes()}
    for name, (img, sq) in res.images.items():
        out[f"img:{name}"] = img.tobytes() + sq.tobytes()
    for k, v in res.records.items():
        out[f"rec:{k}"] = np.ascontiguousarray(v).tobytes()
    return {k: hashlib.sha256(v).hexdigest() for k, v in out.items()}


def _trace(scene, **kw):
    return trace_file(scene, records=True, history=True, **kw)


def test_thread_count_does_not_change_anything(scene):
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs NUMBA_NUM_THREADS >= 2")
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        a = _trace(scene)
        numba.set_num_threads(2)
        b = _trace(scene)
    finally:
        numba.set_num_threads(old)
    assert a.n_traced == b.n_traced > 10000
    assert a.images["screen"][0].sum() > 0
    assert _digest(a) == _digest(b)
    assert ledger_gap(a) < 1e-12


@pytest.mark.parametrize("batch", [1024, 3 * 1024, 1000, 777])
def test_batch_size_does_not_change_anything(scene, batch):
    ref = _trace(scene)                 # default batch (65536): one batch for this scene
    other = _trace(scene, batch=batch)
    assert _digest(other) == _digest(ref)


_CHILD = textwrap.dedent("""
    import hashlib, sys
    import numpy as np
    sys.path.insert(0, {here!r})
    from _trace_util import trace_file
    res = trace_file({scene!r}, records=True, history=True)
    h = hashlib.sha256(res.ledger.tobytes())
    for name in sorted(res.images):
        h.update(res.images[name][0].tobytes())
    for k in sorted(res.records):
        h.update(np.ascontiguousarray(res.records[k]).tobytes())
    print("DIGEST", h.hexdigest())
""")


def test_thread_count_in_fresh_processes(scene):
    """The same with NUMBA_NUM_THREADS set before numba starts, in two fresh interpreters."""
    digests = []
    for nt in ("1", "2"):
        env = dict(os.environ, NUMBA_NUM_THREADS=nt)
        code = _CHILD.format(here=str(Path(__file__).resolve().parent), scene=str(scene))
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, out.stderr
        digests.append([x for x in out.stdout.splitlines() if x.startswith("DIGEST")][-1])
    assert digests[0] == digests[1]


def test_spread_stride_is_a_permutation_that_mixes_each_threads_share():
    """The parallel loop's index k traces chunk (k stride) mod n (trace_kernel._spread_stride): that must be a
    permutation of the chunks (every chunk traced once: the determinism tests above then hold whatever the
    order), and the first half of the indices (one thread's share under Numba's static schedule on 2 threads)
    must hold chunks from both halves of the batch (an image's upper and lower rows)."""
    from irtlang.kernels.trace_kernel import _spread_stride

    for n in range(1, 700):
        st = _spread_stride(n)
        order = [(k * st) % n for k in range(n)]
        assert sorted(order) == list(range(n)), n
        if n >= 8:
            first = order[: n // 2]
            low = sum(c < n // 2 for c in first)
            assert 0.3 * len(first) <= low <= 0.7 * len(first), (n, st, low)
