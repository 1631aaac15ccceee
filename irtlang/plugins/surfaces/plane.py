"""PLANE axis position [RECT hx hy | DISK r | ANNULUS r_in r_out | ELLIPSE a b]

The plane (axis) = position, normal along +axis.  Without an aperture the plane is unbounded.

| parameter | unit | meaning |
|---|---|---|
| axis | X, Y or Z | the plane's normal axis |
| position | length | coordinate of the plane on that axis |
| RECT hx hy | length | half-widths along the two other axes in cyclic order (Z: x, y; X: y, z; Y: z, x) |
| DISK r / ANNULUS r_in r_out / ELLIPSE a b | length | other apertures, in the same local x, y |
"""
from ...lang.spec import Axis, Form, V
from ...core.units import LENGTH
from ...model.scene import AXIS_FRAME, Surface, Transform
from ._aperture import CLAUSES, aperture_from

KIND = "PLANE"
FORM = Form((Axis(), V("position", LENGTH)), CLAUSES)
EXAMPLE = "SURFACE\n  PLANE Z 0 RECT 10 5\nOBJECT 'window'"


def axis_frame(axis: str, position: float) -> Transform:
    R = AXIS_FRAME[axis]
    T = tuple(position * R[3 * i + 2] for i in range(3))
    return Transform(R, T)


def build(b, ctx) -> Surface:
    return Surface(KIND, {}, axis_frame(b["axis"], b["position"]), aperture_from(b), b.span)
