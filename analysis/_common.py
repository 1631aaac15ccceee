"""Shared input checks and file helpers for the analysis package (internal)."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

import numpy as np


class AnalysisError(ValueError):
    """Bad input to an analysis function (wrong shape, ROI outside the image, empty or non-finite data,
    a file of another schema). A subclass of ``ValueError``; the message says what is wrong."""


def as_image(a, name="image", *, allow_zero=False, channels=False):
    """Return ``a`` as a finite float64 2-D array (or (H, W, C) when ``channels`` is true).

    Raises AnalysisError for a wrong number of dimensions, an empty array, NaN/inf values or (unless
    ``allow_zero``) an image that is zero everywhere.
    """
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise AnalysisError(f"{name} is not a numeric array: {exc}") from None
    ok_ndim = (2, 3) if channels else (2,)
    if arr.ndim not in ok_ndim:
        want = "2-D (H, W) or 3-D (H, W, C)" if channels else "2-D (H, W)"
        raise AnalysisError(f"{name} must be {want}, got shape {arr.shape}")
    if arr.size == 0 or min(arr.shape[:2]) < 2:
        raise AnalysisError(f"{name} is empty or too small: shape {arr.shape}")
    check_finite(arr, name)
    if not allow_zero and not np.any(arr):
        raise AnalysisError(f"{name} is all zero")
    return arr


def check_finite(arr, name):
    """Raise AnalysisError if ``arr`` holds NaN or infinite values."""
    bad = ~np.isfinite(arr)
    if np.any(bad):
        raise AnalysisError(f"{name} contains {int(bad.sum())} non-finite value(s) (NaN or inf)")


def same_shape(a, b, names=("a", "b")):
    """Raise AnalysisError unless arrays ``a`` and ``b`` have the same shape."""
    if np.shape(a) != np.shape(b):
        raise AnalysisError(f"{names[0]} and {names[1]} have different shapes: {np.shape(a)} vs {np.shape(b)}")


def check_roi(roi, shape, *, min_size=2):
    """Validate ``roi = (x, y, w, h)`` (column, row of the top-left pixel, width, height; integers) against an
    image of ``shape`` (H, W, ...). Returns the pair of slices ``(rows, cols)``; ``roi=None`` is the whole image."""
    height, width = shape[0], shape[1]
    if roi is None:
        return slice(0, height), slice(0, width)
    try:
        x, y, w, h = (int(v) for v in roi)
    except (TypeError, ValueError):
        raise AnalysisError(f"roi must be four integers (x, y, w, h), got {roi!r}") from None
    if any(int(v) != v for v in roi):
        raise AnalysisError(f"roi must be four integers (x, y, w, h), got {roi!r}")
    if w < min_size or h < min_size:
        raise AnalysisError(f"roi {roi!r} is smaller than {min_size} x {min_size} pixels")
    if x < 0 or y < 0 or x + w > width or y + h > height:
        raise AnalysisError(f"roi (x={x}, y={y}, w={w}, h={h}) lies outside the image of {width} x {height} pixels")
    return slice(y, y + h), slice(x, x + w)


def bilinear(img, x, y):
    """Bilinear samples of ``img`` at positions (x, y) in px (pixel centres at integer coordinates, x along
    columns); beyond the border the edge values continue."""
    from scipy.ndimage import map_coordinates

    return map_coordinates(img, [y, x], order=1, mode="nearest")


def positive(value, name):
    """Return ``float(value)``, raising AnalysisError unless it is finite and > 0."""
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise AnalysisError(f"{name} must be a positive number, got {value!r}")
    return v


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path in the folder of ``path`` with the same suffix; on success it replaces ``path``
    (``os.replace``), on failure it is removed. Readers never see a half-written file."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise AnalysisError(f"cannot write {path}: folder {folder} does not exist")
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{path.name}.", suffix="".join(path.suffixes[-1:]))
    os.close(fd)
    try:
        yield Path(tmp)
        with contextlib.suppress(OSError):   # mkstemp makes 0600: the mode a plain open() would give
            mask = os.umask(0o022)
            os.umask(mask)
            os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(tmp)
        raise


def atomic_write_bytes(path, data: bytes):
    """Write ``data`` to ``path`` atomically (temporary file in the same folder, then ``os.replace``)."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)
