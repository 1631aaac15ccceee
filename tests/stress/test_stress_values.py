"""Stress: the critical angle +- 1e-12, unnormalized directions, zero and denormal fluxes (docs/tracer.md,
"Stress tests").  Besides the common invariants (tests/stress/_stress_util.py: no NaN or inf in any output, a
closed ledger, exactly nothing booked when nothing is emitted, no hang):
* glass to air through an anti-reflection coating (R = 0, T = 1): 1e-12 rad inside the critical angle every
  ray is transmitted (refracted to ~1.5e-6 rad above the surface), 1e-12 rad beyond it every ray is totally
  reflected;
* SOURCE DIRECTION and EMITTING POINT ... AXIS accept any non-zero vector, 1e-310 or 1e300 long, and give the
  same rays as the unit vector;
* FLUX TOTAL 0 W and 5e-324 W (denormal) run SPOTS, STATS and FOCUS as well as the files.
"""
import math
import re

import numpy as np
import pytest
from _stress_util import check_run, fmt, head, outputs, records

N_GLASS = 1.5
THETA_C = math.asin(1.0 / N_GLASS)


def _tir_scene(theta, itf):
    return head() + f"""MEDIUM glass INDEX {N_GLASS}
COATING ar TRANSMIT 1
SURFACE
  PLANE Z 0
OBJECT top
  {itf}
SURFACE
  PLANE Z -10
OBJECT floor
  INTERFACE ABSORB
SURFACE
  SPHERE 0 0 0 1e4
OBJECT dome
GRID RECT Z -1 -1 1 -1 1 5 5
SOURCE DIRECTION {fmt(math.sin(theta))} 0 {fmt(math.cos(theta))}
TRACE
""" + outputs(spectra=("top", "floor", "dome"))


@pytest.mark.parametrize("delta", [-1e-12, 0.0, 1e-12])
def test_critical_angle_coated(runner, tmp_path, delta):
    r = check_run(runner.run(tmp_path, _tir_scene(THETA_C + delta, "INTERFACE COATING ar glass AIR"), "tir"))
    inc, ref, tra, _, _ = r.row("top")
    emitted = r.row("EMITTED")[0]
    assert inc == pytest.approx(emitted, rel=1e-12)
    if delta < 0:
        assert ref == 0.0 and tra == pytest.approx(emitted, rel=1e-12)
        assert r.row("dome")[0] == pytest.approx(emitted, rel=1e-12)
        d = records(r)["direction"]
        # refracted to sin(theta_t) = 1.5 sin(theta_c - 1e-12): cos(theta_t) ~ sqrt(2 x 1.5^2 x 1e-12 cot) ~ 1.5e-6
        assert np.all((d[:, 2] > 1e-7) & (d[:, 2] < 1e-5)), d[:, 2]
    elif delta > 0:
        assert tra == 0.0 and ref == pytest.approx(emitted, rel=1e-12)
        assert r.row("floor")[0] == pytest.approx(emitted, rel=1e-12)


@pytest.mark.parametrize("delta", [-1e-12, 0.0, 1e-12])
def test_critical_angle_fresnel(runner, tmp_path, delta):
    """Uncoated (Fresnel): next to the critical angle R is 1 or within ~1e-5 of it; every ray is accounted
    for, and beyond the critical angle nothing is transmitted."""
    r = check_run(runner.run(tmp_path, _tir_scene(THETA_C + delta, "INTERFACE TRANSMIT glass AIR"), "tir"))
    inc, ref, tra, _, ab = r.row("top")
    assert ref + tra == pytest.approx(inc, rel=1e-12) and ab == pytest.approx(0.0, abs=1e-12 * inc)
    if delta > 0:
        assert tra == 0.0


VECTORS = ["0 0 7", "0 0 1e-200", "0 0 1e200", "0 0 5e-324", "1e300 1e300 1e300", "1e-310 1e-310 1e-310",
           "-3e-320 0 0", "1 1e-300 -1e-300"]


@pytest.mark.parametrize("vec", VECTORS)
def test_unnormalized_directions(runner, tmp_path, vec):
    """A direction of any length gives the unit direction; the same rays as the unit vector would."""
    v = np.array([float(x) for x in vec.split()])
    v = v / np.abs(v).max()
    unit = v / np.linalg.norm(v)
    text = head() + f"""SURFACE
  SPHERE 0 0 0 100
OBJECT dome
GRID RECT Z 0 -1 1 -1 1 3 3
SOURCE DIRECTION {vec}
EMITTING POINT 0 0 0 RAYS 10 CONE 5 AXIS {vec}
TRACE
""" + outputs(spectra=("dome",))
    r = check_run(runner.run(tmp_path, text, "dir"))
    rec = records(r)
    grid = rec["source"] == 0
    # the records of the grid rays: their direction where they end on the dome is the unit vector
    assert np.allclose(rec["direction"][grid], unit, rtol=0, atol=1e-15)
    # the cone rays stay within 5 deg of the axis
    cosang = rec["direction"][~grid] @ unit
    assert np.all(cosang >= math.cos(math.radians(5)) - 1e-15)
    assert r.row("dome")[0] == pytest.approx(r.row("EMITTED")[0], rel=1e-12)


@pytest.mark.parametrize("vec", ["0 0 0", "0 0 -0"])
def test_zero_direction_is_an_error(runner, tmp_path, vec):
    text = head() + f"GRID RECT Z 0 -1 1 -1 1 3 3\nSOURCE DIRECTION {vec}\nTRACE\n"
    r = runner.run(tmp_path, text, "zero")
    assert r.finished and r.code == 2
    assert "zero.inr:6:18: error: SOURCE DIRECTION needs a non-zero vector" in r.stderr


FLUXES = ["0 W", "0", "5e-324 W", "1e-310 W", "2.5e-320 W"]


@pytest.mark.parametrize("flux", FLUXES)
@pytest.mark.parametrize("lines", ["550 NM", "450 550 650 NM"])
def test_zero_and_denormal_flux(runner, tmp_path, flux, lines):
    """Zero and denormal fluxes through a half-silvered filter onto a detector, with every output: the
    ledger closes (exactly nothing anywhere for zero flux), SPOTS, STATS and FOCUS print finite numbers."""
    text = head(lines=lines) + f"""COATING half REFLECT 0.3 TRANSMIT 0.3
SURFACE
  PLANE Z 5
OBJECT filt
  INTERFACE COATING half AIR AIR
SURFACE
  PLANE Z 10 RECT 5 5
OBJECT det
  DETECTOR PIXELS 5 5
SURFACE
  SPHERE 0 0 0 100
OBJECT dome
GRID RECT Z 0 -1 1 -1 1 3 2
SOURCE DIRECTION 0 0.1 1
FLUX TOTAL {flux}
TRACE
SPOTS POSITION 'spots.png'
STATS POSITION
STATS DIRECTION
FOCUS
""" + outputs("det", spectra=("filt", "dome"))
    r = check_run(runner.run(tmp_path, text, "flux"))
    emitted = r.row("EMITTED")[0]
    assert emitted <= float(flux.split()[0])
    assert "FOCUS: best focus" in r.stdout and re.search(r"SPOTS POSITION: \d+ rays", r.stdout)
    if float(flux.split()[0]) == 0.0:
        assert emitted == 0.0
