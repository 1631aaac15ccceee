"""TRACE CAMERA: the language's checks (irt check; no tracing).  The physics is in
tests/physics/test_camera_image.py."""
from __future__ import annotations

import pytest

from irtlang.cli import main

BASE = """UNITS M
WAVELENGTHS 550 NM
MODEL paint LAMBERTIAN 0.5
SURFACE
  SPHERE 0 0 100 1
OBJECT ball
  INTERFACE ABSORB
  SCATTER MODEL paint TOWARD mirror
SURFACE
  CONIC Z 0 RADIUS 2 CONIC -1 DISK 0.2
OBJECT mirror
  INTERFACE REFLECT
SURFACE
  PLANE Z 1 RECT 0.01 0.01
OBJECT fpa
  INTERFACE ABSORB
  {det}
{sources}
{trace}
"""
SUN = "EMITTING SPHERE 1e6 0 0 1e3 RAYS 1\nFLUX TOTAL 1 W"


def _check(tmp_path, capsys, trace, det="DETECTOR PIXELS 16 16", sources=SUN):
    f = tmp_path / "s.inr"
    f.write_text(BASE.format(det=det, sources=sources, trace=trace))
    rc = main(["check", str(f)])
    return rc, capsys.readouterr().err


def test_a_valid_camera_trace_checks(tmp_path, capsys):
    rc, err = _check(tmp_path, capsys, "TRACE CAMERA fpa AIM mirror RAYS 4 SPECTRAL 2 WINDOW 2 14 0 16")
    assert rc == 0, err


@pytest.mark.parametrize("trace,det,sources,message", [
    ("TRACE CAMERA fpa", "DETECTOR PIXELS 16 16", SUN, "needs both CAMERA obj and AIM obj"),
    ("TRACE CAMERA fpa AIM mirror RAYS 3", "DETECTOR PIXELS 16 16", SUN, "must be a square"),
    ("TRACE CAMERA fpa AIM mirror WINDOW 0 17 0 16", "DETECTOR PIXELS 16 16", SUN, "is not inside the detector"),
    ("TRACE CAMERA fpa AIM mirror WINDOW 5 5 0 16", "DETECTOR PIXELS 16 16", SUN, "is not inside the detector"),
    ("TRACE CAMERA fpa AIM mirror", "", SUN, "needs a DETECTOR PIXELS grid"),
    ("TRACE CAMERA fpa AIM mirror", "DETECTOR PIXELS 16 16", SUN + "\n" + SUN, "exactly one source"),
    ("TRACE CAMERA fpa AIM mirror", "DETECTOR PIXELS 16 16",
     "GRID DISK Z 0 1 RAYS 10\nSOURCE DIRECTION 0 0 1", "exactly one source, an EMITTING SPHERE"),
    ("TRACE CAMERA fpa AIM nothing", "DETECTOR PIXELS 16 16", SUN, "nothing"),
    ("TRACE CAMERA fpa AIM mirror UNTIL ERROR 1% ON fpa", "DETECTOR PIXELS 16 16", SUN, "UNTIL ERROR"),
])
def test_bad_camera_traces(tmp_path, capsys, trace, det, sources, message):
    rc, err = _check(tmp_path, capsys, trace, det=det, sources=sources)
    assert rc == 2
    assert "error:" in err and message in err, err
    assert "Traceback" not in err
