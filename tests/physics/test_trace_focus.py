"""Imaging through the tracer: a paraboloid's focus, a BK7 singlet against an independent exact ray trace,
and the FOCUS command's sign convention."""
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import EXAMPLES, ledger_gap, trace_file  # noqa: E402

MM = 1e-3


def _line_distance(p, d, q):
    """Distance from point q to the lines p + t d (d unit)."""
    v = q - p
    return np.linalg.norm(v - np.einsum("ij,ij->i", v, d)[:, None] * d, axis=1)


def _best_focus(p, d, axis=2):
    """The shift along `axis` (coordinate units) from the points p to the plane where the RMS radius of the rays
    about their centroid is smallest: minimize sum |X + s U|^2, X the centred transverse positions, U the
    centred transverse slopes per unit advance along the axis; s = -sum(X.U) / sum(U.U)."""
    tr = [i for i in range(3) if i != axis]
    X = p[:, tr] - p[:, tr].mean(0)
    u = d[:, tr] / d[:, axis:axis + 1]
    U = u - u.mean(0)
    s = -(X * U).sum() / (U * U).sum()
    rms = math.sqrt(((X + s * U) ** 2).sum(1).mean())
    return s, rms


def test_paraboloid_on_axis_focus():
    """examples_scripts/paraboloid_focus.inr: f = R/2 = 200 mm.  Every reflected ray passes through the focus
    (0, 0, 200 mm); the detector is at 199.5 mm."""
    res = trace_file(EXAMPLES / "paraboloid_focus.inr")
    r = res.records
    det = r["object"] == [n.upper() for n in res.packed.object_names].index("DETECTOR")
    p, d = r["position"][det], r["direction"][det]
    assert det.sum() > 4000
    assert np.allclose(p[:, 2], 199.5 * MM, rtol=0, atol=1e-12)
    focus = np.array([0.0, 0.0, 200.0 * MM])
    dist = _line_distance(p, d, focus[None, :])
    assert dist.max() < 1e-6 * MM, dist.max()          # each ray within 1 nm of the focus (1 um asked)
    s, rms = _best_focus(p, d)
    assert abs(p[0, 2] + s - 200.0 * MM) < 1e-6                 # 1 um asked; in fact it is at rounding level
    assert rms < 1e-9
    assert ledger_gap(res) < 1e-12


# ------------------------------------------------------------------ the singlet, traced independently
BK7 = (1.03961212, 0.231792344, 1.01046945, 0.00600069867, 0.0200179144, 103.560653)


def _sellmeier(lam_nm):
    l2 = (lam_nm * 1e-3) ** 2
    B1, B2, B3, C1, C2, C3 = BK7
    return math.sqrt(1 + B1 * l2 / (l2 - C1) + B2 * l2 / (l2 - C2) + B3 * l2 / (l2 - C3))


def _refract(d, nrm, n1, n2):
    """Vector Snell, nrm a unit normal against d (d . nrm < 0)."""
    eta = n1 / n2
    ci = -np.einsum("ij,ij->i", d, nrm)
    k = 1 - eta ** 2 * (1 - ci ** 2)
    return eta * d + (eta * ci - np.sqrt(k))[..., None] * nrm


def _sphere_hit(p, d, centre, R, near):
    """Hit of rays p + t d with a sphere; near=True the smaller root."""
    oc = p - centre
    b = np.einsum("ij,ij->i", oc, d)
    c = np.einsum("ij,ij->i", oc, oc) - R * R
    h = np.sqrt(b * b - c)
    t = -b - h if near else -b + h
    return p + t[:, None] * d


def _singlet_trace(xy, n, z_img):
    """The singlet of examples_scripts/singlet_spot.inr, traced in numpy: front sphere vertex z = 0, R = +100
    (centre z = 100), back sphere vertex z = 5, R = -100 (centre z = -95); rays along +z.  Returns the points
    on the plane z = z_img and the directions there (mm)."""
    p = np.column_stack([xy, np.full(len(xy), -20.0)])
    d = np.tile([0.0, 0.0, 1.0], (len(xy), 1))
    c1 = np.array([0.0, 0.0, 100.0])
    p = _sphere_hit(p, d, c1, 100.0, near=True)
    n1 = (p - c1) / 100.0                      # points into the sphere's outside, i.e. toward -z here
    d = _refract(d, n1, 1.0, n)
    c2 = np.array([0.0, 0.0, -95.0])
    p = _sphere_hit(p, d, c2, 100.0, near=False)
    n2 = -(p - c2) / 100.0                     # against the ray
    d = _refract(d, n2, n, 1.0)
    t = (z_img - p[:, 2]) / d[:, 2]
    return p + t[:, None] * d, d


@pytest.fixture(scope="module")
def singlet():
    return trace_file(EXAMPLES / "singlet_spot.inr", history=False)


def test_singlet_matches_independent_trace(singlet):
    """Direct rays (front T, back T, image plane) of the traced singlet, matched one by one to an exact numpy
    trace from the same lattice (GRID RECT 64 x 64 cell centres over +-3.2 mm, stop r = 3 mm): end points to
    1e-9 mm, best focus to 1e-6 mm; F focuses before d before C, as BK7's dispersion says."""
    res = singlet
    r = res.records
    names = [x.upper() for x in res.packed.object_names]
    direct = (r["object"] == names.index("IMAGE_PLANE")) & (r["events"] == 3)
    g = (np.arange(64) + 0.5) / 64 * 6.4 - 3.2
    X, Y = np.meshgrid(g, g)
    xy = np.column_stack([X.ravel(), Y.ravel()])
    xy = xy[np.hypot(xy[:, 0], xy[:, 1]) < 3.0]
    foci = []
    for k, lam in enumerate(res.packed.lines_nm):
        m = direct & (r["line"] == k)
        p_irt = r["position"][m] / MM
        d_irt = r["direction"][m]
        p_ref, d_ref = _singlet_trace(xy, _sellmeier(lam), 99.5)
        # match every traced ray to the reference ray that lands nearest (a bijection onto a subset)
        dd = np.linalg.norm(p_irt[:, None, :2] - p_ref[None, :, :2], axis=2)
        j = dd.argmin(axis=1)
        assert len(np.unique(j)) == len(j)
        assert dd[np.arange(len(j)), j].max() < 1e-9
        assert np.abs(d_irt - d_ref[j]).max() < 1e-12
        s_irt, rms_irt = _best_focus(p_irt, d_irt)
        s_ref, rms_ref = _best_focus(p_ref[j], d_ref[j])
        assert abs(s_irt - s_ref) < 1e-6
        assert abs(rms_irt - rms_ref) < 1e-7
        foci.append(99.5 + s_ref)
    zF, zd, zC = foci
    assert zF < zd < zC
    # the longitudinal colour is close to the paraxial (thick lens) F-C shift of 1.495 mm at f/16
    assert 1.45 < zC - zF < 1.55
    assert ledger_gap(res) < 1e-12


def _run_cli(tmp_path, text, capsys):
    from irtlang.cli import main

    f = tmp_path / "s.inr"
    f.write_text(text)
    code = main(["run", str(f), "--out", str(tmp_path / "out")])
    out = capsys.readouterr().out
    assert code == 0, out
    return out


@pytest.mark.parametrize("direction", [1, -1])
def test_focus_sign_follows_the_rays(tmp_path, capsys, direction):
    """A paraboloid focusing 0.5 mm beyond the detector: FOCUS says +0.5 along the direction the rays travel,
    for rays going +Z and for rays going -Z (the mirror image of the same scene)."""
    sgn = direction
    text = f"""SYSTEM NEW
UNITS MM
WAVELENGTHS 550 NM
SURFACE
  CONIC Z 0 RADIUS {400 * sgn} CONIC -1 DISK 50
OBJECT mirror
  INTERFACE REFLECT
SURFACE
  PLANE Z {201 * sgn} DISK 3
OBJECT shade
SURFACE
  PLANE Z {199.5 * sgn} RECT 2 2
OBJECT detector
LEVEL 10
GRID DISK Z {400 * sgn} 50 RAYS 2000
SOURCE DIRECTION 0 0 {-sgn}
TRACE
CONSIDER ONLY detector
FOCUS
PRINT 'FOCUS_SHIFT = {{FOCUS_SHIFT}}'
"""
    out = _run_cli(tmp_path, text, capsys)
    m = re.search(r"FOCUS: best focus ([-+0-9.e]+) mm along ([+-])Z", out)
    assert m, out
    assert float(m.group(1)) == pytest.approx(0.5, abs=1e-9)
    assert m.group(2) == "+-"[sgn < 0]
    m2 = re.search(r"FOCUS_SHIFT = ([-+0-9.e]+)", out)
    assert float(m2.group(1)) == pytest.approx(0.5, abs=1e-9)
