"""Fresnel, Snell and total internal reflection through the whole tracer (script -> check -> run_trace).

The kernel functions themselves (fresnel_unpolarized, refract) are tested against the ORACLES values and
closed forms in test_optics.py; here the same physics must come out of traced rays.

Monte Carlo tolerances: at a transmitting interface the kernel picks reflection or transmission with
probability R / (R + T) and the ray keeps its whole weight (R + T = 1 for an uncoated interface), so with HALT 0
every ray ends in exactly one outcome with weight w0 = FLUX / N.  The estimated share is k / N with
k ~ Binomial(N, p): its standard error is sigma = sqrt(p (1 - p) / N) (binomial_sigma); a test allows
5 sigma (a false alarm about once in 1.7 million runs), plus the rounding of the oracle's last digit.
"""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import (ABS, INC, REF, TRA, binomial_sigma, fmt, fresnel_unpolarized_ref, ledger_gap, row,  # noqa: E402
                         trace_file, trace_text)

WATER = 1.333
ORACLE_WATER = {0: 0.02037, 30: 0.02144, 60: 0.05969, 75: 0.21238}   # ORACLES.md, 5 decimals


def _fresnel_script(angles_deg, n2, nside):
    """One interface (air below, medium above, z = 0) and a catcher above it; one TRACE per angle, rays
    coming from below in the x-z plane at the angle from the normal."""
    out = ["SYSTEM NEW", "UNITS MM", "WAVELENGTHS 550 NM", "SEED 2024", f"MEDIUM water INDEX {fmt(n2)}",
           "SURFACE", "  PLANE Z 0", "OBJECT surface", "  INTERFACE TRANSMIT AIR water",
           "SURFACE", "  PLANE Z 10", "OBJECT catcher", "LEVEL 10", "HALT 0"]
    for deg in angles_deg:
        th = math.radians(deg)
        out += ["RESET", f"GRID RECT Z -1 -1 1 -1 1 {nside} {nside}",
                f"SOURCE DIRECTION {fmt(math.sin(th))} 0 {fmt(math.cos(th))}", "FLUX TOTAL 1 W", "TRACE"]
    return "\n".join(out) + "\n"


@pytest.fixture(scope="module")
def fresnel_script(tmp_path_factory):
    p = tmp_path_factory.mktemp("fresnel") / "fresnel.inr"
    p.write_text(_fresnel_script(sorted(ORACLE_WATER), WATER, 400))
    return p


@pytest.mark.parametrize("k,deg", list(enumerate(sorted(ORACLE_WATER))))
def test_fresnel_water_through_tracer(fresnel_script, k, deg):
    res = trace_file(fresnel_script, which=k, records=False)
    n = res.n_traced
    assert n == 400 * 400
    s = row(res, "surface")
    share = s[REF] / s[INC]
    expected = ORACLE_WATER[deg]
    # the oracle agrees with the independent formula (its last digit is rounded)
    assert abs(fresnel_unpolarized_ref(math.radians(deg), 1.0, WATER) - expected) <= 5e-6
    sigma = binomial_sigma(expected, n)          # 160000 rays: sigma = 3.5e-4 at 0 deg, 1.0e-3 at 75 deg
    assert abs(share - expected) <= 5 * sigma + 5e-6, (deg, share, expected, sigma)
    # every ray met the interface once and ended reflected (escaped) or transmitted (on the catcher)
    assert s[INC] == pytest.approx(1.0, rel=1e-12)
    assert s[REF] + s[TRA] == pytest.approx(s[INC], rel=1e-12)
    assert row(res, "catcher")[INC] == pytest.approx(s[TRA], rel=1e-12)
    assert ledger_gap(res) < 1e-12


def _rot(axis, deg):
    """Right-handed rotation matrix about a coordinate axis (LANGUAGE.md section 5), written out here."""
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return {"X": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
            "Y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            "Z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


def test_snell_on_traced_directions(tmp_path):
    """A tilted air/glass interface (ROTATE X 20 then ROTATE Y -35) and an oblique beam: every transmitted
    ray obeys Snell's law in vector form (tangential n d conserved, in the plane of incidence) to 1e-12."""
    n1, n2 = 1.0, 1.7
    d_in = np.array([0.3, -0.2, 1.0])
    d_in /= np.linalg.norm(d_in)
    text = f"""SYSTEM NEW
UNITS MM
WAVELENGTHS 550 NM
SEED 9
MEDIUM flint INDEX {fmt(n2)}
SURFACE
  PLANE Z 0 DISK 30
OBJECT tilted
  INTERFACE TRANSMIT AIR flint
  ROTATE X 20
  ROTATE Y -35
SURFACE
  PLANE Z 40
OBJECT catcher
LEVEL 10
HALT 0
GRID RECT Z -20 -5 5 -5 5 40 40
SOURCE DIRECTION {fmt(d_in[0])} {fmt(d_in[1])} {fmt(d_in[2])}
FLUX TOTAL 1 W
TRACE
"""
    res = trace_text(tmp_path, text)
    r = res.records
    names = [x.upper() for x in res.packed.object_names]
    on = r["object"] == names.index("CATCHER")
    assert on.sum() > 1000
    nrm = _rot("Y", -35) @ _rot("X", 20) @ np.array([0.0, 0.0, 1.0])   # rotations applied in script order
    t = r["direction"][on]
    assert np.all(np.abs(np.linalg.norm(t, axis=1) - 1.0) < 1e-14)
    # tangential components: n1 (d - (d.n) n) == n2 (t - (t.n) n)
    tan_in = n1 * (d_in - (d_in @ nrm) * nrm)
    tan_out = n2 * (t - (t @ nrm)[:, None] * nrm)
    assert np.max(np.abs(tan_out - tan_in)) < 1e-12
    # the same side of the interface as the incident ray went (it is transmitted, not reflected)
    assert np.all((t @ nrm) * (d_in @ nrm) > 0)
    # and the sines: n1 sin(theta_1) = n2 sin(theta_2)
    s1 = np.linalg.norm(np.cross(d_in, nrm))
    s2 = np.linalg.norm(np.cross(t, nrm), axis=1)
    assert np.max(np.abs(n2 * s2 - n1 * s1)) < 1e-12
    assert ledger_gap(res) < 1e-12


@pytest.fixture(scope="module")
def tir_script(tmp_path_factory):
    """Glass (n = 1.5) below z = 0, air above; rays from inside the glass at theta_c + 1e-9 and - 1e-9."""
    n1 = 1.5
    thc = math.asin(1.0 / n1)
    out = ["SYSTEM NEW", "UNITS MM", "WAVELENGTHS 550 NM", "SEED 31", f"MEDIUM glass INDEX {fmt(n1)}",
           "SURFACE", "  PLANE Z 0", "OBJECT boundary", "  INTERFACE TRANSMIT glass AIR",
           "SURFACE", "  PLANE Z 1", "OBJECT catcher", "LEVEL 10", "HALT 0"]
    for eps in (1e-9, -1e-9):
        th = thc + eps
        out += ["RESET", "GRID RECT Z -1 -1 1 -1 1 1000 1000",
                f"SOURCE DIRECTION {fmt(math.sin(th))} 0 {fmt(math.cos(th))}", "FLUX TOTAL 1 W", "TRACE"]
    p = tmp_path_factory.mktemp("tir") / "tir.inr"
    p.write_text("\n".join(out) + "\n")
    return p, n1, thc


def test_tir_just_beyond_critical_angle(tir_script):
    path, n1, thc = tir_script
    res = trace_file(path, which=0, records=False)
    b = row(res, "boundary")
    assert b[INC] > 0
    assert b[REF] == b[INC]          # totally reflected: R = 1 exactly, not close to 1
    assert b[TRA] == 0.0
    assert row(res, "catcher")[INC] == 0.0
    assert ledger_gap(res) < 1e-12


def test_refraction_just_below_critical_angle(tir_script):
    path, n1, thc = tir_script
    res = trace_file(path, which=1, records=True)
    n = res.n_traced
    b = row(res, "boundary")
    T = 1.0 - fresnel_unpolarized_ref(thc - 1e-9, n1, 1.0)     # 2.749e-4: a grazing refracted ray
    # binomial: 1e6 rays, expected k = 275, sigma = sqrt(N T (1 - T)) / N = 1.66e-5: 5 sigma = 30 % of T
    sigma = binomial_sigma(T, n)
    share = b[TRA] / b[INC]
    assert share > 0.0
    assert abs(share - T) <= 5 * sigma, (share, T, sigma)
    # the rays that crossed left along the surface, as Snell's law says: sin(theta_t) = n1 sin(theta_i)
    r = res.records
    on = r["object"] == [x.upper() for x in res.packed.object_names].index("CATCHER")
    assert on.sum() == round(b[TRA] * n)
    d = r["direction"][on]
    sin_t = np.hypot(d[:, 0], d[:, 1])
    assert np.max(np.abs(sin_t - n1 * math.sin(thc - 1e-9))) < 1e-12
    cos_t = math.sqrt(2.0 * n1 ** 2 * math.sin(thc) * math.cos(thc) * 1e-9)      # first order in 1e-9
    assert np.all(d[:, 2] > 0) and np.allclose(d[:, 2], cos_t, rtol=1e-3)
    assert ledger_gap(res) < 1e-12


def test_uncoated_slab_transmission(tmp_path):
    """An n = 1.5 slab at normal incidence, every internal reflection traced: T = (1 - R)/(1 + R) = 0.923077
    (ORACLES.md).  Each ray ends on the transmitted or the reflected catcher with its whole weight, so the
    transmitted share is binomial: N = 90000 gives sigma = 8.9e-4, 5 sigma = 4.4e-3."""
    text = """SYSTEM NEW
UNITS MM
WAVELENGTHS 550 NM
SEED 77
MEDIUM glass INDEX 1.5
SURFACE
  PLANE Z 0
OBJECT front
  INTERFACE TRANSMIT AIR glass
SURFACE
  PLANE Z 10
OBJECT back
  INTERFACE TRANSMIT glass AIR
SURFACE
  PLANE Z 20
OBJECT t_catcher
SURFACE
  PLANE Z -20
OBJECT r_catcher
LEVEL 100000
HALT 0
GRID RECT Z -10 -5 5 -5 5 300 300
SOURCE DIRECTION 0 0 1
FLUX TOTAL 1 W
TRACE
"""
    res = trace_text(tmp_path, text, records=False)
    n = res.n_traced
    R = ((1.5 - 1.0) / (1.5 + 1.0)) ** 2
    T = (1 - R) / (1 + R)
    assert T == pytest.approx(0.923077, abs=5e-7)
    t = row(res, "t_catcher")[INC]
    r = row(res, "r_catcher")[INC]
    sigma = binomial_sigma(T, n)
    assert abs(t - T) <= 5 * sigma, (t, T, sigma)
    assert t + r == pytest.approx(1.0, rel=1e-12)     # nothing absorbed, halted or escaped
    assert row(res, "HALTED")[4] == 0.0 and row(res, "ESCAPED")[4] == 0.0
    assert ledger_gap(res) < 1e-12


def _coated_script(sin_in, n_glass, from_glass):
    """An interface with an R/T-table coating (COATING ar REFLECT 0.01 TRANSMIT 0.98) between air and glass."""
    media = "glass AIR" if from_glass else "AIR glass"
    return f"""SYSTEM NEW
UNITS MM
WAVELENGTHS 550 NM
SEED 3
MEDIUM glass INDEX {fmt(n_glass)}
COATING ar REFLECT 0.01 TRANSMIT 0.98
SURFACE
  PLANE Z 0
OBJECT face
  INTERFACE COATING ar {media}
SURFACE
  PLANE Z 10
OBJECT catcher
LEVEL 10
HALT 0
GRID RECT Z -1 -1 1 -1 1 100 100
SOURCE DIRECTION {fmt(sin_in)} 0 {fmt(math.sqrt(1 - sin_in ** 2))}
FLUX TOTAL 1 W
TRACE
"""


def test_coated_interface_refracts(tmp_path):
    """Regression: a boundary with an R/T coating between two media must bend the transmitted rays by Snell's
    law like an uncoated one (it used to let them through undeviated).  The shares are the coating's:
    R/(R+T) by Monte Carlo (binomial, 5 sigma), weight (R+T) kept, A = 1 - R - T booked exactly."""
    n2 = 1.5
    res = trace_text(tmp_path, _coated_script(0.5, n2, from_glass=False))
    r = res.records
    on = r["object"] == 1
    d = r["direction"][on]
    assert on.sum() > 9000
    assert np.max(np.abs(np.hypot(d[:, 0], d[:, 1]) * n2 - 0.5)) < 1e-12
    f = row(res, "face")
    n = res.n_traced
    assert f[ABS] == pytest.approx(0.01, rel=1e-12)
    p = 0.01 / 0.99
    assert abs(f[REF] / (f[REF] + f[TRA]) - p) <= 5 * binomial_sigma(p, n)
    assert ledger_gap(res) < 1e-12


def test_coated_interface_total_internal_reflection(tmp_path):
    """From inside the glass beyond the critical angle, the coating's transmitted share cannot leave: it is
    reflected (R + T), the absorbed 1 - R - T stays absorbed, nothing reaches the air side."""
    n1 = 1.5
    sin_in = 1.0 / n1 + 1e-6
    res = trace_text(tmp_path, _coated_script(sin_in, n1, from_glass=True))
    f = row(res, "face")
    assert f[TRA] == 0.0
    assert f[REF] == pytest.approx(0.99, rel=1e-12)
    assert f[ABS] == pytest.approx(0.01, rel=1e-12)
    assert row(res, "catcher")[INC] == 0.0
    assert ledger_gap(res) < 1e-12
