"""TRACE CAMERA ... GUIDE g (irtlang/model/camera.py, docs/tracer.md "Camera-side images"): camera rays drawn from
g x g cells of the aim cone in proportion to what a pilot trace saw leave the instrument there, weighted by the
uniform density over the guided one.

The guide changes how the directions are sampled, not the expectation, so the oracles are those of the unguided
camera trace (tests/physics/test_camera_image.py): the closed form of a Lambert sphere lit by a distant sphere
through the Cassegrain of examples_scripts/camera_cassegrain.inr, and the forward trace of the same scene (an
independent estimator), pixel by pixel (chi-square over the pixels with both runs' standard errors) and in total,
5 sigma; the per-pixel standard errors against the scatter between two seeds.  One scene puts the telescope in a
GROUP, where the instrument is the group (the example's telescope is not in one: there it is the objects without
SCATTER specs).
"""
from __future__ import annotations

import math
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from irtlang.cli import main
from irtlang.model.camera import GUIDE_FLOOR, GUIDE_NEAR, guide_tables

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import small_cassegrain  # noqa: E402

SCRIPT = Path(__file__).resolve().parents[2] / "examples_scripts" / "camera_cassegrain.inr"


def _run(tmp_path, name, script=SCRIPT, **sets):
    out = tmp_path / name
    args = ["run", str(script), "--out", str(out)]
    for k, v in sets.items():
        args += ["--set", f"{k}={v!r}" if isinstance(v, str) else f"{k}={v}"]
    assert main(args) == 0
    return np.load(out / "image.npy"), np.load(out / "image.stderr.npy")


def _lambert_flux(albedo):
    """(2/3) A E (R/D)^2 Phi(a) times the primary's clear annulus (test_camera_image.py)."""
    a = math.radians(60.0)
    phi = (math.sin(a) + (math.pi - a) * math.cos(a)) / math.pi
    E = 1e18 / (4 * math.pi * 1e9 ** 2)
    return (2.0 / 3.0) * albedo * E * (100.0 / 1e5) ** 2 * phi * math.pi * (0.25 ** 2 - 0.06 ** 2)


def _agree(a, ae, b, be, label):
    """Pixel by pixel (chi-square per lit pixel below 1 + 5 sigma of its distribution) and in total (5 sigma)."""
    m = (ae > 0) & (be > 0) & (b > 0.05 * b.max())
    dof = int(m.sum())
    assert dof > 100, (label, dof)
    chi2 = float(((a - b)[m] ** 2 / (ae[m] ** 2 + be[m] ** 2)).mean())
    assert chi2 < 1.0 + 5.0 * math.sqrt(2.0 / dof), (label, chi2, dof)
    s = math.sqrt((ae ** 2).sum() + (be ** 2).sum())
    assert abs(a.sum() - b.sum()) < 5 * s, (label, a.sum(), b.sum(), s)


@pytest.mark.parametrize("scene,albedo", [("lambert", 0.6), ("map", 0.4 * 0.6 + 0.6 * 0.1)])
def test_guided_lambert_sphere_closed_form(tmp_path, scene, albedo):
    sets = {"map_file": "data/uniform_040.npy"} if scene == "map" else {}
    img, se = _run(tmp_path, "g", scene=scene, guide_cells=32, **sets)
    expected = _lambert_flux(albedo)
    sig = math.sqrt((se ** 2).sum())
    # + the finite-distance term of the Lambert-sphere law at D = 1000 R (3e-4, test_adjoint_image.py)
    assert abs(img.sum() / expected - 1) < 5 * sig / expected + 3e-4, (img.sum(), expected, sig)


@pytest.mark.parametrize("scene", ["lambert", "slab", "shell"])
def test_guided_camera_agrees_with_forward(tmp_path, scene):
    cam, cse = _run(tmp_path, "cam", mode="camera", scene=scene, guide_cells=32)
    fwd, fse = _run(tmp_path, "fwd", mode="forward", scene=scene)
    _agree(cam, cse, fwd, fse, scene)


def test_guided_standard_errors_are_honest_and_lower(tmp_path):
    """Two seeds of the guided trace: their difference must be explained by their standard errors (the
    chi-square one-sided, as for the unguided trace: stratified points make the errors conservative).  And the
    guide must lower the variance of the unguided trace with the same rays: that is what it is for (measured:
    the summed per-pixel variance falls to about 0.7 of the unguided; 0.9 leaves room for the estimates' own
    noise, a few per cent at 576 pixels x 64 rays).  64 rays per pixel, not 16: unguided, 21 % of the rays stop
    in the telescope, all or nothing, and a pixel whose 16 rays all pass (0.79^16 = 2 %: a few pixels of the
    disk) has a sample variance near 0 and a value 27 % high, a 30-sigma outlier of the chi-square that is
    the per-pixel estimate's, not the guide's; at 64 rays that happens with probability 2e-7 per pixel."""
    a, ae = _run(tmp_path, "s1", seed=1, guide_cells=32, camera_rays=64)
    b, be = _run(tmp_path, "s2", seed=2, guide_cells=32, camera_rays=64)
    _agree(a, ae, b, be, "guided seeds 1 and 2")
    assert not np.array_equal(a, b)
    u, ue = _run(tmp_path, "u", seed=3, guide_cells=0, camera_rays=64)
    _agree(a, ae, u, ue, "guided against unguided")
    assert (ae ** 2).sum() < 0.9 * (ue ** 2).sum(), ((ae ** 2).sum(), (ue ** 2).sum())


# the small Cassegrain with a baffle tube between the mirrors, as a GROUP placed in the scene
_TUBE = """SURFACE
  TUBE Z 0.2 0.26 0.9 0.26
OBJECT tube
  INTERFACE ABSORB
"""
_GROUP_SCENE = """UNITS M
WAVELENGTHS 550 NM
SEED {seed}
MODEL paint LAMBERTIAN 0.6
SURFACE
  SPHERE 0 0 1e5 100
OBJECT ball
  INTERFACE ABSORB
  SCATTER MODEL paint
GROUP telescope
""" + textwrap.indent(small_cassegrain().replace("SURFACE\n  PLANE", _TUBE + "SURFACE\n  PLANE"), "  ") + """END GROUP
PLACE telescope AT 0 0 0 AIM 0 0 1
EMITTING SPHERE (1e9 * sin(60)) 0 (1e5 - 1e9 * cos(60)) 1e6 RAYS 1
FLUX TOTAL 1e18 W
LEVEL 50
HALT 0.01
TRACE CAMERA fpa AIM secondary RAYS 64 GUIDE {guide}
EXPORT fpa 'image.npy'
"""


@pytest.mark.parametrize("near", [None, 0.3])
def test_guided_camera_in_a_group(tmp_path, capsys, near):
    """The telescope in a GROUP (with an absorbing tube that stops some of the rays the secondary sends to the
    primary's edge): the instrument is the group.  Guided against unguided (two seeds) per pixel and in total,
    and the total against the closed form (the tube stops none of the light the primary's annulus collects from
    the sphere 1 mrad off the axis: the closed form stands).  64 rays per pixel: see the test above.  With the
    default near share and with `NEAR 0.3` (six times as many rays over the cells next to the clear ones): any
    share keeps the estimate unbiased, since each ray is weighted by the uniform density over the drawn one."""
    imgs = {}
    for guide, seed in ((32, 5), (0, 6)):
        f = tmp_path / f"g{guide}.inr"
        f.write_text(_GROUP_SCENE.format(seed=seed, guide=f"{guide} NEAR {near}" if guide and near else guide))
        imgs[guide] = _run(tmp_path, f"g{guide}", script=f)
    out = capsys.readouterr().out
    assert "GUIDE 32 x 32 cells" in out and "through 4 objects" in out, out
    assert ("of the rays near the clear cells" in out) == (near is not None), out
    assert near is None or f"{near:g} of the rays near the clear cells" in out, out
    (a, ae), (b, be) = imgs[32], imgs[0]
    _agree(a, ae, b, be, "group: guided against unguided")
    expected = _lambert_flux(0.6)
    sig = math.sqrt((ae ** 2).sum())
    assert abs(a.sum() / expected - 1) < 5 * sig / expected + 3e-4, (a.sum(), expected, sig)


@pytest.mark.parametrize("share", [None, 0.15])
def test_guide_tables(share):
    """The tables' arithmetic (not physics): each tile's pmf sums to 1, spreads GUIDE_FLOOR over every cell (so no
    cell is left out) and the near share (GUIDE_NEAR, or TRACE CAMERA ... NEAR) over the cells next to those the
    pilot saw light leave, follows the pilot's tally elsewhere, and a tile the pilot saw nothing leave stays
    uniform."""
    g, t = 4, 2
    passed = np.zeros((t * t, g * g))
    passed[0, :8] = 1.0          # tile 0: azimuth bands 0 and 1 clear, every radial band
    passed[1, 5] = 2.0           # tile 1: one cell, azimuth band 1, radial band 1
    pmf, stats = guide_tables(passed, g, t, share)
    pmf = np.asarray(pmf).reshape(t * t, g * g)
    ns = GUIDE_NEAR if share is None else share
    main = 1 - ns - GUIDE_FLOOR
    assert np.allclose(pmf.sum(axis=1), 1.0)
    # tile 0: the near cells are azimuth bands 3, 0, 1, 2 (the azimuth wraps around): all 16 cells
    assert np.allclose(pmf[0, :8], main / 8 + ns / 16 + GUIDE_FLOOR / 16)
    assert np.allclose(pmf[0, 8:], ns / 16 + GUIDE_FLOOR / 16)
    # tile 1: the 3 x 3 block of azimuth bands 0-2 and radial bands 0-2 about the cell
    near = np.zeros((g, g), bool)
    near[0:3, 0:3] = True
    want = GUIDE_FLOOR / 16 + ns * near.ravel() / 9
    want[5] += main
    assert np.allclose(pmf[1], want)
    assert np.allclose(pmf[2:], 1.0 / 16)
    assert math.isclose(stats["uniform"], (0.5 + 1 / 16) / 4)


def test_guide_near_wraps_in_azimuth_not_in_radius():
    """A cell in the last azimuth band and the outermost radial band: its near cells are the first and last two
    azimuth bands' two outermost radial bands, nothing at radial band 0 (plumbing, not physics)."""
    g, t = 6, 1
    passed = np.zeros((1, g * g))
    passed[0, (g - 1) * g + (g - 1)] = 1.0
    pmf = np.asarray(guide_tables(passed, g, t)[0]).reshape(g, g)
    base = GUIDE_FLOOR / (g * g)
    near = pmf > base * (1 + 1e-9)
    want = np.zeros((g, g), bool)
    for a in (g - 2, g - 1, 0):
        want[a, g - 2:] = True
    assert (near == want).all(), near.astype(int)


@pytest.mark.parametrize("clause,message", [
    ("GUIDE 3", "must be 4 to 64"),
    ("GUIDE 16 DIRECTIONS 4", "GUIDE cannot be combined with DIRECTIONS"),
    ("GUIDE 16 NEAR 0.7", "must be a share from 0 to 0.5"),
    ("NEAR 0.1", "NEAR is a share of GUIDE's tables"),
])
def test_guide_errors(tmp_path, capsys, clause, message):
    f = tmp_path / "bad.inr"
    f.write_text(_GROUP_SCENE.format(seed=1, guide=0).replace("GUIDE 0", clause))
    assert main(["run", str(f), "--out", str(tmp_path / "o")]) == 2
    assert message in capsys.readouterr().err


def test_guide_pilot_is_cached_and_seed_free(tmp_path, capsys):
    """Two guided traces of one instrument in one run: the second reuses the first's pilot, and since the pilot
    has a seed of its own its image is bitwise what a run with only that trace gives (plumbing, not physics)."""
    one = _GROUP_SCENE.format(seed=9, guide=16)
    k = one.index("EMITTING SPHERE")
    tail = one[k:]
    two = (one[:k].replace("SEED 9", "SEED 8") + tail.replace("'image.npy'", "'first.npy'") + "SEED 9\n" + tail)
    (tmp_path / "one.inr").write_text(one)
    (tmp_path / "two.inr").write_text(two)
    a, _ = _run(tmp_path, "one", script=tmp_path / "one.inr")
    capsys.readouterr()
    b, _ = _run(tmp_path, "two", script=tmp_path / "two.inr")
    out = capsys.readouterr().out
    assert out.count("GUIDE 16 x 16") == 2 and "the pilot of an earlier trace" in out, out
    assert np.array_equal(a, b)
    assert not np.array_equal(a, np.load(tmp_path / "two" / "first.npy"))


_TELESCOPE = "GROUP telescope\n" + textwrap.indent(small_cassegrain(), "  ") + "END GROUP\n"

_MOVED_SCENE = """UNITS M
WAVELENGTHS 550 NM
SEED 9
MODEL paint LAMBERTIAN 0.6
GROUP target
  SURFACE
    SPHERE 0 0 1e5 100
  OBJECT ball
    INTERFACE ABSORB
    SCATTER MODEL paint
END GROUP
{telescope}LEVEL 50
HALT 0.01
DO k = 0, 1
  PLACE target AT (10 * k) 0 0
  PLACE telescope AT (10 * k) 0 0 AIM (10 * k) 0 1
  EMITTING SPHERE (10 * k + 1e9 * sin(60)) 0 (1e5 - 1e9 * cos(60)) 1e6 RAYS 1
  FLUX TOTAL 1e18 W
  TRACE CAMERA fpa AIM secondary RAYS 64 GUIDE 16
  EXPORT fpa 'image_{k}.npy'
END DO
""".replace("{telescope}", _TELESCOPE)


def test_guide_pilot_is_traced_in_the_instruments_frame(tmp_path, capsys):
    """The flagship places its telescope anew every hour.  The pilot is traced in the camera's group's own frame
    (the target brought into it), so the same telescope placed elsewhere, with the scene where it was relative to
    it, reuses the first pilot; the two images (the same seed) agree within their errors (plumbing, not
    physics)."""
    f = tmp_path / "moved.inr"
    f.write_text(_MOVED_SCENE)
    assert main(["run", str(f), "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert out.count("GUIDE 16 x 16") == 2 and "the pilot of an earlier trace" in out, out
    (a, ae), (b, be) = ((np.load(tmp_path / "o" / f"image_{k}.npy"), np.load(tmp_path / "o" / f"image_{k}.stderr.npy"))
                        for k in (0, 1))
    _agree(a, ae, b, be, "moved telescope")


def test_guide_pilot_is_shared_by_hero_traces_of_other_seeds(tmp_path, capsys):
    """Two guided HERO traces of one instrument whose seeds start their blocks of lines in different places
    (hero_offset): the second reuses the first's pilot, which traces one line without HERO (the flagship traced
    a new pilot in 7 of its 25 frames, one per block offset; plumbing, not physics)."""
    from irtlang.engine import hero_offset

    s1 = 8
    s2 = next(s for s in range(9, 100) if hero_offset(s, 3) != hero_offset(s1, 3))
    one = (_GROUP_SCENE.format(seed=s1, guide=16).replace("WAVELENGTHS 550 NM", "WAVELENGTHS 500 550 600 NM")
           .replace("RAYS 64 GUIDE 16", "RAYS 4 SPECTRAL 3 HERO 3 GUIDE 16"))
    k = one.index("EMITTING SPHERE")
    tail = one[k:]
    two = one[:k] + tail.replace("'image.npy'", "'first.npy'") + f"SEED {s2}\n" + tail
    (tmp_path / "two.inr").write_text(two)
    _run(tmp_path, "two", script=tmp_path / "two.inr")
    out = capsys.readouterr().out
    assert out.count("GUIDE 16 x 16") == 2 and "the pilot of an earlier trace" in out, out
