"""PSF figures against an analytic Airy pattern and Gaussian spots (ORACLES.md "Instrument")."""

import numpy as np
import pytest
from _analysis_synth import render_airy

from analysis import (encircled_energy, encircled_energy_rays, ensquared_energy, psf_metrics, psf_metrics_rays,
                      radial_profile)

LAM_N = 10.0  # lambda N in px
PITCH = 21.0  # um
CENTER = (80.37, 79.71)


@pytest.fixture(scope="module")
def airy():
    return render_airy((161, 161), LAM_N, CENTER)


@pytest.fixture(scope="module")
def airy_metrics(airy):
    # The Airy integral over the plane is 4 (lambda N)^2 / pi; the image truncates about 1 % of it.
    return psf_metrics(airy, PITCH, total=4 * LAM_N**2 / np.pi)


# The pixel (1 px box) spreads the pattern a little: with lambda N = 10 px it widens the FWHM by 0.2 % and the
# 80 % diameter by 0.6 %; 2 % bounds these with the profile binning.
def test_airy_fwhm(airy_metrics):
    assert airy_metrics["fwhm"] == pytest.approx(1.0290 * LAM_N * PITCH, rel=0.02)


def test_airy_ee80_diameter(airy_metrics):
    assert airy_metrics["ee80_diameter"] == pytest.approx(1.7939 * LAM_N * PITCH, rel=0.02)


def test_airy_first_dark_ring(airy_metrics):
    # First zero of J1 at x = 3.8317: diameter 2 * 3.8317 / pi lambda N = 2.4393 lambda N.
    assert airy_metrics["ring_diameter"] == pytest.approx(2.4393 * LAM_N * PITCH, rel=0.02)


def test_airy_centroid_and_no_strehl(airy_metrics):
    # The truncated wings are symmetric but pixel-sampled; the centroid is good to a few hundredths of a px.
    assert airy_metrics["centroid"] == pytest.approx((CENTER[0] * PITCH, CENTER[1] * PITCH), abs=0.05 * PITCH)
    assert airy_metrics["strehl"] is None


def test_strehl_of_a_mixture(airy):
    # PSF = 0.6 Airy + 0.4 wide Gaussian with the same total: peak-to-total ratio 0.6 P_airy + 0.4 P_gauss.
    yy, xx = np.mgrid[:161, :161]
    gauss = np.exp(-((xx - CENTER[0]) ** 2 + (yy - CENTER[1]) ** 2) / (2 * 12.0**2))
    gauss *= airy.sum() / gauss.sum()
    mixed = 0.6 * airy + 0.4 * gauss
    expected = 0.6 + 0.4 * gauss.max() / airy.max()  # both peaks fall within the same pixel region
    assert psf_metrics(mixed, PITCH, reference=airy)["strehl"] == pytest.approx(expected, rel=0.01)


def test_encircled_energy_matches_brute_force(airy):
    # Independent check: split every pixel into 40 x 40 uniform sub-pixels and count those inside the circle.
    sub = 40
    crop = airy[60:101, 60:101]
    up = np.kron(crop, np.ones((sub, sub))) / sub**2
    coords = (np.arange(41 * sub) + 0.5) / sub - 0.5
    cx, cy = CENTER[0] - 60, CENTER[1] - 60
    rr = np.hypot(coords[None, :] - cx, coords[:, None] - cy)
    radii = np.array([2.0, 5.3, 8.97, 14.0])
    brute = np.array([up[rr <= r].sum() for r in radii]) / crop.sum()
    _, ee = encircled_energy(crop, 1.0, radii, center=(cx, cy))
    np.testing.assert_allclose(ee, brute, atol=1e-3)


def test_ensquared_energy_is_exact_for_a_flat_image():
    img = np.ones((20, 20))
    hw, es = ensquared_energy(img, 2.0, [1.0, 3.0, 7.0], center=(9.5, 9.5))
    np.testing.assert_allclose(es, [(2 * 0.5) ** 2 / 400, (2 * 1.5) ** 2 / 400, (2 * 3.5) ** 2 / 400])
    np.testing.assert_allclose(hw, [1.0, 3.0, 7.0])


def test_gaussian_psf_has_no_ring_and_known_sizes():
    s = 4.0
    yy, xx = np.mgrid[:81, :81]
    img = np.exp(-((xx - 40.2) ** 2 + (yy - 39.6) ** 2) / (2 * s**2))
    m = psf_metrics(img, 1.0)
    assert m["ring_diameter"] is None
    # pixel-centre sampling, no aperture: FWHM 2.3548 s, EE80 radius s sqrt(2 ln 5), rms radius sqrt(2) s; the
    # uniform-pixel model of the encircled energy adds 1/12 px^2 per axis (0.3 % at s = 4).
    assert m["fwhm"] == pytest.approx(2.3548 * s, rel=0.01)
    assert m["ee80_diameter"] == pytest.approx(2 * s * np.sqrt(2 * np.log(5)), rel=0.01)
    assert m["rms_radius"] == pytest.approx(np.sqrt(2) * s, rel=0.01)


def test_radial_profile_units():
    # An image whose value is the distance from the centre: each annulus' mean value is its mean radius (px),
    # and the radius is reported in pitch units.
    yy, xx = np.mgrid[:21, :21]
    img = np.hypot(xx - 10.3, yy - 9.8)
    r, p, n = radial_profile(img, 3.0, center=(10.3, 9.8), bin_width=1.0)
    np.testing.assert_allclose(r, 3.0 * p)
    assert n.sum() == img.size and np.all(np.diff(r) > 0)


# --- ray records -------------------------------------------------------------------------------------------------
def _spot(n, s, rng):
    return rng.normal(1.0, s, n), rng.normal(-2.0, s, n), rng.uniform(0.5, 1.5, n)


def test_rays_against_gaussian_spot():
    s = 0.01
    rng = np.random.default_rng(5)
    x, y, w = _spot(20000, s, rng)
    m = psf_metrics_rays(x, y, w, center=(1.0, -2.0))
    assert abs(m["ee80_diameter"] - 2 * s * np.sqrt(2 * np.log(5))) < 4 * m["ee80_diameter_se"]
    assert abs(m["rms_radius"] - np.sqrt(2) * s) < 4 * m["rms_radius_se"]
    assert abs(m["centroid"][0] - 1.0) < 4 * m["centroid_se"][0]
    assert abs(m["centroid"][1] + 2.0) < 4 * m["centroid_se"][1]
    radii, ee, se = encircled_energy_rays(x, y, w, [s, 2 * s], center=(1.0, -2.0))
    truth = 1 - np.exp(-0.5 * (radii / s) ** 2)
    assert np.all(np.abs(ee - truth) < 4 * se)


def test_ray_standard_errors_are_calibrated():
    # 400 independent spots of 1000 weighted rays: the scatter of each estimate must match its mean standard
    # error. The scatter of 400 draws is known to 1/sqrt(2 * 399) = 3.5 %; 20 % is about 5 of those.
    rng = np.random.default_rng(9)
    s = 1.0
    ee, ee_se, d80, d80_se, rms, rms_se = [], [], [], [], [], []
    for _ in range(400):
        x, y, w = _spot(1000, s, rng)
        _, e, se = encircled_energy_rays(x, y, w, [s], center=(1.0, -2.0))
        m = psf_metrics_rays(x, y, w, center=(1.0, -2.0))
        ee.append(e[0]), ee_se.append(se[0])
        d80.append(m["ee80_diameter"]), d80_se.append(m["ee80_diameter_se"])
        rms.append(m["rms_radius"]), rms_se.append(m["rms_radius_se"])
    for values, errors in ((ee, ee_se), (d80, d80_se), (rms, rms_se)):
        assert np.std(values, ddof=1) / np.mean(errors) == pytest.approx(1.0, abs=0.2)
