"""Samplers against their densities: chi-square on binned directions, Lambert cone share, HG moments.

Random numbers come from the project's Philox (fixed seeds), so every test is deterministic. The expected
bin probabilities are integrals of the module's own pdf functions (scipy.integrate.quad), which are in turn
checked against analytic normalisations; a chi-square p-value below alpha = 0.01 fails.
"""
import math

import numba
import numpy as np
import pytest
from scipy import integrate, stats

from irtlang.kernels import sampling as S
from irtlang.kernels.rng import uniform2_array

ALPHA = 0.01
N = 400_000


def uniforms(n, seed):
    u = uniform2_array(seed, 0, n, 0, 0)
    return u[:, 0].copy(), u[:, 1].copy()


@numba.njit(cache=True)
def _directions(kind, u0, u1, p):
    n = u0.shape[0]
    out = np.empty((n, 3))
    for i in range(n):
        if kind == 0:
            x, y, z = S.cosine_hemisphere(u0[i], u1[i])
        elif kind == 1:
            x, y, z = S.uniform_cone(u0[i], u1[i], p)
        elif kind == 2:
            x, y, z = S.lambert_cone(u0[i], u1[i], p)
        else:
            x, y, z = S.uniform_sphere(u0[i], u1[i])
        out[i, 0] = x
        out[i, 1] = y
        out[i, 2] = z
    return out


@numba.njit(cache=True)
def _disk(u0, u1):
    n = u0.shape[0]
    out = np.empty((n, 2))
    for i in range(n):
        out[i, 0], out[i, 1] = S.uniform_disk(u0[i], u1[i])
    return out


@numba.njit(cache=True)
def _hg(u, g):
    out = np.empty(u.shape[0])
    for i in range(u.shape[0]):
        out[i] = S.hg_sample(u[i], g)
    return out


def chi2_directions(dirs, pdf_of_cos, cos_lo, cos_hi, n_theta=20, n_phi=12):
    """Chi-square of (cos theta, phi) bins; expected = 2 pi/n_phi * integral of pdf(cos) d(cos)."""
    cos_t = dirs[:, 2]
    phi = np.arctan2(dirs[:, 1], dirs[:, 0]) % (2 * math.pi)
    edges_c = np.linspace(cos_lo, cos_hi, n_theta + 1)
    edges_p = np.linspace(0, 2 * math.pi, n_phi + 1)
    h, _, _ = np.histogram2d(cos_t, phi, bins=[edges_c, edges_p])
    prob_c = np.array([integrate.quad(pdf_of_cos, a, b, epsabs=1e-14, epsrel=1e-12)[0]
                       for a, b in zip(edges_c[:-1], edges_c[1:])])
    expected = np.outer(prob_c * 2 * math.pi / n_phi, np.ones(n_phi)) * len(dirs)
    assert expected.sum() == pytest.approx(len(dirs), rel=1e-9)  # the pdf integrates to 1
    return stats.chisquare(h.ravel(), expected.ravel()).pvalue


def test_all_unit_and_finite():
    u0, u1 = uniforms(50_000, 1)
    u0 = np.concatenate([u0, [0.0, 1.0, 0.5, 0.0, 1.0]])
    u1 = np.concatenate([u1, [0.0, 1.0, 0.5, 1.0, 0.0]])
    for kind, p in [(0, 0.0), (1, 0.3), (1, 1 - 1e-12), (2, 0.2), (2, 1.0), (3, 0.0)]:
        d = _directions(kind, u0, u1, p)
        assert np.all(np.isfinite(d))
        assert np.allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-15)
        if kind in (0, 1, 2):
            assert np.all(d[:, 2] >= 0)


def test_cosine_hemisphere_chi2():
    u0, u1 = uniforms(N, 11)
    d = _directions(0, u0, u1, 0.0)
    p = chi2_directions(d, lambda c: S.cosine_hemisphere_pdf(c), 0.0, 1.0)
    assert p > ALPHA


@pytest.mark.parametrize("cos_max", [0.0, 0.8, math.cos(4.6e-4 / 2)])
def test_uniform_cone_chi2(cos_max):
    u0, u1 = uniforms(N, 12)
    d = _directions(1, u0, u1, cos_max)
    assert d[:, 2].min() >= cos_max
    pdf = S.uniform_cone_pdf(cos_max)
    if cos_max > 0.99:
        # tiny cone (the Earth seen from 0.18 AU): test sin^2(theta) / sin^2(max) ~ U(0, 1), from the
        # direction's transverse components (no cancellation)
        s2 = (d[:, 0] ** 2 + d[:, 1] ** 2) / ((1 - cos_max) * (1 + cos_max))
        counts, _ = np.histogram(s2, bins=50, range=(0, 1))
        assert stats.chisquare(counts).pvalue > ALPHA
        assert s2.max() <= 1.0 + 1e-9
        return
    p = chi2_directions(d, lambda c: pdf, cos_max, 1.0)
    assert p > ALPHA


@pytest.mark.parametrize("sin_max", [0.1, 0.5, 0.9, 1.0])
def test_lambert_cone_chi2(sin_max):
    u0, u1 = uniforms(N, 13)
    d = _directions(2, u0, u1, sin_max)
    cos_min = math.sqrt(1 - sin_max ** 2)
    assert d[:, 2].min() >= cos_min - 1e-15
    p = chi2_directions(d, lambda c: S.lambert_cone_pdf(c, sin_max), cos_min, 1.0)
    assert p > ALPHA


def test_uniform_sphere_chi2():
    u0, u1 = uniforms(N, 14)
    d = _directions(3, u0, u1, 0.0)
    p = chi2_directions(d, lambda c: S.uniform_sphere_pdf(), -1.0, 1.0)
    assert p > ALPHA


def test_uniform_disk_chi2():
    u0, u1 = uniforms(N, 15)
    xy = _disk(u0, u1)
    r2 = (xy ** 2).sum(axis=1)
    assert r2.max() <= 1.0 + 1e-15
    # equal-area bins: r^2 in 10 rings x 16 sectors, each of probability 1/160 (density 1/pi)
    phi = np.arctan2(xy[:, 1], xy[:, 0]) % (2 * math.pi)
    h, _, _ = np.histogram2d(r2, phi, bins=[np.linspace(0, 1, 11), np.linspace(0, 2 * math.pi, 17)])
    assert stats.chisquare(h.ravel()).pvalue > ALPHA
    assert S.uniform_disk_pdf() * math.pi == pytest.approx(1.0)


@pytest.mark.parametrize("t_deg", [10.0, 30.0, 45.0, 60.0, 80.0])
def test_lambert_cone_share(t_deg):
    """ORACLES.md: a Lambertian emitter's flux share inside half-angle t is sin^2 t."""
    n = 1_000_000
    u0, u1 = uniforms(n, 21)
    d = _directions(0, u0, u1, 0.0)
    share = np.mean(d[:, 2] >= math.cos(math.radians(t_deg)))
    expect = math.sin(math.radians(t_deg)) ** 2
    se = math.sqrt(expect * (1 - expect) / n)
    assert abs(share - expect) < 5 * se
    # and lambert_cone's own density, integrated over its cone, carries exactly that share of the full
    # Lambertian density: pdf_cone * sin^2 t == pdf_hemisphere
    c = 0.77
    sm = math.sin(math.radians(t_deg))
    assert S.lambert_cone_pdf(c, sm) * sm ** 2 == pytest.approx(S.cosine_hemisphere_pdf(c), rel=1e-15)


def hg_cdf(m, g):
    """Independent: integral of HG over mu from -1 to m (azimuth integrated)."""
    if g == 0:
        return (m + 1) / 2
    return (1 - g * g) / (2 * g) * (1 / math.sqrt(1 + g * g - 2 * g * m) - 1 / (1 + g))


@pytest.mark.parametrize("g", [0.85, 0.7, 0.3, 1e-7, 0.0, -0.4, -0.9])
def test_hg(g):
    n = 1_000_000
    u0, _ = uniforms(n, 31)
    mu = _hg(u0, g)
    assert np.all(np.isfinite(mu)) and mu.min() >= -1 and mu.max() <= 1
    # mean cosine = g within 5 standard errors
    se = mu.std() / math.sqrt(n)
    assert abs(mu.mean() - g) < 5 * se
    # chi-square against the CDF, in bins of equal probability
    edges = np.linspace(-1, 1, 41)
    probs = np.diff([hg_cdf(m, g) for m in edges])
    counts, _ = np.histogram(mu, bins=edges)
    assert stats.chisquare(counts, probs * n / probs.sum()).pvalue > ALPHA
    # the pdf (per steradian) integrates to 1 and matches the CDF's derivative
    tot = integrate.quad(lambda m: 2 * math.pi * S.hg_pdf(m, g), -1, 1, epsrel=1e-12)[0]
    assert tot == pytest.approx(1.0, rel=1e-9)
    for m in (-0.5, 0.2, 0.9):
        if abs(g) > 1e-3:
            h = 1e-6
            deriv = (hg_cdf(m + h, g) - hg_cdf(m - h, g)) / (2 * h)
            assert 2 * math.pi * S.hg_pdf(m, g) == pytest.approx(deriv, rel=1e-6)
        else:  # first order in g: (1 + 3 g mu) / (4 pi)
            assert S.hg_pdf(m, g) * 4 * math.pi == pytest.approx(1 + 3 * g * m, abs=10 * g * g + 1e-15)
    # inverse CDF agrees with ORACLES.md's formula
    if abs(g) > 1e-3:
        for u in (0.01, 0.3, 0.5, 0.77, 0.999):
            ref = (1 + g * g - ((1 - g * g) / (1 - g + 2 * g * u)) ** 2) / (2 * g)
            assert S.hg_sample(u, g) == pytest.approx(ref, abs=1e-13)
    assert S.hg_sample(0.0, g) == -1.0
    assert S.hg_sample(1.0, g) == 1.0


def test_hg_direction_mean_cosine():
    n = 200_000
    u0, u1 = uniforms(n, 41)
    d_in = np.array([0.3, -0.5, 0.8])
    d_in /= np.linalg.norm(d_in)
    g = 0.6

    @numba.njit
    def run(u0, u1, g, dx, dy, dz):
        out = np.empty((u0.shape[0], 3))
        for i in range(u0.shape[0]):
            out[i, 0], out[i, 1], out[i, 2] = S.hg_direction(u0[i], u1[i], g, dx, dy, dz)
        return out

    d = run(u0, u1, g, *d_in)
    cosines = d @ d_in
    assert abs(cosines.mean() - g) < 5 * cosines.std() / math.sqrt(n)
    assert np.allclose(np.linalg.norm(d, axis=1), 1, atol=1e-15)
    # no preferred azimuth: the mean transverse component vanishes
    trans = d - np.outer(cosines, d_in)
    assert np.all(np.abs(trans.mean(axis=0)) < 5 * trans.std(axis=0) / math.sqrt(n))


def test_onb():
    rng = np.random.default_rng(3)
    normals = list(rng.normal(size=(2000, 3)))
    normals += [np.array(v, float) for v in [(0, 0, 1), (0, 0, -1), (1, 0, 0), (0, -1, 0),
                                              (1e-20, 0, -1), (0, 1e-12, -1), (0, 0, -0.0 + 1e-300),
                                              (3e-9, -2e-9, -1), (1e12, 2e12, -3e12)]]
    for n in normals:
        t1x, t1y, t1z, t2x, t2y, t2z = S.onb(*n)
        t1 = np.array([t1x, t1y, t1z])
        t2 = np.array([t2x, t2y, t2z])
        m = np.abs(n).max()
        nu = (n / m) / np.linalg.norm(n / m)
        basis = np.stack([t1, t2, nu])
        assert np.allclose(basis @ basis.T, np.eye(3), atol=2e-15)
        assert np.allclose(np.cross(t1, t2), nu, atol=2e-15)
    # to_frame maps +z to n
    assert np.allclose(S.to_frame(0.0, 0.0, 1.0, 1.0, 2.0, 2.0), np.array([1, 2, 2]) / 3, atol=1e-16)


def test_systematic_roulette_keeps_each_candidate_with_its_probability():
    """sampling.systematic_keep against the definition of Russian roulette: over the sequence's uniform u0 each
    candidate must survive with exactly its probability p_k (here u0 on a midpoint grid of 100,000 values: the
    frequency of an interval of length p_k mod 1 is p_k to within 1e-5), and for every u0 the number of survivors
    of the first k candidates must be the floor or the ceiling of p_1 + ... + p_k (independent draws give any
    number from 0 to k).  The oracle is the roulette's own definition, not the code's."""
    rng = np.random.default_rng(5)
    p = np.concatenate([rng.uniform(0.0, 1.0, 40), [0.0, 0.999999, 1e-9, 0.5, 0.5]])
    n = 100_000
    u0s = (np.arange(n) + 0.5) / n
    kept = np.zeros((n, p.size), bool)
    for a, u0 in enumerate(u0s):
        total = 0.0
        for k, pk in enumerate(p):
            kept[a, k], total = S.systematic_keep(total, pk, u0)
    assert np.all(np.abs(kept.mean(0) - p) <= 1.5 / n), np.abs(kept.mean(0) - p).max()
    counts = np.cumsum(kept, axis=1)
    sums = np.cumsum(p)
    assert np.all(counts >= np.floor(sums - 1e-9)) and np.all(counts <= np.ceil(sums + 1e-9))
