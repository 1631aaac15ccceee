"""Hero wavelengths (TRACE CAMERA ... DIRECTIONS m HERO K; irtlang/kernels/trace_kernel.py, docs/tracer.md "Hero
wavelengths"): each camera ray of a one-pixel pupil camera carries the K traced lines of its line's block, every
choice made with its hero line's probabilities, each line weighted by the balance heuristic over the block.

Oracles:
* the closed form of the Lambert sphere (ORACLES.md, as in test_camera_pupil.py), here with an albedo that
  changes by a factor of up to 45 from line to line inside a block, so that a line's weight differs from its
  hero's: (2/3) A_j E (R/D)^2 Phi(a) pi r^2 per line j;
* the one-line-per-ray camera trace (test_camera_pupil.py, test_camera_image.py check it against closed forms and
  the forward tracer) on a small planet with everything HERO weighs per line: an atmosphere shell that is a
  Rayleigh slab on an index step (Fresnel and refraction, a different index per line, an absorption band and an
  opaque line), a cloud deck over a fraction map, a Lambertian ground of per-line albedo under the map and a glint
  ocean, the roulettes of paths and of rays toward the light;
* the scatter between seeds for the standard errors.
Lines of one block share their rays, so their errors are correlated: the tolerances count blocks, not lines, as
independent samples (5 sigma), except where the compared one-line trace's own errors, independent from line to
line, dominate.
"""
from __future__ import annotations

import math

import sys
from pathlib import Path

import numpy as np
import pytest

from irtlang import cli

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_camera_pupil import SCENE as PUPIL_SCENE, _expected as _pupil_expected  # noqa: E402

# test_camera_pupil.py's Lambert sphere, its albedo given per line
LAMBERT = PUPIL_SCENE.replace("MODEL paint LAMBERTIAN 0.6", "MODEL paint LAMBERTIAN {albedo}")
assert "{albedo}" in LAMBERT

#: the small planet (centre 0 0 {z}): a Lambertian ground of per-line albedo under a fraction map and a glint
#: ocean, a cloud deck over the map, an atmosphere shell that is a Rayleigh slab on a dispersing index step
#: (test_camera_hero_images.py images it)
PLANET_BODY = """MAP cloudy LATLON '{map}'
MODEL ground LAMBERTIAN {albedo}
MODEL sea GLINT WIND 7 m/s INDEX 1.34 ALBEDO 0.02
MODEL air RAYLEIGH TAU {tau} ALBEDO {ssa}
MODEL murk RAYLEIGH TAU 4 ALBEDO 0.95
MEDIUM lens INDEX {index}
SURFACE
  SPHERE 0 0 {z} 100
OBJECT ball
  INTERFACE ABSORB
  SCATTER MAP cloudy MODELS ground
  SCATTER MODEL sea
SURFACE
  SPHERE 0 0 {z} 102
OBJECT deck
  INTERFACE TRANSMIT lens lens
  SCATTER MAP cloudy MODELS murk
SURFACE
  SPHERE 0 0 {z} 105
OBJECT atmosphere
  INTERFACE TRANSMIT lens AIR
  SCATTER MODEL air
"""
PLANET = """UNITS M
WAVELENGTHS RANGE (400 NM) (700 NM) {nl}
SEED {seed}
""" + PLANET_BODY.replace("{z}", "0") + """SURFACE
  PLANE Z 1e5 DISK 0.25
OBJECT pupil
  DETECTOR PIXELS 1
EMITTING SPHERE (1e9 * sin(60)) 0 (1e9 * cos(60)) 1e6 RAYS 1
FLUX TOTAL ({nl} * 1e18 W)
LEVEL 60
HALT 0.1 IMPORTANCE 0.05
TRACE CAMERA pupil AIM atmosphere {how}
SPECTRUM OF pupil 'spectrum.csv'
"""


def _values(a) -> str:
    return " ".join(f"{x:.6g}" for x in a)


def _albedo(nl: int) -> np.ndarray:
    """A per-line albedo from 0.02 to 0.9 that jumps from line to line (a fixed pseudo-random pattern)."""
    return np.clip(0.4 + 0.35 * np.sin(np.arange(nl) * 2.1) + 0.1 * np.cos(np.arange(nl) * 5.3), 0.02, 0.9)


def _run(tmp_path, name, text):
    d = tmp_path / name
    d.mkdir()
    (d / "s.inr").write_text(text)
    assert cli.main(["run", str(d / "s.inr"), "--out", str(d / "out")]) == 0
    x = np.loadtxt(d / "out" / "spectrum.csv", delimiter=",", skiprows=1)
    return x[:, 1], x[:, 2]


def _lambert_expected(albedo):
    """test_camera_pupil's closed form (albedo 0.6) for the per-line albedo: the flux is linear in it."""
    return _pupil_expected() * albedo / 0.6


def _block_var(se, K):
    """A bound on the variance of the sum of correlated lines: blocks of K independent of each other, inside a
    block the square of the summed standard errors (correlation 1 at most).  The blocks start at a line the
    trace's seed draws (0 .. K - 1): the largest bound over the K possible starts."""
    return max(sum(se[max(0, b):b + K].sum() ** 2 for b in range(o - K, len(se), K)) for o in range(K))


def test_hero_lambert_sphere_with_a_per_line_albedo(tmp_path):
    """Each line against its closed form (5 sigma per line: 256 lines in 32 blocks of 8, the pulls' mean square
    within 5 block-sigma of 1), and the total against the closed form's."""
    nl, K = 256, 8
    A = _albedo(nl)
    v, se = _run(tmp_path, "hero", LAMBERT.format(nl=nl, seed=3, albedo=_values(A), how=f"DIRECTIONS 4 HERO {K}"))
    ex = _lambert_expected(A)
    assert np.all(se > 0)
    pull = (v - ex) / np.hypot(se, 3e-4 * ex)
    assert np.all(np.abs(pull) < 5), (np.abs(pull).max(), int(np.argmax(np.abs(pull))))
    assert np.mean(pull ** 2) < 1 + 5 * math.sqrt(2 / (nl // K)), np.mean(pull ** 2)
    sig = math.sqrt(_block_var(se, K))
    assert abs(v.sum() - ex.sum()) < 5 * sig + 3e-4 * ex.sum(), (v.sum() / ex.sum(), sig / ex.sum())


def test_hero_standard_errors_match_the_scatter_between_seeds(tmp_path):
    """Six seeds of the per-line-albedo sphere: per line the seeds' variance over the mean printed variance,
    averaged over the lines, is 1 within 5 sigma (32 blocks x 5 degrees of freedom: sigma = sqrt(2 / 160)).  A
    variance taken per ray instead of from the pairs, or one that forgot the other heroes' rays, is off by about
    the block's K = 8."""
    nl, K = 256, 8
    A = _albedo(nl)
    runs = [_run(tmp_path, f"s{s}", LAMBERT.format(nl=nl, seed=10 + s, albedo=_values(A),
                                                   how=f"DIRECTIONS 4 HERO {K}")) for s in range(6)]
    V = np.array([r[0] for r in runs])
    S2 = np.array([r[1] ** 2 for r in runs])
    ratio = float(np.mean(V.var(axis=0, ddof=1) / S2.mean(axis=0)))
    assert abs(ratio - 1) < 5 * math.sqrt(2 / ((nl // K) * 5)), ratio


def _planet(nl, seed, how, map_file):
    lam = np.linspace(400, 700, nl)
    tau = 0.3 * (550 / lam) ** 4
    tau = np.where((lam > 640) & (lam < 650), 3.0, tau)            # an opaque line
    ssa = np.where((lam > 590) & (lam < 610), 0.3, 1.0)            # an absorption band
    index = 1.0003 + 2e-5 * (550 / lam) ** 2                        # a dispersing index step
    return PLANET.format(nl=nl, seed=seed, how=how, map=map_file, albedo=_values(_albedo(nl)), tau=_values(tau),
                         ssa=_values(ssa), index=_values(index))


def test_hero_agrees_with_one_line_per_ray_on_a_small_planet(tmp_path):
    """HERO 8 (DIRECTIONS 8) against one line per ray (DIRECTIONS 8, another seed): per line, the pulls' mean
    square within 5 sigma of 1 (the one-line trace's errors, independent from line to line, carry most of the
    difference's variance: sigma = sqrt(2 / lines), widened by the hero's share); the totals within 5 sigma.
    And the point of it: the same rays give each line about K times less variance."""
    nl, K = 192, 8
    m = str(Path(__file__).resolve().parents[2] / "examples_scripts" / "data" / "half_cloudy.npy")
    h, hs = _run(tmp_path, "hero", _planet(nl, 5, f"DIRECTIONS 8 HERO {K}", m))
    o, os_ = _run(tmp_path, "one", _planet(nl, 6, "DIRECTIONS 8", m))
    assert np.all(hs > 0) and np.all(os_ > 0)
    pull2 = (h - o) ** 2 / (hs ** 2 + os_ ** 2)
    share = float(np.mean(hs ** 2 / (hs ** 2 + os_ ** 2)))     # the hero's share of the difference's variance
    tol = 5 * math.sqrt(2 / nl) * (1 - share) + 5 * math.sqrt(2 / (nl // K)) * share
    assert abs(np.mean(pull2) - 1) < tol, (np.mean(pull2), tol)
    sig = math.sqrt(_block_var(hs, K) + (os_ ** 2).sum())
    assert abs(h.sum() - o.sum()) < 5 * sig, (h.sum() / o.sum(), sig / o.sum())
    gain = np.median((os_ / o) ** 2) / np.median((hs / h) ** 2)
    assert gain > 0.5 * K, gain


@pytest.mark.parametrize("how,why", [
    ("HERO 8", "needs DIRECTIONS"),
    ("DIRECTIONS 4 SPECTRAL 2 HERO 8", "SPECTRAL"),
    ("DIRECTIONS 4 CORRELATED HERO 8", "CORRELATED"),
])
def test_hero_refuses_what_it_does_not_carry(tmp_path, capsys, how, why):
    d = tmp_path / "s"
    d.mkdir()
    (d / "s.inr").write_text(LAMBERT.format(nl=8, seed=1, albedo="0.5", how=how))
    assert cli.main(["check", str(d / "s.inr")]) == 2
    err = capsys.readouterr().err
    assert "HERO" in err and why in err, err


def test_hero_total_standard_error(tmp_path, capsys):
    """SPECTRUM_FLUX_SE after a HERO trace: the lines of a block are correlated, so the total's standard error
    adds them within each block and the blocks' variances across them: it lies between the independent-lines
    value sqrt(sum se^2) and the fully correlated sum(se), and the total agrees with the closed form within 5 of
    it."""
    nl, K = 128, 8
    A = _albedo(nl)
    text = LAMBERT.format(nl=nl, seed=4, albedo=_values(A), how=f"DIRECTIONS 4 HERO {K}")
    text += "PRINT 'total {SPECTRUM_FLUX} {SPECTRUM_FLUX_SE}'\n"
    capsys.readouterr()
    v, se = _run(tmp_path, "tot", text)
    line = [x for x in capsys.readouterr().out.splitlines() if x.startswith("total ")][-1]
    tot, tse = (float(x) for x in line.split()[1:3])
    assert abs(tot - v.sum()) < 1e-9 * tot
    assert math.sqrt((se ** 2).sum()) < tse < se.sum(), (tse, math.sqrt((se ** 2).sum()), se.sum())
    ex = _lambert_expected(A).sum()
    assert abs(tot - ex) < 5 * tse + 3e-4 * ex, (tot / ex, tse / ex)
