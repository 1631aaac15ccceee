"""Edge map, Zhuo & Sim defocus estimates and the matting-Laplacian propagation on exactly rendered scenes."""

import numpy as np
import pytest
from _analysis_synth import box_integral_1d, render_edge

from analysis import (AnalysisError, defocus_map, difference_map, edge_map, matting_laplacian,
                      sparse_defocus_map)

CONTRAST = 0.6
NOISE = CONTRAST / 100.0  # SNR 100 (edge contrast over noise standard deviation)


def _noisy_edge(sigma, seed):
    img = render_edge((256, 96), sigma, angle_deg=5.0, low=0.2, high=0.2 + CONTRAST)
    return img + np.random.default_rng(seed).normal(0.0, NOISE, img.shape)


@pytest.mark.parametrize("sigma", [1.0, 1.5, 2.0, 3.0, 4.0])
def test_zhuo_sim_sigma_on_an_edge(sigma):
    # ORACLES.md: about 5 % for 1 to 4 px blur at SNR >= 100. The median over the ~256 edge pixels is the estimate;
    # over 10 noise draws its mean error is -1.0 % and its scatter 0.6 % at 4 px (smaller below), so 5 % is safe.
    sparse, edges = sparse_defocus_map(_noisy_edge(sigma, seed=11))
    values = sparse[np.isfinite(sparse)]
    assert values.size > 200
    assert np.median(values) == pytest.approx(sigma, rel=0.05)


def test_zhuo_sim_is_exact_without_noise():
    # Without noise the only approximation is the Gaussian form of the pixel-integrated gradient profile.
    for sigma in (1.0, 2.5, 4.0):
        sparse, _ = sparse_defocus_map(render_edge((96, 96), sigma))
        assert np.nanmedian(sparse) == pytest.approx(sigma, rel=0.005)


def _tiles(shape, sigma, seed, tile=24, offset=12):
    """Mosaic of random-level square tiles (step patches), blurred by sigma and pixel-integrated exactly."""
    rng = np.random.default_rng(seed)
    h, w = shape
    x, y = np.arange(w, dtype=float), np.arange(h, dtype=float)
    img = np.zeros(shape)
    for y0 in np.arange(-offset, h, tile):
        for x0 in np.arange(-offset, w, tile):
            img += rng.uniform(0, 1) * np.outer(box_integral_1d(y0 - 0.5, y0 + tile - 0.5, y, sigma),
                                                box_integral_1d(x0 - 0.5, x0 + tile - 0.5, x, sigma))
    return img


@pytest.fixture(scope="module")
def two_region_scene():
    """Left half blurred by sigma 1.5, right half by 3 (same 24 px tiles, the seam inside a tile column), noise
    0.004 for tile steps of 0 to 1."""
    shape = (128, 128)
    img = _tiles(shape, 1.5, seed=0)
    img[:, 64:] = _tiles(shape, 3.0, seed=0)[:, 64:]
    return img + np.random.default_rng(100).normal(0.0, 0.004, shape)


@pytest.mark.parametrize("method", ["matting", "guided", "fgs"])
def test_two_region_defocus_map(two_region_scene, method):
    # Region medians within 15 % (the brief's tolerance; junction bias and propagation across the seam take a few
    # per cent). 8 px on each side of the seam are left out: the map needs about one tile to change level there.
    dmap = defocus_map(two_region_scene, method=method)
    assert dmap.shape == two_region_scene.shape and np.all(np.isfinite(dmap))
    assert np.median(dmap[:, :56]) == pytest.approx(1.5, rel=0.15)
    assert np.median(dmap[:, 72:]) == pytest.approx(3.0, rel=0.15)


def test_edge_map_finds_the_boundary_of_a_square():
    sigma = 1.0
    x = np.arange(64, dtype=float)
    img = np.outer(box_integral_1d(20.3, 44.3, x, sigma), box_integral_1d(15.6, 47.6, x, sigma))
    edges = edge_map(img)
    jj, ii = np.nonzero(edges)
    # distance of each edge pixel centre to the square's outline
    dx = np.minimum(np.abs(ii - 15.6), np.abs(ii - 47.6))
    dy = np.minimum(np.abs(jj - 20.3), np.abs(jj - 44.3))
    inside_x = (ii > 15.6) & (ii < 47.6)
    inside_y = (jj > 20.3) & (jj < 44.3)
    dist = np.where(inside_x & inside_y, np.minimum(dx, dy),
                    np.where(inside_x, dy, np.where(inside_y, dx, np.hypot(dx, dy))))
    assert np.all(dist <= 1.0)  # maxima lie within the pixel that straddles the edge
    assert edges.sum() > 0.9 * 2 * (32 + 24)  # the perimeter is covered (corners may be rounded off)
    assert not edge_map(img, high_threshold=1.01, low_threshold=1.0).any()


def test_matting_laplacian_properties():
    rng = np.random.default_rng(3)
    guide = rng.uniform(size=(9, 11))
    lap = matting_laplacian(guide, eps=1e-5)
    assert lap.shape == (99, 99)
    assert abs(lap - lap.T).max() < 1e-12
    assert np.abs(lap @ np.ones(99)).max() < 1e-10
    v = rng.normal(size=99)
    assert v @ (lap @ v) >= -1e-10
    # affine functions of the guide cost almost nothing (exactly nothing as eps -> 0)
    affine = 2.0 * guide.ravel() + 0.5
    assert affine @ (matting_laplacian(guide, eps=1e-9) @ affine) < 1e-6


def test_difference_map():
    a = np.arange(12.0).reshape(3, 4)
    b = np.full((3, 4), 2.0)
    np.testing.assert_array_equal(difference_map(a, b), a - 2.0)
    np.testing.assert_allclose(difference_map(a, b, relative=True), (a - 2.0) / 2.0)
    with pytest.raises(AnalysisError, match="different shapes"):
        difference_map(a, b[:, :3])


def test_conjugate_gradients_match_a_direct_solve():
    import scipy.sparse as sp
    from scipy.sparse.linalg import spsolve

    from analysis.defocus import _pcg

    rng = np.random.default_rng(4)
    lap = matting_laplacian(rng.uniform(size=(20, 24)))
    weight = (rng.uniform(size=lap.shape[0]) < 0.1).astype(float)
    a = (lap + sp.diags(weight)).tocsr()
    b = weight * rng.uniform(1, 3, lap.shape[0])
    direct = spsolve(a.tocsc(), b)
    inv_diag = 1.0 / a.diagonal()
    x = _pcg(a, b, np.zeros_like(b), lambda v: inv_diag * v, 1e-10, 5000)
    np.testing.assert_allclose(x, direct, rtol=1e-6, atol=1e-8)
    with pytest.warns(RuntimeWarning, match="stopped after 3 iterations"):
        _pcg(a, b, np.zeros_like(b), lambda v: v, 1e-12, 3)
