"""Disk-integrated spectra from a camera-side trace at the entrance pupil (TRACE CAMERA on a one-pixel DISK
detector, DIRECTIONS m, CORRELATED; irtlang/model/camera.py, docs/tracer.md "Spectra at the pupil").

The scene: a Lambert sphere (R = 100 m, albedo 0.6) lit at 60 deg phase by a small sphere 1e9 m away (1 mrad,
1e18 W per line), and a pupil disk of radius 0.25 m 100 km away with DETECTOR PIXELS 1, every line traced.

Oracles:
* the closed form of the Lambert sphere (ORACLES.md): the flux on the pupil is (2/3) A E (R/D)^2 Phi(a) pi r^2,
  Phi(a) = (sin a + (pi - a) cos a) / pi, E = P / (4 pi d^2); the finite-distance term at D = 1000 R is 3e-4
  (test_adjoint_image.py);
* the lines are independent, identically distributed samples of that one value (the albedo and the light are
  flat; every line draws its own random numbers): their spread across lines is the variance each line's
  standard error must estimate.  For stratified pairs the estimate is the sum over strata of (a - b)^2; the
  per-ray spread would overstate it (the strata remove the spread between directions).
Tolerances are 5 sigma of the compared quantities, from the runs' own standard errors.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from irtlang import cli

SCENE = """UNITS M
WAVELENGTHS RANGE (400 NM) (700 NM) {nl}
SEED {seed}
MODEL paint LAMBERTIAN 0.6
SURFACE
  SPHERE 0 0 0 100
OBJECT ball
  INTERFACE ABSORB
  SCATTER MODEL paint
SURFACE
  PLANE Z 1e5 DISK 0.25
OBJECT pupil
  DETECTOR PIXELS 1
EMITTING SPHERE (1e9 * sin(60)) 0 (1e9 * cos(60)) 1e6 RAYS 1
FLUX TOTAL ({nl} * 1e18 W)
LEVEL 4
HALT 0
TRACE CAMERA pupil AIM ball {how}
SPECTRUM OF pupil 'spectrum.csv'
"""


def _expected():
    a = math.radians(60.0)
    phi = (math.sin(a) + (math.pi - a) * math.cos(a)) / math.pi
    E = 1e18 / (4 * math.pi * 1e9 ** 2)
    return (2.0 / 3.0) * 0.6 * E * (100.0 / 1e5) ** 2 * phi * math.pi * 0.25 ** 2


def _run(tmp_path, name, how, nl=64, seed=1):
    d = tmp_path / name
    d.mkdir()
    (d / "s.inr").write_text(SCENE.format(nl=nl, seed=seed, how=how))
    assert cli.main(["run", str(d / "s.inr"), "--out", str(d / "out")]) == 0
    x = np.loadtxt(d / "out" / "spectrum.csv", delimiter=",", skiprows=1)
    return x[:, 1], x[:, 2]


@pytest.mark.parametrize("how", ["RAYS 16", "DIRECTIONS 4", "RAYS 4 DIRECTIONS 2", "DIRECTIONS 4 CORRELATED"])
def test_pupil_spectrum_closed_form(tmp_path, how):
    """The lines (chi-square per line within its 5-sigma band) and the total against the closed form.  A DISK
    pupil is sampled over its disk, not its bounding square (which gave 4 / pi too much).  CORRELATED: the lines
    are copies of one estimate (flat albedo, shared random numbers), and the total's standard error is the sum
    of the lines' (the bound for any correlation).  (Per line, 16 pairs make a noisy variance estimate: the
    pulls have heavy tails, so the lines are judged together.)"""
    v, se = _run(tmp_path, "run", how)
    ex = _expected()
    assert np.all(se > 0)
    pull = (v - ex) / np.hypot(se, 3e-4 * ex)
    if "CORRELATED" in how:     # one estimate copied to every line: its pull within 5 sigma
        assert abs(pull[0]) < 5, (how, v[0] / ex, se[0] / ex)
    else:
        assert np.mean(pull ** 2) < 1 + 5 * math.sqrt(2 / len(v)), (how, v / ex, se / ex)
    tot_se = se.sum() if "CORRELATED" in how else math.sqrt((se ** 2).sum())
    assert abs(v.sum() / (len(v) * ex) - 1) < 5 * tot_se / (len(v) * ex) + 3e-4, (how, v.sum(), tot_se)
    if "CORRELATED" in how:
        assert np.all(v == v[0])
    else:
        assert len(np.unique(v)) == len(v)


@pytest.mark.parametrize("how,nl", [("DIRECTIONS 4", 256), ("DIRECTIONS 8", 256), ("RAYS 4 DIRECTIONS 4", 128)])
def test_paired_standard_errors_are_honest(tmp_path, how, nl):
    """The lines' spread equals the mean of their squared standard errors (the variance estimate is unbiased):
    the ratio within 5 sigma of 1, sigma by the delta method from the samples' own fourth moment and the spread
    of the squared errors (a stratum cut by the limb or the terminator gives both heavy tails, so the Gaussian
    sqrt(2 / (n - 1)) would understate it).  And the strata pay: about as many rays drawn without them (RAYS n,
    one direction each) spread more than 1.5 times as much (2.3 measured with 4 x 4 strata)."""
    v, se = _run(tmp_path, "paired", how, nl=nl)
    d = v - v.mean()
    s2 = float(np.mean(d ** 2)) * nl / (nl - 1)
    m2 = float(np.mean(se ** 2))
    ratio = s2 / m2
    sigma = ratio * math.sqrt((np.mean(d ** 4) - s2 ** 2) / nl / s2 ** 2 + np.var(se ** 2) / nl / m2 ** 2)
    assert abs(ratio - 1) < 5 * sigma, (how, ratio, sigma)
    assert sigma < 0.2, (how, sigma)       # teeth: a variance understated by half (ratio 2) lies beyond 5 sigma
    n = 2 * int(how.split()[-1]) ** 2 * (int(how.split()[1]) if how.startswith("RAYS") else 1)
    side = math.isqrt(n)
    u, _ = _run(tmp_path, "plain", f"RAYS {side * side}", nl=nl)
    assert u.std(ddof=1) > 1.5 * v.std(ddof=1) * math.sqrt(n / (side * side)), (how, u.std(), v.std())


def test_pupil_spectrum_seeds_differ_and_repeat(tmp_path):
    """Regression guard (not physics): a seed repeats bitwise, another seed differs."""
    a, _ = _run(tmp_path, "a", "DIRECTIONS 2", nl=8, seed=3)
    b, _ = _run(tmp_path, "b", "DIRECTIONS 2", nl=8, seed=3)
    c, _ = _run(tmp_path, "c", "DIRECTIONS 2", nl=8, seed=4)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


CAMERA_ERRORS = [
    ("PLANE Z 1e5 ANNULUS 0.1 0.25", "DETECTOR PIXELS 1", "DIRECTIONS 2",
     "s.inr:18:14: error: TRACE CAMERA pupil: a camera's detector is a RECT of pixels, or one pixel on a DISK or "
     "ELLIPSE (pupil has ANNULUS)"),
    ("PLANE Z 1e5 DISK 0.25", "DETECTOR PIXELS 4", "DIRECTIONS 2",
     "s.inr:18:14: error: TRACE CAMERA pupil: a camera's detector is a RECT of pixels, or one pixel on a DISK or "
     "ELLIPSE (pupil has DISK and 4 x 4 pixels)"),
    ("PLANE Z 1e5 DISK 0.25", "DETECTOR PIXELS 1", "SPECTRAL 2 CORRELATED",
     "s.inr:18:1: error: TRACE CAMERA ... CORRELATED needs a camera that traces every line into its own image: no "
     "SPECTRAL, and a DETECTOR without FILTERS"),
]


@pytest.mark.parametrize("plane,det,how,message", CAMERA_ERRORS)
def test_camera_pupil_errors(tmp_path, monkeypatch, capsys, plane, det, how, message):
    text = (SCENE.format(nl=4, seed=1, how=how).replace("PLANE Z 1e5 DISK 0.25", plane)
            .replace("DETECTOR PIXELS 1", det))
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.inr").write_text(text)
    rc = cli.main(["check", "s.inr"])
    err = capsys.readouterr().err
    assert rc == 2
    assert message in err, err
