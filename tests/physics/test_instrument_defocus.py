"""The defocus study: changing the mirror spacing of the HRI-like Cassegrain moves its focus.

Oracles: ORACLES.md (+55.498 um moves the paraxial focus 5.813 mm toward the primary, -55.498 um 5.863 mm away);
Gaussian optics of the two mirrors worked out here (tests/physics/_instrument.py: paraxial_focus); the exact numpy
trace of the same rays for the least-RMS focus that the FOCUS command reports.

The traced paraxial focus is the axial crossing of each ray, fitted as a cubic in sin^2 of its convergence angle and
extrapolated to the axis (the annular pupil has no paraxial rays).  The least-RMS focus lies 0.7 % short of the
paraxial one: the despacing adds spherical aberration, and over the annulus 0.32 .. 1 the best compromise is nearer
the marginal focus."""
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _instrument import D0, MM, UM, cassegrain_trace, paraxial_focus, trace_instrument  # noqa: E402

BODY = "GRID DISK Z (z_front + 10) 150 RAYS 20000\nSOURCE DIRECTION 0 0 -1\nFLUX TOTAL 1 W\nTRACE"


def _paraxial_from_rays(p, d):
    t = -(p[:, 0] * d[:, 0] + p[:, 1] * d[:, 1]) / (d[:, 0] ** 2 + d[:, 1] ** 2)
    z = p[:, 2] + t * d[:, 2]
    s2 = d[:, 0] ** 2 + d[:, 1] ** 2
    coef = np.polyfit(s2 / s2.max(), z, 3)
    return coef[-1], float(np.abs(np.polyval(coef, s2 / s2.max()) - z).max())


def _best_focus_z(p, d, w):
    X = p[:, :2] - (p[:, :2] * w[:, None]).sum(0) / w.sum()
    u = d[:, :2] / d[:, 2:3]
    U = u - (u * w[:, None]).sum(0) / w.sum()
    s = -(w[:, None] * X * U).sum() / (w[:, None] * U * U).sum()
    return p[0, 2] + s


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("defocus")
    out = {}
    for sd in (0.0, 55.498, -55.498, 100.0):
        res, fpa = trace_instrument(d, BODY, name=f"sd_{sd}.inr", spacing_delta=sd)
        out[sd] = (res, fpa)
    return out


def test_gaussian_oracle_reproduces_oracles_md():
    """The Gaussian-optics oracle itself: focus 300 mm behind the primary at the design spacing (ORACLES.md's
    e; the design numbers are rounded to 0.1 mm there, so 1e-6 relative), and 5.813 / 5.863 mm for +-55.498 um
    (ORACLES.md's 4 digits: +-0.0005 mm for 5.813; Gaussian optics gives 5.8625 for the other, which ORACLES.md
    writes 5.863: +-0.001 mm)."""
    assert paraxial_focus(D0) == pytest.approx(-300 * MM, rel=1e-9)
    assert (paraxial_focus(D0 + 55.498 * UM) - paraxial_focus(D0)) / MM == pytest.approx(5.813, abs=5e-4)
    assert (paraxial_focus(D0) - paraxial_focus(D0 - 55.498 * UM)) / MM == pytest.approx(5.863, abs=1e-3)


@pytest.mark.parametrize("sd", [55.498, -55.498, 100.0])
def test_traced_paraxial_focus_shift(runs, sd):
    """The traced paraxial focus moves as Gaussian optics says, to 1e-5 relative (the cubic extrapolation from the
    annulus: its residual is < 1e-7 mm); for +55.498 um that is 5.813 mm toward the primary (ORACLES.md; the
    issue asks +-1 %, the oracle's 4 digits give +-0.0005 mm)."""
    z0, res0 = _paraxial_from_rays(runs[0.0][1]["position"], runs[0.0][1]["direction"])
    z1, res1 = _paraxial_from_rays(runs[sd][1]["position"], runs[sd][1]["direction"])
    assert max(res0, res1) < 1e-10
    expect = paraxial_focus(D0 + sd * UM) - paraxial_focus(D0)
    assert (z1 - z0) == pytest.approx(expect, rel=1e-5)
    if sd == 55.498:
        assert (z1 - z0) / MM == pytest.approx(5.813, rel=0.01)
        assert (z1 - z0) / MM == pytest.approx(5.813, abs=5e-4)
    if sd == -55.498:
        assert (z0 - z1) / MM == pytest.approx(5.863, abs=1e-3)


@pytest.mark.parametrize("sd", [55.498, -55.498])
def test_least_rms_focus_matches_independent_trace(runs, sd):
    """The least-RMS focus (what FOCUS reports) from the traced rays equals the one from the exact numpy trace of
    the same rays (1e-9 mm), and lies 0.6 .. 0.8 % short of the paraxial shift (the spherical aberration the
    despacing adds, over the obscured pupil)."""
    res, fpa = runs[sd]
    z_src = D0 + sd * UM + 260 * MM
    p0 = np.column_stack([fpa["start"], np.full(len(fpa["flux"]), z_src)])
    d0 = np.tile([0.0, 0.0, -1.0], (len(p0), 1))
    keep, p, d = cassegrain_trace(p0, d0, spacing_delta_um=sd)
    assert keep.all()
    zb_ref = _best_focus_z(p, d, fpa["flux"])
    zb = _best_focus_z(fpa["position"], fpa["direction"], fpa["flux"])
    assert zb == pytest.approx(zb_ref, abs=1e-12)
    r0 = runs[0.0][1]
    zb0 = _best_focus_z(r0["position"], r0["direction"], r0["flux"])
    par = paraxial_focus(D0 + sd * UM) - paraxial_focus(D0)
    assert 0.992 < (zb - zb0) / par < 0.994
