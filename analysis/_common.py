"""Shared input checks and file helpers for the analysis package (internal)."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

import numpy as np

from irtlang.core.checks import AnalysisError, as_image, check_finite, positive  # noqa: F401  (re-exported)


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
