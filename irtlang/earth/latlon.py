"""Global latitude-longitude grids in irtlang's convention, with their provenance.

The convention (LANGUAGE.md section 6, ``irtlang.kernels.trace_kernel.map_value``): an array of shape
(nlat, nlon) with nlon = 2 nlat; row r covers latitudes from 90 - r d to 90 - (r + 1) d (rows from +90 down),
column q covers longitudes from -180 + q d to -180 + (q + 1) d (columns from -180 east), d = 180 / nlat deg.
Cell centres are at 90 - (r + 1/2) d and -180 + (q + 1/2) d.

Every grid the Earth model writes is a ``.npy`` file (readable by ``MAP name LATLON 'file.npy'``) with a JSON
sidecar ``file.json`` next to it: dataset name, shape, dtype, units, source, licence, whether it is a proxy,
and how it was made.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..io.atomic import atomic_path

EARTH_AUTHALIC_RADIUS_KM = 6371.0072   # radius of the sphere with the WGS84 ellipsoid's area (510.0656e6 km2)


def check_shape(shape) -> None:
    if len(shape) != 2 or shape[1] != 2 * shape[0] or shape[0] < 1:
        raise ValueError(f"shape {tuple(shape)} is not a global LATLON grid (nlat, 2 nlat)")


def cell_centres(nlat: int) -> tuple[np.ndarray, np.ndarray]:
    """Latitudes (nlat,) from north to south and longitudes (2 nlat,) from west to east of the cell centres, deg."""
    d = 180.0 / nlat
    lat = 90.0 - (np.arange(nlat) + 0.5) * d
    lon = -180.0 + (np.arange(2 * nlat) + 0.5) * d
    return lat, lon


def cell_areas_km2(nlat: int, radius_km: float = EARTH_AUTHALIC_RADIUS_KM) -> np.ndarray:
    """Area of each cell of a row (nlat,) on a sphere: R^2 dlon (sin lat_top - sin lat_bottom)."""
    d = math.radians(180.0 / nlat)
    top = math.pi / 2 - np.arange(nlat) * d
    return radius_km ** 2 * d * (np.sin(top) - np.sin(top - d))


def area_weighted_mean(a: np.ndarray, where: np.ndarray | None = None) -> float:
    """Mean of a grid weighted by cell area (over the cells where `where` is true)."""
    w = np.broadcast_to(cell_areas_km2(a.shape[0])[:, None], a.shape)
    if where is not None:
        w = w * where
    return float((a * w).sum() / w.sum())


def area_km2(mask: np.ndarray) -> float:
    """Total area of the cells where `mask` is true (or the area-weighted sum of a fraction grid), km2."""
    return float((np.asarray(mask, float) * cell_areas_km2(mask.shape[0])[:, None]).sum())


def block_mean(a: np.ndarray, k: int) -> np.ndarray:
    """Average over k x k blocks (a fraction grid at k times coarser resolution)."""
    n, m = a.shape
    if n % k or m % k:
        raise ValueError(f"a grid of shape {a.shape} does not divide into {k} x {k} blocks")
    return a.reshape(n // k, k, m // k, k).mean(axis=(1, 3))


def block_mode(a: np.ndarray, k: int, n_classes: int) -> np.ndarray:
    """The most frequent class in each k x k block (ties: the lowest class)."""
    n, m = a.shape
    if n % k or m % k:
        raise ValueError(f"a grid of shape {a.shape} does not divide into {k} x {k} blocks")
    b = a.reshape(n // k, k, m // k, k).transpose(0, 2, 1, 3).reshape(n // k, m // k, k * k)
    counts = np.stack([(b == c).sum(axis=2) for c in range(n_classes)], axis=2)
    return counts.argmax(axis=2).astype(a.dtype)


def regrid_nearest(a: np.ndarray, nlat: int) -> np.ndarray:
    """Nearest-cell resampling of a LATLON grid to nlat rows (any ratio)."""
    n = a.shape[0]
    lat, lon = cell_centres(nlat)
    r = np.clip(((90.0 - lat) / 180.0 * n).astype(int), 0, n - 1)
    q = np.clip(((lon + 180.0) / 360.0 * 2 * n).astype(int), 0, 2 * n - 1)
    return a[r][:, q]


@dataclass
class LatLonGrid:
    """A global grid in irtlang's convention and what it is."""

    data: np.ndarray
    name: str
    units: str = "1"
    meta: dict = field(default_factory=dict)     # source, licence, proxy, notes ...

    def __post_init__(self):
        check_shape(self.data.shape)

    @property
    def nlat(self) -> int:
        return self.data.shape[0]

    def value_at(self, lat_deg: float, lon_deg: float):
        """The value of the cell holding (lat, lon), as the tracer's map_value looks it up."""
        n = self.nlat
        r = min(max(int((90.0 - lat_deg) / 180.0 * n), 0), n - 1)
        q = min(max(int((lon_deg + 180.0) / 360.0 * 2 * n), 0), 2 * n - 1)
        return self.data[r, q]

    def save(self, path) -> Path:
        """Write path (.npy) and its JSON sidecar; the .npy is what `MAP name LATLON 'path'` reads."""
        path = Path(path)
        if path.suffix.lower() != ".npy":
            raise ValueError(f"{path.name}: a grid is saved as .npy")
        save_grid(path, self.data, {"dataset": self.name, "units": self.units, **self.meta})
        return path


def sidecar_path(path) -> Path:
    return Path(path).with_suffix(".json")


def save_grid(path, data: np.ndarray, meta: dict) -> None:
    check_shape(data.shape)
    path = Path(path)
    info = {**meta, "shape": list(data.shape), "dtype": str(data.dtype),
            "convention": "LATLON: rows from +90 deg down, columns from -180 deg east, cell centres at "
                          "90 - (r + 1/2) 180/nlat and -180 + (q + 1/2) 180/nlat"}
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            np.save(f, np.ascontiguousarray(data), allow_pickle=False)
        os.chmod(tmp, 0o644)
    with atomic_path(sidecar_path(path)) as tmp:
        tmp.write_text(json.dumps(info, indent=1, sort_keys=True, default=_jsonable) + "\n")
        os.chmod(tmp, 0o644)


def _jsonable(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


def read_sidecar(path) -> dict:
    p = sidecar_path(path)
    return json.loads(p.read_text()) if p.exists() else {}
