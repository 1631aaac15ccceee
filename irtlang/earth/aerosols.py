"""Aerosol optics per atmospheric layer: the OPAC aerosol types (Hess, Koepke and Schult 1998).

Hess et al. (Bull. Amer. Meteor. Soc. 79, 831-844, 1998), Table 4, give for each of their ten aerosol types
at 0.55 um and 80 % relative humidity the extinction coefficient at the ground sigma_e (km^-1), the
single-scattering albedo omega, the asymmetry parameter g, the optical depth tau of the whole column and the
Angstrom exponents alpha(0.35-0.5 um) and alpha(0.5-0.8 um) (``OPAC_TYPES``; the continental-polluted row
agrees with an OPAC 3.1 output: 0.1746 km^-1, 0.8925, 0.6977, 0.327).  Their height profile (their sect. 3d):
the mixing layer from the ground to H with sigma(h) = sigma_e exp(-h / Z), a free troposphere from H to 12 km
and a stratospheric layer; (H, Z) per type as in OPAC (2 km and 8 km continental, 2 and 1 maritime, 6 and 2
desert, 2 and 99 Arctic; the Antarctic's 10 and 8 do not reproduce its printed tau and are unverified).

The free-tropospheric and stratospheric contributions are not in Table 4; irtlang fits them to it:
sigma_FT(h) = 0.00308 exp(-h / 8 km) km^-1 between H and 12 km and tau_strat = 0.0043 (12-35 km), which
reproduce the printed column tau of all nine types with H, Z above to within 0.0008 (the rounding of the
printed sigma_e; see tests/physics/test_earth_aerosols.py).

Spectral dependence: the extinction follows the Angstrom law with alpha(0.35-0.5) below 500 nm and
alpha(0.5-0.8) above (continuous at 500 nm, extrapolated beyond 800 nm); omega and g keep their 550 nm values
(an approximation: OPAC's omega of absorbing types varies by a few hundredths across 350-950 nm).

The five types used in the Earth model's layers (``EARTH_TYPES``): maritime clean over the oceans, continental
average over vegetated land, desert over barren land, urban (available for a city map), and Arctic / Antarctic
poleward of 60 deg.  (The seed paper's own choice of five types could not be checked here; this is irtlang's.)
"""
from __future__ import annotations

import math

import numpy as np

# type: (sigma_e km^-1, omega, g, tau, alpha 0.35-0.5, alpha 0.5-0.8, H_ML km, Z km)
OPAC_TYPES = {
    "continental clean":    (0.026, 0.972, 0.709, 0.064, 1.10, 1.42, 2.0, 8.0),
    "continental average":  (0.075, 0.925, 0.703, 0.151, 1.11, 1.42, 2.0, 8.0),
    "continental polluted": (0.175, 0.892, 0.698, 0.327, 1.13, 1.45, 2.0, 8.0),
    "urban":                (0.353, 0.817, 0.689, 0.643, 1.14, 1.43, 2.0, 8.0),
    "desert":               (0.145, 0.888, 0.729, 0.286, 0.20, 0.17, 6.0, 2.0),
    "maritime clean":       (0.090, 0.997, 0.772, 0.096, 0.12, 0.08, 2.0, 1.0),
    "maritime polluted":    (0.115, 0.975, 0.756, 0.117, 0.41, 0.35, 2.0, 1.0),
    "maritime tropical":    (0.043, 0.998, 0.774, 0.056, 0.07, 0.04, 2.0, 1.0),
    "arctic":               (0.023, 0.887, 0.721, 0.063, 0.85, 0.89, 2.0, 99.0),
    "antarctic":            (0.011, 1.000, 0.784, 0.072, 0.34, 0.73, 10.0, 8.0),
}
EARTH_TYPES = ("maritime clean", "continental average", "desert", "urban", "arctic")
SIGMA_FT0 = 0.00308      # km^-1 at the ground, free troposphere (scale height 8 km), fitted to Table 4
Z_FT = 8.0
TOP_FT = 12.0
TAU_STRAT = 0.0043       # 12-35 km, fitted to Table 4
STRAT = (12.0, 35.0)


def _type(name: str):
    key = name.lower()
    if key not in OPAC_TYPES:
        raise ValueError(f"unknown OPAC type {name!r}; known: {', '.join(OPAC_TYPES)}")
    return OPAC_TYPES[key]


def spectral_factor(name: str, wavelength_nm) -> np.ndarray:
    """sigma(lambda) / sigma(550 nm) by the Angstrom law with the type's two exponents."""
    _, _, _, _, a1, a2, _, _ = _type(name)
    w = np.asarray(wavelength_nm, float)
    f500 = (500.0 / 550.0) ** (-a2)
    return np.where(w >= 500.0, (w / 550.0) ** (-a2), f500 * (w / 500.0) ** (-a1))


def _exp_integral(s0, Z, z1, z2):
    """Integral of s0 exp(-h / Z) dh from z1 to z2."""
    return s0 * Z * (math.exp(-z1 / Z) - math.exp(-z2 / Z))


def column_tau_550(name: str) -> float:
    """Optical depth of the whole column at 550 nm from the profile (mixing layer + FT + stratosphere)."""
    return float(layer_tau_550(name, [0.0, STRAT[1]]).sum())


def layer_tau_550(name: str, levels_km) -> np.ndarray:
    """Optical depth at 550 nm of each layer between consecutive levels (km, increasing)."""
    s, _, _, _, _, _, H, Z = _type(name)
    z = np.asarray(levels_km, float)
    if np.any(np.diff(z) <= 0):
        raise ValueError("levels must increase")
    out = np.zeros(z.size - 1)
    for i, (a, b) in enumerate(zip(z[:-1], z[1:])):
        t = 0.0
        lo, hi = a, min(b, H)                                  # mixing layer
        if hi > lo:
            t += _exp_integral(s, Z, lo, hi)
        lo, hi = max(a, H), min(b, TOP_FT)                     # free troposphere
        if hi > lo:
            t += _exp_integral(SIGMA_FT0, Z_FT, lo, hi)
        lo, hi = max(a, STRAT[0]), min(b, STRAT[1])            # stratosphere, uniform
        if hi > lo:
            t += TAU_STRAT * (hi - lo) / (STRAT[1] - STRAT[0])
        out[i] = t
    return out


def layer_optics(name: str, levels_km, wavelengths_nm):
    """(tau, omega, g) per layer and line: arrays of shape (n_layers, n_lines).  The free troposphere and the
    stratosphere are given the type's omega and g (OPAC gives them their own components)."""
    s, w, g, *_ = _type(name)
    tau = layer_tau_550(name, levels_km)[:, None] * spectral_factor(name, wavelengths_nm)[None, :]
    return tau, np.full_like(tau, w), np.full_like(tau, g)


def aerosol_model_line(model: str, type_name: str, bottom_km: float, top_km: float, wavelengths_nm,
                       orders: int = 1) -> str:
    """`MODEL model HG G ... TAU ... ALBEDO ...` for the aerosol of one layer."""
    tau, w, g = layer_optics(type_name, [bottom_km, top_km], wavelengths_nm)
    fmt = lambda v: " ".join(f"{x:.6g}" for x in v)  # noqa: E731
    return f"MODEL {model} HG G {fmt(g[0])} TAU {fmt(tau[0])} ALBEDO {fmt(w[0])} ORDERS {orders}"


def aerosol_type_map(landcover: np.ndarray) -> np.ndarray:
    """Index into EARTH_TYPES per cell: maritime clean over water, desert over barren land, continental average
    over other land, urban (3) over urban and built-up land (IGBP 13), Arctic / Antarctic (index 4) poleward of
    60 deg."""
    from .latlon import cell_centres

    lat, _ = cell_centres(landcover.shape[0])
    out = np.where(landcover == 0, 0, np.where(landcover == 16, 2, np.where(landcover == 13, 3, 1))).astype(np.uint8)
    out[np.abs(lat) > 60.0, :] = 4
    return out
