"""PLANE axis position [RECT hx hy | DISK r | ANNULUS r_in r_out | ELLIPSE a b]

The plane (axis) = position, normal along +axis.  Without an aperture the plane is unbounded.

| parameter | unit | meaning |
|---|---|---|
| axis | X, Y or Z | the plane's normal axis |
| position | length | coordinate of the plane on that axis |
| RECT hx hy | length | half-widths along the two other axes in cyclic order (Z: x, y; X: y, z; Y: z, x) |
| DISK r / ANNULUS r_in r_out / ELLIPSE a b | length | other apertures, in the same local x, y |
"""
import math

import numba

from ...core.units import LENGTH
from ...kernels.geometry import drop_leaving_root, hit_plane
from ...lang.spec import Axis, Form, V
from ...model.scene import AXIS_FRAME, Surface, Transform
from ._aperture import CLAUSES, aperture_from, bounding_radius

KIND = "PLANE"
FORM = Form((Axis(), V("position", LENGTH)), CLAUSES)
EXAMPLE = "SURFACE\n  PLANE Z 0 RECT 10 5\nOBJECT 'window'"
FEATURE = None          # the kernel feature flag it needs (irtlang.compile.pack.Features): none


def axis_frame(axis: str, position: float) -> Transform:
    R = AXIS_FRAME[axis]
    T = tuple(position * R[3 * i + 2] for i in range(3))
    return Transform(R, T)


def build(b, ctx) -> Surface:
    return Surface(KIND, {}, axis_frame(b["axis"], b["position"]), aperture_from(b), b.span)


# ---- packing and the kernel (the contract: irtlang/plugins/surfaces/__init__.py) ----
def pack(s: Surface) -> dict:
    """No parameters: the plane z = 0 of its frame."""
    return {}


def bounds(s: Surface) -> tuple:
    if s.aperture is None:
        return (0.0, 0.0, 0.0, math.inf)
    return (0.0, 0.0, 0.0, bounding_radius(s.aperture))


def size(s: Surface) -> float:
    return 1.0


@numba.njit(cache=True, inline="always")
def hit(f, si, S, j, ox, oy, oz, dx, dy, dz, tmin, leaving):
    if not ((oz > 0.0 and dz < 0.0) or (oz < 0.0 and dz > 0.0)):
        return math.inf, math.inf, -1      # the plane is behind, or parallel: hit_plane's root would be <= 0 or inf
    t1, t2 = hit_plane(ox, oy, oz, dx, dy, dz)
    if leaving:
        t1, t2 = drop_leaving_root(t1, t2)
    return t1, t2, -1


@numba.njit(cache=True, inline="always")
def normal(f, si, S, j, x, y, z, face):
    return 0.0, 0.0, 1.0
