"""The diffraction PSF (irtlang/optics/diffraction.py, the PSF command) against analytic and independent numbers.

Oracles:
- Airy pattern of a circular pupil (ORACLES.md "Instrument": FWHM 1.0290 lambda N, 80 % encircled-energy
  diameter 1.7939 lambda N; first dark ring 2.4393 lambda N = 2 x 3.8317 / pi); the analytic intensity
  [2 J1(v)/v]^2 with I0 = pi / (4 lambda^2 N^2) per unit energy.
- Defocus: the central intensity of a pupil with defocus W020 (peak to valley) is sinc^2(pi W020 / lambda) times
  the focused one (the Fourier transform of a uniform pupil at the centre, exactly).
- Tilt: a wave converging to a point xi off the reference point makes the PSF peak at xi (sign and scale of the
  FFT mapping).
- The traced on-axis PSF of the HRI-like Cassegrain against an independent FFT of its analytic pupil (an annulus
  48.5 .. 150 mm with four 2 mm vanes), made here with its own sampling and the design EFL.

Tolerances: the synthetic pupils are sampled at 256 cells across and padded 8 times; the cubic-spline
resampling of the FFT grid is good to ~1e-3 in the core at that padding, the stair-cased pupil rim to ~1e-3 in
encircled energy (measured: FWHM +0.01 %, EE80 +0.06 %, ring +0.05 % at 256 cells), hence 0.5 % where the issue
asks it and 0.3 % elsewhere."""
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.special import j0, j1

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _instrument import EFL, UM, trace_instrument  # noqa: E402
from _trace_util import trace_text  # noqa: E402

from irtlang.optics import diffraction as D

LAM = 550e-9


def _synthetic(n=256, a=0.15, f=10.5, focus=(0.0, 0.0, 0.0), eps=0.0):
    """Rays of a perfect converging wave: pupil lattice (u, v) over [-a, a]^2 (cell centres, |.| in [eps a, a]),
    each from the point (u, v, f) toward `focus`, ending on the plane z = 0 with the optical path that makes the
    path to `focus` the same for all (an ideal lens)."""
    g = (np.arange(n) + 0.5) / n * 2 * a - a
    U, V = np.meshgrid(g, g)
    r = np.hypot(U, V)
    m = (r <= a) & (r >= eps * a)
    uv = np.column_stack([U[m], V[m]])
    Q = np.column_stack([uv, np.full(len(uv), f)])
    F = np.asarray(focus, float)
    d = F - Q
    d /= np.linalg.norm(d, axis=1)[:, None]
    t = -Q[:, 2] / d[:, 2]
    p = Q + t[:, None] * d
    opl = 100.0 - np.einsum("ij,ij->i", F - p, d)     # the signed path still to go to F
    return dict(start_xy=uv, opl=opl, pos=p, dirs=d, flux=np.ones(len(uv)), grid=(-a, a, -a, a, n, n))


def test_airy_from_a_perfect_wave():
    """f/35 perfect wave: density = the analytic Airy pattern in the core (0.3 %), FWHM and EE80 (0.5 %), ring
    (0.3 %); the fitted EFL is the lens's f (to the f/35 sine-condition term, 1e-4)."""
    psf = D.psf_from_rays(**_synthetic(), wavelength=LAM)
    assert psf.efl == pytest.approx(10.5, rel=1e-4)
    lamN = LAM * 35
    r = np.array([0.0, 0.25, 0.5, 0.75, 1.0]) * lamN
    for ang in (0.0, 0.7):
        got = psf.density(r * math.cos(ang), r * math.sin(ang))
        ref = D.airy_annular_intensity(r, LAM, 35.0)
        assert got == pytest.approx(ref, rel=3e-3)
    fig = D.fine_figures([psf], [1.0])
    assert fig["fwhm"] / lamN == pytest.approx(1.0290, rel=5e-3)
    assert fig["ee80_diameter"] / lamN == pytest.approx(1.7939, rel=5e-3)
    assert fig["ring_diameter"] / lamN == pytest.approx(2 * 3.8317 / math.pi, rel=3e-3)
    assert fig["centred"] and fig["outer_ring_diameter"] is None


def test_annular_analytic_intensity_and_energy():
    """airy_annular_intensity integrates to 1 (its normalisation) and its encircled energy at the first zeros
    matches the textbook curve for eps = 0 (1 - J0^2 - J1^2)."""
    r = np.linspace(0, 60, 240001) * LAM * 35
    for eps in (0.0, 0.323):
        I = D.airy_annular_intensity(r, LAM, 35.0, eps)
        ee = np.cumsum(2 * math.pi * r * I) * (r[1] - r[0])
        assert ee[-1] == pytest.approx(1.0, abs=6e-3)      # the rest lies beyond 60 lambda N (~1/(pi^2 r))
    I = D.airy_annular_intensity(r, LAM, 35.0, 0.0)
    ee = np.cumsum(2 * math.pi * r * I) * (r[1] - r[0])
    v = math.pi * r / (LAM * 35)
    k = np.searchsorted(v, 3.8317)
    assert ee[k] == pytest.approx(1 - j0(v[k]) ** 2 - j1(v[k]) ** 2, abs=1e-4)


@pytest.mark.parametrize("w020_waves", [0.25, 0.5])
def test_defocus_central_intensity(w020_waves):
    """A wave converging to a point dz beyond the reference plane: W020 = dz (1 - cos u_max); the PSF at the
    reference point is sinc^2(pi W020 / lambda) of the focused peak (0.3 %); opd_rms is W020 / sqrt(12) (the rms
    of a uniform-pupil defocus, 1 %)."""
    a, f = 0.15, 10.5
    cos_u = f / math.hypot(a, f)
    dz = w020_waves * LAM / (1 - cos_u)
    focused = D.psf_from_rays(**_synthetic(a=a, f=f), wavelength=LAM)
    defoc = D.psf_from_rays(**_synthetic(a=a, f=f, focus=(0.0, 0.0, -dz)), wavelength=LAM, p_ref=(0.0, 0.0, 0.0))
    x = w020_waves * math.pi
    assert defoc.density(0.0, 0.0) / focused.density(0.0, 0.0) == pytest.approx((math.sin(x) / x) ** 2, rel=3e-3)
    assert defoc.opd_rms == pytest.approx(w020_waves * LAM / math.sqrt(12), rel=0.01)


def test_tilt_moves_the_peak():
    """Rays converging to (xi, eta) with the reference point at the origin: the PSF peaks at (xi, eta) (its
    sign and scale: to 2 % of the FFT sampling, found by a parabola through the densest samples)."""
    xi, eta = 37e-6, -21e-6
    psf = D.psf_from_rays(**_synthetic(focus=(xi, eta, 0.0)), wavelength=LAM, p_ref=(0.0, 0.0, 0.0))
    g = np.linspace(-80e-6, 80e-6, 321)
    X, Y = np.meshgrid(g, g)
    dens = psf.density(X, Y)
    j, i = np.unravel_index(dens.argmax(), dens.shape)
    assert abs(g[i] - xi) < 1e-6 and abs(g[j] - eta) < 1e-6


def test_lattice_and_inputs():
    """Start points off the lattice, and duplicated cells, are refused with a clear message."""
    s = _synthetic(n=16)
    bad = dict(s, start_xy=s["start_xy"] + 1e-4)
    with pytest.raises(D.DiffractionError, match="lattice"):
        D.psf_from_rays(**bad, wavelength=LAM)
    dup = {k: (np.concatenate([v, v[:1]]) if isinstance(v, np.ndarray) else v) for k, v in s.items()}
    with pytest.raises(D.DiffractionError, match="one pupil cell"):
        D.psf_from_rays(**dup, wavelength=LAM)


def test_pixelate_and_convolve_conserve_energy():
    """Pixel sums: the whole PSF in a wide array is 1 (the part beyond 65 x 10 um is the Airy wing, 1 - EE(r) ~
    1/(pi^2 r / lambda N) for the corner-inscribed circle: below 1.2 %); a convolution with a kernel of sum k
    multiplies an image's sum by k (away from the edges)."""
    psf = D.psf_from_rays(**_synthetic(), wavelength=LAM)
    k = psf.pixelate(10e-6, 65)
    assert 0.985 < k.sum() <= 1.0 + 1e-9
    assert np.unravel_index(k.argmax(), k.shape) == (32, 32)
    img = np.zeros((1, 200, 200))
    img[0, 100, 100] = 2.0
    img[0, 60, 140] = 1.0
    out = D.convolve_lines(img, k[None])
    assert out.sum() == pytest.approx(3.0 * k.sum(), rel=1e-9)
    assert out[0, 100, 100] == pytest.approx(2.0 * k[32, 32], rel=1e-9)


def test_convolve_lines_is_the_direct_convolution_with_exact_support():
    """Oracle: scipy.ndimage.convolve, the direct sum (no FFT), on images with isolated stars, sparse and dense
    fields, an empty line and sources at the edges, kernels of 1 .. 65 pixels.  Every value agrees to 1e-12 of the
    image's maximum, and a pixel no kernel reaches from a lit pixel is exactly 0 (an FFT over the whole frame leaves
    ~1e-16 of the peak there), a reached one is not."""
    from scipy.ndimage import convolve

    rng = np.random.default_rng(5)
    for trial in range(30):
        ny, nx = rng.integers(20, 90, size=2)
        img = np.zeros((3, ny, nx))
        for k in range(1, 3):
            m = rng.random((ny, nx)) < rng.choice([0.0005, 0.01, 0.4])
            img[k][m] = rng.random(m.sum())
        img[2, 0, -1] = 1.0
        kk = int(rng.choice([1, 3, 9, 65]))
        ker = rng.random((3, kk, kk)) + 0.01
        out = D.convolve_lines(img, ker)
        ref = np.array([convolve(img[k], ker[k], mode="constant") for k in range(3)])
        assert np.allclose(out, ref, rtol=0, atol=1e-12 * ref.max()), trial
        assert np.array_equal(out == 0, ref == 0), trial
    assert not D.convolve_lines(np.zeros((1, 8, 8)), np.ones((1, 3, 3))).any()


# ------------------------------------------------------------------------------------------ traced PSFs
PARABOLOID = """UNITS MM
WAVELENGTHS 550 NM
SURFACE
  CONIC Z 0 RADIUS 21000 CONIC -1 DISK 150
OBJECT mirror
  INTERFACE REFLECT
SURFACE
  PLANE Z 10500 RECT 0.105 0.105       !! at the focus; it shadows 2e-6 of the pupil
OBJECT det
  DETECTOR PIXELS 21
GRID RECT Z 10600 -150 150 -150 150 256 256
SOURCE DIRECTION 0 0 -1
TRACE
"""


def _psf_of(res, obj, lam=LAM, grid=None, **kw):
    names = [n.upper() for n in res.packed.object_names]
    r = res.records
    m = r["object"] == names.index(obj.upper())
    return D.psf_from_rays(start_xy=r["start"][m], opl=r["opl"][m], pos=r["position"][m], dirs=r["direction"][m],
                           flux=r["flux"][m], grid=grid, wavelength=lam,
                           start_path=D.plane_wave_start(r["start"][m], (0, 0, -1)), **kw)


def test_traced_paraboloid_is_airy(tmp_path):
    """A perfect paraboloid (f = 10.5 m, D = 300 mm: f/35), traced: rms wavefront < 1e-6 waves, Airy FWHM,
    EE80 diameter (ORACLES.md, 0.5 %) and first dark ring (0.3 %)."""
    res = trace_text(tmp_path, PARABOLOID)
    psf = _psf_of(res, "det", grid=(-0.15, 0.15, -0.15, 0.15, 256, 256), p_ref=(0.0, 0.0, 10.5))
    assert psf.opd_rms < 1e-6 * LAM
    fig = D.fine_figures([psf], [1.0])
    lamN = LAM * 35
    assert fig["fwhm"] / lamN == pytest.approx(1.0290, rel=5e-3)
    assert fig["ee80_diameter"] / lamN == pytest.approx(1.7939, rel=5e-3)
    assert fig["ring_diameter"] / lamN == pytest.approx(2.4393, rel=3e-3)


def test_psf_command_on_the_paraboloid(tmp_path, capsys):
    """The PSF command prints and sets the same figures; the .npy it writes holds the pixel PSF."""
    from irtlang.cli import main

    f = tmp_path / "airy.inr"
    f.write_text(PARABOLOID + "PSF 'psf.npy' SIZE 11\n"
                 "PRINT 'ratios {PSF_FWHM / (550 nm * 35):.6f} {PSF_EE80 / (550 nm * 35):.6f} {PSF_STREHL:.6f}'\n")
    code = main(["run", str(f), "--out", str(tmp_path / "out")])
    out = capsys.readouterr().out
    assert code == 0, out
    fw, ee, st = (float(x) for x in out.split("ratios ")[1].split()[:3])
    assert fw == pytest.approx(1.0290, rel=5e-3) and ee == pytest.approx(1.7939, rel=5e-3)
    assert st == pytest.approx(1.0, abs=1e-6)
    img = np.load(tmp_path / "out" / "psf.npy")
    assert img.shape == (1, 11, 11) and 0.9 < img.sum() < 1.0
    assert np.unravel_index(img[0].argmax(), (11, 11)) == (5, 5)


def _analytic_cassegrain_pupil(n=1024, a=0.15, r_in=0.0485, vane_half=0.001, r_vane=(0.0475, 0.166)):
    g = (np.arange(n) + 0.5) / n * 2 * a - a
    X, Y = np.meshgrid(g, g)
    r = np.hypot(X, Y)
    P = ((r >= r_in) & (r <= a)).astype(float)
    for i in range(4):
        t = math.radians(45 + 90 * i)
        along = X * math.cos(t) + Y * math.sin(t)
        across = -X * math.sin(t) + Y * math.cos(t)
        P[(np.abs(across) <= vane_half) & (along >= r_vane[0]) & (along <= r_vane[1])] = 0.0
    return P, 2 * a / n


def test_traced_cassegrain_matches_analytic_pupil(tmp_path):
    """The on-axis PSF of the instrument (cassegrain.inr, 550 nm, 256 x 256 pupil lattice) against an independent
    zero-padded FFT of its analytic pupil on a 1024 lattice with the design EFL (m f1): the traced wavefront is
    flat (rms < 1e-6 waves), the pupil transmits the same share (0.5 %: the vanes are 1.7 lattice cells wide),
    and the PSFs agree: FWHM 0.5 %, encircled energy within 5, 10, 20, 40 and 80 um 0.005 absolute, the 21 um
    pixel PSF (central 5 x 5) 0.01 of its peak."""
    body = "GRID RECT Z (z_front + 10) -150 150 -150 150 256 256\nSOURCE DIRECTION 0 0 -1\nFLUX TOTAL 1 W\nTRACE"
    res, fpa = trace_instrument(tmp_path, body)
    psf = D.psf_from_rays(start_xy=fpa["start"], opl=fpa["opl"], pos=fpa["position"] - np.array([0, 0, -0.3]),
                          dirs=fpa["direction"], flux=fpa["flux"], grid=(-0.15, 0.15, -0.15, 0.15, 256, 256),
                          wavelength=LAM, start_path=D.plane_wave_start(fpa["start"], (0, 0, -1)))
    assert psf.opd_rms < 1e-6 * LAM
    P, dx = _analytic_cassegrain_pupil()
    share_traced = len(fpa["flux"]) / 256 ** 2 / (math.pi / 4)
    share_analytic = P.sum() / 1024 ** 2 / (math.pi / 4)
    assert share_traced == pytest.approx(share_analytic, rel=5e-3)
    # the independent FFT: sampling lambda EFL / (M dx), intensity per unit area normalised to 1
    M = 4096
    I = np.fft.fftshift(np.abs(np.fft.fft2(P, s=(M, M))) ** 2)   # 4 x padding
    I /= I.sum()
    step = LAM * EFL / (M * dx)
    I /= step * step
    c = M // 2
    k = 40                                                   # +- 40 samples: +-103 um
    sub = I[c - k:c + k + 1, c - k:c + k + 1]
    g = (np.arange(-k, k + 1)) * step
    X, Y = np.meshgrid(g, g)
    traced = psf.density(X, Y)
    R = np.hypot(X, Y)
    for rad in (5, 10, 20, 40, 80):
        m = R <= rad * UM
        assert traced[m].sum() * step ** 2 == pytest.approx(sub[m].sum() * step ** 2, abs=5e-3)
    from analysis.psf import psf_metrics

    fa = psf_metrics(sub * step ** 2, step, center=(k, k), total=1.0)
    ft = D.fine_figures([psf], [1.0])
    assert ft["fwhm"] == pytest.approx(fa["fwhm"], rel=5e-3)
    # 21 um pixels: integrate the analytic density over each pixel (sub-sampled) and compare
    pix = psf.pixelate(21e-6, 5)
    sub_s = 15
    o = ((np.arange(sub_s) + 0.5) / sub_s - 0.5) * 21e-6
    xs = ((np.arange(5) - 2)[:, None] * 21e-6 + o[None, :]).ravel()
    YY, XX = np.meshgrid(xs, xs, indexing="ij")
    from scipy.ndimage import map_coordinates

    kk = 80
    win = I[c - kk:c + kk + 1, c - kk:c + kk + 1]
    v = map_coordinates(win, [YY / step + kk, XX / step + kk], order=3)
    ref = v.reshape(5, sub_s, 5, sub_s).mean(axis=(1, 3)) * (21e-6) ** 2
    assert np.abs(pix - ref).max() < 0.01 * ref.max()


def test_fft_intensity_crop_is_the_centre_of_the_whole_plane():
    """The cropped intensity (only the pupil's columns along y, then the kept rows along x) against the centre of
    the whole zero-padded fft2, shifted, of random pupils: square and oblong lattices, odd and even fast lengths.
    The normalisation (Parseval, M^2 sum |E|^2, against the sum over the M^2 samples) agrees to rounding."""
    rng = np.random.default_rng(11)
    for ny, nx, pad, half in ((64, 64, 8.0, 100), (40, 72, 4.0, 30), (33, 33, 3.0, 49), (16, 16, 8.0, 200)):
        E = np.zeros((ny, nx), complex)
        m = rng.random((ny, nx)) < 0.7
        E[m] = rng.random(m.sum()) * np.exp(2j * np.pi * rng.random(m.sum()))
        whole = D.fft_intensity(E, pad)
        M = whole.shape[0]
        assert M == D.fft_size(E.shape, pad)
        crop = D.fft_intensity(E, pad, half=half)
        if half >= M // 2:
            assert np.array_equal(crop, whole)
            continue
        ref = whole[M // 2 - half:M // 2 + half + 1, M // 2 - half:M // 2 + half + 1]
        assert crop.shape == ref.shape
        assert np.allclose(crop, ref, rtol=1e-12, atol=1e-15 * ref.max())
        assert crop[half, half] == pytest.approx(whole[M // 2, M // 2], rel=1e-12)
