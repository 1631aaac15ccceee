"""Source spectra for scattering runs (irtlang/io/spectra.py): rebinning onto the wavelength lines conserves
energy; SOLAR is the ASTM G173 extraterrestrial spectrum scaled to the TSI; BLACKBODY is pi B_lambda.

Rebinning (module docstring of irtlang.io.spectra): each line stands for the band between the midpoints to
its neighbours (the end lines' bands symmetric), and carries the mean of the piecewise-linear spectrum over
that band.  So sum over lines of (band mean x band width) is the integral of the piecewise-linear spectrum
from the first band's lower edge to the last band's upper edge, whatever the lines' order or spacing.  The
reference integral here is computed segment by segment (the exact area of each linear piece clipped to the
range), in double precision: the two sums differ by rounding only, 1e-12 relative.
"""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import constants, integrate

from irtlang.io.spectra import G173_TOTAL, band_edges, planck_exitance, solar_reference
from irtlang.lang.interp import Interpreter


def spectra_of(text: str) -> dict:
    it = Interpreter(check_only=True)
    it.run_text(text)
    assert not it.diags, it.diags.items
    return it.state.spectra


def piecewise_linear_integral(w, v, a, b) -> float:
    """Exact integral over [a, b] of the function linear between the samples (w, v)."""
    total = 0.0
    for i in range(len(w) - 1):
        x0, x1 = max(w[i], a), min(w[i + 1], b)
        if x1 <= x0:
            continue
        f = lambda x: v[i] + (v[i + 1] - v[i]) * (x - w[i]) / (w[i + 1] - w[i])  # noqa: E731
        total += 0.5 * (x1 - x0) * (f(x0) + f(x1))
    return total


def energy_on_lines(sp, lines) -> tuple[float, float, float]:
    """(sum of band means x widths, lowest edge, highest edge)."""
    e = band_edges(lines)
    return float(np.dot(sp.on_lines, e[:, 1] - e[:, 0])), float(e.min()), float(e.max())


# ----------------------------------------------------------------------------------------------- TABLE
def test_table_rebinning_conserves_energy(tmp_path):
    """An irregularly sampled table and unevenly spaced, unsorted lines whose band edges fall between samples."""
    w = np.array([380.0, 391.5, 402.0, 447.3, 450.0, 498.9, 530.0, 561.25, 620.0, 700.0, 755.5, 801.0, 880.0])
    v = np.array([0.12, 0.3, 0.31, 0.9, 1.4, 1.1, 0.2, 0.25, 0.7, 0.69, 0.05, 0.4, 0.33])
    f = tmp_path / "refl.csv"
    f.write_text("# wavelength_nm, value\n" + "".join(f"{float(a)!r}, {float(b)!r}\n" for a, b in zip(w, v)))
    lines = [650.0, 410.0, 555.0, 470.0, 800.0, 530.0]
    sp = spectra_of(f"WAVELENGTHS {' '.join(map(repr, lines))} NM\nSPECTRUM r TABLE '{f}'\n")["R"]
    got, lo, hi = energy_on_lines(sp, lines)
    ref = piecewise_linear_integral(w, v, lo, hi)
    assert got == pytest.approx(ref, rel=1e-12, abs=0.0)
    # each band on its own too (the band mean is the integral over the band / its width)
    for line, mean, (a, b) in zip(lines, sp.on_lines, band_edges(lines)):
        assert mean * (b - a) == pytest.approx(piecewise_linear_integral(w, v, a, b), rel=1e-12), line


# ----------------------------------------------------------------------------------------------- SOLAR
def test_solar_reference_table_integral():
    """The shipped ASTM G173 table covers 280-4000 nm and integrates (trapezoid = exact for the linear
    interpolation) to the 1347.93 W/m2 its header states (of the 1366.1 W/m2 the full spectrum carries)."""
    w, v = solar_reference()
    assert (w[0], w[-1]) == (280.0, 4000.0)
    assert piecewise_linear_integral(w, v, 280.0, 4000.0) == pytest.approx(1347.93, abs=0.005)


@pytest.mark.parametrize("tsi", [None, 1361.0, 1000.0])
def test_solar_is_g173_scaled_to_the_tsi(tsi):
    """SOLAR [TSI T] = G173 x T / 1366.1 (the full G173 integral becomes T; default T = 1360.8, Kopp & Lean
    2011): sample by sample, and on 37 lines 330 .. 3930 nm (bands 280 .. 3980 nm) the energy on the lines
    is T / 1366.1 times the G173 integral over those bands, to 1e-12."""
    t = 1360.8 if tsi is None else tsi
    sp = spectra_of("WAVELENGTHS RANGE 330 3930 37 NM\nSPECTRUM sun SOLAR" + ("" if tsi is None else f" TSI {tsi}") + "\n")["SUN"]
    w, v = solar_reference()
    assert np.allclose(sp.values, v * (t / G173_TOTAL), rtol=1e-15, atol=0.0)
    assert G173_TOTAL == 1366.1
    lines = np.linspace(330.0, 3930.0, 37)
    got, lo, hi = energy_on_lines(sp, lines)
    assert (lo, hi) == pytest.approx((280.0, 3980.0), abs=1e-9)
    assert got == pytest.approx(t / 1366.1 * piecewise_linear_integral(w, v, lo, hi), rel=1e-12)
    # the covered part of the spectrum: (1347.93 / 1366.1) T, less the 3980 .. 4000 nm sliver
    assert got < t * 1347.94 / 1366.1


# ----------------------------------------------------------------------------------------------- BLACKBODY
def planck_ref(lam_nm, T):
    """pi B_lambda in W/m2/nm from scipy's CODATA constants (h, c, k exact in SI since 2019)."""
    lam = lam_nm * 1e-9
    h, c, k = constants.h, constants.c, constants.k
    return math.pi * 2 * h * c * c / lam ** 5 / math.expm1(h * c / (lam * k * T)) * 1e-9


@pytest.mark.parametrize("T", [300.0, 1000.0, 5778.0, 20000.0])
def test_blackbody_integrates_to_sigma_t4(T):
    """pi int B_lambda d lambda = sigma T^4 (Stefan-Boltzmann; scipy's sigma).  quad over ln(lambda) from
    lambda T = 1e5 nm K (x = hc / lambda k T = 144: the short tail beyond is e^-144) to 1e11 nm K (x = 1.4e-4: the
    long tail beyond is (15 / pi^4) x^3 / 3 = 1.5e-13 of the total), to a relative 1e-10: the 1e-4 asked for
    is met with room."""
    f = lambda u: planck_exitance(np.array([math.exp(u)]), T)[0] * math.exp(u)  # noqa: E731
    lo, hi = math.log(1e5 / T), math.log(1e11 / T)
    pts = np.linspace(lo, hi, 41)
    total = sum(integrate.quad(f, a, b, epsrel=1e-12, epsabs=0.0)[0] for a, b in zip(pts[:-1], pts[1:]))
    assert total == pytest.approx(constants.sigma * T ** 4, rel=1e-4)
    # and point by point against the independent formula
    for lam in (200.0, 500.0, 2897.77 * 1e6 / T / 1e3, 1e4, 1e6):
        assert planck_exitance(np.array([lam]), T)[0] == pytest.approx(planck_ref(lam, T), rel=1e-12)


def test_blackbody_rebinned_band_energies():
    """BLACKBODY on the lines: each band mean x width against the exact Planck band integral (quad).  The
    spectrum is sampled on 20001 points over [0.5, 1.5] x the line range (0.065 nm apart for 450-1050 nm), and
    the trapezoid rule's error on a band is h^2 / 12 f'' / f <= (0.065 nm)^2 / 12 x (x_max + 5)^2 / lambda^2,
    x = hc / (lambda k T) (7.7 at 450 nm for 4000 K): 3.4e-7 relative.  Allowed: 1e-6."""
    lines = [450.0, 550.0, 650.0, 750.0, 850.0, 950.0, 1050.0]
    T = 4000.0
    sp = spectra_of(f"WAVELENGTHS {' '.join(map(repr, lines))} NM\nSPECTRUM bb BLACKBODY {T!r} K\n")["BB"]
    for mean, (a, b) in zip(sp.on_lines, band_edges(lines)):
        exact = integrate.quad(lambda x: planck_ref(x, T), a, b, epsrel=1e-13)[0]
        assert mean * (b - a) == pytest.approx(exact, rel=1e-6)
    # energy conservation of the rebinning itself, on the spectrum's own samples: to rounding
    got, lo, hi = energy_on_lines(sp, lines)
    assert got == pytest.approx(piecewise_linear_integral(np.array(sp.wavelengths_nm), np.array(sp.values), lo, hi),
                                rel=1e-12)
