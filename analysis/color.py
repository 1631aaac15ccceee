"""True-colour composites: I/F band composites, the CIE 1931 path from full spectra, PNG/GIF/MP4 writers."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ._common import AnalysisError, as_image, atomic_path, atomic_write_bytes, check_finite, same_shape

__all__ = [
    "srgb_encode", "srgb_decode", "cie1931_cmf", "XYZ_TO_LINEAR_SRGB", "rgb_composite", "spectrum_to_rgb",
    "to_uint8", "save_png", "save_animation",
]

# IEC 61966-2-1 (sRGB), D65 white: linear sRGB = M @ XYZ.
XYZ_TO_LINEAR_SRGB = np.array([
    [3.2404542, -1.5371385, -0.4985314],
    [-0.9692660, 1.8760108, 0.0415560],
    [0.0556434, -0.2040259, 1.0572252],
])
_D65_XYZ = np.array([0.95047, 1.0, 1.08883])
_BRADFORD = np.array([
    [0.8951, 0.2664, -0.1614],
    [-0.7502, 1.7135, 0.0367],
    [0.0389, -0.0685, 1.0296],
])

# Wyman, Sloan & Shirley (2013), "Simple Analytic Approximations to the CIE XYZ Color Matching Functions",
# Journal of Computer Graphics Techniques 2(2), 1-11: multi-lobe piecewise Gaussian fit of the CIE 1931 2-degree
# observer. Each lobe: (weight, mean nm, sigma below the mean nm, sigma above the mean nm).
_WYMAN_LOBES = (
    ((1.056, 599.8, 37.9, 31.0), (0.362, 442.0, 16.0, 26.7), (-0.065, 501.1, 20.4, 26.2)),  # x-bar
    ((0.821, 568.8, 46.9, 40.5), (0.286, 530.9, 16.3, 31.1)),  # y-bar
    ((1.217, 437.0, 11.8, 36.0), (0.681, 459.0, 26.0, 13.8)),  # z-bar
)


def srgb_encode(linear):
    """sRGB transfer function (IEC 61966-2-1), linear value -> encoded value, both in [0, 1].

    ``12.92 c`` for ``c <= 0.0031308``, else ``1.055 c**(1/2.4) - 0.055``; inputs are clipped to [0, 1] first.
    ``srgb_encode(0.18) = 0.46136``.

    Signature: ``srgb_encode(linear) -> array like linear``.
    """
    c = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)


def srgb_decode(encoded):
    """Inverse of :func:`srgb_encode`: ``v/12.92`` for ``v <= 0.04045``, else ``((v + 0.055)/1.055)**2.4``.

    Signature: ``srgb_decode(encoded) -> array like encoded``.
    """
    v = np.clip(np.asarray(encoded, dtype=np.float64), 0.0, 1.0)
    return np.where(v <= 0.04045, v / 12.92, np.power((v + 0.055) / 1.055, 2.4))


def _encode(linear, gamma):
    """Apply the display encoding named by ``gamma``: "srgb", None/"linear", or a number g (c**(1/g))."""
    if isinstance(gamma, str):
        if gamma.lower() == "srgb":
            return srgb_encode(linear)
        if gamma.lower() == "linear":
            return np.clip(linear, 0.0, 1.0)
        raise AnalysisError(f"gamma must be 'srgb', 'linear' or a positive number, got {gamma!r}")
    if gamma is None:
        return np.clip(linear, 0.0, 1.0)
    g = float(gamma)
    if not g > 0:
        raise AnalysisError(f"gamma must be positive, got {gamma!r}")
    return np.power(np.clip(linear, 0.0, 1.0), 1.0 / g)


def to_uint8(values):
    """Map encoded values in [0, 1] to uint8 by ``round(255 v)`` (values outside [0, 1] are clipped)."""
    return np.round(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8)


def _white_level(linear, stretch, percentile):
    """The single linear value that the common stretch maps to display white."""
    if stretch is None:
        return 1.0
    if isinstance(stretch, str):
        if stretch == "max":
            level = float(np.max(linear))
        elif stretch == "percentile":
            level = float(np.percentile(linear, percentile))
            if level <= 0 and np.any(linear > 0):
                # a small or sparsely sampled target (a planet's disk on a dark sky): the percentile of the
                # pixels with signal
                level = float(np.percentile(linear[linear > 0], percentile))
        else:
            raise AnalysisError(f"stretch must be 'max', 'percentile', None or a positive number, got {stretch!r}")
    else:
        level = float(stretch)
    if not np.isfinite(level) or level <= 0:
        raise AnalysisError(f"the stretch white level is {level!r}: the scene has no positive signal")
    return level


def rgb_composite(red, green, blue, *, solar_irradiance=None, if_scale=np.pi, stretch="percentile",
                  percentile=99.5, gamma="srgb"):
    """True-colour composite of three band images.

    Signature: ``rgb_composite(red, green, blue, *, solar_irradiance=None, if_scale=pi, stretch="percentile",
    percentile=99.5, gamma="srgb") -> uint8 (H, W, 3)``.

    Parameters
    ----------
    red, green, blue : (H, W) arrays
        Band images (e.g. radiance in W m^-2 sr^-1 nm^-1, or any quantity proportional to it per band).
    solar_irradiance : 3 numbers or None
        Solar spectral irradiance at the target for the (red, green, blue) bands, in the unit that turns each band
        into reflectance: ``I/F = if_scale * band / solar_irradiance`` (with radiance and irradiance,
        ``if_scale = pi`` gives the usual I/F). This is the white balance against the solar spectrum: a grey
        (wavelength-flat) reflector becomes R = G = B. ``None``: the bands already are reflectance (I/F).
    if_scale : float
        Factor of the I/F conversion (default pi), only used with ``solar_irradiance``.
    stretch : "percentile", "max", None or float
        ONE linear stretch common to all three channels (so a grey scene stays grey): the reflectance mapped to
        display white is the ``percentile``-th percentile of all channel values ("percentile"), their maximum
        ("max"), the given number (float, a reflectance), or 1 (None: I/F shown as is).
    percentile : float
        Percentile used by ``stretch="percentile"`` (default 99.5).
    gamma : "srgb", "linear"/None or float
        Display encoding after the stretch: the sRGB curve (default), none, or ``v = c**(1/gamma)``.

    Returns
    -------
    (H, W, 3) uint8 array, channel order R, G, B.
    """
    bands = [as_image(b, name) for b, name in ((red, "red"), (green, "green"), (blue, "blue"))]
    same_shape(bands[0], bands[1], ("red", "green"))
    same_shape(bands[0], bands[2], ("red", "blue"))
    cube = np.stack(bands, axis=-1)
    if solar_irradiance is not None:
        e = np.asarray(solar_irradiance, dtype=np.float64).reshape(-1)
        if e.shape != (3,) or not np.all(np.isfinite(e)) or np.any(e <= 0):
            raise AnalysisError(f"solar_irradiance must be 3 positive numbers (R, G, B), got {solar_irradiance!r}")
        cube = float(if_scale) * cube / e
    level = _white_level(cube, stretch, percentile)
    return to_uint8(_encode(cube / level, gamma))


def cie1931_cmf(wavelengths_nm):
    """CIE 1931 2-degree colour-matching functions from the analytic multi-lobe Gaussian fit of Wyman, Sloan &
    Shirley (2013, JCGT 2(2)): returns an array (3, L) of x-bar, y-bar, z-bar at ``wavelengths_nm`` (nm).

    Each function is a sum of piecewise Gaussians ``w exp(-(l - m)^2 / (2 s^2))`` with ``s`` the lower width for
    ``l < m`` and the upper width otherwise. Accuracy against the tabulated CIE 1931 data is about 0.01-0.02 absolute
    (y-bar(555 nm) = 0.998).

    Signature: ``cie1931_cmf(wavelengths_nm) -> (3, L) array``.
    """
    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    out = np.zeros((3,) + lam.shape)
    for k, lobes in enumerate(_WYMAN_LOBES):
        for weight, mean, s_low, s_high in lobes:
            s = np.where(lam < mean, s_low, s_high)
            out[k] += weight * np.exp(-0.5 * ((lam - mean) / s) ** 2)
    return out


def _adaptation_matrix(white):
    """Bradford chromatic adaptation from the source white ``white`` (XYZ) to D65."""
    src = _BRADFORD @ white
    dst = _BRADFORD @ _D65_XYZ
    return np.linalg.inv(_BRADFORD) @ np.diag(dst / src) @ _BRADFORD


def spectrum_to_rgb(cube, wavelengths_nm, *, axis=0, white="E", normalize="max", gamma="srgb"):
    """Colour of full spectra through the CIE 1931 2-degree observer.

    Signature: ``spectrum_to_rgb(cube, wavelengths_nm, *, axis=0, white="E", normalize="max", gamma="srgb")
    -> uint8 (..., 3)``.

    Path: spectrum -> XYZ (trapezoid integral of the spectrum times the Wyman et al. 2013 colour-matching functions,
    :func:`cie1931_cmf`) -> Bradford adaptation from the source white ``white`` to D65 -> linear sRGB (IEC 61966-2-1
    D65 matrix) -> one common stretch -> encoding.

    Parameters
    ----------
    cube : array
        Spectra along ``axis`` (default 0, e.g. an image cube (L, H, W)); a 1-D spectrum (L,) gives shape (3,).
        Any radiometric unit per nm; only ratios matter.
    wavelengths_nm : (L,) array
        Wavelengths in nm, strictly increasing.
    white : "E", "D65" or 3 numbers
        XYZ of the illuminant whose spectra must look white. "E" (default): the equal-energy spectrum maps to
        display white, so reflectance or I/F spectra render a grey reflector as grey. "D65": no adaptation
        (spectra are emitted light seen by a D65-adapted observer).
    normalize : "max" or float
        Common stretch: the linear sRGB value mapped to 1 is the maximum over all pixels and channels ("max") or the
        given number.
    gamma : "srgb", "linear"/None or float
        Display encoding, as in :func:`rgb_composite`.
    """
    lam = np.asarray(wavelengths_nm, dtype=np.float64).reshape(-1)
    spec = np.asarray(cube, dtype=np.float64)
    if spec.ndim == 0:
        raise AnalysisError("cube must have a wavelength axis")
    spec = np.moveaxis(spec, axis, -1)
    if spec.shape[-1] != lam.size or lam.size < 2:
        raise AnalysisError(f"cube has {spec.shape[-1]} samples along axis {axis} but {lam.size} wavelengths")
    check_finite(spec, "cube")
    check_finite(lam, "wavelengths_nm")
    if np.any(np.diff(lam) <= 0):
        raise AnalysisError("wavelengths_nm must be strictly increasing")
    if not np.any(spec):
        raise AnalysisError("cube is all zero")
    cmf = cie1931_cmf(lam)  # (3, L)
    xyz = np.stack([np.trapezoid(spec * cmf[k], lam, axis=-1) for k in range(3)], axis=-1)
    if isinstance(white, str):
        if white.upper() == "E":
            xyz = xyz @ _adaptation_matrix(np.ones(3)).T
        elif white.upper() != "D65":
            raise AnalysisError(f"white must be 'E', 'D65' or an XYZ triple, got {white!r}")
    else:
        w = np.asarray(white, dtype=np.float64).reshape(-1)
        if w.shape != (3,) or np.any(w <= 0):
            raise AnalysisError(f"white must be 'E', 'D65' or a positive XYZ triple, got {white!r}")
        xyz = xyz @ _adaptation_matrix(w / w[1]).T
    linear = xyz @ XYZ_TO_LINEAR_SRGB.T
    if isinstance(normalize, str) and normalize != "max":
        raise AnalysisError(f"normalize must be 'max' or a positive number, got {normalize!r}")
    level = _white_level(linear, normalize, None)
    return to_uint8(_encode(linear / level, gamma))


def _as_rgb8(rgb, name="rgb"):
    arr = np.asarray(rgb)
    if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] not in (3, 4)):
        raise AnalysisError(f"{name} must be (H, W), (H, W, 3) or (H, W, 4), got shape {arr.shape}")
    if arr.dtype != np.uint8:
        f = np.asarray(arr, dtype=np.float64)
        check_finite(f, name)
        if f.min() < 0 or f.max() > 1:
            raise AnalysisError(f"{name}: float images must lie in [0, 1] (or pass uint8)")
        arr = to_uint8(f)
    return arr


def save_png(rgb, path):
    """Write an 8-bit image (H, W), (H, W, 3) RGB or (H, W, 4) RGBA to a PNG file, atomically.

    Float input in [0, 1] is converted with ``round(255 v)``. Returns the path.

    Signature: ``save_png(rgb, path) -> Path``.
    """
    import cv2

    arr = _as_rgb8(rgb)
    if arr.ndim == 3:
        arr = cv2.cvtColor(arr, cv2.COLOR_RGB2BGR if arr.shape[2] == 3 else cv2.COLOR_RGBA2BGRA)
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(arr))
    if not ok:
        raise AnalysisError(f"PNG encoding failed for {path}")
    return atomic_write_bytes(path, buf.tobytes())


def save_animation(frames, path, *, fps=10.0, loop=0):
    """Write frames (a sequence of (H, W, 3) uint8 RGB images, all the same shape) as an animation, atomically.

    ``.gif``: animated GIF via Pillow (``loop`` = 0 repeats forever); ``.mp4``: MPEG-4 via ``cv2.VideoWriter``
    (fourcc ``mp4v``). ``fps`` is frames per second. Returns the path.

    Signature: ``save_animation(frames, path, *, fps=10.0, loop=0) -> Path``.
    """
    frames = [_as_rgb8(f, f"frame {i}") for i, f in enumerate(frames)]
    if not frames:
        raise AnalysisError("save_animation needs at least one frame")
    for i, f in enumerate(frames[1:], 1):
        same_shape(frames[0], f, ("frame 0", f"frame {i}"))
    fps = float(fps)
    if not fps > 0:
        raise AnalysisError(f"fps must be positive, got {fps}")
    suffix = Path(path).suffix.lower()
    if suffix == ".gif":
        from PIL import Image

        images = [Image.fromarray(f) for f in frames]
        buf = io.BytesIO()
        images[0].save(buf, format="GIF", save_all=True, append_images=images[1:],
                       duration=int(round(1000.0 / fps)), loop=int(loop))
        return atomic_write_bytes(path, buf.getvalue())
    if suffix == ".mp4":
        import cv2

        h, w = frames[0].shape[:2]
        with atomic_path(path) as tmp:
            writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
            if not writer.isOpened():
                raise AnalysisError(f"cv2.VideoWriter cannot write MP4 to {path}")
            try:
                for f in frames:
                    rgb = f if f.ndim == 3 else np.repeat(f[..., None], 3, axis=2)
                    writer.write(np.ascontiguousarray(rgb[..., 2::-1]))
            finally:
                writer.release()
        return Path(path)
    raise AnalysisError(f"unsupported animation format {suffix!r}: use .gif or .mp4")
