"""TUBE axis z1 r1 z2 r2

The side wall of a frustum along `axis` from (z1, r1) to (z2, r2); a cylinder when r1 = r2.  The normal
points outward (away from the axis).

| parameter | unit | meaning |
|---|---|---|
| axis | X, Y or Z | the tube's axis |
| z1 r1 | length | first end: position on the axis and radius |
| z2 r2 | length | second end |
"""
from ...core.diagnostics import error
from ...lang.spec import Axis, Form, V, nonneg
from ...core.units import LENGTH
from ...model.scene import Surface
from .plane import axis_frame

KIND = "TUBE"
FORM = Form((Axis(), V("z1", LENGTH), V("r1", LENGTH, check=nonneg), V("z2", LENGTH), V("r2", LENGTH, check=nonneg)))
EXAMPLE = "SURFACE\n  TUBE Z 0 160 -900 160\nOBJECT 'baffle'"


def build(b, ctx) -> Surface:
    if b["z1"] == b["z2"]:
        raise error(b.span, "TUBE needs z1 != z2", "use a PLANE with an ANNULUS for a flat ring")
    if b["r1"] == 0 and b["r2"] == 0:
        raise error(b.span, "TUBE needs a radius > 0 at one end at least")
    p = {"z1": b["z1"], "r1": b["r1"], "z2": b["z2"], "r2": b["r2"]}
    return Surface(KIND, p, axis_frame(b["axis"], 0.0), None, b.span)
