"""Global latitude-longitude maps: rows from +90 down, columns from -180 east (LANGUAGE.md section 6)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.diagnostics import Span, error


def load_latlon(path: Path) -> np.ndarray:
    ext = path.suffix.lower()
    if ext == ".npy":
        return np.load(path, allow_pickle=False)
    if ext in (".h5", ".hdf5", ".he5", ".nc", ".nc4"):
        import h5py

        with h5py.File(path, "r") as f:
            found = []
            f.visititems(lambda n, o: found.append(n) if isinstance(o, h5py.Dataset) and o.ndim == 2 else None)
            if not found:
                raise ValueError("no 2-D dataset in the file")
            name = "data" if "data" in found else found[0]
            return f[name][()]
    raise ValueError(f"unsupported map format '{ext}' (use .npy, .h5 or .nc)")


def check_latlon_file(path: Path, span: Span) -> np.ndarray:
    try:
        a = load_latlon(path)
    except Exception as e:  # numpy and h5py raise several kinds on a bad file
        # not the reader's message: numpy quotes the bytes it found where a header should be
        why = str(e) if isinstance(e, ValueError) and str(e).startswith(("unsupported", "no 2-D")) else \
            f"not a valid {path.suffix.lower() or 'map'} file ({type(e).__name__})"
        raise error(span, f"cannot read map '{path.name}': {why}") from None
    if a.ndim != 2:
        raise error(span, f"map '{path.name}' has shape {a.shape}; a LATLON map is 2-D (lat rows, lon columns)")
    nlat, nlon = a.shape
    if nlon != 2 * nlat:
        raise error(span, f"map '{path.name}' has shape {a.shape}: a global LATLON grid has twice as many "
                    "columns (longitude, 360 deg) as rows (latitude, 180 deg)")
    if not np.all(np.isfinite(a)):
        raise error(span, f"map '{path.name}' holds values that are not finite")
    return a


def class_count(path: str) -> int | None:
    """For an integer class map: the number of classes (max + 1); None for a fraction map."""
    a = load_latlon(Path(path))
    if np.issubdtype(a.dtype, np.integer):
        return int(a.max()) + 1
    return None
