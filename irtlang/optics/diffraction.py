"""The diffraction point-spread function from the traced wavefront.

Pure NumPy/SciPy functions of ray records; ``irtlang.engine`` calls them for the ``PSF`` command (documented in
docs/language.md and docs/instrument.md) and the tests call them directly.

The model (scalar Debye / angular-spectrum integral)
----------------------------------------------------
A regular lattice of rays (``GRID RECT``) is traced from the entrance pupil to the detector.  Near the image
point ``P`` the field is a superposition of plane waves, one per ray: ray i, which ends at ``p_i`` with unit
direction ``d_i`` after the optical path ``opl_i`` (the sum of n t from its start), contributes the plane wave
whose phase at ``P + x`` is ``k (W_i + d_i . x)`` with::

    W_i = s_i + opl_i + d_i . (P - p_i)

``s_i`` is the optical path from the incoming reference wavefront to the ray's start point (for a collimated
source of direction ``d0`` in the grid's frame, ``d0 . (x_i, y_i, 0)``; for a point source the distance to the
point).  ``d_i . (P - p_i)`` carries the ray's plane wave from its end point to P: this is the phase of that plane
wave at P exactly, not a first-order expansion, so ``W_i`` (less its mean) is the wavefront error relative to the
reference sphere about P in the far-field (Debye) limit; the usual finite-radius reference sphere differs from it
by ``h_i^2 / 2R`` (h the ray's miss distance at P, R the exit-pupil distance): on the HRI-like telescope at most
0.005 waves 5.8 mm out of focus (h = 83 um, R = 1.33 m), nothing in focus.

The transverse direction cosines on the detector are fitted as an affine function of the pupil coordinates,
``d_perp = c + J (u, v)`` (``J = -I / EFL`` for an aplanatic system: that fit *is* the effective focal length,
``EFL = 1 / sqrt|det J|``), so the plane-wave sum is a Fourier transform over the pupil lattice::

    U(x) ~ sum_i a_i exp(i k W_i) exp(i k (J (u_i, v_i)) . x)

computed with a zero-padded FFT (``pad`` times the lattice).  FFT index ``k`` along x is the detector offset
``x = -lambda J^-T (k / (M dx), l / (M dy))``: for ``J = -I/EFL`` the focal-plane sampling is
``lambda EFL / (M dx)``.  Amplitudes are ``a_i = sqrt(flux_i)`` for rays that reached the detector and 0 where
the pupil is blocked (central obscuration, vanes, vignetting).  What the affine fit leaves out (pupil
distortion) is reported as ``fit_residual`` (direction cosines, rms); it shifts a ray's plane wave by
``residual x |x|`` at the image offset x (1.2e-7 for an f/35 paraboloid: 2e-4 waves 0.7 mm from P).

The intensity is normalised to unit energy over the whole FFT plane and sampled at any detector offsets by
cubic-spline interpolation of the FFT grid (``density``: energy per unit area); ``pixelate`` integrates it over
square pixels (sub-sampled); ``combine_density`` and ``combine_pixels`` add wavelength lines with weights
(source x filter x QE); ``fine_figures`` measures the result.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import fft as sfft
from scipy import ndimage

__all__ = ["DiffractionError", "opd_at_reference", "plane_wave_start", "point_source_start", "lattice_indices",
           "fit_direction_map", "pupil_field", "fft_size", "fft_intensity", "MonoPSF", "psf_from_rays",
           "combine_density", "combine_pixels", "fine_figures", "convolve_lines", "airy_annular_intensity"]


class DiffractionError(ValueError):
    """Inputs the PSF computation cannot use (not a lattice, too few rays, a degenerate direction map)."""


# ---------------------------------------------------------------------------------------------- wavefront
def opd_at_reference(opl, pos, dirs, p_ref) -> np.ndarray:
    """``opl_i + d_i . (P - p_i)``: each ray's optical path carried by its plane wave to the reference point P
    (arrays (N,), (N, 3), (N, 3), (3,); one length unit)."""
    opl = np.asarray(opl, float)
    pos = np.asarray(pos, float)
    dirs = np.asarray(dirs, float)
    return opl + np.einsum("ij,ij->i", dirs, np.asarray(p_ref, float)[None, :] - pos)


def plane_wave_start(start_xy, d0) -> np.ndarray:
    """Optical path from the plane wavefront through the grid origin to each start point (x, y, 0) in the
    grid's frame, for a collimated source of direction d0 (3,) in that frame."""
    d0 = np.asarray(d0, float)
    d0 = d0 / np.linalg.norm(d0)
    s = np.asarray(start_xy, float)
    return s[:, 0] * d0[0] + s[:, 1] * d0[1]


def point_source_start(start_xy, point, converge=False) -> np.ndarray:
    """Optical path from a point source (diverging) or to a point (converging, negative) to each start point
    (x, y, 0) in the grid's frame."""
    s = np.asarray(start_xy, float)
    q = np.asarray(point, float)
    r = np.sqrt((s[:, 0] - q[0]) ** 2 + (s[:, 1] - q[1]) ** 2 + q[2] ** 2)
    return -r if converge else r


def lattice_indices(start_xy, x_range, y_range, nx, ny, tol=1e-6):
    """Column and row of each start point on the GRID RECT lattice of cell centres
    ``x = x_min + (i + 1/2) dx``; raises DiffractionError if a point is off the lattice by more than tol cells."""
    s = np.asarray(start_xy, float)
    dx = (x_range[1] - x_range[0]) / nx
    dy = (y_range[1] - y_range[0]) / ny
    if not (dx > 0 and dy > 0):
        raise DiffractionError("the pupil lattice needs a non-empty GRID RECT (x_min < x_max, y_min < y_max)")
    fx = (s[:, 0] - x_range[0]) / dx - 0.5
    fy = (s[:, 1] - y_range[0]) / dy - 0.5
    ix, iy = np.rint(fx).astype(np.int64), np.rint(fy).astype(np.int64)
    if s.size and (np.abs(fx - ix).max() > tol or np.abs(fy - iy).max() > tol):
        raise DiffractionError("the rays' start points are not on a regular lattice (a RANDOM grid?)")
    if s.size and (ix.min() < 0 or iy.min() < 0 or ix.max() >= nx or iy.max() >= ny):
        raise DiffractionError("a start point lies outside its GRID RECT")
    return ix, iy, dx, dy


def fit_direction_map(uv, dperp, w=None):
    """Least-squares affine fit ``dperp = c + J uv``: returns (c (2,), J (2, 2), rms residual)."""
    uv = np.asarray(uv, float)
    dperp = np.asarray(dperp, float)
    if len(uv) < 3:
        raise DiffractionError("fewer than 3 rays reached the detector")
    w = np.ones(len(uv)) if w is None else np.asarray(w, float)
    A = np.column_stack([np.ones(len(uv)), uv])
    sw = np.sqrt(w / w.sum())[:, None]
    coef, *_ = np.linalg.lstsq(A * sw, dperp * sw, rcond=None)
    c, J = coef[0], coef[1:].T
    res = dperp - A @ coef
    if abs(np.linalg.det(J)) < 1e-300:
        raise DiffractionError("the rays' directions do not depend on their pupil position (no focusing)")
    return c, J, float(np.sqrt((w[:, None] * res * res).sum() / w.sum()))


def pupil_field(nx, ny, ix, iy, amplitude, opd, wavelength) -> np.ndarray:
    """The complex pupil field on the lattice (ny, nx): ``a exp(2 pi i W / lambda)``, 0 where no ray is."""
    E = np.zeros((ny, nx), complex)
    W = np.asarray(opd, float)
    W = W - (W * amplitude ** 2).sum() / max((amplitude ** 2).sum(), 1e-300)   # piston out (precision only)
    E[iy, ix] = amplitude * np.exp(2j * math.pi * W / wavelength)
    return E


def fft_size(shape, pad) -> int:
    """The padded FFT size M: the next fast length >= pad * max(nx, ny)."""
    return sfft.next_fast_len(int(math.ceil(pad * max(shape))))


def fft_intensity(E, pad, half: int | None = None) -> np.ndarray:
    """``|FFT(E zero-padded to M x M)|^2``, M = :func:`fft_size`, normalised to sum 1 over the M x M plane and
    shifted so that zero frequency sits at index [M // 2, M // 2].

    ``half``: only the central (2 half + 1)^2 samples of the shifted plane, computed without the rest: the pupil's
    nx columns transformed along y, then only the kept rows along x.  These are the 1-D transforms ``fft2`` does, in
    its order (y, then x), so the kept values are bitwise fft2's; the sum over the plane is M^2 sum |E|^2
    (Parseval) instead of a sum over M^2 samples.  For the 256^2 pupil padded to 2048 and the default crop this
    transforms 256 + 1041 lines instead of 4096, and touches 25 MB of memory instead of 200."""
    ny, nx = E.shape
    M = fft_size(E.shape, pad)
    if half is not None and half < M // 2:
        sel = (np.arange(M // 2 - half, M // 2 + half + 1) - M // 2) % M     # the kept band, unshifted indices
        F = sfft.fft(sfft.fft(E, n=M, axis=0, workers=-1)[sel], n=M, axis=1, workers=-1)[:, sel]
        I = F.real ** 2 + F.imag ** 2
        tot = M * M * float((E.real ** 2 + E.imag ** 2).sum())
        if not tot > 0:
            raise DiffractionError("the pupil is dark: no ray reached the detector")
        I /= tot
        return I
    F = sfft.fft2(E, s=(M, M), workers=-1)
    I = (F.real ** 2 + F.imag ** 2)
    tot = I.sum()
    if not tot > 0:
        raise DiffractionError("the pupil is dark: no ray reached the detector")
    return np.fft.fftshift(I / tot)


# ---------------------------------------------------------------------------------------------- one line
@dataclass
class MonoPSF:
    """One wavelength line's PSF.  Lengths in metres; detector-frame offsets are from ``p_ref``.

    ``intensity`` is the central part of the M x M FFT intensity (the whole plane sums to 1), zero frequency at
    index ``[center, center]``; the density is 0 outside it."""

    wavelength: float
    intensity: np.ndarray           # (K, K) crop of the normalised FFT intensity
    center: int                     # index of zero frequency in the crop
    M: int                          # FFT size (padded)
    dx: float
    dy: float
    J: np.ndarray                   # d(direction cosine) / d(pupil coordinate), detector frame
    p_ref: np.ndarray               # reference point (detector frame)
    nx: int                         # pupil lattice
    ny: int
    n_rays: int                     # rays that reached the detector (lit lattice cells)
    fit_residual: float             # rms of the affine direction fit
    opd_rms: float                  # rms wavefront error (m), about the mean, relative to p_ref
    power: float                    # sum of the rays' flux
    _spline: np.ndarray | None = field(default=None, repr=False)

    @property
    def efl(self) -> float:
        return 1.0 / math.sqrt(abs(np.linalg.det(self.J)))

    @property
    def sampling(self) -> tuple[float, float]:
        """FFT grid spacing on the detector, ``lambda EFL / (M dx)`` and ``lambda EFL / (M dy)``."""
        return (self.wavelength * self.efl / (self.M * self.dx), self.wavelength * self.efl / (self.M * self.dy))

    @property
    def half_extent(self) -> float:
        """Detector half-width (m) inside which the density is kept."""
        return (self.intensity.shape[0] // 2 - 4) * min(self.sampling)

    def _index(self, x, y):
        jt = self.J.T
        fx = -(jt[0, 0] * x + jt[0, 1] * y) / self.wavelength
        fy = -(jt[1, 0] * x + jt[1, 1] * y) / self.wavelength
        return self.M * self.dy * fy + self.center, self.M * self.dx * fx + self.center

    def density(self, x, y) -> np.ndarray:
        """PSF energy per unit area (1/m^2) at detector offsets (x, y) from p_ref (any matching shapes): cubic
        spline through the FFT samples; 0 outside the kept window."""
        from ..kernels.spline import spline3_affine, spline_filter3

        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        shape = x.shape
        if self._spline is None:
            self._spline = spline_filter3(np.ascontiguousarray(self.intensity, float))   # ndimage.spline_filter's
        cell = self.wavelength ** 2 / (self.M * self.M * self.dx * self.dy * abs(np.linalg.det(self.J)))
        jt = self.J.T
        out = np.empty(x.size)
        # map_coordinates(order=3, mode="mirror", prefilter=False) at _index(x, y), 0 outside the window, clipped
        # at 0 and divided by the cell area: one pass over the points (irtlang/kernels/spline.py)
        spline3_affine(self._spline, np.ascontiguousarray(x).reshape(-1), np.ascontiguousarray(y).reshape(-1),
                       float(jt[0, 0]), float(jt[0, 1]), float(jt[1, 0]), float(jt[1, 1]), float(self.wavelength),
                       float(self.M * self.dx), float(self.M * self.dy), float(self.center), float(cell), out)
        return out.reshape(shape)

    def pixelate(self, pitch: float, n: int, offset=(0.0, 0.0), n_sub: int | None = None) -> np.ndarray:
        """Energy in each of n x n square pixels of side ``pitch`` (row j along y, column i along x), the
        centre of the middle pixel (n odd) at detector offset ``offset`` from p_ref.  A PSF that fits in the
        array sums to ~1."""
        if n_sub is None:
            n_sub = max(3, int(math.ceil(2.0 * pitch / min(self.sampling))))
        return _pixelate(lambda X, Y: self.density(X, Y), pitch, n, offset, n_sub)


def _pixelate(density, pitch, n, offset, n_sub) -> np.ndarray:
    c = (np.arange(n) - (n - 1) / 2.0) * pitch
    sub = ((np.arange(n_sub) + 0.5) / n_sub - 0.5) * pitch
    xs = (c[:, None] + sub[None, :]).ravel() + offset[0]          # (n * n_sub,)
    ys = (c[:, None] + sub[None, :]).ravel() + offset[1]
    Y, X = np.meshgrid(ys, xs, indexing="ij")
    d = density(X, Y).reshape(n, n_sub, n, n_sub)
    return d.mean(axis=(1, 3)) * pitch * pitch


def psf_from_rays(*, start_xy, opl, pos, dirs, flux, grid, wavelength, start_path=None, p_ref=None, pad=8.0,
                  perfect=False, keep=None) -> MonoPSF:
    """One line's PSF from the records of the rays that reached the detector.

    ``start_xy`` (N, 2): start points in the grid's frame; ``opl`` (N,); ``pos``, ``dirs`` (N, 3) in the
    detector's frame (z along its normal); ``flux`` (N,); ``grid`` = (x_min, x_max, y_min, y_max, nx, ny) of the
    GRID RECT; ``start_path`` (N,): the path from the incoming reference wavefront to each start point
    (:func:`plane_wave_start`, :func:`point_source_start`); ``p_ref`` (3,): the reference point, default the
    flux-weighted centroid of ``pos``; ``pad``: zero-padding factor (8: the cubic-spline resampling of the FFT
    grid is then good to ~1e-3 in encircled-energy diameters; 4: ~2e-3); ``perfect``: drop the wavefront error
    (the aberration-free PSF of the same pupil, e.g. a convolution kernel for a ray-traced image, which already
    holds the geometric blur); ``keep``: detector half-width (m) of the FFT intensity kept (default 64 lambda
    EFL / pupil width, ~64 lambda N).
    """
    start_xy = np.asarray(start_xy, float)
    pos = np.asarray(pos, float)
    dirs = np.asarray(dirs, float)
    flux = np.asarray(flux, float)
    if len(flux) < 3:
        raise DiffractionError(f"{len(flux)} rays reached the detector; the PSF needs a lit pupil lattice")
    x0, x1, y0, y1, nx, ny = grid
    ix, iy, dx, dy = lattice_indices(start_xy, (x0, x1), (y0, y1), int(nx), int(ny))
    if len(np.unique(iy * int(nx) + ix)) != len(ix):
        raise DiffractionError("several rays reached the detector from one pupil cell (split or scattered paths)")
    if p_ref is None:
        p_ref = (pos * flux[:, None]).sum(0) / flux.sum()
    p_ref = np.asarray(p_ref, float)
    W = opd_at_reference(opl, pos, dirs, p_ref)
    if start_path is not None:
        W = W + np.asarray(start_path, float)
    amp = np.sqrt(flux / flux.max())
    Wc = W - (W * flux).sum() / flux.sum()
    opd_rms = float(np.sqrt((Wc * Wc * flux).sum() / flux.sum()))
    c, J, res = fit_direction_map(start_xy, dirs[:, :2], flux)
    E = pupil_field(int(nx), int(ny), ix, iy, amp, np.zeros_like(W) if perfect else W, wavelength)
    M = fft_size(E.shape, pad)
    efl = 1.0 / math.sqrt(abs(np.linalg.det(J)))
    if keep is None:
        keep = 64.0 * wavelength * efl / max(int(nx) * dx, int(ny) * dy)
    K = int(min(M // 2, math.ceil(keep / (wavelength * efl / (M * max(dx, dy)))) + 8))
    crop = fft_intensity(E, pad, half=K)       # (2K + 1)^2, or the whole plane when K = M // 2
    return MonoPSF(float(wavelength), crop, K if K < M // 2 else M // 2, M, dx, dy, J, p_ref, int(nx), int(ny),
                   len(flux), res, 0.0 if perfect else opd_rms, float(flux.sum()))


# ---------------------------------------------------------------------------------------------- several lines
def _weights(psfs, weights):
    w = np.asarray(weights, float) if weights is not None else np.ones(len(psfs))
    if len(w) != len(psfs) or np.any(w < 0) or not w.sum() > 0:
        raise DiffractionError("line weights must be >= 0, one per line, with a positive sum")
    return w / w.sum()


def combine_density(psfs, weights, step: float, n: int, offset=(0.0, 0.0)) -> np.ndarray:
    """The weighted sum of the lines' densities on an n x n grid of spacing ``step`` (points, not cells) centred
    at detector offset ``offset``: ``img[j, i]`` at ``(x_i, y_j)``; times step^2 it is energy per cell."""
    w = _weights(psfs, weights)
    c = (np.arange(n) - (n - 1) / 2.0) * step
    Y, X = np.meshgrid(c + offset[1], c + offset[0], indexing="ij")
    out = np.zeros((n, n))
    for p, wk in zip(psfs, w):
        if wk > 0:
            out += wk * p.density(X, Y)
    return out


def combine_pixels(psfs, weights, pitch: float, n: int, offset=(0.0, 0.0)) -> np.ndarray:
    """The weighted sum of the lines' pixel PSFs (:meth:`MonoPSF.pixelate`), n x n pixels of side ``pitch``."""
    w = _weights(psfs, weights)
    out = np.zeros((n, n))
    for p, wk in zip(psfs, w):
        if wk > 0:
            out += wk * p.pixelate(pitch, n, offset)
    return out


def fine_figures(psfs, weights, *, step=None, half_width=None, ring_floor=0.1) -> dict:
    """Figures of the (polychromatic) PSF on a fine grid about p_ref, in metres.

    ``fwhm``: for a PSF whose azimuthally averaged profile peaks at p_ref (``centred``), the full width at half
    maximum of :func:`irtlang.optics.psf_measures.psf_metrics` (the profile's first half-maximum crossing); otherwise (a
    defocused, ring-shaped PSF) twice the outermost radius where the profile crosses half its maximum.
    ``ring_diameter``: the first dark ring (centred PSFs only).  ``outer_ring_diameter``: twice the radius of the
    outermost local maximum of the profile that reaches ``ring_floor`` (0.1) times the profile's maximum; None
    when that is the central core.  ``ee80_diameter``, ``ee50_diameter`` (fractions of the whole PSF's energy,
    the FFT plane, not of the window), ``rms_radius`` (of the window), ``peak`` (energy per m^2), ``step`` and
    ``half_width`` used, ``image`` (energy per cell).

    Defaults: ``step`` a third of the finest FFT sampling of the lines; ``half_width`` 1.3 times the radius that
    holds 95 % of the energy on a coarse survey (+-60 lambda N, steps lambda N / 4), plus 2 lambda N.  The grid is
    centred on p_ref, which is also the centre of the radial profiles and encircled energies.
    """
    from .psf_measures import psf_metrics, radial_profile

    w = _weights(psfs, weights)
    lam_n = max(p.wavelength * p.efl / (max(p.nx * p.dx, p.ny * p.dy)) for p in psfs)   # ~ lambda N, longest
    if step is None:
        step = min(min(p.sampling) for p in psfs) / 3.0
    if half_width is None:
        coarse = lam_n / 4.0
        nc = 2 * int(60 * 4) + 1                                           # +- 60 lambda N
        img = combine_density(psfs, w, coarse, nc) * coarse * coarse
        r, prof, cnt = radial_profile(img, coarse, center=((nc - 1) / 2, (nc - 1) / 2), bin_width=1.0)
        cum = np.cumsum(prof * cnt)
        r95 = r[min(int(np.searchsorted(cum, 0.95 * cum[-1])), len(r) - 1)]
        half_width = 1.3 * r95 + 2.0 * lam_n
    n = 2 * int(math.ceil(half_width / step)) + 1
    if n > 2001:
        step = 2.0 * half_width / 2000.0
        n = 2001
    img = combine_density(psfs, w, step, n) * step * step
    c0 = ((n - 1) / 2.0, (n - 1) / 2.0)
    m = psf_metrics(img, step, center=c0, total=1.0)
    r, prof, _ = radial_profile(img, step, center=c0, bin_width=1.0)
    top = prof.max()
    centred = prof[0] >= 0.9 * top          # the core peaks at p_ref (not a defocused ring)
    fwhm, ring = m["fwhm"], m["ring_diameter"]
    if not centred:
        # the width at half the profile's maximum, from the outside in (a ring-shaped, defocused PSF)
        above = np.nonzero(prof >= 0.5 * top)[0]
        i = int(above[-1])
        fwhm = 2.0 * (float(np.interp(0.5 * top, [prof[i + 1], prof[i]], [r[i + 1], r[i]])) if i + 1 < len(r)
                      else float(r[i]))
        ring = None
    outer = None
    for i in range(len(prof) - 2, 0, -1):
        if prof[i] >= prof[i - 1] and prof[i] >= prof[i + 1] and prof[i] >= ring_floor * top:
            outer = 2.0 * r[i] if (r[i] > 0 and not (centred and prof[i] >= 0.9 * top)) else None
            break
    return {"fwhm": fwhm, "ee80_diameter": m["ee80_diameter"], "ee50_diameter": m["ee50_diameter"],
            "ring_diameter": ring, "outer_ring_diameter": outer, "rms_radius": m["rms_radius"],
            "peak": float(img.max() / (step * step)), "energy_in_window": float(img.sum()), "step": step,
            "half_width": (n - 1) / 2 * step, "centred": bool(centred), "image": img}


def convolve_lines(image, kernels) -> np.ndarray:
    """Each line of an (L, ny, nx) image convolved with its kernel (L, k, k), k odd, same size out (FFT).

    Exact support: a line is convolved over the bounding box of its non-zero pixels only, and the result is
    zero wherever no kernel reaches from a non-zero pixel.  An FFT over the whole frame leaves round-off of
    about 1e-16 of the peak on every pixel (for a star on a 1024 x 1024 detector, half the frame held values
    of 1e-22 .. 1e-18 W where no light can arrive), which is wrong and makes the files incompressible."""
    from scipy.signal import fftconvolve

    image = np.asarray(image, float)
    kernels = np.asarray(kernels, float)
    L, ny, nx = image.shape
    out = np.zeros(image.shape)     # (calloc: the pages no light reaches are never written)
    nonneg = bool(np.all(image >= 0))
    for k in range(L):
        ker = kernels[k]
        hy, hx = ker.shape[0] // 2, ker.shape[1] // 2
        lit = image[k] != 0
        rows = np.flatnonzero(lit.any(axis=1))
        if len(rows) == 0:
            continue
        cols = np.flatnonzero(lit.any(axis=0))
        r0, r1, c0, c1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
        full = fftconvolve(image[k, r0:r1, c0:c1], ker, mode="full")     # rows r0-hy .. r1+hy of the frame
        o0, o1 = max(r0 - hy, 0), min(r1 + hy, ny)
        p0, p1 = max(c0 - hx, 0), min(c1 + hx, nx)
        cut = (slice(o0 - (r0 - hy), o1 - (r0 - hy)), slice(p0 - (c0 - hx), p1 - (c0 - hx)))
        reach = ndimage.maximum_filter(np.pad(lit[r0:r1, c0:c1], ((hy, hy), (hx, hx))).view(np.uint8),
                                       size=ker.shape, mode="constant")[cut]
        part = np.where(reach != 0, full[cut], 0.0)
        out[k, o0:o1, p0:p1] = np.maximum(part, 0.0, out=part) if nonneg else part
    return out


# ---------------------------------------------------------------------------------------------- analytic
def airy_annular_intensity(r, wavelength, fnum, eps=0.0) -> np.ndarray:
    """Intensity of the diffraction pattern of an annular pupil (obscuration ratio eps) at radius r, per unit
    area, normalised to unit total energy: I(v) = [2 J1(v)/v - eps^2 2 J1(eps v)/(eps v)]^2 / (1 - eps^2)^2
    times I0 = pi (1 - eps^2) / (4 lambda^2 N^2), v = pi r / (lambda N)."""
    from scipy.special import j1

    r = np.asarray(r, float)
    v = math.pi * r / (wavelength * fnum)
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.where(v == 0, 1.0, 2 * j1(v) / np.where(v == 0, 1, v))
        ev = eps * v
        b = np.where(ev == 0, 1.0, 2 * j1(ev) / np.where(ev == 0, 1, ev))
    amp = (a - eps * eps * b) / (1 - eps * eps)
    i0 = math.pi * (1 - eps * eps) / (4 * wavelength ** 2 * fnum ** 2)
    return amp * amp * i0
