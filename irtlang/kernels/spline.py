"""Cubic B-spline interpolation of a 2-D grid: the coefficients (``spline_filter3``) and their evaluation at points
given by an affine map (``spline3_affine``), for the PSF's density (irtlang.optics.diffraction.MonoPSF.density) at
detector offsets.

``spline_filter3(a)`` is ``scipy.ndimage.spline_filter(a, order=3, mode="mirror")``: the recursive filter of
M. Unser, A. Aldroubi, M. Eden, "Fast B-spline transforms for continuous image representation and
interpolation", IEEE PAMI 13 (1991) 277-285, with its mirror-boundary initialisation, along axis 0 and then axis
1 (the gain 6, then the causal and the anticausal pass with the pole z = sqrt(3) - 2).  The columns of axis 0 are
filtered side by side, a row at a time, so that the inner loop runs over contiguous memory; each column sees the
same operations in the same order as a line filtered alone.

``spline3_affine``'s contract is ``scipy.ndimage.map_coordinates(coef, [r, c], order=3, mode="mirror", prefilter=False)`` on
coefficients ``coef`` that ``scipy.ndimage.spline_filter(..., order=3, mode="mirror")`` made, restricted to points
inside the grid (0 <= r, c <= K - 1; a point outside gets 0), with the grid coordinates computed from detector
offsets in the kernel::

    r = (-(a10 x + a11 y) / lam) * mdy + centre
    c = (-(a00 x + a01 y) / lam) * mdx + centre

the same operations in the same order as ``MonoPSF._index`` (so r and c are bitwise its).  The value agrees with
map_coordinates to rounding (tests/unit/test_spline.py; the summation order of the 16 taps differs), and costs
a fraction of it: map_coordinates was a quarter of the defocus study's run (130 M points at 140 ns each).
"""
import math

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def _weights(t):
    """The four cubic B-spline weights of the taps floor - 1 .. floor + 2 at fraction t in [0, 1)."""
    s = 1.0 - t
    return s * s * s / 6.0, (4.0 - 6.0 * t * t + 3.0 * t * t * t) / 6.0, \
        (1.0 + 3.0 * t + 3.0 * t * t - 3.0 * t * t * t) / 6.0, t * t * t / 6.0


@numba.njit(cache=True, inline="always")
def _mirror(i, n):
    """scipy.ndimage's 'mirror' extension (d c b | a b c d | c b a) for an index at most n - 1 out of range."""
    if i < 0:
        return -i
    if i > n - 1:
        return 2 * (n - 1) - i
    return i


@numba.njit(cache=True, parallel=True)
def spline3_affine(coef, x, y, a00, a01, a10, a11, lam, mdx, mdy, centre, cell, out):
    """out[i] = max(spline(r_i, c_i), 0) / cell for the points (x[i], y[i]) (flat float64 arrays), 0 where
    (r_i, c_i) lies outside the grid.  coef: (K, K) C-contiguous spline coefficients."""
    ny, nx = coef.shape
    for i in numba.prange(x.shape[0]):
        fx = -(a00 * x[i] + a01 * y[i]) / lam
        fy = -(a10 * x[i] + a11 * y[i]) / lam
        r = mdy * fy + centre
        c = mdx * fx + centre
        if not (r >= 0.0 and c >= 0.0 and r <= ny - 1 and c <= nx - 1):
            out[i] = 0.0
            continue
        r0 = int(np.floor(r))
        c0 = int(np.floor(c))
        wr0, wr1, wr2, wr3 = _weights(r - r0)
        wc0, wc1, wc2, wc3 = _weights(c - c0)
        ca = _mirror(c0 - 1, nx)
        cb = _mirror(c0, nx)
        cc = _mirror(c0 + 1, nx)
        cd = _mirror(c0 + 2, nx)
        v = 0.0
        for k in range(4):
            rr = _mirror(r0 - 1 + k, ny)
            row = wc0 * coef[rr, ca] + wc1 * coef[rr, cb] + wc2 * coef[rr, cc] + wc3 * coef[rr, cd]
            v += (wr0 if k == 0 else wr1 if k == 1 else wr2 if k == 2 else wr3) * row
        out[i] = (v if v > 0.0 else 0.0) / cell


Z3 = -0.267949192431122706472553658494127633      # the cubic B-spline's pole, sqrt(3) - 2


@numba.njit(cache=True, parallel=True)
def spline_filter3(a):
    """Cubic B-spline coefficients of a 2-D array (mirror boundary), axis 0 then axis 1; a new float64 array."""
    c = np.empty(a.shape)
    ny, nx = a.shape
    z = Z3
    gain = (1.0 - z) * (1.0 - 1.0 / z)
    nb = (nx + 63) // 64
    # axis 0: the columns in blocks of 64, each block a row at a time
    for b in numba.prange(nb):
        j0 = b * 64
        j1 = min(nx, j0 + 64)
        for i in range(ny):
            for j in range(j0, j1):
                c[i, j] = a[i, j] * gain if ny > 1 else a[i, j]     # (an axis of length 1 is left alone)
        if ny > 1:
            zn1 = math.pow(z, ny - 1)
            for j in range(j0, j1):
                c[0, j] = c[0, j] + zn1 * c[ny - 1, j]
            zi = z
            for i in range(1, ny - 1):
                for j in range(j0, j1):
                    c[0, j] += zi * (c[i, j] + zn1 * c[ny - 1 - i, j])
                zi *= z
            for j in range(j0, j1):
                c[0, j] /= 1 - zn1 * zn1
            for i in range(1, ny):
                for j in range(j0, j1):
                    c[i, j] += z * c[i - 1, j]
            for j in range(j0, j1):
                c[ny - 1, j] = (z * c[ny - 2, j] + c[ny - 1, j]) * z / (z * z - 1)
            for i in range(ny - 2, -1, -1):
                for j in range(j0, j1):
                    c[i, j] = z * (c[i + 1, j] - c[i, j])
    # axis 1: each row alone
    if nx > 1:
        zn1 = math.pow(z, nx - 1)
        for i in numba.prange(ny):
            row = c[i]
            for j in range(nx):
                row[j] *= gain
            row[0] = row[0] + zn1 * row[nx - 1]
            zi = z
            for j in range(1, nx - 1):
                row[0] += zi * (row[j] + zn1 * row[nx - 1 - j])
                zi *= z
            row[0] /= 1 - zn1 * zn1
            for j in range(1, nx):
                row[j] += z * row[j - 1]
            row[nx - 1] = (z * row[nx - 2] + row[nx - 1]) * z / (z * z - 1)
            for j in range(nx - 2, -1, -1):
                row[j] = z * (row[j + 1] - row[j])
    return c
