"""The real data tier: loaders for the original Earth-observation products, from local files (never downloaded).

Each loader returns a ``LatLonGrid`` (irtlang.earth.latlon) in irtlang's LATLON convention (rows from +90
down, columns from -180), labelled with the file it came from; ``grid.save('x.npy')`` writes the file that
``MAP name LATLON 'x.npy'`` reads.  A missing file, a file without the product's dataset, or a dataset on the
wrong grid raises ``ProductError`` (a ``ValueError``) or ``FileNotFoundError`` that says which.

| loader | product | dataset(s) read | grid |
|---|---|---|---|
| read_mcd43c1 | MODIS MCD43C1 (v006/v061) BRDF/albedo model parameters, 0.05 deg CMG | BRDF_Albedo_Parameter{1,2,3}_Band{b} (iso, vol, geo; int16, scale 0.001, fill 32767) | 3600 x 7200 |
| read_mcd12c1 | MODIS MCD12C1 land cover, 0.05 deg CMG | Majority_Land_Cover_Type_1 (uint8 IGBP 0-16, fill 255) | 3600 x 7200 |
| read_mod10cm | MODIS/Terra MOD10CM monthly snow cover, 0.05 deg CMG | Snow_Cover_Monthly_CMG (uint8 percent 0-100; 211 night, 250 cloud, 254 water, 255 fill) | 3600 x 7200 |
| read_amsre_seaice | AMSR-E AE_SI12 daily sea ice, 12.5 km NSIDC polar stereographic | SI_12km_NH_ICECON_DAY (896 x 608), SI_12km_SH_ICECON_DAY (664 x 632) (percent 0-100; 110 missing, 120 land) | reprojected |
| read_merra2 | MERRA-2 monthly means, e.g. M2TMNXRAD (CLDTOT, CLDLOW, CLDMID, CLDHGH) or M2TMNXSLV (TQL, TQI) | any (time, lat, lon) variable | 361 x 576 (0.5 x 0.625 deg), regridded |

File formats.  The MODIS and AMSR-E products are HDF4-EOS: they are read with ``pyhdf`` when it is installed
(``pip install pyhdf``, the optional extra ``irtlang[hdf4]``).  Without it, convert them to HDF5 or netCDF4 first
(e.g. ``h4toh5 MCD43C1.hdf``, or ``gdal_translate -of netCDF HDF4_EOS:EOS_GRID:"file.hdf":grid:dataset out.nc``);
the converted file is read with h5py and the dataset found by its name anywhere in the file (a converter may
put it under ``/MOD_Grid_BRDF/Data Fields/``).  MERRA-2 files are netCDF4 (HDF5) and are read with h5py;
classic netCDF-3 files are read with scipy.  Attributes ``scale_factor``, ``add_offset`` and ``_FillValue`` are
applied where the file has them (MODIS convention: value = scale_factor (stored - add_offset)), else the
product's documented defaults.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .latlon import LatLonGrid, block_mean, block_mode, cell_centres, regrid_nearest

CMG_SHAPE = (3600, 7200)


class ProductError(ValueError):
    """A product file that is not what its loader reads (no such dataset, wrong grid, wrong values)."""


# ============================================================================ reading datasets
HDF4_MAGIC = b"\x0e\x03\x13\x01"
HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"


def _format(path: Path) -> str:
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file")
    with open(path, "rb") as f:
        head = f.read(4096)
    if head.startswith(HDF4_MAGIC):
        return "hdf4"
    for off in (0, 512, 1024, 2048):
        if head[off:off + 8] == HDF5_MAGIC:
            return "hdf5"
    if head[:3] == b"CDF":
        return "netcdf3"
    raise ProductError(f"{path.name}: not an HDF4, HDF5/netCDF4 or netCDF-3 file")


def list_datasets(path) -> list:
    """The names of the arrays in a product file (HDF4 SDS, HDF5 datasets with their group path, netCDF vars)."""
    path = Path(path)
    fmt = _format(path)
    if fmt == "hdf4":
        SD, SDC = _pyhdf(path)
        f = SD(str(path), SDC.READ)
        try:
            return sorted(f.datasets())
        finally:
            f.end()
    if fmt == "netcdf3":
        from scipy.io import netcdf_file

        with netcdf_file(str(path), "r", mmap=False) as f:
            return sorted(f.variables)
    import h5py

    out = []
    with h5py.File(path, "r") as f:
        f.visititems(lambda n, o: out.append(n) if isinstance(o, h5py.Dataset) else None)
    return sorted(out)


def _pyhdf(path):
    try:
        from pyhdf.SD import SD, SDC
    except ImportError:
        raise ProductError(f"{path.name} is HDF4: install pyhdf (pip install pyhdf) or convert the file to HDF5 / "
                           "netCDF4 (h4toh5, or gdal_translate -of netCDF)") from None
    return SD, SDC


def _attr(v):
    if isinstance(v, bytes):
        return v.decode("latin-1")
    a = np.asarray(v)
    if a.dtype.kind in "SU":
        return str(a.ravel()[0]) if a.size else ""
    return a.ravel()[0].item() if a.size == 1 else a


def read_dataset(path, name: str) -> tuple[np.ndarray, dict]:
    """(raw array, attributes) of the dataset `name` (matched on its last path component, case-insensitive)."""
    path = Path(path)
    fmt = _format(path)
    want = name.lower()
    if fmt == "hdf4":
        SD, SDC = _pyhdf(path)
        f = SD(str(path), SDC.READ)
        try:
            names = {n.lower(): n for n in f.datasets()}
            if want not in names:
                raise ProductError(f"{path.name} has no dataset {name!r}; it holds: {', '.join(sorted(names.values()))}")
            s = f.select(names[want])
            arr = np.asarray(s.get())
            attrs = {k: _attr(v) for k, v in s.attributes().items()}
            s.endaccess()
            return arr, attrs
        finally:
            f.end()
    if fmt == "netcdf3":
        from scipy.io import netcdf_file

        with netcdf_file(str(path), "r", mmap=False) as f:
            names = {n.lower(): n for n in f.variables}
            if want not in names:
                raise ProductError(f"{path.name} has no variable {name!r}; it holds: {', '.join(sorted(f.variables))}")
            v = f.variables[names[want]]
            return np.array(v[:]), {k: _attr(a) for k, a in v._attributes.items()}
    import h5py

    with h5py.File(path, "r") as f:
        found = []
        f.visititems(lambda n, o: found.append(n) if isinstance(o, h5py.Dataset) and
                     n.rsplit("/", 1)[-1].lower() == want else None)
        if not found:
            alln = []
            f.visititems(lambda n, o: alln.append(n) if isinstance(o, h5py.Dataset) else None)
            raise ProductError(f"{path.name} has no dataset {name!r}; it holds: {', '.join(sorted(alln))}")
        d = f[sorted(found, key=len)[0]]
        return d[()], {k: _attr(v) for k, v in d.attrs.items()}


def _scaled(arr: np.ndarray, attrs: dict, *, fill=None, scale=None, offset=0.0, valid=None) -> np.ndarray:
    """Physical values (float64, NaN where fill or out of the valid range): scale (stored - offset)."""
    a = arr.astype(np.float64)
    fill = attrs.get("_FillValue", fill)
    bad = np.zeros(a.shape, bool)
    if fill is not None:
        bad |= arr == fill
    vr = attrs.get("valid_range", valid)
    if vr is not None and np.size(vr) == 2:
        bad |= (arr < vr[0]) | (arr > vr[1])
    sf = attrs.get("scale_factor", scale)
    off = attrs.get("add_offset", offset)
    if sf is not None:
        a = float(sf) * (a - float(off or 0.0))
    a[bad] = np.nan
    return a


def _check_cmg(path: Path, name: str, arr: np.ndarray) -> np.ndarray:
    if arr.ndim == 3 and arr.shape[0] == 1:
        arr = arr[0]
    if arr.shape != CMG_SHAPE:
        raise ProductError(f"{path.name}: dataset {name} has shape {arr.shape}, not the 0.05 deg climate-modelling "
                           f"grid {CMG_SHAPE} (rows from 90 N, columns from 180 W)")
    return arr


def _meta(path: Path, product: str, dataset, **kw) -> dict:
    return {"tier": "real", "product": product, "file": str(path), "dataset_read": dataset, "proxy": False,
            "licence": "NASA EOSDIS data: no restrictions on use (cite the product)", **kw}


def _resample(a: np.ndarray, nlat: int | None, classes: int | None = None) -> np.ndarray:
    """From the product's own grid to nlat rows: block mean (fractions) or block mode (classes) when nlat divides
    it, else nearest cell."""
    if nlat is None or nlat == a.shape[0]:
        return a
    k = a.shape[0] // nlat
    if a.shape[0] % nlat == 0:
        if classes is not None:
            return block_mode(a, k, classes)
        return block_mean(a, k)
    return regrid_nearest(a, nlat)


# ============================================================================ MODIS
MCD43_BANDS = {1: 645, 2: 858.5, 3: 469, 4: 555, 5: 1240, 6: 1640, 7: 2130}     # nm, band centres


def read_mcd43c1(path, band, nlat: int | None = None) -> dict:
    """MCD43C1 kernel weights of one band (1-7, or 'vis', 'nir', 'shortwave'): {'iso', 'vol', 'geo'} grids.

    Fill values (no retrieval) are NaN; a grid meant for a MAP must be filled first (``fill_nan``)."""
    path = Path(path)
    b = str(band).lower()
    if b not in {str(k) for k in MCD43_BANDS} | {"vis", "nir", "shortwave"}:
        raise ValueError(f"MCD43C1 band {band!r}: give 1-7, 'vis', 'nir' or 'shortwave'")
    suffix = f"Band{b}" if b.isdigit() else b
    out = {}
    for k, key in zip((1, 2, 3), ("iso", "vol", "geo")):
        name = f"BRDF_Albedo_Parameter{k}_{suffix}"
        raw, attrs = read_dataset(path, name)
        raw = _check_cmg(path, name, raw)
        val = _scaled(raw, attrs, fill=32767, scale=0.001, valid=(0, 32766))
        out[key] = LatLonGrid(_resample(val, nlat), f"MCD43C1 {key} {suffix}", "1",
                              _meta(path, "MCD43C1", name, band=b, wavelength_nm=MCD43_BANDS.get(int(b)) if
                                    b.isdigit() else None))
    return out


def read_mcd12c1(path, layer: str = "Majority_Land_Cover_Type_1", nlat: int | None = None) -> LatLonGrid:
    """MCD12C1 majority land cover: uint8 classes 0 water, 1-16 IGBP (irtlang's LANDCOVER legend); fill (255)
    becomes water (0) and is counted in the metadata."""
    path = Path(path)
    raw, attrs = read_dataset(path, layer)
    raw = _check_cmg(path, layer, raw)
    fill = int(attrs.get("_FillValue", 255))
    bad = raw == fill
    cls = np.where(bad, 0, raw).astype(np.int64)
    if cls.max() > 16 or cls.min() < 0:
        raise ProductError(f"{path.name}: {layer} holds classes {cls.min()} .. {cls.max()}; the IGBP legend is 0-16")
    cls = _resample(cls.astype(np.uint8), nlat, classes=17)
    return LatLonGrid(cls, "MCD12C1 " + layer, "class",
                      _meta(path, "MCD12C1", layer, legend="0 water, 1-16 IGBP", fill_cells=int(bad.sum())))


def read_mod10cm(path, nlat: int | None = None, flagged: float = 0.0) -> LatLonGrid:
    """MOD10CM monthly snow cover as a fraction [0, 1]: percent / 100; water (254) is 0, other flags (night,
    cloud, no decision, fill) become `flagged` (default 0) and are counted in the metadata."""
    path = Path(path)
    name = "Snow_Cover_Monthly_CMG"
    raw, attrs = read_dataset(path, name)
    raw = _check_cmg(path, name, raw)
    f = raw.astype(np.float64) / 100.0
    water = raw == 254
    flag = (raw > 100) & ~water
    f[water] = 0.0
    f[flag] = flagged
    return LatLonGrid(_resample(f, nlat).astype(np.float32), "MOD10CM snow fraction", "1",
                      _meta(path, "MOD10CM", name, flagged_cells=int(flag.sum()), flagged_value=flagged))


# ============================================================================ AMSR-E sea ice (NSIDC polar stereographic)
# NSIDC polar stereographic grids: Hughes 1980 ellipsoid, true scale at 70 deg, the northern grid rotated so
# that 45 W points down the image (longitude + 45 in the formulas), 12.5 km cells; corner coordinates (km)
# of the upper-left and lower-right cell edges.  (NSIDC, "Polar Stereographic Projections and Grids".)
HUGHES_A_KM = 6378.273
HUGHES_E = 0.081816153
TRUE_LAT = 70.0
POLAR_GRIDS = {
    "north": {"dataset": "SI_12km_NH_ICECON_DAY", "shape": (896, 608), "x0": -3850.0, "y0": 5850.0, "delta": 45.0,
              "sign": 1.0},
    "south": {"dataset": "SI_12km_SH_ICECON_DAY", "shape": (664, 632), "x0": -3950.0, "y0": 4350.0, "delta": 0.0,
              "sign": -1.0},
}
CELL_KM = 12.5


def _tfun(phi):
    e = HUGHES_E
    s = np.sin(phi)
    return np.tan(np.pi / 4 - phi / 2) / ((1 - e * s) / (1 + e * s)) ** (e / 2)


def polar_xy(lat_deg, lon_deg, hemisphere: str):
    """NSIDC polar stereographic (x, y) in km of (lat, lon) in deg (Snyder 1987, eqs. 21-33 to 21-36)."""
    g = POLAR_GRIDS[hemisphere]
    h = g["sign"]
    phi = np.radians(np.abs(np.asarray(lat_deg, float)))
    lam = np.radians(np.asarray(lon_deg, float) + g["delta"])
    pc = math.radians(TRUE_LAT)
    mc = math.cos(pc) / math.sqrt(1 - HUGHES_E ** 2 * math.sin(pc) ** 2)
    rho = HUGHES_A_KM * mc * _tfun(phi) / _tfun(pc)
    return rho * h * np.sin(h * lam), -rho * h * np.cos(h * lam)


def polar_latlon(x_km, y_km, hemisphere: str):
    """The inverse of polar_xy (latitude by fixed-point iteration of Snyder's eq. 7-9)."""
    g = POLAR_GRIDS[hemisphere]
    h = g["sign"]
    x = np.asarray(x_km, float)
    y = np.asarray(y_km, float)
    rho = np.hypot(x, y)
    pc = math.radians(TRUE_LAT)
    mc = math.cos(pc) / math.sqrt(1 - HUGHES_E ** 2 * math.sin(pc) ** 2)
    t = rho * _tfun(pc) / (HUGHES_A_KM * mc)
    phi = np.pi / 2 - 2 * np.arctan(t)
    for _ in range(8):
        s = np.sin(phi)
        phi = np.pi / 2 - 2 * np.arctan(t * ((1 - HUGHES_E * s) / (1 + HUGHES_E * s)) ** (HUGHES_E / 2))
    lam = np.degrees(np.arctan2(h * x, -h * y)) * h - g["delta"]
    lam = (lam + 180.0) % 360.0 - 180.0
    return h * np.degrees(phi), lam


def _grid_index(x, y, g):
    col = np.floor((x - g["x0"]) / CELL_KM).astype(np.int64)
    row = np.floor((g["y0"] - y) / CELL_KM).astype(np.int64)
    return row, col


def read_amsre_seaice(path, nlat: int = 360, kind: str = "DAY") -> LatLonGrid:
    """AE_SI12 daily sea-ice concentration, both hemispheres, as a global fraction grid of nlat rows.  kind: the
    field read, DAY (the daily average, SI_12km_NH_ICECON_DAY ...), ASC or DSC (ascending / descending passes).

    Each output cell averages the 12.5 km cells whose centres fall in it (cells of the polar grid are located
    by the inverse projection); cells no polar cell falls in take the polar cell under their centre.  Land
    (120) counts as 0; missing (110, e.g. the pole hole) takes the nearest valid value; latitudes outside both
    grids are 0 (no ice)."""
    path = Path(path)
    out = np.zeros((nlat, 2 * nlat))
    lat_c, lon_c = cell_centres(nlat)
    kind = kind.upper()
    if kind not in ("DAY", "ASC", "DSC"):
        raise ValueError(f"AE_SI12 field {kind!r}: give DAY, ASC or DSC")
    names = []
    for hemi, g in POLAR_GRIDS.items():
        g = {**g, "dataset": g["dataset"].replace("_DAY", "_" + kind)}
        names.append(g["dataset"])
        raw, attrs = read_dataset(path, g["dataset"])
        if raw.ndim == 3 and raw.shape[0] == 1:
            raw = raw[0]
        if raw.shape != g["shape"]:
            raise ProductError(f"{path.name}: {g['dataset']} has shape {raw.shape}, not the NSIDC 12.5 km "
                               f"{hemi}ern polar stereographic grid {g['shape']}")
        v = raw.astype(np.float64)
        odd = (raw < 0) | ((raw > 100) & ~np.isin(raw, (110, 120)))
        if odd.any():
            raise ProductError(f"{path.name}: {g['dataset']} holds values other than 0-100 (percent), 110 (missing) "
                               f"and 120 (land), e.g. {raw[odd].ravel()[0]}")
        v[raw == 120] = 0.0
        v[raw == 110] = np.nan
        v = _fill_nearest(v) / 100.0
        # forward: every latlon cell centre to the polar cell under it
        LA, LO = np.meshgrid(lat_c, lon_c, indexing="ij")
        side = LA > 0 if hemi == "north" else LA < 0
        x, y = polar_xy(LA[side], LO[side], hemi)
        r, c = _grid_index(x, y, g)
        inside = (r >= 0) & (r < g["shape"][0]) & (c >= 0) & (c < g["shape"][1])
        fwd = np.zeros(side.sum())
        fwd[inside] = v[r[inside], c[inside]]
        # inverse: the mean of the polar cells whose centres fall in each latlon cell
        rr, cc = np.meshgrid(np.arange(g["shape"][0]), np.arange(g["shape"][1]), indexing="ij")
        plat, plon = polar_latlon(g["x0"] + (cc + 0.5) * CELL_KM, g["y0"] - (rr + 0.5) * CELL_KM, hemi)
        R = np.clip(((90.0 - plat) / 180.0 * nlat).astype(np.int64), 0, nlat - 1)
        Q = np.clip(((plon + 180.0) / 360.0 * 2 * nlat).astype(np.int64), 0, 2 * nlat - 1)
        idx = (R * 2 * nlat + Q).ravel()
        s = np.bincount(idx, v.ravel(), minlength=nlat * 2 * nlat).reshape(nlat, 2 * nlat)
        n = np.bincount(idx, minlength=nlat * 2 * nlat).reshape(nlat, 2 * nlat)
        half = np.zeros((nlat, 2 * nlat))
        half[side] = fwd
        has = (n > 0) & side
        half[has] = s[has] / n[has]
        out[side] = half[side]
    return LatLonGrid(np.clip(out, 0, 1).astype(np.float32), "AE_SI12 sea-ice concentration", "1",
                      _meta(path, "AE_SI12", names,
                            projection="NSIDC polar stereographic 12.5 km, Hughes 1980 ellipsoid, true at 70 deg"))


def _fill_nearest(a: np.ndarray) -> np.ndarray:
    bad = ~np.isfinite(a)
    if not bad.any():
        return a
    if bad.all():
        return np.zeros_like(a)
    from scipy.ndimage import distance_transform_edt

    idx = distance_transform_edt(bad, return_distances=False, return_indices=True)
    return a[tuple(idx)]


def fill_nan(grid: LatLonGrid, value: float | None = None) -> LatLonGrid:
    """A copy with NaN cells set to `value`, or to the nearest valid cell when value is None."""
    a = grid.data.astype(np.float64)
    a = np.where(np.isfinite(a), a, value) if value is not None else _fill_nearest(a)
    return LatLonGrid(a.astype(grid.data.dtype), grid.name, grid.units, {**grid.meta, "nan_filled": value})


# ============================================================================ MERRA-2
def read_merra2(path, variable: str = "CLDTOT", nlat: int = 360, time_index: int | None = None) -> LatLonGrid:
    """A MERRA-2 2-D field on irtlang's grid: bilinear in latitude and (periodic) longitude from the 0.5 x 0.625
    deg MERRA-2 grid (361 latitudes -90 .. 90 including the poles, 576 longitudes from -180).  A file with
    several times is averaged over them unless time_index picks one.  Fill values (1e15) are not allowed."""
    path = Path(path)
    raw, attrs = read_dataset(path, variable)
    lat, _ = read_dataset(path, "lat")
    lon, _ = read_dataset(path, "lon")
    lat = np.asarray(lat, float).ravel()
    lon = np.asarray(lon, float).ravel()
    if raw.ndim == 3:
        raw = raw[time_index] if time_index is not None else raw
    elif raw.ndim != 2:
        raise ProductError(f"{path.name}: {variable} has shape {raw.shape}; expected (time, lat, lon) or (lat, lon)")
    val = _scaled(raw, attrs, fill=1e15)
    if val.ndim == 3:
        val = val.mean(axis=0)
    if val.shape != (lat.size, lon.size):
        raise ProductError(f"{path.name}: {variable} has shape {val.shape} but lat, lon have {lat.size}, {lon.size}")
    dlat, dlon = np.diff(lat), np.diff(lon)
    if (lat.size < 2 or lon.size < 2 or not np.allclose(dlat, dlat[0]) or not np.allclose(dlon, dlon[0])
            or abs(lat[0] + 90) > 1e-6 or abs(lat[-1] - 90) > 1e-6 or abs(lon[0] + 180) > 1e-6
            or abs(lon.size * dlon[0] - 360) > 1e-6):
        raise ProductError(f"{path.name}: lat/lon is not the global MERRA-2 grid (latitudes -90 .. 90 with the poles, "
                           f"longitudes from -180 evenly round the globe); got lat {lat[0]:g} .. {lat[-1]:g} "
                           f"({lat.size}), lon {lon[0]:g} .. {lon[-1]:g} ({lon.size})")
    if not np.all(np.isfinite(val)):
        raise ProductError(f"{path.name}: {variable} has fill values; a global map needs every cell")
    lat_c, lon_c = cell_centres(nlat)
    fi = (lat_c - lat[0]) / dlat[0]
    i0 = np.clip(np.floor(fi).astype(int), 0, lat.size - 2)
    wi = (fi - i0)[:, None]
    fj = (lon_c - lon[0]) / dlon[0]
    j0 = np.floor(fj).astype(int) % lon.size
    j1 = (j0 + 1) % lon.size
    wj = (fj - np.floor(fj))[None, :]
    top = val[i0][:, j0] * (1 - wj) + val[i0][:, j1] * wj
    bot = val[i0 + 1][:, j0] * (1 - wj) + val[i0 + 1][:, j1] * wj
    out = top * (1 - wi) + bot * wi
    units = attrs.get("units", "1")
    return LatLonGrid(out.astype(np.float32), f"MERRA-2 {variable}", str(units),
                      _meta(path, "MERRA-2", variable, time_index=time_index, regrid="bilinear",
                            licence="NASA GMAO MERRA-2: no restrictions on use (cite Gelaro et al. 2017)"))


def merra2_times(path) -> list:
    """The times (naive UTC datetimes) of a MERRA-2 file's steps, from its `time` variable ('minutes since
    2008-03-18 00:30:00': the hourly files stamp each mean at the middle of its hour)."""
    import datetime as dt
    import re

    path = Path(path)
    t, attrs = read_dataset(path, "time")
    units = str(attrs.get("units", ""))
    m = re.match(r"\s*(minutes|hours|seconds|days)\s+since\s+(\d{4}-\d{1,2}-\d{1,2})[ T]?(\d{1,2}:\d{2}(:\d{2})?)?",
                 units)
    if not m:
        raise ProductError(f"{path.name}: the time variable's units {units!r} are not '<unit> since <date>'")
    base = dt.datetime.fromisoformat(m.group(2) + " " + (m.group(3) or "00:00"))
    step = {"minutes": 60.0, "hours": 3600.0, "seconds": 1.0, "days": 86400.0}[m.group(1)]
    return [base + dt.timedelta(seconds=float(v) * step) for v in np.atleast_1d(np.asarray(t, float))]


def merra2_step(files, when) -> tuple:
    """(file, time index) of the step whose averaging interval holds `when` (a datetime or ISO text): each
    step covers its time stamp -+ half the spacing of the file's steps (one hour for M2T1NX files)."""
    import datetime as dt

    if isinstance(when, str):
        when = dt.datetime.fromisoformat(when)
    have = []
    for f in files:
        ts = merra2_times(f)
        half = (ts[1] - ts[0]) / 2 if len(ts) > 1 else dt.timedelta(minutes=30)
        for i, t in enumerate(ts):
            if t - half <= when < t + half:
                return Path(f), i
        if ts:
            have.append(f"{Path(f).name}: {ts[0] - half:%Y-%m-%d %H:%M} to {ts[-1] + half:%Y-%m-%d %H:%M}")
    raise ProductError(f"no MERRA-2 step covers {when:%Y-%m-%d %H:%M} UTC; the files cover " + "; ".join(have))


def merra2_cloud_map(files, variable: str, when, cache_dir=None, levels: int | None = None) -> Path:
    """The MERRA-2 cloud fraction `variable` (CLDLOW, CLDMID, CLDHGH or CLDTOT of the hourly M2T1NXRAD files)
    of the step that holds `when`, on the default tier's 0.5 deg grid (read_merra2: bilinear), quantized to the
    ten levels of the seed's fraction maps (irtlang.earth.data.quantize: 0, 1/9, ..., 1), written into the data
    cache (data_dir()/merra2/) with its sidecar; returns the .npy path (reused while the file is unchanged)."""
    from .data import CLOUD_LEVELS, data_dir, quantize
    from .latlon import read_sidecar, save_grid

    path, i = merra2_step([Path(f) for f in files], when)
    st = path.stat()
    prm = {"file": str(path.resolve()), "size": st.st_size, "mtime_ns": st.st_mtime_ns, "variable": variable,
           "time_index": i, "levels": levels or CLOUD_LEVELS}
    out = data_dir(cache_dir) / "merra2" / f"{path.stem}_{variable.upper()}_{i:02d}.npy"
    if out.exists() and read_sidecar(out).get("parameters") == prm:
        return out
    g = read_merra2(path, variable, 360, time_index=i)
    v = g.data
    if np.nanmin(v) < -1e-3 or np.nanmax(v) > 1 + 1e-3:
        raise ProductError(f"{path.name}: {variable} runs from {np.nanmin(v):g} to {np.nanmax(v):g}; a cloud "
                           "fraction lies in [0, 1]")
    t = merra2_times(path)[i]
    out.parent.mkdir(parents=True, exist_ok=True)
    save_grid(out, quantize(v, levels or CLOUD_LEVELS),
              {**g.meta, "dataset": f"MERRA-2 {variable.upper()}", "units": "1", "time_utc": f"{t:%Y-%m-%dT%H:%M}",
               "source": f"MERRA-2 {variable.upper()} of {path.name} at {t:%Y-%m-%d %H:%M} UTC (Gelaro et al. "
                         "2017), bilinear to 0.5 deg, quantized to 10 levels", "parameters": prm})
    return out
