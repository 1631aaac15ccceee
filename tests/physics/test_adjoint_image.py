"""Adjoint (detector-side) images: `DETECTOR PIXELS ... START x_min x_max y_min y_max` bins what reaches an object
by where each ray started, so a camera traced backwards (rays from its detector through its pinhole, next-event
rays TOWARD a small far "sun" disk) gives the camera's image (docs/tracer.md, "Adjoint (detector-side) images").

The scene (all tests): a Lambert sphere (albedo A, radius R = 1 m) at the origin; a pinhole at (0, 0, D) looking
down -z, its detector F behind it (z = D + F, half-width H, N x N pixels, local x, y = world x, y); the sun in the
direction s = (-sin a, 0, cos a) (phase angle a), irradiance E = 1 W/m2.

Adjoint trace: GRID RECT over the detector, SOURCE POSITION at the pinhole (CONVERGE), FLUX TOTAL Phi over n rays
(w = Phi / n each); the sun is a disk of radius r at distance d = 1e6 m facing the sphere, whose bounding sphere
(radius r) gives the solid angle Omega = 2 pi (1 - cos(asin(r / d))) that the next-event weights use.  Pixel
radiance:  L_pix = E * S_pix / (n_pix w Omega),  S_pix the pixel's sum, n_pix the rays started in it (the lattice:
exactly s^2; RANDOM: n / N^2 on average, which keeps the estimate unbiased), i.e. L_pix = E N^2 S_pix / (Phi Omega).

Oracles (independent of the tracer):
* the radiance of the lit, visible sphere, L = A E cos(i) / pi (cos(i) = n . s at the point each pixel's ray
  reaches), averaged over the pixel (this file's own ray-sphere intersection);
* ORACLES.md's Lambert-sphere law for the disk-integrated flux density at the pinhole,
  F = (2/3) A E (R/D)^2 Phi(a); at D = 1000 R the finite distance changes it by +0.0275 % (DELTA_FD below);
* reciprocity: the same scene traced from the light (GRID + SOURCE DIRECTION, SCATTER ... TOWARD the pinhole, a
  0.1 mm pinhole and a DETECTOR behind it) gives the same image within the two runs' standard errors.
"""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

from irtlang.cli import main
from irtlang.compile.pack import pack
from irtlang.lang.interp import Interpreter
from irtlang.tracer import Progress, run_trace, standard_error

A = 0.6
ALPHA = 57.7
D = 1000.0            # m, sphere centre to pinhole
F = 1000.0            # m, pinhole to detector
H = 1.05              # m, detector half-width (the sphere's disk, 1 mrad, fits in the 1.05 mrad half field)
N = 32                # pixels per side
D_SUN = 1.0e6         # m
R_SUN = 1.0           # m
R_PIN = 1e-4          # m (forward trace only): its blur on the detector, 2e-4 m, is 0.3 % of a pixel
# the finite-distance term of the disk-integrated flux at D = 1000 R: +2.75e-4 relative (quadrature in
# benchmarks/bench_mitsuba.py, finite_distance_flux); the tolerance adds its size, not its value
DELTA_FD = 3e-4

SUN = (-math.sin(math.radians(ALPHA)), 0.0, math.cos(math.radians(ALPHA)))


def omega_sun() -> float:
    """The solid angle of the cone that holds the sun disk's bounding sphere (radius R_SUN) from the sphere's centre:
    2 pi (1 - cos t), sin t = r / d, written without cancellation."""
    s = R_SUN / D_SUN
    return 2 * math.pi * s * s / (1 + math.sqrt(1 - s * s))


def adjoint_script(rays_per_side: int, random: bool, seed: int = 7) -> str:
    return f"""UNITS M
WAVELENGTHS 550 NM
SEED {seed}
MODEL paint LAMBERTIAN {A}
SURFACE
  SPHERE 0 0 0 1
OBJECT ball
  INTERFACE ABSORB
  SCATTER MODEL paint TOWARD sun
SURFACE
  PLANE Z {D_SUN} DISK {R_SUN}
OBJECT sun                      !! faces the sphere; binned by the camera rays' start points
  INTERFACE ABSORB
  DETECTOR PIXELS {N} {N} START {-H} {H} {-H} {H}
  ROTATE Y {-ALPHA}
GRID RECT Z {D + F} {-H} {H} {-H} {H} {rays_per_side} {rays_per_side}{' RANDOM' if random else ''}
SOURCE POSITION 0 0 {D} CONVERGE
FLUX TOTAL 1 W
LEVEL 2
HALT 0
TRACE
"""


def forward_script(n: int, seed: int = 9) -> str:
    """The same camera and sun traced from the light: a collimated beam along -s from the plane z = 2 (a
    rectangle that holds the sphere's shadow cylinder, centre x = -2 tan a, half-widths 1/cos a and 1)."""
    a = math.radians(ALPHA)
    xc, hx, hy = -2 * math.tan(a), 1.02 / math.cos(a), 1.02
    area = 4 * hx * hy
    return f"""UNITS M
WAVELENGTHS 550 NM
SEED {seed}
MODEL paint LAMBERTIAN {A}
COATING clear TRANSMIT 1
SURFACE
  SPHERE 0 0 0 1
OBJECT ball
  INTERFACE ABSORB
  SCATTER MODEL paint TOWARD pinhole
SURFACE
  PLANE Z {D} DISK {R_PIN}
OBJECT pinhole
  INTERFACE COATING clear AIR AIR
SURFACE
  PLANE Z {D} ANNULUS {R_PIN} 3
OBJECT screen
  INTERFACE ABSORB
SURFACE
  PLANE Z {D + F} RECT {H} {H}
OBJECT camera
  INTERFACE ABSORB
  DETECTOR PIXELS {N} {N}
GRID RECT Z 2 {xc - hx!r} {xc + hx!r} {-hy} {hy} {n} {n} RANDOM
SOURCE DIRECTION {-SUN[0]!r} 0 {-SUN[2]!r}
FLUX TOTAL {area * math.cos(a)!r} W          !! E = 1 W/m2 across the beam
LEVEL 4
HALT 0
TRACE
"""


def trace(text: str, seed: int):
    it = Interpreter(check_only=True)
    it.run_text(text)
    assert not it.diags, it.diags.items
    scene = [s for s in it.steps if s.kind == "TRACE"][0].scene
    p = [s for s in it.steps if s.kind == "TRACE"][0].params
    return run_trace(scene, seed=seed, level=p["level"], halt=p["halt"], progress=Progress(0, enabled=False))


# ---------------------------------------------------------------------------------------------- the oracle
def radiance(x, y):
    """A E cos(i) / pi along the ray from detector point (x, y, D + F) through the pinhole (0, 0, D); 0 where it
    misses the sphere or meets its dark side.  Also (hit, lit)."""
    d = np.stack([-x, -y, -F * np.ones_like(x)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    p = np.array([0.0, 0.0, D])
    b = d @ p
    disc = b * b - (p @ p - 1.0)
    hit = disc > 0
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    q = p + t[..., None] * d                  # the hit point = the outward normal (R = 1)
    ci = q @ np.array(SUN)
    lit = hit & (ci > 0)
    return np.where(lit, A * ci / math.pi, 0.0), hit, lit


def pixel_average(ss: int):
    """(the radiance averaged over each pixel at ss x ss cell-centred points, mask of the pixels whose points
    and whose neighbours' points are all lit: the interior)."""
    f = (np.arange(N * ss) + 0.5) / (N * ss)
    X, Y = np.meshgrid(-H + 2 * H * f, -H + 2 * H * f)       # rows: y, columns: x
    L, hit, lit = radiance(X, Y)
    img = L.reshape(N, ss, N, ss).mean(axis=(1, 3))
    full = lit.reshape(N, ss, N, ss).all(axis=(1, 3))
    inner = full.copy()
    for ax in (0, 1):
        for sh in (1, -1):
            inner &= np.roll(full, sh, ax)
    return img, inner


def phi(a_deg: float) -> float:
    a = math.radians(a_deg)
    return (math.sin(a) + (math.pi - a) * math.cos(a)) / math.pi


def pixel_solid_angle():
    """Each pixel's solid angle seen from the pinhole (its area projected, over the distance squared)."""
    c = -H + 2 * H * (np.arange(N) + 0.5) / N
    X, Y = np.meshgrid(c, c)
    return (2 * H / N) ** 2 * F / (F * F + X * X + Y * Y) ** 1.5


def adjoint_radiance(res, n_rays: int):
    """(radiance image, its standard errors, the per-ray scale) of an adjoint run: L = E N^2 S / (Phi Omega)."""
    s1, s2 = res.images["sun"][0][0], res.images["sun"][1][0]
    k = N * N / (1.0 * omega_sun())          # E = 1 W/m2, Phi = 1 W
    return k * s1, k * standard_error(s1, s2, n_rays), k


# ---------------------------------------------------------------------------------------------- tests
def test_adjoint_lattice_is_the_radiance_at_its_sample_points():
    """A lattice of 4 x 4 camera rays per pixel: each ray's next-event weight is w f cos(s) Omega up to the spread
    of cos(s) over the sun's cone (1e-6 rad) and of Omega over the sphere (2 R / d = 2e-6), so the image equals the
    analytic radiance averaged over the same 16 points per pixel to 1e-5 of A/pi, every pixel (limb and terminator
    included): the normalization E N^2 S / (Phi Omega) and the orientation (row j = detector y, column i = x)
    are exact."""
    ss = 4
    res = trace(adjoint_script(N * ss, random=False), 7)
    img, _, _ = adjoint_radiance(res, (N * ss) ** 2)
    ref, _ = pixel_average(ss)
    assert ref.max() > 0.9 * A / math.pi            # the sub-solar point is in view
    assert np.max(np.abs(img - ref)) <= 1e-5 * A / math.pi, np.max(np.abs(img - ref))
    # the ledger closes (the next-event rays are booked as IMPORTANCE)
    led = res.ledger.sum(axis=2)
    assert abs(led[:, 4].sum() - led[-4, 0]) <= 1e-12 * led[-4, 0]


def test_adjoint_random_image_against_the_lambert_sphere():
    """Uniform random camera rays (256 per pixel on average): every interior pixel within 5 sigma of the
    pixel-averaged radiance, chi-square per degree of freedom within 5 of its own sigma (sqrt(2 / dof)) of 1,
    and the disk-integrated flux density sum(L Omega_pix) within 5 sigma + the finite-distance term of
    (2/3) A E (R/D)^2 Phi(a)."""
    side = N * 16
    n = side * side
    res = trace(adjoint_script(side, random=True), 7)
    img, se, k = adjoint_radiance(res, n)
    ref, inner = pixel_average(16)
    assert inner.sum() > 300
    z = (img - ref)[inner] / se[inner]
    dof = int(inner.sum())
    assert np.max(np.abs(z)) < 5.0, np.max(np.abs(z))
    assert abs(np.mean(z * z) - 1.0) < 5 * math.sqrt(2.0 / dof), np.mean(z * z)
    # disk-integrated: each ray deposits in one pixel at most (one scattering, one next-event ray), so the
    # per-ray contributions to sum(c_p S_p) are c_p times the pixel's deposits and its variance follows exactly
    om = pixel_solid_angle()
    s1, s2 = res.images["sun"][0][0], res.images["sun"][1][0]
    c = k * om
    total = float((c * s1).sum())
    se_total = float(standard_error((c * s1).sum(), (c * c * s2).sum(), n))
    oracle = 2.0 / 3.0 * A / D ** 2 * phi(ALPHA)
    assert se_total / total < 3e-3
    assert abs(total - oracle) <= 5 * se_total + DELTA_FD * oracle, (total / oracle - 1, se_total / total)


def test_adjoint_and_forward_images_agree():
    """Reciprocity: the camera's image traced from the light (radiance = flux / (pi r_pin^2 Omega_pix)) and from
    the detector agree pixel by pixel within their combined standard errors over the interior pixels (every
    |z| < 5, chi-square per dof within 5 sqrt(2 / dof) of 1), and their disk-integrated sums within 5 sigma."""
    side = N * 16
    resa = trace(adjoint_script(side, random=True, seed=3), 3)
    La, sa, _ = adjoint_radiance(resa, side * side)
    nf = 1200
    resf = trace(forward_script(nf), 9)
    s1, s2 = resf.images["camera"][0][0], resf.images["camera"][1][0]
    kf = 1.0 / (math.pi * R_PIN ** 2 * pixel_solid_angle())
    Lf, sf = kf * s1, kf * standard_error(s1, s2, nf * nf)
    _, inner = pixel_average(8)
    z = (Lf - La)[inner] / np.hypot(sf, sa)[inner]
    dof = int(inner.sum())
    assert np.max(np.abs(z)) < 5.0, np.max(np.abs(z))
    assert abs(np.mean(z * z) - 1.0) < 5 * math.sqrt(2.0 / dof), np.mean(z * z)
    om = pixel_solid_angle()
    tf, ta = float((Lf * om).sum()), float((La * om).sum())
    # each ray of either run deposits in one pixel at most: the per-ray variance of sum(c_p S_p) is exact
    sef = float(standard_error((kf * om * s1).sum(), ((kf * om) ** 2 * s2).sum(), nf * nf))
    k = N * N / omega_sun()
    a1, a2 = resa.images["sun"][0][0], resa.images["sun"][1][0]
    sea = float(standard_error((k * om * a1).sum(), ((k * om) ** 2 * a2).sum(), side * side))
    assert abs(tf - ta) <= 5 * math.hypot(sef, sea), (tf / ta - 1, sef / tf, sea / ta)


@pytest.mark.parametrize("start, col, what", [("1 -1 -1 1", 30, "x_min < x_max, got x_min = 1 mm and x_max = -1 mm"),
                                              ("-1 1 2 2", 35, "y_min < y_max, got y_min = 2 mm and y_max = 2 mm")])
def test_detector_start_window_must_be_ordered(tmp_path, capsys, start, col, what):
    f = tmp_path / "bad_start.inr"
    f.write_text(f"UNITS MM\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT d\n  DETECTOR PIXELS 10 START {start}\n"
                 "GRID RECT Z 5 -1 1 -1 1 3 3\nSOURCE DIRECTION 0 0 -1\nTRACE\n")
    assert main(["check", str(f)]) == 2
    err = capsys.readouterr().err
    assert re.search(re.escape(f"bad_start.inr:5:{col}: error: DETECTOR START needs {what}"), err), err


def test_detector_start_packs_in_metres_and_plain_detectors_are_unchanged():
    """START takes the UNITS unit and any place among the options; a DETECTOR without it keeps its aperture's
    rectangle and d_start = 0."""
    it = Interpreter(check_only=True)
    it.run_text("UNITS MM\nWAVELENGTHS 450 550 NM\nSURFACE\n  PLANE Z 0 RECT 2 3\nOBJECT plain\n"
                "  DETECTOR PIXELS 4 5 QE 0.5\nSURFACE\n  PLANE Z 9 DISK 1\nOBJECT adj\n"
                "  DETECTOR PIXELS 8 START -2 cm 3 cm -10 10 QE 0.9 0.8\n"
                "GRID RECT Z 5 -1 1 -1 1 3 3\nSOURCE DIRECTION 0 0 -1\nTRACE\n")
    assert not it.diags, it.diags.items
    scene = [s for s in it.steps if s.kind == "TRACE"][0].scene
    pk = pack(scene)
    names = [n.upper() for n in pk.detector_names]
    p, a = names.index("PLAIN"), names.index("ADJ")
    assert pk.d_start[p] == 0 and pk.d_start[a] == 1
    assert np.allclose(pk.d_ext[p], (-2e-3, 2e-3, -3e-3, 3e-3), rtol=0, atol=1e-15)
    assert np.allclose(pk.d_ext[a], (-0.02, 0.03, -0.01, 0.01), rtol=0, atol=1e-15)
    assert (pk.d_nx[a], pk.d_ny[a]) == (8, 8)
    assert np.allclose(pk.d_qe[a], (0.9, 0.8))


def test_detector_start_needs_no_aperture_a_sphere_sun_gives_the_same_image():
    """With START the pixel grid has its window, so any object may record: a sphere sun of radius r at d (its own
    bounding sphere: Omega is the same cone) gives the disk sun's lattice image to 1e-5 of A/pi.  Without START a
    sphere is still refused (no flat aperture)."""
    text = adjoint_script(N * 2, random=False).replace(f"  PLANE Z {D_SUN} DISK {R_SUN}\n",
                                                      f"  SPHERE 0 0 {D_SUN} {R_SUN}\n")
    assert "SPHERE 0 0 1000000.0 1.0" in text
    img, _, _ = adjoint_radiance(trace(text, 7), (N * 2) ** 2)
    ref, _ = pixel_average(2)
    assert np.max(np.abs(img - ref)) <= 1e-5 * A / math.pi, np.max(np.abs(img - ref))
    it = Interpreter(check_only=True)
    it.run_text("UNITS M\nSURFACE\n  SPHERE 0 0 0 1\nOBJECT sun\n  DETECTOR PIXELS 8\n")
    assert any("no flat aperture" in d.message for d in it.diags.items)
