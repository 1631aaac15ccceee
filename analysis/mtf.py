"""Edge-based resolution measures: super-sampled edge-spread function, ISO 12233 slanted-edge MTF, MTF50,
ESF slope and 10-90 % width."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from ._common import AnalysisError, as_image, check_roi, positive

__all__ = ["EdgeProfile", "edge_spread_function", "slanted_edge_mtf", "mtf50", "esf_slope", "esf_width_10_90"]


@dataclass(frozen=True)
class EdgeProfile:
    """A super-sampled edge-spread function.

    Attributes
    ----------
    distance : (M,) array
        Bin centres in px: signed distance from the fitted edge, perpendicular to it, positive on the bright side.
    esf : (M,) array
        ESF at the bin centres (image units): the mean pixel value of each bin, placed at the mean distance of the
        bin's pixels, linearly interpolated onto the centres (empty bins are interpolated the same way).
    counts : (M,) int array
        Number of pixels per bin.
    oversample : int
        Bins per pixel.
    coefficients : array
        Polynomial (highest power first) of the edge position along the rows, in ROI pixel coordinates
        (column as a function of row, or row as a function of column if ``transposed``).
    transposed : bool
        True when the edge is closer to horizontal (then columns were used as the scan lines).
    angle_deg : float
        Mean edge angle from the scan-line normal (0 for an edge exactly along the columns/rows).
    """

    distance: np.ndarray
    esf: np.ndarray
    counts: np.ndarray
    oversample: int
    coefficients: np.ndarray
    transposed: bool
    angle_deg: float


def _hamming(x, half_width):
    """Hamming window 0.54 + 0.46 cos(pi x / half_width), zero for |x| > half_width."""
    w = 0.54 + 0.46 * np.cos(np.pi * x / half_width)
    return np.where(np.abs(x) <= half_width, w, 0.0)


def _row_centroids(deriv, centres=None):
    """Centroid of each row of ``deriv`` (positions i + 0.5), optionally Hamming-windowed about ``centres``."""
    pos = np.arange(deriv.shape[1]) + 0.5
    weights = deriv
    if centres is not None:
        weights = deriv * _hamming(pos[None, :] - centres[:, None], deriv.shape[1] / 2.0)
    total = weights.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (weights * pos).sum(axis=1) / total, total


def _fit_edge(deriv, degree):
    """Fit the edge position per scan line: centroid of the derivative, polynomial fit, then a second pass with a
    Hamming window centred on the first fit (as in ISO 12233 / sfrmat). Returns the polynomial coefficients."""
    rows = np.arange(deriv.shape[0], dtype=np.float64)
    strength = np.abs(deriv).sum(axis=1)
    centres, total = _row_centroids(deriv)
    for _ in range(2):
        good = np.isfinite(centres) & (total > 0.2 * np.median(strength))
        if good.sum() < degree + 2:
            raise AnalysisError("no edge found in the region: too few scan lines show a consistent step")
        coeffs = np.polyfit(rows[good], centres[good], degree)
        centres, total = _row_centroids(deriv, np.polyval(coeffs, rows))
    return coeffs


def edge_spread_function(image, roi=None, *, oversample=4, edge_fit_degree=1):
    """Super-sampled edge-spread function of a (slanted or curved) edge.

    Signature: ``edge_spread_function(image, roi=None, *, oversample=4, edge_fit_degree=1) -> EdgeProfile``.

    Definition (ISO 12233 slanted edge): the scan lines are the rows (or the columns, whichever crosses the edge);
    on each line the edge position is the centroid of the first difference of the pixel values (two passes, the
    second Hamming-windowed about the first fit); a polynomial of degree ``edge_fit_degree`` (1: a straight edge;
    2: a curved limb) is fitted to these positions; every pixel is then projected onto the edge normal,
    ``d = (x - p(y)) / sqrt(1 + p'(y)^2)`` (px, positive towards the bright side), and the pixel values are averaged
    in bins of ``1/oversample`` px over the distance range that every scan line covers; each bin mean is placed at
    the mean distance of its pixels and resampled linearly onto the uniform bin centres.

    Parameters
    ----------
    image : (H, W) array
    roi : (x, y, w, h) or None
        Column and row of the top-left pixel, width and height, in pixels; None: the whole image.
    oversample : int
        Bins per pixel (default 4).
    edge_fit_degree : int
        Degree of the polynomial fitted to the edge positions.
    """
    rows_sl, cols_sl = check_roi(roi, np.shape(image), min_size=3)
    sub = as_image(image, "image")[rows_sl, cols_sl]
    oversample = int(oversample)
    degree = int(edge_fit_degree)
    if oversample < 1 or degree < 0:
        raise AnalysisError("oversample must be >= 1 and edge_fit_degree >= 0")
    transposed = np.abs(np.diff(sub, axis=0)).sum() > np.abs(np.diff(sub, axis=1)).sum()
    if transposed:
        sub = sub.T
    deriv = np.diff(sub, axis=1)
    sign = 1.0 if deriv.sum() >= 0 else -1.0
    if not np.any(deriv):
        raise AnalysisError("no edge found in the region: the image is constant along the scan lines")
    coeffs = _fit_edge(sign * deriv, degree)

    n_rows, n_cols = sub.shape
    rows = np.arange(n_rows, dtype=np.float64)
    edge = np.polyval(coeffs, rows)
    slope = np.polyval(np.polyder(coeffs), rows) if degree > 0 else np.zeros(n_rows)
    dist = sign * (np.arange(n_cols)[None, :] - edge[:, None]) / np.sqrt(1.0 + slope**2)[:, None]
    lo = dist.min(axis=1).max()
    hi = dist.max(axis=1).min()
    k0, k1 = int(np.ceil(lo * oversample)), int(np.floor(hi * oversample))
    if k1 - k0 < 4 * oversample:
        raise AnalysisError("the edge is too close to the region border: widen the ROI")
    idx = np.floor(dist * oversample).astype(np.int64) - k0
    inside = (idx >= 0) & (idx < k1 - k0)
    counts = np.bincount(idx[inside], minlength=k1 - k0)
    sums = np.bincount(idx[inside], weights=sub[inside], minlength=k1 - k0)
    dsums = np.bincount(idx[inside], weights=dist[inside], minlength=k1 - k0)
    centres = (np.arange(k0, k1) + 0.5) / oversample
    filled = counts > 0
    # Each bin's mean lies at the mean distance of its pixels, not exactly at the bin centre: resample there.
    esf = np.interp(centres, dsums[filled] / counts[filled], sums[filled] / counts[filled])
    angle = float(np.degrees(np.arctan(np.mean(slope))))
    return EdgeProfile(centres, esf, counts, oversample, coeffs, bool(transposed), angle)


def slanted_edge_mtf(image, roi=None, *, oversample=4, edge_fit_degree=1, window="hamming", max_frequency=1.0):
    """Modulation transfer function from a slanted (or curved) edge, ISO 12233 style.

    Signature: ``slanted_edge_mtf(image, roi=None, *, oversample=4, edge_fit_degree=1, window="hamming",
    max_frequency=1.0) -> (frequency_cycles_per_px, mtf)``.

    Steps: super-sampled ESF (:func:`edge_spread_function`, 1/``oversample`` px bins); line-spread function by the
    central difference ``(E[k+1] - E[k-1]) / 2``; Hamming window centred on the LSF centroid (``window=None`` to
    skip); ``|FFT|`` normalized to 1 at zero frequency; divided by the central difference's own transfer function
    ``sinc(2 f / oversample)`` (the ISO derivative correction, ``sinc(x) = sin(pi x)/(pi x)``). Frequencies are in
    cycles per pixel along the edge normal, up to ``max_frequency`` (at most ``oversample / 4``, where the
    correction is still <= pi/2).
    """
    prof = edge_spread_function(image, roi, oversample=oversample, edge_fit_degree=edge_fit_degree)
    lsf = np.gradient(prof.esf)
    k = np.arange(lsf.size, dtype=np.float64)
    if window == "hamming":
        weight = np.abs(lsf)
        centre = float((weight * k).sum() / weight.sum())
        lsf = lsf * _hamming(k - centre, max(centre, lsf.size - 1 - centre) + 1.0)
    elif window is not None:
        raise AnalysisError(f"window must be 'hamming' or None, got {window!r}")
    spectrum = np.abs(np.fft.rfft(lsf))
    if spectrum[0] <= 0:
        raise AnalysisError("the edge has no contrast (zero line-spread integral)")
    freq = np.fft.rfftfreq(lsf.size, d=1.0 / prof.oversample)
    mtf = spectrum / spectrum[0] / np.sinc(2.0 * freq / prof.oversample)
    keep = freq <= min(float(max_frequency), prof.oversample / 4.0) + 1e-12
    return freq[keep], mtf[keep]


def mtf50(freq, mtf, level=0.5):
    """Frequency (same unit as ``freq``) where the MTF first falls below ``level`` (default 0.5), by linear
    interpolation between the two bracketing samples. Raises AnalysisError if it never does.

    Signature: ``mtf50(freq, mtf, level=0.5) -> float``.
    """
    freq = np.asarray(freq, dtype=np.float64)
    mtf = np.asarray(mtf, dtype=np.float64)
    if freq.shape != mtf.shape or freq.ndim != 1:
        raise AnalysisError(f"freq and mtf must be 1-D arrays of one length, got {freq.shape} and {mtf.shape}")
    below = np.nonzero(mtf < level)[0]
    below = below[below > 0]
    if below.size == 0:
        raise AnalysisError(f"the MTF does not fall below {level} within the frequency range")
    i = below[0]
    return float(np.interp(level, [mtf[i], mtf[i - 1]], [freq[i], freq[i - 1]]))


def _normalized_esf(image, roi, oversample, edge_fit_degree, plateau, levels):
    """ESF scaled so that its dark plateau is 0 and its bright plateau 1 (see :func:`esf_slope`), as bin centres,
    values and an interpolating cubic spline."""
    prof = edge_spread_function(image, roi, oversample=oversample, edge_fit_degree=edge_fit_degree)
    if levels is None:
        n = max(1, int(round(plateau * prof.esf.size)))
        lo, hi = np.mean(prof.esf[:n]), np.mean(prof.esf[-n:])
    else:
        lo, hi = (float(v) for v in levels)
    if not hi > lo:
        raise AnalysisError(f"the edge has no contrast between its plateaus ({lo:g} and {hi:g})")
    e = (prof.esf - lo) / (hi - lo)
    return prof.distance, e, CubicSpline(prof.distance, e)


def esf_width_10_90(image, roi=None, *, oversample=4, edge_fit_degree=1, plateau=0.2, levels=None):
    """10-90 % rise distance of the edge-spread function, in px (along the edge normal).

    Signature: ``esf_width_10_90(image, roi=None, *, oversample=4, edge_fit_degree=1, plateau=0.2, levels=None)
    -> float``.

    The ESF (:func:`edge_spread_function`) is normalized between its plateaus (see :func:`esf_slope`) and
    interpolated by a cubic spline through the bin values; from the 0.5 crossing nearest the middle of the edge,
    the nearest 0.1 crossing on the dark side and the nearest 0.9 crossing on the bright side are taken.
    For a Gaussian blur sigma (no pixel aperture): 2.5631 sigma.
    """
    x, e, spline = _normalized_esf(image, roi, oversample, edge_fit_degree, plateau, levels)
    mid = spline.solve(0.5, extrapolate=False)
    if mid.size == 0:
        raise AnalysisError("the normalized ESF does not cross 0.5 inside the region")
    x50 = mid[np.argmin(np.abs(mid - np.median(mid)))]
    low = spline.solve(0.1, extrapolate=False)
    high = spline.solve(0.9, extrapolate=False)
    low, high = low[low < x50], high[high > x50]
    if low.size == 0 or high.size == 0:
        raise AnalysisError("the normalized ESF does not reach 0.1 and 0.9 inside the region: widen the ROI")
    return float(high.min() - low.max())


def esf_slope(image, roi=None, *, half_span=0.5, oversample=4, edge_fit_degree=1, plateau=0.2, levels=None):
    """The "ESF slope" of an edge in a small pixel region (Ryu et al. 2017), in 1/px.

    Signature: ``esf_slope(image, roi=None, *, half_span=0.5, oversample=4, edge_fit_degree=1, plateau=0.2,
    levels=None) -> float``; ``roi = (x, y, w, h)`` is the N x N (or any) pixel region, None for the whole image.

    Definition used here: the super-sampled ESF of the region (:func:`edge_spread_function`) is normalized to run
    from 0 (dark plateau) to 1 (bright plateau) and interpolated by a cubic spline E through the bin values; the
    slope is the largest finite difference across one pixel, ``max_x [E(x + h) - E(x - h)] / (2 h)`` with
    ``h = half_span`` = 0.5 px, x on a 1/(4 ``oversample``) px grid. The plateaus are the means of the outer
    ``plateau`` fraction (default 20 %) of the bins on each side, or the given ``levels = (dark, bright)`` (use them
    when the region is too small to reach the plateaus). For a Gaussian edge of blur sigma seen without pixel
    aperture: ``(2 Phi(h/sigma) - 1) / (2 h)``, which tends to ``1/(sqrt(2 pi) sigma)`` for large sigma.
    Larger values mean a sharper edge.
    """
    h = positive(half_span, "half_span")
    x, _, spline = _normalized_esf(image, roi, oversample, edge_fit_degree, plateau, levels)
    grid = np.arange(x[0] + h, x[-1] - h, 0.25 / oversample)
    if grid.size == 0:
        raise AnalysisError("the region is too small for the requested half_span")
    return float(np.max((spline(grid + h) - spline(grid - h)) / (2.0 * h)))
