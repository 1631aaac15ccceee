"""Point-spread-function figures from images and from ray records: FWHM, encircled and ensquared energy, RMS
radius, centroid, Strehl ratio, first dark ring."""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from ..core.checks import AnalysisError, as_image, check_finite, positive

__all__ = [
    "centroid", "peak_value", "radial_profile", "encircled_energy", "ensquared_energy", "psf_metrics",
    "encircled_energy_rays", "psf_metrics_rays",
]

_HALF_DIAGONAL = np.sqrt(0.5)  # a pixel lies entirely on one side of a circle whose radius differs by more


def centroid(image):
    """Intensity-weighted centroid ``(x, y)`` of an image, in px (pixel (row j, col i) has its centre at
    x = i, y = j).

    Signature: ``centroid(image) -> (x, y)``.
    """
    img = as_image(image)
    total = img.sum()
    if total <= 0:
        raise AnalysisError("image has no positive total signal")
    h, w = img.shape
    return float(img.sum(axis=0) @ np.arange(w) / total), float(img.sum(axis=1) @ np.arange(h) / total)


def peak_value(image):
    """Sub-pixel peak value: least-squares quadratic surface over the 3 x 3 pixels around the brightest pixel,
    evaluated at its stationary point if that is a maximum within 1 px; otherwise the brightest pixel value.

    Signature: ``peak_value(image) -> float``.
    """
    img = as_image(image)
    j, i = np.unravel_index(np.argmax(img), img.shape)
    best = float(img[j, i])
    if not (0 < j < img.shape[0] - 1 and 0 < i < img.shape[1] - 1):
        return best
    dy, dx = np.mgrid[-1:2, -1:2]
    dx, dy = dx.ravel().astype(np.float64), dy.ravel().astype(np.float64)
    design = np.column_stack([np.ones(9), dx, dy, dx * dx, dy * dy, dx * dy])
    c0, cx, cy, cxx, cyy, cxy = np.linalg.lstsq(design, img[j - 1:j + 2, i - 1:i + 2].ravel(), rcond=None)[0]
    hess = np.array([[2 * cxx, cxy], [cxy, 2 * cyy]])
    if np.linalg.det(hess) <= 0 or hess[0, 0] >= 0:
        return best
    x0, y0 = np.linalg.solve(hess, [-cx, -cy])
    if abs(x0) > 1 or abs(y0) > 1:
        return best
    return max(best, float(c0 + cx * x0 + cy * y0 + cxx * x0 * x0 + cyy * y0 * y0 + cxy * x0 * y0))


def _resolve_center(img, center):
    if center is None or (isinstance(center, str) and center == "centroid"):
        return centroid(img)
    if isinstance(center, str):
        raise AnalysisError(f"center must be None, 'centroid' or (x, y) in px, got {center!r}")
    cx, cy = (float(v) for v in center)
    if not (np.isfinite(cx) and np.isfinite(cy)):
        raise AnalysisError(f"center must be finite, got {center!r}")
    return cx, cy


def _pixel_radii(shape, cx, cy):
    h, w = shape
    return np.hypot(np.arange(w)[None, :] - cx, np.arange(h)[:, None] - cy)


def radial_profile(image, pixel_pitch=1.0, *, center=None, bin_width=0.5):
    """Azimuthally averaged profile.

    Signature: ``radial_profile(image, pixel_pitch=1.0, *, center=None, bin_width=0.5) -> (radius, profile, counts)``.

    Pixels are grouped by the distance of their centres from ``center`` ((x, y) in px; default the centroid) in
    annuli ``bin_width`` px wide; ``profile`` is the mean pixel value per non-empty annulus and ``radius`` the
    mean distance of its pixels, in units of ``pixel_pitch``.
    """
    img = as_image(image)
    pitch = positive(pixel_pitch, "pixel_pitch")
    cx, cy = _resolve_center(img, center)
    r = _pixel_radii(img.shape, cx, cy).ravel()
    k = np.floor(r / positive(bin_width, "bin_width")).astype(np.int64)
    counts = np.bincount(k)
    ok = counts > 0
    rsum = np.bincount(k, weights=r)[ok]
    vsum = np.bincount(k, weights=img.ravel())[ok]
    return rsum / counts[ok] * pitch, vsum / counts[ok], counts[ok]


class _EnergyInCircles:
    """Energy inside circles about (cx, cy): pixels entirely inside are summed exactly (sorted cumulative sum);
    pixels the circle crosses are split into ``supersample`` x ``supersample`` sub-pixels."""

    def __init__(self, img, cx, cy, supersample):
        self.img = img
        r = _pixel_radii(img.shape, cx, cy).ravel()
        self.order = np.argsort(r, kind="stable")
        self.r_sorted = r[self.order]
        self.cum = np.concatenate([[0.0], np.cumsum(img.ravel()[self.order])])
        n = int(supersample)
        if n < 1:
            raise AnalysisError("supersample must be >= 1")
        off = (np.arange(n) + 0.5) / n - 0.5
        self.sub_dx, self.sub_dy = (a.ravel() for a in np.meshgrid(off, off))
        self.cx, self.cy = cx, cy
        self.r_max = float(self.r_sorted[-1]) + _HALF_DIAGONAL

    def __call__(self, radius):
        lo = np.searchsorted(self.r_sorted, radius - _HALF_DIAGONAL, side="right")
        hi = np.searchsorted(self.r_sorted, radius + _HALF_DIAGONAL, side="right")
        idx = self.order[lo:hi]
        jj, ii = np.unravel_index(idx, self.img.shape)
        sx = ii[:, None] + self.sub_dx[None, :] - self.cx
        sy = jj[:, None] + self.sub_dy[None, :] - self.cy
        frac = (sx * sx + sy * sy <= radius * radius).mean(axis=1)
        return float(self.cum[lo] + self.img.ravel()[idx] @ frac)


def _total(img, total):
    t = float(img.sum()) if total is None else positive(total, "total")
    if t <= 0:
        raise AnalysisError("image has no positive total signal")
    return t


def encircled_energy(image, pixel_pitch=1.0, radii=None, *, center=None, total=None, supersample=10):
    """Encircled-energy curve.

    Signature: ``encircled_energy(image, pixel_pitch=1.0, radii=None, *, center=None, total=None, supersample=10)
    -> (radii, fraction)``.

    ``fraction[k]`` is the energy inside the circle of radius ``radii[k]`` (unit of ``pixel_pitch``) about
    ``center`` ((x, y) in px, default the centroid), divided by ``total`` (default: the image sum; pass the known
    total when the image truncates the wings). Each pixel is a uniform square; pixels the circle crosses are split
    into ``supersample`` x ``supersample`` sub-pixels, so the curve is continuous and sub-pixel accurate.
    Default radii: 0 to the farthest pixel in steps of 0.25 px.
    """
    img = as_image(image)
    pitch = positive(pixel_pitch, "pixel_pitch")
    cx, cy = _resolve_center(img, center)
    ee = _EnergyInCircles(img, cx, cy, supersample)
    if radii is None:
        radii_px = np.arange(0.0, ee.r_max + 0.25, 0.25)
    else:
        radii_px = np.asarray(radii, dtype=np.float64).reshape(-1) / pitch
        check_finite(radii_px, "radii")
    t = _total(img, total)
    return radii_px * pitch, np.array([ee(r) for r in radii_px]) / t


def ensquared_energy(image, pixel_pitch=1.0, half_widths=None, *, center=None, total=None):
    """Ensquared-energy curve: energy inside the axis-aligned square of half-width ``half_widths[k]`` (unit of
    ``pixel_pitch``; the square's side is twice that) about ``center`` (default the centroid), divided by
    ``total`` (default the image sum). Exact for uniform square pixels (the pixel/square overlap is separable).
    Default half-widths: 0 to the largest useful one in steps of 0.25 px. Returns ``(half_widths, fraction)``.

    Signature: ``ensquared_energy(image, pixel_pitch=1.0, half_widths=None, *, center=None,
    total=None) -> (half_widths, fraction)``.
    """
    img = as_image(image)
    pitch = positive(pixel_pitch, "pixel_pitch")
    cx, cy = _resolve_center(img, center)
    h, w = img.shape
    if half_widths is None:
        hw = np.arange(0.0, max(cx + 0.5, w - 0.5 - cx, cy + 0.5, h - 0.5 - cy) + 0.25, 0.25)
    else:
        hw = np.asarray(half_widths, dtype=np.float64).reshape(-1) / pitch
        check_finite(hw, "half_widths")

    def overlap(n, c, half):  # length of [k - 1/2, k + 1/2] inside [c - half, c + half], shape (len(half), n)
        k = np.arange(n)[None, :]
        return np.clip(np.minimum(k + 0.5, c + half[:, None]) - np.maximum(k - 0.5, c - half[:, None]), 0, None)

    energy = np.einsum("kj,ji,ki->k", overlap(h, cy, hw), img, overlap(w, cx, hw))
    return hw * pitch, energy / _total(img, total)


def _fwhm_radius(r, p, peak):
    """Radius (px) where the profile first drops below peak/2, linear interpolation (from (0, peak) if needed)."""
    below = np.nonzero(p < 0.5 * peak)[0]
    if below.size == 0:
        return None, None
    i = below[0]
    r0, p0 = (r[i - 1], p[i - 1]) if i > 0 else (0.0, peak)
    return float(np.interp(0.5 * peak, [p[i], p0], [r[i], r0])), i


def _first_ring(r, p, start, peak, min_rise):
    """Radius (px) of the first local minimum of the profile at or after index ``start`` that is followed, before
    twice its radius, by a rise of at least ``min_rise * peak``; parabolic vertex through the three bins."""
    for i in range(max(start, 1), p.size - 1):
        if not (p[i] <= p[i - 1] and p[i] <= p[i + 1]):
            continue
        ahead = p[i + 1:][r[i + 1:] <= 2.0 * r[i]]
        if ahead.size and ahead.max() - p[i] >= min_rise * peak:
            x, y = r[i - 1:i + 2], p[i - 1:i + 2]
            a, b, _ = np.polyfit(x, y, 2)
            return float(np.clip(-b / (2 * a), x[0], x[2])) if a > 0 else float(r[i])
    return None


def psf_metrics(image, pixel_pitch=1.0, *, reference=None, center=None, total=None, bin_width=0.5,
                ee_fraction=0.8, supersample=10, ring_min_rise=0.002):
    """Figures of merit of a PSF image.

    Signature: ``psf_metrics(image, pixel_pitch=1.0, *, reference=None, center=None, total=None, bin_width=0.5,
    ee_fraction=0.8, supersample=10, ring_min_rise=0.002) -> dict``.

    Lengths are in the unit of ``pixel_pitch`` (e.g. um); pixel (row j, col i) has its centre at
    ``(i, j) * pixel_pitch``. Subtract any background first: every figure uses the raw pixel values.

    Keys
    ----
    centroid : (x, y), the intensity-weighted centroid.
    peak : the sub-pixel peak value (:func:`peak_value`), image units.
    total : the total energy used for normalisation (``total`` or the image sum).
    fwhm : full width at half maximum, ``2 r_half`` where ``r_half`` is where the azimuthally averaged profile
        (:func:`radial_profile` about ``center``, default the centroid, annuli ``bin_width`` px) first falls below
        ``peak / 2``, linearly interpolated between annuli. Meaningful for a well-sampled core (FWHM >~ 3 px).
    ee80_diameter : diameter of the circle about the centre holding ``ee_fraction`` (0.8) of ``total``
        (:func:`encircled_energy`, sub-pixel; root-found). None if the image holds less than that.
    ee50_diameter : the same for half the energy.
    rms_radius : ``sqrt(sum I r^2 / sum I)`` about the centroid (sensitive to noise in the wings).
    ring_diameter : diameter of the first dark ring: the first local minimum of the azimuthally averaged profile
        beyond the half-maximum radius that is followed (before twice its radius) by a rise of at least
        ``ring_min_rise * peak``; parabolic sub-bin vertex. Airy pattern: 2.4393 lambda N. None when the profile
        has no such minimum (e.g. a Gaussian, or a defocused PSF: use ee80_diameter for its size).
    strehl : ``(peak / total) / (peak_ref / total_ref)`` when ``reference`` is given: a reference PSF image on the
        same pixel grid (diffraction-limited, any normalisation; same peak and total estimators) or a number, the
        reference's peak-to-total ratio ``peak_ref / total_ref`` in 1/px. None without a reference.
    """
    img = as_image(image)
    pitch = positive(pixel_pitch, "pixel_pitch")
    t = _total(img, total)
    cx0, cy0 = centroid(img)
    cx, cy = _resolve_center(img, center)
    peak = peak_value(img)

    r, p, _ = radial_profile(img, 1.0, center=(cx, cy), bin_width=bin_width)
    r_half, i_half = _fwhm_radius(r, p, peak)
    ring = _first_ring(r, p, i_half, peak, ring_min_rise) if i_half is not None else None

    ee = _EnergyInCircles(img, cx, cy, supersample)

    def ee_diameter(fraction):
        target = fraction * t
        if ee(ee.r_max) < target:
            return None
        return 2.0 * brentq(lambda rad: ee(rad) - target, 0.0, ee.r_max, xtol=1e-6) * pitch

    rr = _pixel_radii(img.shape, cx0, cy0)
    strehl = None
    if reference is not None:
        if np.ndim(reference) == 0:
            ref_ratio = positive(reference, "reference")
        else:
            ref = as_image(reference, "reference")
            ref_ratio = peak_value(ref) / _total(ref, None)
        strehl = peak / t / ref_ratio
    return {
        "centroid": (cx0 * pitch, cy0 * pitch),
        "peak": peak,
        "total": t,
        "fwhm": None if r_half is None else 2.0 * r_half * pitch,
        "ee80_diameter": ee_diameter(ee_fraction),
        "ee50_diameter": ee_diameter(0.5),
        "rms_radius": float(np.sqrt((img * rr * rr).sum() / img.sum())) * pitch,
        "ring_diameter": None if ring is None else 2.0 * ring * pitch,
        "strehl": strehl,
    }


def _rays(x, y, w):
    x = np.asarray(x, dtype=np.float64).reshape(-1)
    y = np.asarray(y, dtype=np.float64).reshape(-1)
    w = np.ones_like(x) if w is None else np.asarray(w, dtype=np.float64).reshape(-1)
    if not (x.shape == y.shape == w.shape):
        raise AnalysisError(f"x, y and w must have one length, got {x.shape}, {y.shape}, {w.shape}")
    for arr, name in ((x, "x"), (y, "y"), (w, "w")):
        check_finite(arr, name)
    if x.size == 0:
        raise AnalysisError("no rays")
    if np.any(w < 0) or w.sum() <= 0:
        raise AnalysisError("ray weights must be >= 0 with a positive sum")
    return x, y, w


def _weighted_mean_se(v, w):
    """Weighted mean sum(w v)/sum(w) and its standard error sqrt(sum w^2 (v - mean)^2) / sum(w) (rays independent,
    the ratio estimator linearised)."""
    sw = w.sum()
    m = float(w @ v / sw)
    return m, float(np.sqrt(np.sum(w * w * (v - m) ** 2)) / sw)


def encircled_energy_rays(x, y, w=None, radii=None, *, center=None):
    """Encircled energy of ray records with standard errors.

    Signature: ``encircled_energy_rays(x, y, w=None, radii=None, *, center=None) -> (radii, fraction, stderr)``.

    ``fraction = sum(w [r < R]) / sum(w)`` about ``center`` (x, y) (default the weighted centroid); the weighted
    binomial standard error is ``sqrt(sum w^2 ([r < R] - fraction)^2) / sum(w)`` (equal weights:
    ``sqrt(p (1 - p) / N)``). Units: those of x and y. Default radii: 200 steps up to the farthest ray.
    """
    x, y, w = _rays(x, y, w)
    cx, cy = (_weighted_mean_se(x, w)[0], _weighted_mean_se(y, w)[0]) if center is None else map(float, center)
    r = np.hypot(x - cx, y - cy)
    radii = np.linspace(0.0, r.max(), 201) if radii is None else np.asarray(radii, dtype=np.float64).reshape(-1)
    inside = (r[None, :] < radii[:, None]).astype(np.float64)
    out = [_weighted_mean_se(row, w) for row in inside]
    return radii, np.array([o[0] for o in out]), np.array([o[1] for o in out])


def _weighted_quantile(sorted_r, cum_fraction, q):
    return float(np.interp(np.clip(q, 0.0, 1.0), cum_fraction, sorted_r))


def _standard_error(s1, s2, n):
    """Standard error of a sum of n independent per-source-ray contributions with sums s1 and s2 (squares): the
    formula of irtlang's tracer (irtlang.tracer.standard_error), so that a total has one standard error."""
    if n <= 1:
        return 0.0
    return float(np.sqrt(max(s2 / n - (s1 / n) ** 2, 0.0) * n * n / (n - 1)))


def psf_metrics_rays(x, y, w=None, *, center=None, ee_fraction=0.8, n_traced=None):
    """PSF figures of ray records (positions x, y on the detector plane, weights/fluxes w), with standard errors.

    Signature: ``psf_metrics_rays(x, y, w=None, *, center=None, ee_fraction=0.8) -> dict``. Lengths are in the
    unit of x and y. Rays are treated as independent weighted samples.

    Keys: ``n_rays``; ``total`` = sum(w) and ``total_se``: with ``n_traced`` (the source rays traced, the ray
    file's ``rays_traced``) the standard error irtlang prints for the same total, else sqrt(sum w^2); ``centroid`` (x, y) and
    ``centroid_se``; ``rms_radius`` = sqrt(sum w r^2 / sum w) about the centre (default the centroid) and
    ``rms_radius_se`` (delta method on the weighted mean of r^2; the centroid's own error is neglected);
    ``ee80_diameter`` (twice the weighted ``ee_fraction`` quantile of r) and ``ee80_diameter_se``: the binomial
    error of the encircled fraction at that radius, carried to the radius by inverting the encircled-energy curve
    (half the distance between the radii where it equals fraction -/+ one standard error).
    """
    x, y, w = _rays(x, y, w)
    (mx, sx), (my, sy) = _weighted_mean_se(x, w), _weighted_mean_se(y, w)
    cx, cy = (mx, my) if center is None else (float(center[0]), float(center[1]))
    r = np.hypot(x - cx, y - cy)
    m2, s2 = _weighted_mean_se(r * r, w)
    rms = float(np.sqrt(m2))
    order = np.argsort(r, kind="stable")
    rs = r[order]
    cum = np.cumsum(w[order]) / w.sum()
    r_q = _weighted_quantile(rs, cum, ee_fraction)
    _, se_p = _weighted_mean_se((r < r_q).astype(np.float64), w)
    r_lo = _weighted_quantile(rs, cum, ee_fraction - se_p)
    r_hi = _weighted_quantile(rs, cum, ee_fraction + se_p)
    return {
        "n_rays": int(x.size),
        "total": float(w.sum()),
        "total_se": (_standard_error(float(w.sum()), float(np.sum(w * w)), int(n_traced)) if n_traced
                     else float(np.sqrt(np.sum(w * w)))),
        "centroid": (mx, my),
        "centroid_se": (sx, sy),
        "rms_radius": rms,
        "rms_radius_se": s2 / (2.0 * rms) if rms > 0 else 0.0,
        "ee80_diameter": 2.0 * r_q,
        "ee80_diameter_se": float(r_hi - r_lo),
    }
