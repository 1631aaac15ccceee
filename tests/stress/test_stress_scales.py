"""Stress: coordinates from 1e-9 to 1e12 (UNITS M) and groups PLACEd far away (docs/tracer.md,
"Stress tests").  Besides the common invariants (tests/stress/_stress_util.py):
* one scene (a glass ball, a paraboloid, a detector, a point source and a grid) scaled by 1e-9 .. 1e12 gives
  the same ledger and the same detector image at every scale: no ray changes its fate with the scale;
* a small telescope (a paraboloid focusing onto a 2 um detector of 0.1 um pixels) placed 1e9 .. 1.4e12 m away,
  with and without AIM, gives the image it gives at the origin.
"""
import numpy as np
import pytest
from _stress_util import check_run, fmt, head, outputs

SCALES = [1e-9, 1e-6, 1e-3, 1.0, 1e3, 1e6, 1e9, 1e12]


def _scaled(sc):
    s = lambda v: fmt(v * sc)   # noqa: E731
    return head(units="M") + f"""MEDIUM glass INDEX 1.5
SURFACE
  SPHERE {s(0.2)} {s(-0.1)} {s(3)} {s(1)}
OBJECT lens
  INTERFACE TRANSMIT AIR glass
SURFACE
  CONIC Z {s(-5)} RADIUS {s(-20)} CONIC -1 DISK {s(4)}
OBJECT mir
  INTERFACE REFLECT
SURFACE
  PLANE Z {s(10)} RECT {s(3)} {s(3)}
OBJECT det
  DETECTOR PIXELS 16 16
SURFACE
  ELLIPSOID {s(50)} {s(40)} {s(30)}
OBJECT dome
GRID DISK Z {s(0)} {s(3.5)} RAYS 200
SOURCE DIRECTION 0.01 0.02 -1
EMITTING POINT {s(0)} {s(0.5)} {s(-2)} RAYS 100
LEVEL 100
TRACE
""" + outputs("det", spectra=("lens", "mir"))


@pytest.fixture(scope="module")
def scaled(runner, tmp_path_factory):
    d = tmp_path_factory.mktemp("scales")
    return {sc: runner.run(d / f"s{i}", _scaled(sc), f"scale_{i}") for i, sc in enumerate(SCALES)}


@pytest.mark.parametrize("sc", SCALES)
def test_same_scene_at_every_scale(scaled, sc):
    r = check_run(scaled[sc])
    ref = check_run(scaled[1.0])
    assert r.row("det")[0] > 0 and r.row("lens")[0] > 0 and r.row("mir")[0] > 0
    for name, row in ref.ledger.items():
        assert np.allclose(r.ledger[name], row, rtol=1e-12, atol=1e-15), (sc, name, r.ledger[name], row)
    a, b = np.load(r.folder / "img_det.npy"), np.load(ref.folder / "img_det.npy")
    assert np.allclose(a, b, rtol=1e-12, atol=1e-15)


def _telescope(place):
    # off-axis by 3.3e-7 rad: the focus lands inside pixel 13 of 20 (not on a pixel boundary)
    return head(units="M", lines="550 NM") + f"""GROUP tel
SURFACE
  CONIC Z 0 RADIUS -2 CONIC -1 DISK 0.1
OBJECT m1
  INTERFACE REFLECT
SURFACE
  PLANE Z -1 RECT 1e-6 1e-6
OBJECT fpa
  DETECTOR PIXELS 20 20
GRID DISK Z -3 0.09 RAYS 300
SOURCE DIRECTION 3.3e-7 -3.3e-7 1
END GROUP
{place}
LEVEL 10
TRACE
""" + outputs("fpa")


PLACES = ["PLACE tel AT 0 0 0", "PLACE tel AT 1e12 0 0", "PLACE tel AT 1e12 -1e12 3e11",
          "PLACE tel AT 1e12 0 0 AIM 0 0 0", "PLACE tel AT 1e12 -1e12 3e11 AIM 0 0 0 UP 0 0 1",
          "PLACE tel AT 1e9 1e9 1e9 AIM 1e9 1e9 2e9"]


@pytest.fixture(scope="module")
def placed(runner, tmp_path_factory):
    d = tmp_path_factory.mktemp("far")
    return {p: runner.run(d / f"p{i}", _telescope(p), f"far_{i}") for i, p in enumerate(PLACES)}


@pytest.mark.parametrize("place", PLACES)
def test_far_group_same_image(placed, place):
    r = check_run(placed[place])
    ref = check_run(placed[PLACES[0]])
    img, img0 = np.load(r.folder / "img_fpa.npy"), np.load(ref.folder / "img_fpa.npy")
    assert img0.sum() > 0.5 * ref.row("EMITTED")[0]          # the spot is on the detector
    assert np.count_nonzero(img0) <= 4                        # and it is a spot
    assert np.array_equal(img, img0), place
    assert r.row("fpa")[0] == ref.row("fpa")[0]


@pytest.mark.slow
@pytest.mark.parametrize("e", range(-9, 13))
def test_same_scene_at_every_decade_long(runner, tmp_path, e):
    """The long form: every power of ten from 1e-9 to 1e12, against the scene at 1 m."""
    r = check_run(runner.run(tmp_path / "s", _scaled(10.0 ** e), "scale"))
    ref = check_run(runner.run(tmp_path / "ref", _scaled(1.0), "ref"))
    for name, row in ref.ledger.items():
        assert np.allclose(r.ledger[name], row, rtol=1e-12, atol=1e-15), (e, name)
    assert np.allclose(np.load(r.folder / "img_det.npy"), np.load(ref.folder / "img_det.npy"), rtol=1e-12,
                       atol=1e-15)
