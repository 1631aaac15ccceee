"""Exact synthetic images with known answers for the analysis tests (independent of the code under test)."""

from __future__ import annotations

import numpy as np
from scipy.special import j1
from scipy.stats import norm


def esf_antiderivative(u, sigma):
    """F(u) = integral of Phi(t / sigma) dt = u Phi(u/sigma) + sigma phi(u/sigma)."""
    return u * norm.cdf(u / sigma) + sigma * norm.pdf(u / sigma)


def esf_second_antiderivative(u, sigma):
    """G(u) = integral of F(t) dt = (u^2 + sigma^2)/2 Phi(u/sigma) + u sigma/2 phi(u/sigma)."""
    return 0.5 * (u**2 + sigma**2) * norm.cdf(u / sigma) + 0.5 * u * sigma * norm.pdf(u / sigma)


def pixel_esf(x, sigma):
    """ESF of a Gaussian edge seen through a 1-px box aperture along the normal: mean of Phi over [x-1/2, x+1/2]."""
    return esf_antiderivative(x + 0.5, sigma) - esf_antiderivative(x - 0.5, sigma)


def render_edge(shape, sigma, angle_deg=5.0, center=None, low=0.1, high=0.9):
    """Gaussian-blurred step edge integrated exactly over each pixel.

    The edge line passes through ``center`` (x, y) and is tilted ``angle_deg`` from the columns; its normal
    n = (cos a, sin a) points to the bright side. Pixel (row j, col i) covers [i-1/2, i+1/2] x [j-1/2, j+1/2].
    """
    h, w = shape
    cx, cy = center if center is not None else ((w - 1) / 2.0 + 0.21, (h - 1) / 2.0 - 0.13)
    a = np.radians(angle_deg)
    ca, sa = np.cos(a), np.sin(a)
    xs = np.arange(w)[None, :] - cx
    ys = np.arange(h)[:, None] - cy

    def g(dx, dy):
        return esf_second_antiderivative((xs + dx) * ca + (ys + dy) * sa, sigma)

    frac = (g(0.5, 0.5) - g(-0.5, 0.5) - g(0.5, -0.5) + g(-0.5, -0.5)) / (ca * sa)
    return low + (high - low) * frac


def box_integral_1d(edges_lo, edges_hi, x, sigma):
    """Mean over the pixel [x-1/2, x+1/2] of the blurred box Phi((t - lo)/s) - Phi((t - hi)/s)."""
    return (esf_antiderivative(x + 0.5 - edges_lo, sigma) - esf_antiderivative(x - 0.5 - edges_lo, sigma)
            - esf_antiderivative(x + 0.5 - edges_hi, sigma) + esf_antiderivative(x - 0.5 - edges_hi, sigma))


def render_patches(shape, sigma, n_patches, rng, size=(14, 30)):
    """Sum of random axis-aligned rectangles (random levels), Gaussian-blurred by sigma and pixel-integrated
    exactly (a blurred rectangle is separable)."""
    h, w = shape
    img = np.full(shape, 0.5)
    x = np.arange(w, dtype=np.float64)
    y = np.arange(h, dtype=np.float64)
    for _ in range(n_patches):
        sw, sh = rng.uniform(size[0], size[1], 2)
        x0 = rng.uniform(-sw / 2, w - sw / 2)
        y0 = rng.uniform(-sh / 2, h - sh / 2)
        level = rng.uniform(-0.35, 0.35)
        img += level * np.outer(box_integral_1d(y0, y0 + sh, y, sigma), box_integral_1d(x0, x0 + sw, x, sigma))
    return img


def render_airy(shape, lam_n_px, center, supersample=8):
    """Airy pattern I(r) = [2 J1(x)/x]^2, x = pi r / (lambda N) (r, lambda N in px), averaged over each pixel
    with ``supersample`` x ``supersample`` sub-samples. Peak 1; its integral over the plane is 4 (lambda N)^2 / pi."""
    h, w = shape
    off = (np.arange(supersample) + 0.5) / supersample - 0.5
    ys = (np.arange(h)[:, None] + off[None, :]).reshape(-1) - center[1]
    xs = (np.arange(w)[:, None] + off[None, :]).reshape(-1) - center[0]
    r = np.hypot(xs[None, :], ys[:, None])
    x = np.pi * r / lam_n_px
    with np.errstate(invalid="ignore", divide="ignore"):
        val = np.where(x > 1e-8, (2.0 * j1(x) / x) ** 2, 1.0)
    return val.reshape(h, supersample, w, supersample).mean(axis=(1, 3))


def _subpixel_grid(shape, supersample):
    h, w = shape
    off = (np.arange(supersample) + 0.5) / supersample - 0.5
    ys = (np.arange(h)[:, None] + off[None, :]).reshape(-1)
    xs = (np.arange(w)[:, None] + off[None, :]).reshape(-1)
    return np.meshgrid(xs, ys)


def _pixel_mean(values, shape, supersample):
    h, w = shape
    return values.reshape(h, supersample, w, supersample).mean(axis=(1, 3))


def render_ellipse(shape, center, semi_axes, angle_deg, supersample=16, value=1.0):
    """Uniform ellipse, anti-aliased by ``supersample`` x ``supersample`` coverage sampling per pixel."""
    X, Y = _subpixel_grid(shape, supersample)
    t = np.radians(angle_deg)
    dx, dy = X - center[0], Y - center[1]
    u = dx * np.cos(t) + dy * np.sin(t)
    v = -dx * np.sin(t) + dy * np.cos(t)
    inside = (u / semi_axes[0]) ** 2 + (v / semi_axes[1]) ** 2 <= 1.0
    return value * _pixel_mean(inside.astype(np.float64), shape, supersample)


def render_lambert_sphere(shape, center, radius, phase_deg, sun_azimuth_deg=30.0, supersample=8):
    """Lambert sphere seen along +z (towards the viewer), lit from a sun at phase angle ``phase_deg`` whose
    image-plane direction has azimuth ``sun_azimuth_deg``: radiance proportional to max(0, n . s)."""
    X, Y = _subpixel_grid(shape, supersample)
    px, py = (X - center[0]) / radius, (Y - center[1]) / radius
    rho2 = px**2 + py**2
    nz = np.sqrt(np.clip(1.0 - rho2, 0.0, None))
    a, b = np.radians(phase_deg), np.radians(sun_azimuth_deg)
    s = (np.sin(a) * np.cos(b), np.sin(a) * np.sin(b), np.cos(a))
    mu0 = np.where(rho2 <= 1.0, px * s[0] + py * s[1] + nz * s[2], 0.0)
    return _pixel_mean(np.clip(mu0, 0.0, None), shape, supersample)


def gaussian_mtf50_with_pixel(sigma):
    """Solve exp(-2 pi^2 sigma^2 f^2) |sinc(f)| = 0.5 for f (cycles/px)."""
    from scipy.optimize import brentq

    return brentq(lambda f: np.exp(-2 * np.pi**2 * sigma**2 * f**2) * np.abs(np.sinc(f)) - 0.5, 1e-6, 0.99)

