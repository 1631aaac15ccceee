"""The enclosure of the HRI-like instrument keeps light from outside the field of view off the focal plane.

Field of view: the focal plane is 21.504 mm square at EFL 10.5 m, +-0.0587 deg along x and y.  A star just
outside it images off the detector; the stray paths that remain in a bare Cassegrain are the direct ones, through
the primary's hole past the secondary (from about 0.3 deg off axis on).  cassegrain.inr closes them with the
central baffle (a cone from the hole to z = 560 mm), the 97 mm obscuration, the tube, the covers and the filter
mount (docs/instrument.md gives the geometry: every line from the detector through the top of the cone meets
the obscuration).  Oracle: geometry, so the expected flux is exactly 0; random rays (200,000 per direction over a
1.2 m disk, 0.18 per mm^2) would find an open path of a few mm^2, as they do on the bare telescope."""
import math
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _instrument import EXAMPLES  # noqa: E402
from _trace_util import trace_text  # noqa: E402

OUTSIDE = [(0.07, 0), (0.1, 45), (0.2, 30), (0.33, 0), (0.5, 45), (1.0, 0), (2.0, 30), (3.0, 45), (5.0, 0),
           (10.0, 30), (30.0, 45), (60.0, 0), (85.0, 30)]


def _script(inc, theta, az, rays=200000, band=True):
    t = math.tan(math.radians(theta))
    ax = math.degrees(math.atan(t * math.cos(math.radians(az))))
    ay = math.degrees(math.atan(t * math.sin(math.radians(az))))
    return (f"WAVELENGTHS 550 NM\nSEED 3\nspacing_delta = 0\n" + ("band = 550\n" if band else "")
            + f"INCLUDE '{EXAMPLES / inc}'\nLEVEL 50\n"
            f"GRID DISK Z 1400 600 RAYS {rays} RANDOM\nSOURCE FIELD {ax!r} {ay!r}\nFLUX TOTAL 1 W\nTRACE\n")


def _on_fpa(res):
    names = [n.upper() for n in res.packed.object_names]
    return float(res.ledger[names.index("FPA"), 0].sum())


@pytest.mark.parametrize("theta,az", OUTSIDE, ids=[f"{t}deg_az{a}" for t, a in OUTSIDE])
def test_nothing_from_outside_the_field_reaches_the_fpa(tmp_path, theta, az):
    res = trace_text(tmp_path, _script("cassegrain.inr", theta, az), records=False)
    assert _on_fpa(res) == 0.0


def test_inside_the_field_reaches_the_fpa(tmp_path):
    """A star inside the field (0.05, 0.05 deg) does reach it: the share of the 1.2 m disk's flux that the
    0.3 m annular pupil (less the vanes) passes, times two mirror reflectances and the filter (0.9 x 0.91^2 x
    (150^2 - 48.5^2)/600^2 = 0.0522, less 1.7 % for the vanes): binomial error over 200,000 rays, 5 sigma."""
    res = trace_text(tmp_path, _script("cassegrain.inr", math.degrees(math.atan(math.hypot(
        math.tan(math.radians(0.05)), math.tan(math.radians(0.05))))), 45), records=False)
    p = (150 ** 2 - 48.5 ** 2) / 600 ** 2
    vanes = 4 * 2 * (165 - 48.5) / (math.pi * (150 ** 2 - 48.5 ** 2))   # their strips over the annulus (upper bound)
    T = 0.9 * 0.91 ** 2 * 0.99991 ** 2       # filter peak (logistic edges at +-50 nm: 0.99991 each) x mirrors
    f = _on_fpa(res)
    sigma = T * math.sqrt(p * (1 - p) / 200000)
    assert T * p * (1 - vanes) - 5 * sigma < f < T * p + 5 * sigma


@pytest.mark.parametrize("theta", [1.0, 2.0, 5.0])
def test_the_bare_telescope_leaks(tmp_path, theta):
    """The same directions on the bare two mirrors (cassegrain_optics.inr, no enclosure): light reaches the
    focal plane directly through the primary's hole, so the test above can see a leak."""
    res = trace_text(tmp_path, _script("cassegrain_optics.inr", theta, 0, rays=400000, band=False), records=False)
    assert _on_fpa(res) > 0.0
