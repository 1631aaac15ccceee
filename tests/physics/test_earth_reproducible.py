"""Bitwise reproducibility of the flagship (issue 18, item 8): two runs of an Earth frame with the same seed give the
same bits, whatever the thread count, the hash seed of the process and the load on the machine.

The cause of the old run-to-run differences (up to 1.5e-15 relative in every frame): the slab scatter models
(Rayleigh layers, aerosol HG slabs) interpolate their albedo tables in log tau with SciPy's BarycentricInterpolator,
which, without explicit weights, computes them from a random permutation of the nodes drawn from NumPy's global
RandomState (seeded from the OS).  The tables now use the closed-form weights of Chebyshev points of the first kind,
w_k = (-1)^k sin((2k + 1) pi / 2n) (Berrut & Trefethen, SIAM Review 46, 2004): the same bits in every process.
"""
from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from irtlang.plugins.bsdfs import REGISTRY as BSDFS
from irtlang.plugins.bsdfs import _common as C

ROOT = Path(__file__).resolve().parents[2]
EARTH = ROOT / "examples_scripts" / "earth.inr"


def _rayleigh_pack():
    """A Rayleigh layer on the flagship's 295 lines (tau ~ lambda^-4: many distinct taus, the interpolated path)."""
    lam = np.linspace(300.0, 2500.0, 295)
    tau = 0.0088 * (lam / 1000.0) ** -4.05 * 0.1
    return BSDFS["RAYLEIGH"].pack({"tau": tuple(tau), "albedo": (1.0,) * 295, "depol": 0.0279}, 295)


def test_slab_tables_ignore_the_global_random_state():
    np.random.seed(1)
    a = _rayleigh_pack()
    np.random.seed(2)
    np.random.random(17)
    b = _rayleigh_pack()
    assert a.tobytes() == b.tobytes()


def test_chebyshev_weights_interpolate_exactly():
    """The closed-form weights reproduce a polynomial of degree n - 1 through n Chebyshev points (to rounding)."""
    from scipy.interpolate import BarycentricInterpolator

    n = C.CHEB_TAU_NODES
    k = np.arange(n)
    a, b = -7.0, -5.8
    x = 0.5 * (a + b) + 0.5 * (b - a) * np.cos(np.pi * (2 * k + 1) / (2 * n))
    w = (-1.0) ** k * np.sin((2 * k + 1) * np.pi / (2 * n))
    coef = np.linspace(0.3, -0.2, n)
    q = np.linspace(a, b, 101)
    got = BarycentricInterpolator(x, np.polyval(coef, x - a), wi=w)(q)
    want = np.polyval(coef, q - a)
    assert np.max(np.abs(got - want)) <= 1e-12 * np.max(np.abs(want))


def _busy(seconds: float):
    """A process that keeps one core busy (the loaded machine of the issue)."""
    return subprocess.Popen([sys.executable, "-c", f"import time\nt = time.time() + {seconds}\nwhile time.time() < t: pass"])


def _run_frame(out: Path, threads: int, hash_seed: str) -> dict:
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads), PYTHONHASHSEED=hash_seed)
    cmd = [sys.executable, "-m", "irtlang.cli", "run", str(EARTH), "--out", str(out), "--set", "hours=1",
           "--set", "sun_rays=30", "--set", "save_rays=0"]
    r = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True, timeout=3000)
    assert r.returncode == 0, r.stderr[-3000:]
    files = sorted(p for p in out.rglob("*") if p.suffix in (".npy", ".csv"))
    assert any(p.parent.name == "frames" for p in files) and any(p.parent.name == "spectra" for p in files)
    return {str(p.relative_to(out)): hashlib.sha256(p.read_bytes()).hexdigest() for p in files}


@pytest.mark.slow
def test_earth_frame_is_bitwise_reproducible(tmp_path):
    """One Earth frame (full model, few rays) traced in two processes: 1 thread, then 2 threads on a machine made
    busy by another process, with different hash seeds: every frame, spectrum and ledger file has the same bytes."""
    a = _run_frame(tmp_path / "a", 1, "1")
    busy = _busy(3000)
    try:
        b = _run_frame(tmp_path / "b", 2, "2")
    finally:
        busy.kill()
        busy.wait()
    assert a.keys() == b.keys()
    differ = [k for k in a if a[k] != b[k]]
    assert not differ, f"{len(differ)} of {len(a)} files differ: {differ[:10]}"
