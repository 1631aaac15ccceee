"""Whole-disk measures of a planet image: limb ellipse, diameters, scale, illuminated fraction and phase angle;
disk-integrated spectra, time x wavelength maps and apparent albedo against a Lambert sphere."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import binary_erosion, sobel

from ._common import AnalysisError, as_image, bilinear, check_finite, positive, same_shape

__all__ = [
    "lambert_phase", "lambert_sphere_flux", "apparent_albedo", "disk_metrics", "limb_points",
    "disk_averaged_spectrum", "time_wavelength_map",
]


def lambert_phase(phase_angle_deg):
    """Lambert-sphere phase function ``Phi(a) = [sin a + (pi - a) cos a] / pi`` (a in degrees, 0..180);
    Phi(0) = 1, Phi(90 deg) = 1/pi.

    Signature: ``lambert_phase(phase_angle_deg) -> array``.
    """
    a = np.radians(np.asarray(phase_angle_deg, dtype=np.float64))
    if np.any(~np.isfinite(a)) or np.any(a < 0) or np.any(a > np.pi + 1e-12):
        raise AnalysisError("phase angles must lie in [0, 180] degrees")
    return (np.sin(a) + (np.pi - a) * np.cos(a)) / np.pi


def lambert_sphere_flux(albedo, solar_irradiance, radius, distance, phase_angle_deg):
    """Disk-integrated flux density of a Lambert sphere: ``F = (2/3) A E (R/d)^2 Phi(a)``.

    ``albedo`` A (Lambert albedo; geometric albedo is 2A/3), ``solar_irradiance`` E at the sphere (any unit, e.g.
    W m^-2 nm^-1; F has the same unit), ``radius`` R and observer ``distance`` d in one length unit,
    ``phase_angle_deg`` a in degrees.

    Signature: ``lambert_sphere_flux(albedo, solar_irradiance, radius, distance, phase_angle_deg) -> array``.
    """
    ratio = positive(radius, "radius") / positive(distance, "distance")
    return (2.0 / 3.0) * np.asarray(albedo, dtype=np.float64) * np.asarray(solar_irradiance, dtype=np.float64) \
        * ratio**2 * lambert_phase(phase_angle_deg)


def apparent_albedo(flux, wavelength_nm=None, *, solar_irradiance, radius, distance, phase_angle_deg):
    """Apparent (Lambert-equivalent) albedo: ``flux / F_Lambert(A = 1)`` at the same geometry.

    Signature: ``apparent_albedo(flux, wavelength_nm=None, *, solar_irradiance, radius, distance,
    phase_angle_deg) -> array like flux``.

    ``flux``: disk-integrated flux density at the observer (per wavelength or band); ``solar_irradiance``: the
    solar irradiance at the body in the same unit, an array matching ``flux``, a number, or a callable of
    ``wavelength_nm`` (which is then required); ``radius`` and ``distance`` in one length unit; phase angle in
    degrees. A Lambert sphere of albedo A returns A (its geometric albedo is 2A/3).
    """
    f = np.asarray(flux, dtype=np.float64)
    check_finite(f, "flux")
    if callable(solar_irradiance):
        if wavelength_nm is None:
            raise AnalysisError("a callable solar_irradiance needs wavelength_nm")
        e = np.asarray(solar_irradiance(np.asarray(wavelength_nm, dtype=np.float64)), dtype=np.float64)
    else:
        e = np.asarray(solar_irradiance, dtype=np.float64)
    if np.any(~np.isfinite(e)) or np.any(e <= 0):
        raise AnalysisError("solar_irradiance must be positive and finite")
    reference = lambert_sphere_flux(1.0, e, radius, distance, phase_angle_deg)
    if np.any(reference <= 0):
        raise AnalysisError("the Lambert sphere is dark at this phase angle (180 deg): albedo undefined")
    return f / reference


def limb_points(image, *, threshold=0.02, limb_contrast=0.2, edge_level=0.5, profile_halfwidth=3.0, step=0.25):
    """Sub-pixel limb points of a lit disk and a mask of the lit area.

    Signature: ``limb_points(image, *, threshold=0.02, limb_contrast=0.2, edge_level=0.5, profile_halfwidth=3.0,
    step=0.25) -> (points (N, 2) as (x, y) px, lit_mask)``.

    The lit area is the pixels above ``threshold`` x max. At every pixel on its boundary, the profile along the
    outward normal (minus the Sobel gradient direction) is sampled from ``-profile_halfwidth`` to
    ``+profile_halfwidth`` px in ``step`` px (bilinear); the edge point is the outermost crossing of
    ``edge_level`` x the inner value (the sample 1 px from the inner end): 0.5 puts an anti-aliased sharp edge
    exactly at the limb; a limb-darkened edge (e.g. a Lambert sphere near full phase, whose brightness falls like
    sqrt(1 - rho^2)) is placed slightly inside (about 0.7 px for an 80 px radius), less with a lower level.
    Only sharp edges are kept: inner minus outer value at least ``limb_contrast`` x max. This selects the limb
    and rejects the terminator, whose brightness fades gradually.
    """
    img = as_image(image)
    top = img.max()
    if top <= 0:
        raise AnalysisError("image has no positive signal")
    lit = img > threshold * top
    boundary = lit & ~binary_erosion(lit)
    jj, ii = np.nonzero(boundary)
    if jj.size < 5:
        raise AnalysisError("no lit disk found above the threshold")
    gx, gy = sobel(img, axis=1), sobel(img, axis=0)
    g = np.hypot(gx[jj, ii], gy[jj, ii])
    ok = g > 0
    jj, ii, nx, ny = jj[ok], ii[ok], -gx[jj, ii][ok] / g[ok], -gy[jj, ii][ok] / g[ok]
    s = np.arange(-profile_halfwidth, profile_halfwidth + step / 2, step)
    xs = ii[:, None] + s[None, :] * nx[:, None]
    ys = jj[:, None] + s[None, :] * ny[:, None]
    prof = bilinear(img, xs.ravel(), ys.ravel()).reshape(xs.shape)
    inner = prof[:, int(round(1.0 / step))]  # 1 px from the inner end
    sharp = inner - prof[:, -1] >= limb_contrast * top
    prof, level = prof[sharp], edge_level * inner[sharp]
    above = prof >= level[:, None]
    last = s.size - 1 - np.argmax(above[:, ::-1], axis=1)  # outermost sample still at or above the level
    ok = above.any(axis=1) & (last < s.size - 1)
    rows, last = np.nonzero(ok)[0], last[ok]
    p0, p1 = prof[rows, last], prof[rows, last + 1]
    t = s[last] + (p0 - level[rows]) / (p0 - p1) * step
    sel = np.nonzero(sharp)[0][rows]
    pts = np.column_stack([ii[sel] + t * nx[sel], jj[sel] + t * ny[sel]])
    if len(pts) < 6:
        raise AnalysisError("too few sharp limb points: lower limb_contrast or check the image")
    return pts, lit


def _fit_circle(pts):
    """Algebraic (Kasa) circle fit: returns centre (x, y) and radius."""
    x, y = pts[:, 0], pts[:, 1]
    a = np.column_stack([x, y, np.ones_like(x)])
    c, *_ = np.linalg.lstsq(a, x * x + y * y, rcond=None)
    cx, cy = c[0] / 2, c[1] / 2
    return (cx, cy), float(np.sqrt(c[2] + cx * cx + cy * cy))


def _ellipse_coverage(shape, center, axes, angle_deg, supersample=8):
    """Fraction of each pixel inside the ellipse (full axes ``axes``, major axis at ``angle_deg``), by
    ``supersample`` x ``supersample`` sub-samples; pixels are unit squares centred on integer coordinates."""
    h, w = shape
    off = (np.arange(supersample) + 0.5) / supersample - 0.5
    t = np.radians(angle_deg)
    dx = (np.arange(w)[:, None] + off[None, :]).ravel() - center[0]
    dy = (np.arange(h)[:, None] + off[None, :]).ravel() - center[1]
    u = dx[None, :] * np.cos(t) + dy[:, None] * np.sin(t)
    v = -dx[None, :] * np.sin(t) + dy[:, None] * np.cos(t)
    inside = (2.0 * u / axes[0]) ** 2 + (2.0 * v / axes[1]) ** 2 <= 1.0
    return inside.reshape(h, supersample, w, supersample).mean(axis=(1, 3))


def disk_metrics(image, *, threshold=0.02, limb_contrast=0.2, edge_level=0.5, shape="ellipse", radius_km=None):
    """Limb ellipse, diameters, scale and illuminated fraction of a planet image.

    Signature: ``disk_metrics(image, *, threshold=0.02, limb_contrast=0.2, edge_level=0.5, shape="ellipse",
    radius_km=None) -> dict``.

    Sub-pixel limb points (:func:`limb_points`, which also defines ``threshold``, ``limb_contrast`` and
    ``edge_level``) are fitted by an ellipse (``cv2.fitEllipseDirect``, Fitzgibbon's direct least squares) or, with
    ``shape="circle"``, by an algebraic circle (steadier for a sphere seen at a large phase angle, where only
    half of the limb is lit and the ends of that arc are faint).

    Keys
    ----
    center : (x, y) px of the limb ellipse (pixel centres at integer coordinates).
    equatorial_diameter_px, polar_diameter_px : the major and minor axes of the limb ellipse, px.
    angle_deg : direction of the major axis, degrees from the +x (column) axis towards +y (row), in [0, 180).
    km_per_px : ``radius_km / (equatorial_diameter_px / 2)`` when ``radius_km`` (equatorial radius) is given.
    disk_area_px : area of the limb ellipse, ``pi a b`` (px^2).
    lit_area_px : area of the disk brighter than ``threshold`` x max: the sum, over pixels above the threshold,
        of the fraction of the pixel inside the limb ellipse (sub-sampled 8 x 8), so that the anti-aliased limb
        counts once.
    illuminated_fraction : lit_area_px / disk_area_px, clipped to [0, 1]. It misses the terminator band fainter
        than the threshold: for a Lambert sphere at most ``2 threshold / pi`` (0.013 with the default).
    phase_angle_deg : from the illuminated fraction of a sphere, ``k = (1 + cos a) / 2`` -> ``a = acos(2k - 1)``.
    n_limb_points : number of limb points fitted.
    """
    import cv2

    img = as_image(image)
    pts, lit = limb_points(img, threshold=threshold, limb_contrast=limb_contrast, edge_level=edge_level)
    if shape == "ellipse":
        (cx, cy), (d1, d2), angle = cv2.fitEllipseDirect(pts.astype(np.float32))
        # OpenCV: d1 is the axis along `angle`, d2 the perpendicular one; report the major axis' direction.
        major, minor = max(d1, d2), min(d1, d2)
        angle = angle if d1 >= d2 else angle + 90.0
    elif shape == "circle":
        (cx, cy), rad = _fit_circle(pts)
        major = minor = 2.0 * rad
        angle = 0.0
    else:
        raise AnalysisError(f"shape must be 'ellipse' or 'circle', got {shape!r}")
    if not (np.isfinite(major) and np.isfinite(minor)) or minor <= 0:
        raise AnalysisError("the limb fit failed (degenerate limb points)")
    disk_area = np.pi * major * minor / 4.0
    lit_area = float(_ellipse_coverage(img.shape, (cx, cy), (major, minor), angle)[lit].sum())
    k = float(np.clip(lit_area / disk_area, 0.0, 1.0))
    return {
        "center": (float(cx), float(cy)),
        "equatorial_diameter_px": float(major),
        "polar_diameter_px": float(minor),
        "angle_deg": float(angle % 180.0),
        "km_per_px": None if radius_km is None else positive(radius_km, "radius_km") / (major / 2.0),
        "disk_area_px": float(disk_area),
        "lit_area_px": lit_area,
        "illuminated_fraction": k,
        "phase_angle_deg": float(np.degrees(np.arccos(2.0 * k - 1.0))),
        "n_limb_points": int(len(pts)),
    }


def disk_averaged_spectrum(cube, wavelengths_nm=None, *, mask=None, sum2=None):
    """Disk-integrated spectrum of an image cube.

    Signature: ``disk_averaged_spectrum(cube, wavelengths_nm=None, *, mask=None, sum2=None)
    -> (wavelengths_nm, flux, stderr)``.

    ``cube`` (L, H, W): flux per pixel per wavelength line (e.g. W, a detector's ``sum``). ``flux[l]`` is the sum
    over the disk pixels: ``mask`` (H, W) boolean, or None for every pixel (a dark sky adds nothing).
    ``sum2``: the matching sum of squared ray fluxes (ray-file ``sum2``); then ``stderr[l] = sqrt(sum sum2)``
    (independent rays, Poisson counts), else stderr is None. ``wavelengths_nm`` defaults to the line index.
    """
    c = np.asarray(cube, dtype=np.float64)
    if c.ndim != 3:
        raise AnalysisError(f"cube must be 3-D (L, H, W), got shape {c.shape}")
    check_finite(c, "cube")
    if not np.any(c):
        raise AnalysisError("cube is all zero")
    if mask is None:
        m = np.ones(c.shape[1:], dtype=bool)
    else:
        m = np.asarray(mask, dtype=bool)
        same_shape(m, c[0], ("mask", "cube image"))
    wl = np.arange(c.shape[0], dtype=np.float64) if wavelengths_nm is None else \
        np.asarray(wavelengths_nm, dtype=np.float64).reshape(-1)
    if wl.size != c.shape[0]:
        raise AnalysisError(f"{wl.size} wavelengths for a cube of {c.shape[0]} lines")
    flux = c[:, m].sum(axis=1)
    se = None
    if sum2 is not None:
        s2 = np.asarray(sum2, dtype=np.float64)
        same_shape(s2, c, ("sum2", "cube"))
        check_finite(s2, "sum2")
        se = np.sqrt(s2[:, m].sum(axis=1))
    return wl, flux, se


def time_wavelength_map(spectra, *, reference=None, mode="relative"):
    """Time x wavelength deviation map of disk-integrated spectra.

    Signature: ``time_wavelength_map(spectra, *, reference=None, mode="relative") -> (T, L) array``.

    ``spectra`` (T, L): one spectrum per time. ``reference``: None (the time-mean spectrum, giving the diurnal
    variation), an (L,) spectrum, or a (T, L) array (e.g. the simulation, giving observation minus simulation).
    ``mode="relative"``: ``(spectra - reference) / reference``; ``"difference"``: ``spectra - reference``.
    """
    s = np.asarray(spectra, dtype=np.float64)
    if s.ndim != 2:
        raise AnalysisError(f"spectra must be 2-D (T, L), got shape {s.shape}")
    check_finite(s, "spectra")
    ref = s.mean(axis=0) if reference is None else np.asarray(reference, dtype=np.float64)
    if ref.shape not in (s.shape, s.shape[1:]):
        raise AnalysisError(f"reference must have shape {s.shape} or {s.shape[1:]}, got {ref.shape}")
    check_finite(ref, "reference")
    diff = s - ref
    if mode == "difference":
        return diff
    if mode != "relative":
        raise AnalysisError(f"mode must be 'relative' or 'difference', got {mode!r}")
    if np.any(ref == 0):
        raise AnalysisError("the reference spectrum has zeros: use mode='difference'")
    return diff / ref
