"""irtlang.kernels.spline against its oracle, scipy.ndimage.map_coordinates (order 3, mirror, on coefficients from
ndimage.spline_filter), at points given by MonoPSF's affine map: rotated and sheared maps, points inside, on the
edges (r, c = 0 and K - 1, integers) and outside the grid (0 there), negative coefficients (clipped at 0)."""
import numpy as np
import pytest
from scipy import ndimage

from irtlang.kernels.spline import spline3_affine


def _reference(coef, x, y, a, lam, mdx, mdy, centre, cell):
    fx = -(a[0] * x + a[1] * y) / lam
    fy = -(a[2] * x + a[3] * y) / lam
    r, c = mdy * fy + centre, mdx * fx + centre
    K = coef.shape[0]
    v = ndimage.map_coordinates(coef, [r, c], order=3, mode="mirror", prefilter=False)
    v = np.where((r >= 0) & (c >= 0) & (r <= K - 1) & (c <= K - 1), v, 0.0)
    return np.clip(v, 0.0, None) / cell, r, c


@pytest.mark.parametrize("seed", range(6))
def test_spline3_affine_is_map_coordinates(seed):
    rng = np.random.default_rng(seed)
    K = int(rng.integers(5, 60))
    img = rng.random((K, K)) ** 3 - (0.2 if seed % 2 else 0.0)          # odd seeds: negative samples too
    coef = np.ascontiguousarray(ndimage.spline_filter(img, order=3, mode="mirror"))
    lam, centre = 5e-7, (K - 1) / 2
    th = rng.uniform(0, 2 * np.pi) if seed > 1 else 0.0
    s = rng.uniform(0.5, 2.0)
    a = (s * np.cos(th), -s * np.sin(th) + (0.1 if seed == 5 else 0.0), s * np.sin(th), s * np.cos(th))
    mdx, mdy = rng.uniform(0.5, 2) * lam, rng.uniform(0.5, 2) * lam
    n = 4000
    x, y = rng.uniform(-0.8, 0.8, n) * K, rng.uniform(-0.8, 0.8, n) * K
    out = np.empty(n)
    spline3_affine(coef, x, y, *a, lam, mdx, mdy, centre, 2.5, out)
    ref, r, c = _reference(coef, x, y, a, lam, mdx, mdy, centre, 2.5)
    inside = (r >= 0) & (c >= 0) & (r <= K - 1) & (c <= K - 1)
    assert 0 < inside.sum() < n                 # both kinds of points are tested
    assert np.all(out[~inside] == 0)
    assert np.allclose(out, ref, rtol=1e-12, atol=1e-13 * np.abs(ref).max())


def test_spline3_affine_on_the_grid_and_its_edges():
    """At the grid's own nodes (integer r, c, the edges included) the spline interpolates the samples."""
    rng = np.random.default_rng(9)
    K = 17
    img = rng.random((K, K))
    coef = np.ascontiguousarray(ndimage.spline_filter(img, order=3, mode="mirror"))
    jj, ii = np.meshgrid(np.arange(K), np.arange(K), indexing="ij")
    # identity map: a = (-1, 0, 0, -1), lam = mdx = mdy = 1, centre 0 -> r = y, c = x
    out = np.empty(K * K)
    spline3_affine(coef, ii.ravel().astype(float), jj.ravel().astype(float), -1.0, 0.0, 0.0, -1.0, 1.0, 1.0, 1.0,
                   0.0, 1.0, out)
    assert np.allclose(out.reshape(K, K), img, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (6, 1), (2, 2), (2, 9), (9, 3), (64, 65), (130, 70), (257, 257)])
def test_spline_filter3_is_ndimage_spline_filter(shape):
    """The coefficients against scipy.ndimage.spline_filter(order=3, mode='mirror'), the same recursive filter:
    equal to rounding (in practice bit for bit) for every shape, axes of length 1 and 2 and column blocks that do
    not fill 64 included; and interpolating with them reproduces the samples."""
    from irtlang.kernels.spline import spline_filter3

    a = np.random.default_rng(sum(shape)).random(shape) - 0.3
    ref = ndimage.spline_filter(a, order=3, mode="mirror")
    got = spline_filter3(a)
    assert got.shape == ref.shape and got.dtype == np.float64
    assert np.allclose(got, ref, rtol=1e-13, atol=1e-13)
    back = ndimage.map_coordinates(got, np.indices(shape).reshape(2, -1), order=3, mode="mirror", prefilter=False)
    assert np.allclose(back.reshape(shape), a, atol=1e-12)
