"""Precision across scales (DESIGN.md): the Cassegrain of examples_scripts/cassegrain.inr, with its source inside
the same GROUP, traced at the origin and PLACEd 0.18 AU away (on the z axis, and off every axis with AIM back
at the origin, so that its frame is rotated): the spot on the focal plane, expressed in the group's frame, must
be the same to 1e-3 um.  A float64 world coordinate near 2.7e10 m resolves only about 4 um, so this holds only
if the trace and the ray records keep the far positions in double-double."""
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import EXAMPLES, ledger_gap, trace_file  # noqa: E402

PLACEMENTS = {
    "origin": "PLACE tel AT 0 0 0",
    "axis": "PLACE tel AT 0 0 0.18 AU",
    "shifted": "PLACE tel AT 0.1 AU -0.12 AU 0.0943 AU",
    "oblique": "PLACE tel AT 0.1 AU -0.12 AU 0.0943 AU AIM 0 0 0 UP 0 0 1",
}


def _script(place: str) -> str:
    return f"""SYSTEM NEW
WAVELENGTHS 550 NM
SEED 1
spacing_delta = 0
band = 550
GROUP tel
INCLUDE '{EXAMPLES / "cassegrain.inr"}'
GRID DISK Z 1200 150 RAYS 20000
SOURCE FIELD 0.03 -0.02
FLUX TOTAL 1 W
END GROUP
{place}
LEVEL 20
TRACE
CONSIDER ONLY fpa
SPOTS POSITION
FOCUS
"""


@pytest.fixture(scope="module")
def spots(tmp_path_factory):
    d = tmp_path_factory.mktemp("prec")
    out = {}
    for key, place in PLACEMENTS.items():
        f = d / f"{key}.inr"
        f.write_text(_script(place))
        res = trace_file(f)
        from irtlang.lang.interp import check_file

        scene = [s for s in check_file(f).steps if s.kind == "TRACE"][-1].scene
        P = scene.groups["TEL"].placement
        R, T = np.array(P.R).reshape(3, 3), np.array(P.T)
        r = res.records
        on = r["object"] == [n.upper() for n in res.packed.object_names].index("FPA")
        lo = r.get("position_lo")
        assert lo is not None, "ray records carry no low part of their positions"
        # group frame: R^T ((hi - T) + lo); hi - T is exact (Sterbenz), the low part then restores the rest
        pg = ((r["position"][on] - T) + lo[on]) @ R
        w = r["flux"][on]
        c = (pg[:, :2] * w[:, None]).sum(0) / w.sum()
        rms = math.sqrt((((pg[:, :2] - c) ** 2).sum(1) * w).sum() / w.sum())
        out[key] = dict(res=res, pg=pg, c=c, rms=rms, img=res.images["fpa"][0], file=f)
    return out


@pytest.mark.parametrize("key", ["axis", "shifted", "oblique"])
def test_far_placement_same_spot(spots, key):
    a, b = spots["origin"], spots[key]
    assert len(a["pg"]) == len(b["pg"]) > 15000
    um = 1e-6
    # the focal plane is at z = -300 mm in the group frame, for every ray
    assert np.allclose(b["pg"][:, 2], -0.3, rtol=0, atol=1e-3 * um)
    assert np.all(np.abs(b["c"] - a["c"]) < 1e-3 * um), (b["c"] - a["c"]) / um
    assert abs(b["rms"] - a["rms"]) < 1e-3 * um, (b["rms"] - a["rms"]) / um
    # ray by ray, too
    assert np.max(np.abs(b["pg"] - a["pg"])) < 1e-3 * um
    # the detector image (binned in the plane's own frame) is the same
    assert np.array_equal(a["img"], b["img"])
    assert ledger_gap(b["res"]) < 1e-12
    # the spot itself: the EFL 10.5 m maps the field angles (0.03, -0.02) deg to (5.498, -3.665) mm,
    # an RMS radius of a few um (ORACLES.md: 0.5 to 5.9 um over the field)
    assert a["c"] / 1e-3 == pytest.approx([10500 * math.tan(math.radians(0.03)),
                                           -10500 * math.tan(math.radians(0.02))], rel=2e-3)
    assert 0.5 * um < a["rms"] < 6 * um


def test_far_placement_same_spots_and_focus_printed(spots, capsys, tmp_path):
    """SPOTS and FOCUS through the CLI print the same numbers for the telescope 0.18 AU away (its axes the world's:
    SPOTS and FOCUS work in world axes) as at the origin: every coordinate of those rays is near 1e10 m."""
    from irtlang.cli import main

    printed = {}
    for key in ("origin", "shifted"):
        code = main(["run", str(spots[key]["file"]), "--out", str(tmp_path / key)])
        out = capsys.readouterr().out
        assert code == 0, out
        printed[key] = (re.search(r"SPOTS POSITION: .*rms radius ([-+0-9.e]+) mm", out).group(1),
                        re.search(r"FOCUS: best focus ([-+0-9.e]+) mm .*RMS radius ([-+0-9.e]+) mm there", out).groups())
    assert printed["origin"] == printed["shifted"]
    assert float(printed["origin"][0]) == pytest.approx(spots["origin"]["rms"] / 1e-3, rel=1e-5)
