"""Spectra: the built-in solar reference, tables and black bodies, rebinned onto the wavelength lines.

Rebinning conserves energy: each line stands for the band between the midpoints to its neighbours (the
end lines' bands are symmetric), and its value is the mean of the spectrum over that band, integrated
exactly for the piecewise-linear spectrum.  With a single line the value is the spectrum at that line.
"""
from __future__ import annotations

import math
from importlib import resources

import numpy as np

from ..core.diagnostics import error
from ..model.scene import Spectrum, frozen_params

DEFAULT_TSI = 1360.8          # W/m2, Kopp & Lean (2011)
G173_TOTAL = 1366.1           # W/m2, the total of the ASTM G173 extraterrestrial spectrum (all wavelengths)
H, C, KB = 6.62607015e-34, 2.99792458e8, 1.380649e-23


def band_edges(lines_nm) -> np.ndarray:
    x = np.asarray(lines_nm, float)
    order = np.argsort(x)
    xs = x[order]
    mid = 0.5 * (xs[1:] + xs[:-1])
    lo = np.concatenate([[xs[0] - (mid[0] - xs[0])], mid])
    hi = np.concatenate([mid, [xs[-1] + (xs[-1] - mid[-1])]])
    inv = np.empty_like(order)
    inv[order] = np.arange(len(order))
    return np.stack([lo[inv], hi[inv]], axis=1)


def rebin(w_src, v_src, lines_nm) -> np.ndarray:
    """Band means of the piecewise-linear spectrum (w_src, v_src) over each line's band."""
    w_src = np.asarray(w_src, float)
    v_src = np.asarray(v_src, float)
    lines = np.asarray(lines_nm, float)
    if len(lines) == 1:
        return np.interp(lines, w_src, v_src)
    edges = band_edges(lines)
    grid = np.union1d(w_src, edges.ravel())
    grid = grid[(grid >= w_src[0]) & (grid <= w_src[-1])]
    vals = np.interp(grid, w_src, v_src)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (vals[1:] + vals[:-1]) * np.diff(grid))])
    lo = np.interp(edges[:, 0], grid, cum)
    hi = np.interp(edges[:, 1], grid, cum)
    # a band mean lies within the values it averages: clip the rounding of the cumulative sums (a plateau of 1.0
    # must not come back as 1.0000000000000002, which a transmission check would refuse)
    return np.clip((hi - lo) / (edges[:, 1] - edges[:, 0]), v_src.min(), v_src.max())


def line_widths(lines_nm) -> np.ndarray:
    """Width in nm of each line's band (``band_edges``); a single line counts 1 nm (its value is per nm).
    These are the widths by which FLUX SPECTRUM multiplies a spectrum's band means (compile/pack.py)."""
    lines = np.asarray(lines_nm, float).reshape(-1)
    return np.diff(band_edges(lines), axis=1)[:, 0] if len(lines) > 1 else np.ones(1)


def solar_line_irradiance(lines_nm, tsi: float = DEFAULT_TSI) -> np.ndarray:
    """Solar irradiance at 1 AU in each wavelength line's band, W/m2: what ``FLUX SPECTRUM sun`` of
    ``SPECTRUM sun SOLAR TSI tsi`` puts on each line per m2 at 1 AU (the ASTM G173 reference scaled by
    ``tsi / G173_TOTAL``, band mean (:func:`rebin`) times band width (:func:`line_widths`)).  Raises ValueError
    when a band reaches outside the reference's 280-4000 nm or a line is repeated."""
    lines = np.asarray(lines_nm, float).reshape(-1)
    if lines.size == 0 or not np.all(np.isfinite(lines)):
        raise ValueError("the wavelength lines must be finite numbers (at least one)")
    if len(np.unique(lines)) != len(lines):
        raise ValueError("the wavelength lines must be distinct")
    if not (math.isfinite(tsi) and tsi > 0):
        raise ValueError(f"the TSI must be a positive number of W/m2, got {tsi!r}")
    w, v = solar_reference()
    edges = band_edges(lines) if len(lines) > 1 else np.array([[lines[0], lines[0]]])
    if edges.min() < w[0] - 1e-9 or edges.max() > w[-1] + 1e-9:
        raise ValueError(f"the solar reference covers {w[0]:g}-{w[-1]:g} nm but the wavelength lines need "
                         f"{edges.min():g}-{edges.max():g} nm")
    return rebin(w, v * (tsi / G173_TOTAL), lines) * line_widths(lines)


def solar_reference() -> tuple[np.ndarray, np.ndarray]:
    """ASTM G173-03 extraterrestrial spectrum, W/m2/nm at 1 AU (shipped from pvlib; see the CSV header)."""
    txt = resources.files("irtlang.data").joinpath("solar_astm_g173_etr.csv").read_text()
    d = np.loadtxt(txt.splitlines(), delimiter=",", comments="#", skiprows=4)
    return d[:, 0], d[:, 1]


def planck_exitance(w_nm, T) -> np.ndarray:
    """pi * B_lambda(T): spectral exitance of a black body, W/m2/nm."""
    lam = np.asarray(w_nm, float) * 1e-9
    with np.errstate(over="ignore", divide="ignore"):  # a tiny T: x = inf, clamped below (exitance ~ 0)
        x = H * C / (lam * KB * T)
        b = 2 * H * C ** 2 / lam ** 5 / np.expm1(np.minimum(x, 700.0))
    return math.pi * b * 1e-9


def make_spectrum(it, b, name: str, source: str) -> Spectrum:
    lines = it.state.wavelengths_nm
    span = b.span
    if source == "SOLAR":
        w, v = solar_reference()
        tsi = b.get("tsi", DEFAULT_TSI)
        v = v * (tsi / G173_TOTAL)
        params = {"tsi_W_m2": tsi, "reference": "ASTM G173-03 extraterrestrial (pvlib copy)"}
        unit = "W/m2/nm"
    elif source == "TABLE":
        from .tables import read_table

        path = it.input_path(b["file"], b.span_of("file"))
        tab = read_table(path, b.span_of("file"))
        w, v = tab.data[:, 0], tab.data[:, 1]
        params = {"file": str(path)}
        unit = ""
    else:
        T = b["temperature"]
        lo = min(lines) * 0.5
        hi = max(lines) * 1.5
        w = np.linspace(lo, hi, 20001)
        v = planck_exitance(w, T)
        params = {"temperature_K": T}
        unit = "W/m2/nm"
    edges = band_edges(lines) if len(lines) > 1 else np.array([[lines[0], lines[0]]])
    if edges.min() < w[0] - 1e-9 or edges.max() > w[-1] + 1e-9:
        raise error(span, f"spectrum {name} covers {w[0]:g}-{w[-1]:g} nm but the wavelength lines need "
                    f"{edges.min():g}-{edges.max():g} nm", "narrow WAVELENGTHS or extend the table")
    on = rebin(w, v, lines)
    it.n_lines()
    return Spectrum(name, source.lower(), tuple(map(float, w)), tuple(map(float, v)), tuple(map(float, on)), unit,
                    frozen_params(params), span)
