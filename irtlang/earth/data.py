"""The default data tier: global grids built offline from registry packages (no download), cached, labelled.

``MAP name LATLON DEFAULT dataset`` reads these.  They are built at first use (or by
``build_default_tier(cache_dir)``, or ``python -m irtlang.earth.data build``) into
``$IRT_DATA_DIR`` (default ``~/.cache/irtlang/data``), one ``NAME.npy`` per dataset with a JSON sidecar
``NAME.json`` saying its source, licence and whether it is a proxy.  Every grid is 0.5 deg (360 x 720) in the
LATLON convention of ``irtlang.earth.latlon`` (rows from +90 down, columns from -180).

| dataset | values | source | proxy |
|---|---|---|---|
| LAND_MASK | uint8: 0 water, 1 land (land share of the cell >= 1/2) | GLOBE 30" land/sea mask via the PyPI package global-land-mask | no |
| LAND_FRACTION | float32 land share of the cell (Python only) | same | no |
| LANDCOVER | uint8 classes: 0 water, 1-16 IGBP (MCD12C1 Type 1 legend) | latitude belts and hand-drawn regions on the land mask | **yes** |
| SNOW_FRACTION | float32 [0, 1], March | latitude ramp over land set by continentality, ice sheets 1 | **yes** |
| SEA_ICE_FRACTION | float32 [0, 1], March | ice edge by longitude sector, enclosed seas | **yes** |
| CLOUD_FRACTION | float32, 10 levels 0, 1/9 .. 1, total (random overlap of the three layers) | seeded generator, zonal climatology | **yes** |
| CLOUD_LOW, CLOUD_MIDDLE, CLOUD_HIGH | float32, 10 levels, per layer | same | **yes** |
| ELEVATION | not in the default tier: no registry package carries a relief grid | -- | -- |

The proxies are honest stand-ins with the right large-scale geography, not observations; the real tier
(``irtlang.earth.products``) reads the MODIS, AMSR-E and MERRA-2 products from local files instead.
See docs/earth.md for each dataset's construction and the numbers it is checked against.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .latlon import cell_centres, read_sidecar, save_grid

DATA_VERSION = 1             # bump when a builder changes: cached grids of another version are rebuilt
NLAT = 360                   # 0.5 deg
DEFAULT_CLOUD_SEED = 20080318  # the EPOXI EarthObs1 date
CLOUD_LEVELS = 10


class DatasetUnavailable(LookupError):
    """A dataset the default tier cannot provide (unknown, or its source package is missing)."""


def data_dir(cache_dir=None) -> Path:
    """Where the default tier lives: cache_dir, else $IRT_DATA_DIR, else ~/.cache/irtlang/data."""
    if cache_dir is not None:
        return Path(cache_dir)
    env = os.environ.get("IRT_DATA_DIR")
    if env:
        return Path(env).expanduser()
    return Path.home() / ".cache" / "irtlang" / "data"


def _versions(*pkgs) -> dict:
    import importlib.metadata as md

    out = {}
    for p in pkgs:
        try:
            out[p] = md.version(p)
        except md.PackageNotFoundError:
            out[p] = None
    return out


# ============================================================================ land mask (GLOBE)
GLOBE_SOURCE = ("GLOBE 30-arc-second land/sea mask (NOAA NGDC GLOBE Task Team, 1999; cells GLOBE marks as ocean "
                "are water, lakes count as land), from the PyPI package global-land-mask 1.0 (T. Karin), "
                "block-averaged to 0.5 deg")
GLOBE_LICENCE = "global-land-mask: MIT; GLOBE data: NOAA/NGDC, U.S. Government work, public domain"


def land_fraction_from_globe(nlat: int = NLAT) -> np.ndarray:
    """Share of land in each cell of an nlat x 2 nlat grid, from the 21600 x 43200 GLOBE mask (float32)."""
    from importlib import resources

    try:
        res = resources.files("global_land_mask").joinpath("globe_combined_mask_compressed.npz")
    except ModuleNotFoundError:
        raise DatasetUnavailable("the land mask needs the PyPI package global-land-mask "
                                 "(pip install global-land-mask)") from None
    with resources.as_file(res) as p, np.load(p) as z:
        lat, lon = z["lat"], z["lon"]
        ocean = z["mask"]                       # True = ocean; rows from +90 down, columns from -180
    n, m = ocean.shape
    if not (m == 2 * n and lat[0] > lat[-1] and lon[0] < lon[-1] and abs(lat[0] - 90) < 1e-6
            and abs(lon[0] + 180) < 1e-6):
        raise DatasetUnavailable(f"global-land-mask holds an unexpected grid {ocean.shape}")
    if n % nlat:
        raise ValueError(f"{nlat} rows do not divide the GLOBE grid of {n} rows")
    k = n // nlat
    out = np.empty((nlat, 2 * nlat), np.float32)
    for r in range(nlat):
        blk = ocean[r * k:(r + 1) * k]
        out[r] = 1.0 - blk.reshape(k, 2 * nlat, k).sum(axis=(0, 2), dtype=np.int64) / (k * k)
    return out


def continentality(land_frac: np.ndarray, sigma_deg: float = 5.0) -> np.ndarray:
    """Land share smoothed over about sigma_deg (Gaussian; periodic in longitude): 0 open ocean .. 1 interior."""
    from scipy.ndimage import gaussian_filter

    s = sigma_deg * land_frac.shape[0] / 180.0
    return gaussian_filter(land_frac.astype(np.float64), sigma=(s, s), mode=("nearest", "wrap"))


# ============================================================================ land cover proxy
IGBP_CLASSES = ("water", "evergreen needleleaf forest", "evergreen broadleaf forest",
                "deciduous needleleaf forest", "deciduous broadleaf forest", "mixed forests", "closed shrublands",
                "open shrublands", "woody savannas", "savannas", "grasslands", "permanent wetlands", "croplands",
                "urban and built-up", "cropland/natural vegetation mosaic", "snow and ice",
                "barren or sparsely vegetated")
(WATER, ENF, EBF, DNF, DBF, MF, CSH, OSH, WSAV, SAV, GRA, WET, CRO, URB, MOS, SNOW, BAR) = range(17)

# Base classes by latitude belt over land, (lat_min, lat_max, class).
_BELTS = [(-90, -60, SNOW), (-60, -50, OSH), (-50, -35, GRA), (-35, -20, SAV), (-20, -10, WSAV), (-10, 10, EBF),
          (10, 20, SAV), (20, 35, OSH), (35, 50, GRA), (50, 60, MF), (60, 68, ENF), (68, 75, OSH), (75, 90, BAR)]

# Regions that override the belts, applied in order (later wins): (class, lat_min, lat_max, lon_min, lon_max).
# Drawn by hand from the large-scale geography of the MODIS IGBP map; boxes, not coastlines (the land mask
# gives the coastlines).
_REGIONS = [
    # ---- Africa
    (GRA, 13, 17, -17, 40), (SAV, 8, 13, -17, 35), (WSAV, 6, 9, -13, 12), (EBF, 3, 6, -10, 10),
    (BAR, 16, 31, -17, 34), (BAR, 20, 30, 30, 35),                                   # Sahara
    (SAV, -12, 6, 33, 42), (OSH, 2, 12, 40, 52), (MOS, 6, 14, 35, 40),                # East Africa, Horn
    (EBF, -6, 5, 9, 30), (WSAV, -18, -6, 12, 40), (OSH, -28, -18, 17, 26), (BAR, -28, -17, 11, 16),
    (OSH, -33, -28, 17, 26), (GRA, -31, -24, 26, 32), (WSAV, -26, -12, 43, 50), (EBF, -25, -13, 48.5, 51),
    # ---- Arabia, Iran, Central Asia, Tibet, Mongolia, China
    (BAR, 14, 32, 36, 58), (OSH, 25, 38, 44, 70), (BAR, 28, 34, 53, 62), (OSH, 24, 29, 69, 73),
    (GRA, 36, 42, 26, 46), (GRA, 45, 53, 48, 86), (OSH, 36, 45, 46, 80), (BAR, 39, 43.5, 55, 65),
    (BAR, 36.5, 41.5, 77, 90), (GRA, 28, 38, 78, 100), (BAR, 32, 37, 78, 88),
    (GRA, 42, 52, 88, 120), (BAR, 40.5, 45, 97, 111),
    (CRO, 32, 40, 110, 122), (MOS, 20, 32, 100, 122), (CRO, 40, 48, 120, 130), (MF, 45, 53, 125, 135),
    (MF, 33, 46, 125, 146),                                                             # Korea, Japan
    # ---- South and Southeast Asia
    (CRO, 8, 30, 68, 90), (OSH, 24, 29, 69, 73), (MOS, 8, 22, 95, 110), (EBF, -11, 8, 95, 155),
    # ---- Siberia, Russia, Europe
    (ENF, 55, 68, 60, 100), (DNF, 52, 70, 100, 170), (MF, 50, 60, 25, 60), (CRO, 44, 52, 28, 60),
    (CRO, 43, 56, -10, 30), (MOS, 36, 44, -10, 30), (ENF, 58, 68, 5, 32), (OSH, 63, 67, -25, -13),
    # ---- North America
    (SNOW, 59.5, 84, -73, -11),                                                          # Greenland
    (OSH, 62, 75, -170, -60), (ENF, 50, 62, -130, -55), (CRO, 49, 55, -115, -97), (ENF, 40, 60, -128, -115),
    (GRA, 30, 50, -105, -95), (CRO, 36, 48, -98, -82), (MF, 25, 36, -95, -75), (DBF, 36, 44, -90, -60),
    (MF, 44, 50, -90, -60), (OSH, 31, 42, -121, -103), (OSH, 20, 33, -118, -98), (MOS, 7, 20, -106, -77),
    # ---- South America
    (SAV, 4, 10, -72, -62), (BAR, -18, -4, -81.5, -75.5), (BAR, -28, -18, -72, -68.5), (OSH, -23, -15, -69, -65),
    (SAV, -20, -5, -56, -42), (WSAV, -12, -3, -45, -35), (WSAV, -28, -20, -64, -58), (MOS, -34, -20, -58, -44),
    (CRO, -39, -30, -64, -56), (OSH, -56, -38, -76, -63),
    # ---- Australia, New Zealand
    (SAV, -19, -11, 120, 146), (OSH, -32, -19, 115, 142), (BAR, -27, -22, 124, 134), (WSAV, -38, -15, 145, 154),
    (CRO, -39, -32, 138, 150), (CSH, -35, -30, 115, 120), (GRA, -47, -34, 166, 179),
]


def landcover_proxy(land_frac: np.ndarray) -> np.ndarray:
    """IGBP class per cell (uint8; 0 where the land share is below 1/2): a proxy, see the module docstring."""
    nlat = land_frac.shape[0]
    lat, lon = cell_centres(nlat)
    LA, LO = np.meshgrid(lat, lon, indexing="ij")
    land = land_frac >= 0.5
    cls = np.zeros(land_frac.shape, np.uint8)
    for lo, hi, c in _BELTS:
        cls[(LA >= lo) & (LA < hi)] = c
    for c, la0, la1, lo0, lo1 in _REGIONS:
        cls[(LA >= la0) & (LA < la1) & (LO >= lo0) & (LO < lo1)] = c
    cls[~land] = WATER
    return cls


# ============================================================================ snow and sea ice (March)
# regions whose winters are milder than their continentality says (the North Atlantic and North Pacific drift):
# the snow line moves north by the given degrees, (shift, lat_min, lat_max, lon_min, lon_max)
_MILD = [(7.0, 35, 72, -12, 30), (4.0, 40, 62, -135, -120)]


def snow_fraction_proxy(landcover: np.ndarray, cont: np.ndarray) -> np.ndarray:
    """March snow cover over land: 1 on ice sheets; in the north a ramp over 10 deg of latitude from
    lat0 = 53 - 14 c (c the continentality: the snow line reaches 39 N in continental interiors and 50 N on
    oceanic coasts), moved north in the mild regions of _MILD (Europe west of 30 E, the Pacific Northwest);
    none elsewhere in the south (the end of the austral summer)."""
    lat, lon = cell_centres(landcover.shape[0])
    LA, LO = np.meshgrid(lat, lon, indexing="ij")
    lat0 = 53.0 - 14.0 * cont
    for d, la0, la1, lo0, lo1 in _MILD:
        lat0 = lat0 + d * ((LA >= la0) & (LA < la1) & (LO >= lo0) & (LO < lo1))
    f = np.clip((LA - lat0) / 10.0, 0.0, 1.0)
    f[LA < 0] = 0.0
    f[landcover == SNOW] = 1.0
    f[landcover == WATER] = 0.0
    return f.astype(np.float32)


# ice edge latitude (March) by longitude, northern hemisphere: (lon, lat of the 50 % point)
_NH_EDGE = [(-180, 61), (-170, 60.5), (-163, 59.5), (-155, 64.5), (-150, 69.5), (-140, 70), (-120, 66.5),
            (-95, 60.5), (-75, 58.5), (-62, 55.5), (-56, 62.5), (-50, 67), (-45, 61.5), (-40, 64.5), (-30, 68),
            (-20, 72.5), (-10, 76.5), (0, 79), (10, 80.5), (20, 78), (30, 76.5), (40, 74.5), (50, 71), (60, 69.5),
            (70, 66.5), (140, 66.5), (160, 62.5), (170, 61.5), (180, 61)]
# southern hemisphere: (lon, lat of the 50 % point)
_SH_EDGE = [(-180, -75.3), (-150, -75.3), (-130, -73.8), (-100, -72.8), (-70, -70.3), (-60, -66.3), (-40, -66.8),
            (-20, -68.8), (0, -70.8), (40, -69.8), (80, -67.8), (110, -67.8), (150, -68.8), (165, -73.3),
            (180, -75.3)]
# enclosed seas, (concentration, lat_min, lat_max, lon_min, lon_max)
_SEAS = [(0.95, 51, 64.5, -95, -76.5),     # Hudson Bay
         (0.9, 60, 66.5, 16.5, 30.5),      # Gulf of Bothnia, Gulf of Finland
         (0.85, 44, 60, 135, 157),         # Sea of Okhotsk
         (0.7, 45.5, 51, -70, -57),        # Gulf of St. Lawrence
         (0.5, 44, 47.5, 46, 54),          # northern Caspian
         (0.4, 37, 41, 117.5, 122)]        # Bohai


def sea_ice_fraction_proxy(landcover: np.ndarray, nh_max: float = 0.95, sh_max: float = 0.75,
                           width_deg: float = 3.0) -> np.ndarray:
    """March sea-ice concentration over water: a ramp of width_deg across an ice edge interpolated in
    longitude (_NH_EDGE, _SH_EDGE), the interior at nh_max / sh_max; enclosed seas set apart (_SEAS)."""
    lat, lon = cell_centres(landcover.shape[0])
    LA, LO = np.meshgrid(lat, lon, indexing="ij")
    e_n = np.interp(lon, *zip(*_NH_EDGE))[None, :]
    e_s = np.interp(lon, *zip(*_SH_EDGE))[None, :]
    f = np.where(LA > 0, nh_max * np.clip(0.5 + (LA - e_n) / width_deg, 0, 1),
                 sh_max * np.clip(0.5 + (e_s - LA) / width_deg, 0, 1))
    for c, la0, la1, lo0, lo1 in _SEAS:
        f[(LA >= la0) & (LA < la1) & (LO >= lo0) & (LO < lo1)] = c
    f[landcover != WATER] = 0.0
    return f.astype(np.float32)


# ============================================================================ clouds
# Zonal climatology of each layer's own coverage (what an observer below it would see, not the top-down view),
# nodes every 15 deg from -90: low (cloud top below ~680 hPa), middle (440-680 hPa), high (above 440 hPa).
# Shaped after the ISCCP / CALIPSO zonal means: the ITCZ near the equator, dry subtropics, storm tracks near
# 55-60 deg (the southern one cloudier), subtropical stratocumulus over the oceans; land less cloudy.
CLOUD_LAT_NODES = np.arange(-90.0, 90.1, 15.0)
CLOUD_CLIMATOLOGY = {
    ("low", "ocean"):    [0.32, 0.48, 0.70, 0.63, 0.51, 0.45, 0.35, 0.41, 0.51, 0.58, 0.62, 0.47, 0.42],
    ("low", "land"):     [0.20, 0.30, 0.45, 0.40, 0.22, 0.22, 0.28, 0.15, 0.15, 0.30, 0.40, 0.40, 0.35],
    ("middle", "ocean"): [0.25, 0.30, 0.38, 0.32, 0.16, 0.13, 0.18, 0.13, 0.16, 0.30, 0.36, 0.30, 0.25],
    ("middle", "land"):  [0.20, 0.25, 0.30, 0.26, 0.13, 0.16, 0.24, 0.10, 0.15, 0.26, 0.32, 0.30, 0.25],
    ("high", "ocean"):   [0.15, 0.20, 0.30, 0.26, 0.16, 0.23, 0.36, 0.26, 0.16, 0.25, 0.26, 0.20, 0.15],
    ("high", "land"):    [0.15, 0.20, 0.30, 0.25, 0.12, 0.32, 0.42, 0.18, 0.15, 0.26, 0.26, 0.20, 0.15],
}
CLOUD_CORRELATION_KM = {"low": 400.0, "middle": 600.0, "high": 800.0}
CLOUD_SPREAD = 1.5     # s: a cell's fraction is Phi(mu + s z), z a unit Gaussian random field
EARTH_RADIUS_KM = 6371.0


def cloud_climatology(layer: str, land_frac: np.ndarray) -> np.ndarray:
    """Expected coverage of one layer per cell: the land and ocean zonal profiles mixed by the land share."""
    lat, _ = cell_centres(land_frac.shape[0])
    oc = np.interp(lat, CLOUD_LAT_NODES, CLOUD_CLIMATOLOGY[(layer, "ocean")])[:, None]
    la = np.interp(lat, CLOUD_LAT_NODES, CLOUD_CLIMATOLOGY[(layer, "land")])[:, None]
    return oc + (la - oc) * land_frac


def gaussian_random_field(nlat: int, corr_km: float, rng: np.random.Generator, modes: int = 512) -> np.ndarray:
    """A unit-variance, isotropic Gaussian random field on the sphere, on the cell centres of an nlat grid.

    Random Fourier features in 3-D: z(x) = sqrt(2/M) sum_m cos(k_m . x + phi_m), k_m ~ N(0, I / l^2), phi_m
    uniform, x the point on the sphere of radius 6371 km.  Its covariance is exp(-|x - y|^2 / (2 l^2)), |x - y|
    the chord: isotropic on the sphere, correlation exp(-1/2) at a chord of l.  Gaussian by the central limit
    theorem (M = 512 terms: excess kurtosis -1.5/M).  The phases are formed in float64 and their cosines taken in
    float32 (4x faster; the field then agrees with a float64 evaluation to about 1e-4)."""
    lat, lon = cell_centres(nlat)
    la = np.radians(lat)[:, None]
    lo = np.radians(lon)[None, :]
    xyz = np.stack([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la) * np.ones_like(lo)], -1)
    xyz = (xyz * EARTH_RADIUS_KM).reshape(-1, 3)
    k = rng.standard_normal((modes, 3)) / corr_km
    ph = rng.uniform(0.0, 2.0 * math.pi, modes)
    z = np.zeros(xyz.shape[0])
    for s in range(0, modes, 128):
        arg = (xyz @ k[s:s + 128].T + ph[s:s + 128]).astype(np.float32)
        z += np.cos(arg).sum(axis=1, dtype=np.float64)
    return (z * math.sqrt(2.0 / modes)).reshape(nlat, 2 * nlat)


def quantize(f: np.ndarray, levels: int = CLOUD_LEVELS) -> np.ndarray:
    """Levels as in the paper's fraction maps: `levels` evenly spaced values from 0 (clear) to 1 (overcast),
    k / (levels - 1), each cell rounded to the nearest (rounding to bin centres instead would bias the
    U-shaped distribution of cell fractions by +0.015 for a layer of 20 % mean cover)."""
    n = levels - 1
    return (np.round(np.clip(f, 0.0, 1.0) * n) / n).astype(np.float32)


def cloud_fraction_maps(land_frac: np.ndarray, seed: int = DEFAULT_CLOUD_SEED, levels: int | None = CLOUD_LEVELS,
                        spread: float = CLOUD_SPREAD) -> dict:
    """Seeded cloud cover: {'low', 'middle', 'high', 'total'} grids (float32, quantized to `levels` unless None).

    Each layer: c = Phi(mu + s z), z a Gaussian random field (gaussian_random_field; correlation length
    CLOUD_CORRELATION_KM) with its mean along each latitude row removed -- the climatology sets the zonal means,
    the field only the weather along them -- and mu = sqrt(1 + s^2 v) Phi^-1(f), v the variance of z along the
    row and f the climatology (cloud_climatology): then E Phi(mu + s z) = Phi(mu / sqrt(1 + s^2 v)) = f, each
    cell's expected coverage is its climatology.  The layers are independent, so the total is their random
    overlap 1 - (1 - l)(1 - m)(1 - h), computed before quantizing.  The same seed gives the same maps (numpy's
    PCG64 stream)."""
    from scipy.special import ndtr, ndtri

    rng = np.random.Generator(np.random.PCG64(seed))
    nlat = land_frac.shape[0]
    out = {}
    for layer in ("low", "middle", "high"):
        f = np.clip(cloud_climatology(layer, land_frac), 1e-4, 1 - 1e-4)
        z = gaussian_random_field(nlat, CLOUD_CORRELATION_KM[layer], rng)
        z -= z.mean(axis=1, keepdims=True)
        v = z.var(axis=1, keepdims=True)
        out[layer] = ndtr(np.sqrt(1 + spread ** 2 * v) * ndtri(f) + spread * z)
    out["total"] = 1.0 - (1.0 - out["low"]) * (1.0 - out["middle"]) * (1.0 - out["high"])
    if levels:
        return {k: quantize(v, levels) for k, v in out.items()}
    return {k: v.astype(np.float32) for k, v in out.items()}


# ============================================================================ the registry
@dataclass(frozen=True)
class Dataset:
    name: str
    description: str
    units: str
    source: str
    licence: str
    proxy: bool
    needs: tuple              # datasets it is derived from
    build: Callable           # (inputs: dict name -> array, params) -> array
    params: tuple = ()        # the build parameters it depends on (recorded in the sidecar)


def _b_land_fraction(inp, prm):
    return land_fraction_from_globe(NLAT)


def _b_land_mask(inp, prm):
    return (inp["LAND_FRACTION"] >= 0.5).astype(np.uint8)


def _b_landcover(inp, prm):
    return landcover_proxy(inp["LAND_FRACTION"])


def _b_snow(inp, prm):
    return snow_fraction_proxy(inp["LANDCOVER"], continentality(inp["LAND_FRACTION"]))


def _b_sea_ice(inp, prm):
    return sea_ice_fraction_proxy(inp["LANDCOVER"])


def _b_aerosol(inp, prm):
    from .aerosols import aerosol_type_map

    return aerosol_type_map(inp["LANDCOVER"])


def _cloud_builder(key):
    def b(inp, prm):
        return cloud_fraction_maps(inp["LAND_FRACTION"], seed=prm["cloud_seed"])[key]
    return b


_PROXY_LICENCE = "irtlang (BSD-3-Clause); derived from LAND_FRACTION (" + GLOBE_LICENCE + ")"
_CLOUD_SRC = ("seeded synthetic cloud field (irtlang.earth.data.cloud_fraction_maps): zonal land/ocean "
              "climatology of layer coverage shaped after ISCCP/CALIPSO, Gaussian random fields (correlation "
              "400/600/800 km low/middle/high), random overlap, 10 levels")

DATASETS: dict[str, Dataset] = {d.name: d for d in [
    Dataset("LAND_FRACTION", "land share of each 0.5 deg cell", "1", GLOBE_SOURCE, GLOBE_LICENCE, False, (),
            _b_land_fraction),
    Dataset("LAND_MASK", "0 water, 1 land (land share >= 1/2)", "class", GLOBE_SOURCE, GLOBE_LICENCE, False,
            ("LAND_FRACTION",), _b_land_mask),
    Dataset("LANDCOVER", "IGBP land cover classes: 0 water, 1-16 as MCD12C1 Land_Cover_Type_1", "class",
            "PROXY built by irtlang.earth.data.landcover_proxy: latitude belts and hand-drawn regions after the "
            "large-scale geography of the MODIS IGBP map, on the GLOBE land mask", _PROXY_LICENCE, True,
            ("LAND_FRACTION",), _b_landcover),
    Dataset("SNOW_FRACTION", "March snow cover fraction over land", "1",
            "PROXY built by irtlang.earth.data.snow_fraction_proxy: ice sheets 1, northern latitude ramp set by "
            "continentality", _PROXY_LICENCE, True, ("LAND_FRACTION", "LANDCOVER"), _b_snow),
    Dataset("SEA_ICE_FRACTION", "March sea-ice concentration over water", "1",
            "PROXY built by irtlang.earth.data.sea_ice_fraction_proxy: ice edge by longitude sector and enclosed "
            "seas, after the NSIDC March climatology", _PROXY_LICENCE, True, ("LANDCOVER",), _b_sea_ice),
    Dataset("CLOUD_FRACTION", "total cloud fraction (random overlap of the three layers), 10 levels", "1",
            _CLOUD_SRC, _PROXY_LICENCE, True, ("LAND_FRACTION",), _cloud_builder("total"), ("cloud_seed",)),
    Dataset("CLOUD_LOW", "low-cloud coverage (tops below ~680 hPa), 10 levels", "1", _CLOUD_SRC, _PROXY_LICENCE,
            True, ("LAND_FRACTION",), _cloud_builder("low"), ("cloud_seed",)),
    Dataset("CLOUD_MIDDLE", "middle-cloud coverage (440-680 hPa), 10 levels", "1", _CLOUD_SRC, _PROXY_LICENCE,
            True, ("LAND_FRACTION",), _cloud_builder("middle"), ("cloud_seed",)),
    Dataset("CLOUD_HIGH", "high-cloud coverage (tops above 440 hPa), 10 levels", "1", _CLOUD_SRC, _PROXY_LICENCE,
            True, ("LAND_FRACTION",), _cloud_builder("high"), ("cloud_seed",)),
    Dataset("AEROSOL_TYPE", "aerosol type per cell, classes 0-4 as irtlang.earth.aerosols.EARTH_TYPES: maritime "
            "clean, continental average, desert, urban, arctic", "class",
            "PROXY built by irtlang.earth.aerosols.aerosol_type_map from LANDCOVER: water maritime, barren desert, "
            "other land continental, poleward of 60 deg arctic", _PROXY_LICENCE, True, ("LANDCOVER",), _b_aerosol),
]}

UNAVAILABLE = {
    "ELEVATION": "no package on the registries carries a global relief grid, so the default tier has no "
                 "ELEVATION; give one as a file: MAP name LATLON 'elevation.npy' (metres, LATLON convention)",
}


def _params(d: Dataset, cloud_seed: int) -> dict:
    allp = {"cloud_seed": int(cloud_seed)}
    return {k: allp[k] for k in d.params}


def dataset_path(name: str, cache_dir=None) -> Path:
    return data_dir(cache_dir) / f"{name.upper()}.npy"


def _is_current(name: str, cache_dir, prm) -> bool:
    p = dataset_path(name, cache_dir)
    if not p.exists():
        return False
    info = read_sidecar(p)
    return info.get("data_version") == DATA_VERSION and info.get("parameters") == prm


def _check_name(name: str) -> str:
    n = name.upper()
    if n in UNAVAILABLE:
        raise DatasetUnavailable(UNAVAILABLE[n])
    if n not in DATASETS:
        raise DatasetUnavailable(f"unknown dataset {name!r}; the default tier has: {', '.join(DATASETS)}")
    return n


def ensure(name: str, cache_dir=None, *, force: bool = False, cloud_seed: int = DEFAULT_CLOUD_SEED,
           _built: dict | None = None) -> Path:
    """The path of a dataset, building it (and what it derives from) if it is missing or stale."""
    n = _check_name(name)
    d = DATASETS[n]
    prm = _params(d, cloud_seed)
    p = dataset_path(n, cache_dir)
    if _built is not None and n in _built:
        return p
    if not force and _is_current(n, cache_dir, prm):
        return p
    built = {} if _built is None else _built
    inputs = {}
    for dep in d.needs:
        if dep not in built:
            ensure(dep, cache_dir, force=force, cloud_seed=cloud_seed, _built=built)
        inputs[dep] = np.load(dataset_path(dep, cache_dir), allow_pickle=False)
    arr = d.build(inputs, prm)
    meta = {"dataset": n, "description": d.description, "units": d.units, "source": d.source,
            "licence": d.licence, "proxy": d.proxy, "derived_from": list(d.needs), "data_version": DATA_VERSION,
            "parameters": prm, "tier": "default",
            "built_with": {"irtlang": _irt_version(), **_versions("numpy", "scipy", "global-land-mask")}}
    save_grid(p, arr, meta)
    built[n] = True
    return p


def _irt_version() -> str:
    from .. import _version

    return _version.__version__


def build_default_tier(cache_dir=None, names=None, *, force: bool = False,
                       cloud_seed: int = DEFAULT_CLOUD_SEED) -> dict:
    """Build (or refresh) the default tier into cache_dir; returns {name: path}.  Nothing is downloaded."""
    built: dict = {}
    return {n: ensure(n, cache_dir, force=force, cloud_seed=cloud_seed, _built=built)
            for n in (names or DATASETS)}


def load_dataset(name: str, cache_dir=None) -> np.ndarray:
    """The grid of a default-tier dataset (built at first use)."""
    return np.load(ensure(name, cache_dir), allow_pickle=False)


def dataset_info(name: str, cache_dir=None) -> dict:
    """The sidecar of a default-tier dataset: source, licence, proxy, ..."""
    return json.loads(ensure(name, cache_dir).with_suffix(".json").read_text())


def export_dataset(name: str, path, cache_dir=None) -> Path:
    """Copy a dataset (and its sidecar) to path (.npy), e.g. next to a script that names it as a file."""
    p = ensure(name, cache_dir)
    save_grid(Path(path), np.load(p, allow_pickle=False), json.loads(p.with_suffix(".json").read_text()))
    return Path(path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m irtlang.earth.data",
                                 description="Build or list irtlang's default Earth data tier (offline).")
    sub = ap.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("build", help="build every dataset (or the named ones) into the cache")
    b.add_argument("names", nargs="*")
    b.add_argument("--dir", default=None, help="cache folder (default $IRT_DATA_DIR or ~/.cache/irtlang/data)")
    b.add_argument("--force", action="store_true")
    b.add_argument("--cloud-seed", type=int, default=DEFAULT_CLOUD_SEED)
    ls = sub.add_parser("list", help="list the datasets and their labels")
    ls.add_argument("--dir", default=None)
    a = ap.parse_args(argv)
    if a.cmd == "build":
        paths = build_default_tier(a.dir, a.names or None, force=a.force, cloud_seed=a.cloud_seed)
        for n, p in paths.items():
            print(f"{n:17s} {p}")
        return 0
    for n, d in DATASETS.items():
        print(f"{n:17s} {'PROXY' if d.proxy else 'data '}  {d.description}")
    for n, why in UNAVAILABLE.items():
        print(f"{n:17s} n/a    {why}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
