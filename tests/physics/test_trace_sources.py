"""Sources through the tracer: a Lambertian disk's angular distribution and its CONE option.

A scene with no objects: every ray escapes at once, and its record holds where and in which direction it left
the source (the record of a ray is its last state before it ended)."""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import EMITTED, ESCAPED, INC, ABS, binomial_sigma, ledger_gap, trace_file  # noqa: E402

N = 100_000


@pytest.fixture(scope="module")
def lambert(tmp_path_factory):
    """EMITTING DISK Z 0 5 without CONE (TRACE 1), and with CONE 10, 30 and 60 deg (TRACE 2..4)."""
    lines = ["SYSTEM NEW", "UNITS MM", "WAVELENGTHS 550 NM", "SEED 123", "LEVEL 5", "HALT 0",
             f"EMITTING DISK Z 0 5 RAYS {N}", "FLUX TOTAL 2 W", "TRACE"]
    for t in (10, 30, 60):
        lines += ["RESET", f"EMITTING DISK Z 0 5 RAYS {N} CONE {t}", "FLUX TOTAL 2 W", "TRACE"]
    p = tmp_path_factory.mktemp("lambert") / "lambert.inr"
    p.write_text("\n".join(lines) + "\n")
    return p


@pytest.mark.parametrize("t_deg", [10, 30, 60])
def test_lambertian_cone_fraction(lambert, t_deg):
    """The share of a Lambertian emitter's flux within t of its normal is sin^2 t (ORACLES.md).  Every ray
    carries the same weight, so the share is a binomial proportion: sigma = sqrt(p (1 - p) / N), N = 1e5
    (sigma = 5.4e-4, 1.4e-3, 1.4e-3 at 10, 30, 60 deg); 5 sigma allowed."""
    res = trace_file(lambert, which=0)
    r = res.records
    w, d = r["flux"], r["direction"]
    assert len(w) == N and np.all(w == w[0])
    assert np.all(d[:, 2] > 0.0)                        # into the + side of PLANE Z: the disk's normal
    p = math.sin(math.radians(t_deg)) ** 2
    share = w[d[:, 2] >= math.cos(math.radians(t_deg))].sum() / w.sum()
    assert abs(share - p) <= 5 * binomial_sigma(p, N), (t_deg, share, p)
    assert ledger_gap(res) < 1e-12


def test_lambertian_disk_positions_and_azimuth(lambert):
    """Start points uniform over the disk of radius 5 mm: <r^2> = R^2 / 2 with sigma = R^2 / sqrt(12 N)
    (r^2 is uniform on [0, R^2]); azimuths of the directions uniform: <cos phi> = 0 with sigma =
    sqrt(1/2 / N)."""
    res = trace_file(lambert, which=0)
    r = res.records
    R = 5e-3
    p, d = r["position"], r["direction"]
    assert np.allclose(p[:, 2], 0.0, atol=1e-15)
    r2 = (p[:, 0] ** 2 + p[:, 1] ** 2)
    assert r2.max() <= R * R * (1 + 1e-12)
    assert abs(r2.mean() - R * R / 2) <= 5 * R * R / math.sqrt(12 * N)
    phi = np.arctan2(d[:, 1], d[:, 0])
    assert abs(np.cos(phi).mean()) <= 5 * math.sqrt(0.5 / N)
    assert abs(np.sin(phi).mean()) <= 5 * math.sqrt(0.5 / N)


@pytest.mark.parametrize("k,t_deg", [(1, 10), (2, 30), (3, 60)])
def test_cone_carries_sin2_of_the_total(lambert, k, t_deg):
    """EMITTING DISK ... CONE t: the rays it emits carry exactly sin^2 t of FLUX TOTAL (the part of the
    Lambertian emission inside the cone), all inside the cone, Lambertian within it: the share within a
    half-angle a < t is sin^2 a / sin^2 t (binomial, 5 sigma)."""
    res = trace_file(lambert, which=k)
    s2 = math.sin(math.radians(t_deg)) ** 2
    led = res.ledger.sum(axis=2)
    assert led[EMITTED, INC] == pytest.approx(2.0 * s2, rel=1e-12)
    assert led[ESCAPED, ABS] == pytest.approx(2.0 * s2, rel=1e-12)
    r = res.records
    d, w = r["direction"], r["flux"]
    assert w.sum() == pytest.approx(2.0 * s2, rel=1e-12)
    assert d[:, 2].min() >= math.cos(math.radians(t_deg)) - 1e-15
    a = math.radians(t_deg / 2)
    p = math.sin(a) ** 2 / s2
    share = w[d[:, 2] >= math.cos(a)].sum() / w.sum()
    assert abs(share - p) <= 5 * binomial_sigma(p, N), (share, p)
    assert ledger_gap(res) < 1e-12
