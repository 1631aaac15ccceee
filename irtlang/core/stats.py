"""Monte Carlo standard errors: one formula for every total a run reports (the tracer's tallies, images,
ray-record sums)."""
from __future__ import annotations

import numpy as np


def standard_error(s1, s2, n):
    """Standard error of a sum of n independent per-ray contributions with sums s1 and s2 (squares)."""
    if n <= 1:
        return 0.0
    s1, s2 = np.asarray(s1), np.asarray(s2)
    dt = _standard_error(s1.flat[:1], s2.flat[:1], n).dtype
    if s1.ndim < 3 or s1.shape != s2.shape or not s1.dtype == s2.dtype == dt:
        return _standard_error(s1, s2, n)
    # an image cube (hundreds of MB) one plane at a time, in place: the same operations in the same order, without
    # five temporaries of the cube's size (fresh memory costs more to touch than the arithmetic)
    out = np.empty(s1.shape, dt)
    m = np.empty(s1.shape[1:], dt)
    for k in range(s1.shape[0]):
        v = out[k]
        np.divide(s2[k], n, out=v)
        np.divide(s1[k], n, out=m)
        np.multiply(m, m, out=m)
        np.subtract(v, m, out=v)
        np.maximum(v, 0.0, out=v)
        v *= n
        v *= n
        v /= n - 1
        np.sqrt(v, out=v)
    return out


def _standard_error(s1, s2, n):
    var = np.maximum(s2 / n - (s1 / n) ** 2, 0.0)
    return np.sqrt(var * n * n / (n - 1))


def result_standard_error(res, s1, s2):
    """A trace result's standard error of a total with sums s1 and s2: `standard_error` over its source rays,
    or for stratified pairs (a camera trace with DIRECTIONS or a paired SPECTRAL: res.paired) sqrt(s2), s2 being
    the sum over pairs of (a - b)^2, an unbiased estimate of the stratified total's variance."""
    if getattr(res, "paired", False):
        return np.sqrt(np.maximum(np.asarray(s2, float), 0.0))
    return standard_error(s1, s2, res.n_traced)


def total_standard_error(res, s1, s2):
    """The standard error of a total over lines from per-line sums s1, s2 (shape (..., L)).  A ray carries one
    line, so the lines' variances add; but the lines of a CORRELATED camera trace (res.correlated) share their
    random numbers and their errors are correlated: then the sum of the lines' standard errors, the bound that
    holds for any correlation."""
    s1 = np.asarray(s1, float)
    s2 = np.asarray(s2, float)
    if getattr(res, "correlated", False):
        return float(np.sum(result_standard_error(res, s1, s2)))
    return float(result_standard_error(res, float(s1.sum()), float(s2.sum())))


def lit_pixels(img, frac: float = 0.02):
    """The pixels of an image (..., ny, nx) above `frac` of its bright level, per image: the lit disk of a
    planet's frame.  The bright level is the 99th percentile of the image's non-zero pixels, not its maximum:
    one Monte Carlo outlier (a rare path of large weight, 10-20 times the disk's brightest pixels in an Earth
    frame) would otherwise raise the threshold above the dark ocean and leave half the disk out."""
    img = np.asarray(img, float)
    flat = img.reshape((-1,) + img.shape[-2:]) if img.ndim >= 2 else img.reshape(1, 1, -1)
    out = np.zeros(flat.shape, bool)
    for k, im in enumerate(flat):
        pos = im[im > 0]
        if pos.size:
            out[k] = im > frac * np.percentile(pos, 99)
    return out.reshape(img.shape)
