"""Standard-atmosphere profiles, Rayleigh optical depth per layer and the refractive index of air.

* Temperature and pressure: the U.S. Standard Atmosphere 1976 (NOAA/NASA/USAF, 1976), its seven geopotential
  layers to 84.852 km geopotential (86 km geometric) with their lapse rates; above that, the tabulated
  pressures of its Table I interpolated in log p up to 100 km.  g0 = 9.80665 m/s2, R* = 8.31432 J/mol/K,
  M0 = 28.9644 g/mol, r0 = 6356.766 km (geometric -> geopotential).
* Rayleigh optical depth of a full column at 1013.25 hPa: Bodhaine et al. (1999), eq. 30; a layer's share is
  its pressure difference over 1013.25 hPa (hydrostatic: the optical depth follows the column mass).
* Refractive index (n - 1) of dry air: the LOWTRAN 7 form (Kneizys et al. 1988), Edlen-type dispersion scaled
  by P/T: (n - 1) 1e6 = (77.46 + 0.459 / lambda^2) P[hPa] / T[K], lambda in um.
"""
from __future__ import annotations

import math

import numpy as np

G0 = 9.80665
RSTAR = 8.31432
M0 = 28.9644e-3
R0 = 6356.766e3
P0 = 101325.0
# base geopotential height (m), lapse rate (K/m)
_LAYERS = [(0.0, -0.0065), (11000.0, 0.0), (20000.0, 0.0010), (32000.0, 0.0028), (47000.0, 0.0),
           (51000.0, -0.0028), (71000.0, -0.0020), (84852.0, 0.0)]
# USSA 1976 Table I above 86 km (geometric km, Pa)
_HIGH = [(86.0, 0.37338), (90.0, 0.18359), (95.0, 0.075966), (100.0, 0.032011)]


def _bases():
    T, p = 288.15, P0
    out = []
    for i, (h, lapse) in enumerate(_LAYERS):
        out.append((h, lapse, T, p))
        if i + 1 < len(_LAYERS):
            h2 = _LAYERS[i + 1][0]
            T2 = T + lapse * (h2 - h)
            p = p * (T / T2) ** (G0 * M0 / (RSTAR * lapse)) if lapse else p * math.exp(-G0 * M0 * (h2 - h) / (RSTAR * T))
            T = T2
    return out


_BASES = _bases()


def geopotential(z_m: float) -> float:
    return R0 * z_m / (R0 + z_m)


def ussa1976(z_m: float) -> tuple[float, float]:
    """(temperature K, pressure Pa) at geometric altitude z (0 .. 100 km)."""
    if z_m < -5000 or z_m > 100000:
        raise ValueError(f"altitude {z_m / 1e3:g} km is outside 0-100 km")
    if z_m > 86000.0:
        zs = [a for a, _ in _HIGH]
        lp = np.interp(z_m / 1e3, zs, [math.log(p) for _, p in _HIGH])
        return 186.87, math.exp(lp)
    h = geopotential(z_m)
    for hb, lapse, Tb, pb in reversed(_BASES):
        if h >= hb:
            T = Tb + lapse * (h - hb)
            if lapse:
                p = pb * (Tb / T) ** (G0 * M0 / (RSTAR * lapse))
            else:
                p = pb * math.exp(-G0 * M0 * (h - hb) / (RSTAR * Tb))
            return T, p
    raise AssertionError("unreachable")  # pragma: no cover


def rayleigh_tau_column(wavelength_nm) -> np.ndarray:
    """Rayleigh optical depth of the whole atmosphere at 1013.25 hPa (Bodhaine et al. 1999, eq. 30)."""
    l = np.asarray(wavelength_nm, float) * 1e-3
    return 0.0021520 * (1.0455996 - 341.29061 * l ** -2 - 0.90230850 * l ** 2) / (
        1.0 + 0.0027059889 * l ** -2 - 85.968563 * l ** 2)


def rayleigh_tau_layers(levels_km, wavelength_nm, surface_pressure_pa: float = P0) -> np.ndarray:
    """Optical depth of each layer between consecutive levels (km): (n_levels - 1, n_lines)."""
    z = np.asarray(levels_km, float) * 1e3
    p = np.array([ussa1976(zz)[1] for zz in z]) * (surface_pressure_pa / P0)
    dp = -np.diff(p)
    if np.any(dp < 0):
        raise ValueError("levels must increase")
    return (dp / P0)[:, None] * rayleigh_tau_column(wavelength_nm)[None, :]


def refractivity_lowtran(wavelength_nm, pressure_pa: float, temperature_k: float):
    """n - 1 of dry air, LOWTRAN 7 form."""
    l = np.asarray(wavelength_nm, float) * 1e-3
    return (77.46 + 0.459 / l ** 2) * (pressure_pa / 100.0) / temperature_k * 1e-6
