"""Fresnel, Snell, reflection and Beer's law against ORACLES.md and independent closed forms."""
import math

import numpy as np
import pytest

from irtlang.kernels.optics import beer_transmission, fresnel_rs_rp, fresnel_unpolarized, reflect, refract


def fresnel_angle_form(theta_i, n1, n2):
    """Independent: Fresnel's sine and tangent laws (valid for 0 < theta_i, no TIR)."""
    theta_t = math.asin(n1 * math.sin(theta_i) / n2)
    rs = math.sin(theta_i - theta_t) ** 2 / math.sin(theta_i + theta_t) ** 2
    rp = math.tan(theta_i - theta_t) ** 2 / math.tan(theta_i + theta_t) ** 2
    return rs, rp


@pytest.mark.parametrize("deg,expected", [(0, 0.02037), (30, 0.02144), (60, 0.05969), (75, 0.21238)])
def test_fresnel_water_oracle(deg, expected):
    r = fresnel_unpolarized(math.cos(math.radians(deg)), 1.0, 1.333)
    assert abs(r - expected) < 5e-6  # ORACLES.md gives 5 decimals


def test_fresnel_vs_angle_form():
    for n1, n2 in [(1.0, 1.333), (1.0, 1.5), (1.5, 1.0), (1.333, 1.0), (1.0, 4.0)]:
        for deg in np.linspace(0.5, 89.5, 179):
            th = math.radians(deg)
            if n1 * math.sin(th) / n2 >= 1.0:
                continue
            rs_ref, rp_ref = fresnel_angle_form(th, n1, n2)
            rs, rp = fresnel_rs_rp(math.cos(th), n1, n2)
            assert abs(rs - rs_ref) < 1e-12 and abs(rp - rp_ref) < 1e-12, (n1, n2, deg)
            assert abs(fresnel_unpolarized(math.cos(th), n1, n2) - 0.5 * (rs_ref + rp_ref)) < 1e-12
    # normal incidence: ((n1 - n2)/(n1 + n2))^2, both polarisations
    assert fresnel_unpolarized(1.0, 1.0, 1.5) == pytest.approx(0.04, abs=1e-15)
    # Brewster: Rp = 0 at atan(n2/n1)
    rs, rp = fresnel_rs_rp(math.cos(math.atan(1.5)), 1.0, 1.5)
    assert rp < 1e-30 and rs > 0.1
    # grazing -> 1, sign of cos ignored
    assert fresnel_unpolarized(0.0, 1.0, 1.5) == 1.0
    assert fresnel_unpolarized(-0.5, 1.0, 1.5) == fresnel_unpolarized(0.5, 1.0, 1.5)


def _dir(theta):
    """Unit direction going down (-z) at angle theta from the normal +z, in the x-z plane."""
    return math.sin(theta), 0.0, -math.cos(theta)


@pytest.mark.parametrize("n1,n2", [(1.5, 1.0), (1.333, 1.0), (2.4, 1.33)])
def test_tir_switches_at_critical_angle(n1, n2):
    thc = math.asin(n2 / n1)
    for eps, expect in [(1e-9, True), (-1e-9, False)]:
        d = _dir(thc + eps)
        tx, ty, tz, tir = refract(*d, 0.0, 0.0, 1.0, n1, n2)
        assert tir is expect
        r = fresnel_unpolarized(math.cos(thc + eps), n1, n2)
        if expect:
            assert r == 1.0
            # reflected direction returned under TIR
            rx, ry, rz = reflect(*d, 0.0, 0.0, 1.0)
            assert (tx, ty, tz) == pytest.approx((rx, ry, rz), abs=1e-15)
        else:
            assert r < 1.0
            assert tz < 0.0 and abs(tz) < 1e-3  # just below grazing


def test_snell_law_random():
    rng = np.random.default_rng(5)
    for _ in range(2000):
        d = rng.normal(size=3) * rng.uniform(0.1, 10.0)
        nrm = rng.normal(size=3) * rng.uniform(0.1, 10.0)
        n1, n2 = rng.uniform(1.0, 2.5, size=2)
        tx, ty, tz, tir = refract(*d, *nrm, n1, n2)
        t = np.array([tx, ty, tz])
        assert np.all(np.isfinite(t))
        assert abs(np.linalg.norm(t) - 1.0) < 1e-14
        du = d / np.linalg.norm(d)
        nu = nrm / np.linalg.norm(nrm)
        sin_i = np.linalg.norm(np.cross(du, nu))
        sin_t = np.linalg.norm(np.cross(t, nu))
        # coplanar with d and n
        assert abs(np.dot(np.cross(du, nu), t)) < 1e-12
        if tir:
            assert n1 * sin_i > n2 - 1e-12
            assert abs(np.dot(t, nu) + np.dot(du, nu)) < 1e-12  # mirror
        else:
            assert abs(n1 * sin_i - n2 * sin_t) < 1e-12
            # transmitted ray continues on the same side as the incident one
            assert np.dot(t, nu) * np.dot(du, nu) >= 0.0


def test_refract_normal_orientation_and_identity():
    d = np.array([0.3, -0.2, -0.9])
    a = refract(*d, 0.0, 0.0, 1.0, 1.0, 1.5)
    b = refract(*d, 0.0, 0.0, -1.0, 1.0, 1.5)
    assert a == pytest.approx(b, abs=1e-16)
    t = refract(*d, 0.0, 0.0, 1.0, 1.4, 1.4)
    assert np.allclose(t[:3], d / np.linalg.norm(d), atol=1e-15, rtol=0)
    # normal incidence passes straight
    assert refract(0.0, 0.0, -2.0, 0.0, 0.0, 5.0, 1.0, 1.5)[:3] == pytest.approx((0.0, 0.0, -1.0), abs=0)
    # exact grazing: no NaN
    g = refract(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.5)
    assert np.all(np.isfinite(g[:3]))


def test_reflect():
    rng = np.random.default_rng(7)
    for _ in range(500):
        d = rng.normal(size=3)
        n = rng.normal(size=3)
        r = np.array(reflect(*d, *n))
        du = d / np.linalg.norm(d)
        nu = n / np.linalg.norm(n)
        assert abs(np.linalg.norm(r) - 1.0) < 1e-14
        assert abs(np.dot(r, nu) + np.dot(du, nu)) < 1e-14
        assert np.allclose(np.cross(r, nu), np.cross(du, nu), atol=1e-14)
    # grazing 1e-9 rad stays finite and grazing
    r = reflect(math.cos(1e-9), 0.0, -math.sin(1e-9), 0.0, 0.0, 1.0)
    assert r[2] == pytest.approx(math.sin(1e-9), rel=1e-12)


def test_beer():
    assert beer_transmission(0.5, 2.0) == pytest.approx(math.exp(-1.0), rel=1e-15)
    assert beer_transmission(0.0, np.inf) == 1.0
    assert beer_transmission(1.0, np.inf) == 0.0
    assert beer_transmission(1e-3, 0.0) == 1.0
    assert beer_transmission(1e300, 1e300) == 0.0
    # slab oracle (ORACLES.md): uncoated slab n = 1.5, incoherent multiple reflections, no absorption
    r = fresnel_unpolarized(1.0, 1.0, 1.5)
    assert (1 - r) / (1 + r) == pytest.approx(0.923077, abs=5e-7)
