"""Checks of the array and number arguments of pure data functions, and their error, AnalysisError.

Used by the ray-file format (irtlang/io/rayfile.py), the PSF measures (irtlang/optics/psf_measures.py) and the
analysis package, which re-exports them (``analysis.AnalysisError`` is this class): they live here, in the bottom
layer, so that irtlang never imports the analysis package (docs/architecture.md).
"""

from __future__ import annotations

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


def positive(value, name):
    """Return ``float(value)``, raising AnalysisError unless it is finite and > 0."""
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise AnalysisError(f"{name} must be a positive number, got {value!r}")
    return v
