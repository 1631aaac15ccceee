"""Disk metrics, Lambert-sphere radiometry, disk-integrated spectra (ORACLES.md "Radiometry")."""

import numpy as np
import pytest
from _analysis_synth import render_ellipse, render_lambert_sphere

from analysis import (AnalysisError, apparent_albedo, disk_averaged_spectrum, disk_metrics, lambert_phase,
                      lambert_sphere_flux, time_wavelength_map)


@pytest.mark.parametrize("center, axes, angle", [
    ((64.37, 60.81), (40.3, 33.7), 20.0),
    ((70.0, 64.5), (50.0, 49.8), 0.0),
    ((60.2, 66.9), (30.7, 18.2), 123.0),
])
def test_diameters_of_antialiased_ellipses(center, axes, angle):
    img = render_ellipse((128, 136), center, axes, angle)
    m = disk_metrics(img)
    assert m["equatorial_diameter_px"] == pytest.approx(2 * axes[0], abs=0.5)
    assert m["polar_diameter_px"] == pytest.approx(2 * axes[1], abs=0.5)
    assert m["center"] == pytest.approx(center, abs=0.25)
    if axes[0] - axes[1] > 1:
        assert (m["angle_deg"] - angle + 90) % 180 - 90 == pytest.approx(0, abs=1.0)
    assert m["illuminated_fraction"] == pytest.approx(1.0, abs=0.01)
    assert m["km_per_px"] is None
    assert disk_metrics(img, radius_km=6378.137)["km_per_px"] == pytest.approx(6378.137 / axes[0], rel=0.5 / axes[0])


@pytest.mark.parametrize("phase", [30.0, 57.7, 90.0, 120.0])
def test_illuminated_fraction_of_a_lambert_sphere(phase):
    # k = (1 + cos a) / 2. The threshold (2 % of the maximum) drops the terminator band where cos i < 0.02:
    # at most 2 * 0.02 / pi = 0.013 of the disk; with the limb-circle fit that stays inside 0.02.
    img = render_lambert_sphere((200, 200), (100.3, 98.7), 80.0, phase)
    m = disk_metrics(img, shape="circle")
    k = (1 + np.cos(np.radians(phase))) / 2
    assert m["illuminated_fraction"] == pytest.approx(k, abs=0.02)
    # the phase angle follows: |da| <= 0.02 / (sin a / 2)
    assert m["phase_angle_deg"] == pytest.approx(phase, abs=np.degrees(0.04 / np.sin(np.radians(phase))))
    assert m["equatorial_diameter_px"] == pytest.approx(160.0, abs=1.0)


@pytest.mark.parametrize("angle, value", [(0, 1.0), (30, 0.88084), (57.7, 0.63212), (74.99, 0.45854),
                                          (90, 0.31831), (120, 0.10900)])
def test_lambert_phase_function(angle, value):
    assert lambert_phase(angle) == pytest.approx(value, abs=5e-6)


def test_apparent_albedo_of_a_lambert_sphere():
    wl = np.array([450.0, 550.0, 650.0, 850.0])
    albedo = np.array([0.35, 0.3, 0.25, 0.2])
    radius, distance, phase = 6371.0, 0.184 * 1.495978707e8, 57.7

    def solar(lam):
        return 1.9 - 0.001 * (lam - 450.0)

    a = np.radians(phase)
    phi = (np.sin(a) + (np.pi - a) * np.cos(a)) / np.pi
    flux = 2.0 / 3.0 * albedo * solar(wl) * (radius / distance) ** 2 * phi  # written out independently
    got = apparent_albedo(flux, wl, solar_irradiance=solar, radius=radius, distance=distance, phase_angle_deg=phase)
    np.testing.assert_allclose(got, albedo, rtol=1e-12)
    np.testing.assert_allclose(lambert_sphere_flux(albedo, solar(wl), radius, distance, phase), flux, rtol=1e-12)
    with pytest.raises(AnalysisError):
        apparent_albedo(flux, solar_irradiance=solar, radius=radius, distance=distance, phase_angle_deg=phase)


def test_disk_averaged_spectrum_and_errors():
    rng = np.random.default_rng(2)
    cube = rng.uniform(0, 1, (3, 8, 9))
    sum2 = cube**2 / 10
    mask = np.zeros((8, 9), bool)
    mask[2:6, 3:7] = True
    wl, flux, se = disk_averaged_spectrum(cube, [450, 550, 650], mask=mask, sum2=sum2)
    np.testing.assert_allclose(flux, cube[:, 2:6, 3:7].sum(axis=(1, 2)))
    np.testing.assert_allclose(se, np.sqrt(sum2[:, 2:6, 3:7].sum(axis=(1, 2))))
    np.testing.assert_array_equal(wl, [450, 550, 650])
    _, flux_all, se_none = disk_averaged_spectrum(cube)
    np.testing.assert_allclose(flux_all, cube.sum(axis=(1, 2)))
    assert se_none is None


def test_time_wavelength_map():
    t = np.linspace(0, 24, 25)[:, None]
    base = np.array([1.0, 2.0, 4.0])
    spectra = base * (1 + 0.1 * np.sin(2 * np.pi * t / 24))
    rel = time_wavelength_map(spectra)
    np.testing.assert_allclose(rel, spectra / spectra.mean(axis=0) - 1, atol=1e-12)
    np.testing.assert_allclose(time_wavelength_map(spectra, reference=spectra), 0.0)
    np.testing.assert_allclose(time_wavelength_map(spectra, reference=base, mode="difference"), spectra - base)
