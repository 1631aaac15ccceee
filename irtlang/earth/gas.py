"""Gas absorption per atmospheric layer: ozone, water vapour and the uniformly mixed gases (O2), from the
SPCTRAL2 band model (Bird and Riordan 1986, J. Clim. Appl. Meteor. 25, 87-97) and its coefficient table.

The coefficients come from a registry package: pvlib (BSD-3-Clause) carries the SPCTRAL2 table (122 wavelengths,
300-4000 nm: extraterrestrial irradiance and the absorption coefficients of water vapour a_w, ozone a_o and the
mixed gases a_u, after Leckner 1978) in ``pvlib.spectrum.spectrl2``.  ``spectrl2_coefficients`` extracts it at
first use into the default data tier (``gas_spectrl2.json`` in $IRT_DATA_DIR, labelled with its source and
licence); nothing is downloaded.

Transmittances along a path of relative air mass M (Bird and Riordan, eqs. 2-8 to 2-11; the constants of
pvlib / spectrl2_2.c):

    T_o = exp(-a_o O M)                                         O: ozone column, atm-cm
    T_w = exp(-0.2385 a_w W M / (1 + 20.07 a_w W M)^0.45)       W: precipitable water, cm
    T_u = exp(-1.41 a_u M' / (1 + 118.3 a_u M')^0.45)           M' = M p / p0

Band model to layers.  A band (e.g. an HRI filter, ``HRI_FILTERS``: 100 nm boxes) is averaged with the
extraterrestrial spectrum as weight: T_band(M) = sum E T / sum E on the SPCTRAL2 nodes in the band (trapezoid,
edges interpolated).  The effective vertical optical depth is tau = -ln T_band(M_ref) / M_ref at a reference air
mass (default 2: a typical two-way path at the seed case's phase angle), and it is shared among the layers in
proportion to each gas's column in them: ozone by Green's (1964) profile with its maximum at 22 km (the
SPCTRAL2 ozone height) and width 4.35 km, water vapour exponentially with a 2 km scale height, the mixed gases
in proportion to pressure (USSA 1976).  What differs from a line-by-line or correlated-k treatment: the water
and oxygen bands are saturated (their T is not exp(-k u)), so a single tau fitted at M_ref is exact only at
M_ref; at M = 1 and 4 the 950 nm water band transmittance is off by a few per cent (see docs/earth.md).
"""
from __future__ import annotations

import json
import math
import os
from functools import lru_cache
from pathlib import Path

import numpy as np

from .atmosphere import P0, ussa1976

HRI_FILTERS = {c: (c - 50.0, c + 50.0) for c in (350.0, 450.0, 550.0, 650.0, 750.0, 850.0, 950.0)}
DEFAULT_OZONE_ATM_CM = 0.30      # 300 DU
DEFAULT_WATER_CM = 1.42          # US Standard Atmosphere 1976 precipitable water
OZONE_PEAK_KM = 22.0
OZONE_WIDTH_KM = 4.35
WATER_SCALE_KM = 2.0
GAS_FILE = "gas_spectrl2.json"
GAS_VERSION = 1


def _extract_from_pvlib() -> dict:
    try:
        import importlib
        import importlib.metadata as md

        sp = importlib.import_module("pvlib.spectrum.spectrl2")   # the module (pvlib.spectrum.spectrl2 is also a function)
    except ImportError:
        raise ImportError("the gas absorption table comes from the PyPI package pvlib (pip install pvlib)") from None
    c = sp._SPECTRL2_COEFFS
    need = ("wavelength", "spectral_irradiance_et", "water_vapor_absorption", "ozone_absorption", "mixed_absorption")
    if c.dtype.names is None or any(n not in c.dtype.names for n in need) or len(c) != 122:
        raise ImportError(f"pvlib {md.version('pvlib')} holds an unexpected SPCTRAL2 table")
    return {"wavelength_nm": c["wavelength"].tolist(), "et_W_m2_nm": c["spectral_irradiance_et"].tolist(),
            "a_w": c["water_vapor_absorption"].tolist(), "a_o": c["ozone_absorption"].tolist(),
            "a_u": c["mixed_absorption"].tolist(),
            "source": "SPCTRAL2 (Bird and Riordan 1986; coefficients after Leckner 1978), extracted from "
                      f"pvlib {md.version('pvlib')} (pvlib.spectrum.spectrl2._SPECTRL2_COEFFS)",
            "licence": "pvlib: BSD-3-Clause; SPCTRAL2: NREL public report", "proxy": False,
            "data_version": GAS_VERSION, "tier": "default"}


def spectrl2_coefficients(cache_dir=None) -> dict:
    """The SPCTRAL2 table as numpy arrays (cached in the default data tier at first use)."""
    from .data import data_dir

    return dict(_coefficients(str(data_dir(cache_dir) / GAS_FILE)))


@lru_cache(maxsize=4)
def _coefficients(path: str) -> dict:
    from ..io.atomic import atomic_path

    p = Path(path)
    d = None
    if p.exists():
        d = json.loads(p.read_text())
        if d.get("data_version") != GAS_VERSION:
            d = None
    if d is None:
        d = _extract_from_pvlib()
        with atomic_path(p) as tmp:
            tmp.write_text(json.dumps(d, indent=1) + "\n")
            os.chmod(tmp, 0o644)
    return {k: (np.asarray(v, float) if isinstance(v, list) else v) for k, v in d.items()}


def transmittances(wavelength_nm=None, *, airmass: float = 1.0, ozone_atm_cm: float = DEFAULT_OZONE_ATM_CM,
                   water_cm: float = DEFAULT_WATER_CM, pressure_pa: float = P0, ozone_airmass: float | None = None,
                   cache_dir=None) -> dict:
    """T_o, T_w, T_u at the SPCTRAL2 nodes (or interpolated to wavelength_nm) along a path of air mass M."""
    c = spectrl2_coefficients(cache_dir)
    mo = airmass if ozone_airmass is None else ozone_airmass
    aw = c["a_w"] * water_cm * airmass
    au = c["a_u"] * airmass * pressure_pa / 101300.0        # pvlib / spectrl2_2.c pressure reference
    t = {"wavelength_nm": c["wavelength_nm"],
         "ozone": np.exp(-c["a_o"] * ozone_atm_cm * mo),
         "water": np.exp(-0.2385 * aw / (1 + 20.07 * aw) ** 0.45),
         "mixed": np.exp(-1.41 * au / (1 + 118.3 * au) ** 0.45)}
    if wavelength_nm is not None:
        w = np.asarray(wavelength_nm, float)
        t = {k: (np.interp(w, c["wavelength_nm"], v) if k != "wavelength_nm" else w) for k, v in t.items()}
    return t


def _trapezoid(y, x):
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)))


def _band_average(w, y, weight, lo, hi):
    grid = np.concatenate([[lo], w[(w > lo) & (w < hi)], [hi]])
    yy = np.interp(grid, w, y) * np.interp(grid, w, weight)
    ww = np.interp(grid, w, weight)
    return _trapezoid(yy, grid) / _trapezoid(ww, grid)


def band_transmittance(band_nm: tuple, **kw) -> dict:
    """Band-averaged T_o, T_w, T_u (weight: the extraterrestrial spectrum) for a band (lo, hi) in nm."""
    c = spectrl2_coefficients(kw.get("cache_dir"))
    t = transmittances(**kw)
    lo, hi = band_nm
    return {k: _band_average(c["wavelength_nm"], v, c["et_W_m2_nm"], lo, hi)
            for k, v in t.items() if k != "wavelength_nm"}


def ozone_above(z_km, total: float = 1.0) -> np.ndarray:
    """Ozone column above altitude z (Green 1964): total (1 + e^(-b/c)) / (1 + e^((z - b)/c))."""
    z = np.asarray(z_km, float)
    b, c = OZONE_PEAK_KM, OZONE_WIDTH_KM
    return total * (1 + math.exp(-b / c)) / (1 + np.exp((z - b) / c))


def layer_shares(levels_km) -> dict:
    """Share of each gas's column in each layer between consecutive levels (each sums to at most 1)."""
    z = np.asarray(levels_km, float)
    p = np.array([ussa1976(zz * 1e3)[1] for zz in z])
    return {"ozone": -np.diff(ozone_above(z)),
            "water": -np.diff(np.exp(-z / WATER_SCALE_KM)),
            "mixed": -np.diff(p) / P0}


def layer_absorption(levels_km, bands=None, *, ref_airmass: float = 2.0, ozone_atm_cm: float = DEFAULT_OZONE_ATM_CM,
                     water_cm: float = DEFAULT_WATER_CM, cache_dir=None) -> dict:
    """Absorption optical depth per layer and band: {'ozone', 'water', 'mixed', 'total'}, each (n_layers, n_bands).

    bands: a list of (lo, hi) in nm, or of band centres (HRI_FILTERS keys); default the seven HRI bands."""
    if bands is None:
        bands = list(HRI_FILTERS)
    bands = [HRI_FILTERS.get(float(b), (float(b) - 50.0, float(b) + 50.0)) if np.isscalar(b) else tuple(b)
             for b in bands]
    sh = layer_shares(levels_km)
    out = {}
    for gas in ("ozone", "water", "mixed"):
        col = []
        for band in bands:
            t = band_transmittance(band, airmass=ref_airmass, ozone_atm_cm=ozone_atm_cm, water_cm=water_cm,
                                   cache_dir=cache_dir)[gas]
            col.append(-math.log(max(t, 1e-300)) / ref_airmass)
        out[gas] = sh[gas][:, None] * np.asarray(col)[None, :]
    out["total"] = out["ozone"] + out["water"] + out["mixed"]
    return out
