"""BICONIC traced by the kernel (its dispatch generated from the surface registry), against closed forms.

* kx = ky = -1 is the elliptic paraboloid z = x^2/(2 Rx) + y^2/(2 Ry).  A collimated beam along its axis,
  reflected: every ray of the plane y = 0 passes through (0, 0, Rx/2), every ray of the plane x = 0 through
  (0, 0, Ry/2) (each section is a parabola with its focus there).  Checked on the rays' recorded end states to
  1e-9 of the focal length where they cross a small plane at the focus.
* Rx = Ry, kx = ky: a CONIC.  The same beam reflected off CONIC and off BICONIC (closed-form quadric roots
  against the biconic's quartic) ends at the same points to 1e-9 relative.
"""
import numpy as np

from irtlang.lang.diagnostics import Source
from irtlang.lang.interp import Interpreter
from irtlang.tracer import Progress, run_trace

BEAM = {"x": "GRID RECT Z 300 10 40 -1 1 31 1", "y": "GRID RECT Z 300 -1 1 10 40 1 31"}


def _scene(mirror, beam, zf=100.0):
    text = f"""WAVELENGTHS 550 NM
SEED 3
SURFACE
  {mirror}
OBJECT mirror
  INTERFACE REFLECT
SURFACE
  PLANE Z {zf} DISK 3
OBJECT stop
  INTERFACE ABSORB
{beam}
SOURCE DIRECTION 0 0 -1
TRACE
"""
    it = Interpreter(check_only=True)
    it.run_source(Source("biconic.inr", text))
    assert not it.diags, it.diags.items
    return [s for s in it.steps if s.kind == "TRACE"][0].scene


def _rays(mirror, beam, zf=100.0):
    r = run_trace(_scene(mirror, beam, zf), seed=3, level=10, halt=0.0, records=True, progress=Progress(0, enabled=False))
    rec = r.records
    return rec["position"] + rec["position_lo"], rec["direction"], rec["object"], r


def test_elliptic_paraboloid_sections_focus_at_half_their_radii():
    Rx, Ry = 400.0, 600.0       # mm
    mirror = f"BICONIC Z 0 RADIUS {Rx} {Ry} CONIC -1 -1 RECT 60 60"
    for sec, R in (("x", Rx), ("y", Ry)):
        p, d, obj, _ = _rays(mirror, BEAM[sec], R / 2)
        # every ray reflected once and ended on the small plane at z = R/2 (object 1), at its centre
        assert len(p) == 31 and np.all(obj == 1)
        np.testing.assert_allclose(p, np.tile([0.0, 0.0, R / 2 * 1e-3], (31, 1)), rtol=0, atol=1e-9 * R * 1e-3)
        # at the other section's focus the same rays do not meet there (the check can fail)
        other = (Rx + Ry) - R
        p2, _, obj2, _ = _rays(mirror, BEAM[sec], other / 2)
        hit = obj2 == 1
        assert not hit.all() or np.abs(p2[hit, :2]).max() > 1e-4


def test_equal_sections_trace_as_the_conic():
    for beam in BEAM.values():
        pa, da, oa, _ = _rays("CONIC Z 0 RADIUS 500 CONIC -0.6 DISK 60", beam)
        pb, db, ob, _ = _rays("BICONIC Z 0 RADIUS 500 500 CONIC -0.6 -0.6 DISK 60", beam)
        assert np.array_equal(oa, ob) and len(pa) == 31
        np.testing.assert_allclose(pb, pa, rtol=0, atol=1e-12)
        np.testing.assert_allclose(db, da, rtol=0, atol=1e-12)
