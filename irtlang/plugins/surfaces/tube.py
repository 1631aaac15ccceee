"""TUBE axis z1 r1 z2 r2

The side wall of a frustum along `axis` from (z1, r1) to (z2, r2); a cylinder when r1 = r2.  The normal
points outward (away from the axis).

| parameter | unit | meaning |
|---|---|---|
| axis | X, Y or Z | the tube's axis |
| z1 r1 | length | first end: position on the axis and radius |
| z2 r2 | length | second end |
"""
import math

import numba

from ...core.diagnostics import error
from ...kernels.geometry import drop_leaving_root, hit_tube, tube_normal
from ...kernels.layout import SF_PAR
from ...lang.spec import Axis, Form, V, nonneg
from ...core.units import LENGTH
from ...model.scene import Surface
from .plane import axis_frame

KIND = "TUBE"
FORM = Form((Axis(), V("z1", LENGTH), V("r1", LENGTH, check=nonneg), V("z2", LENGTH), V("r2", LENGTH, check=nonneg)))
EXAMPLE = "SURFACE\n  TUBE Z 0 160 -900 160\nOBJECT 'baffle'"
FEATURE = "quadric"


def build(b, ctx) -> Surface:
    if b["z1"] == b["z2"]:
        raise error(b.span, "TUBE needs z1 != z2", "use a PLANE with an ANNULUS for a flat ring")
    if b["r1"] == 0 and b["r2"] == 0:
        raise error(b.span, "TUBE needs a radius > 0 at one end at least")
    p = {"z1": b["z1"], "r1": b["r1"], "z2": b["z2"], "r2": b["r2"]}
    return Surface(KIND, p, axis_frame(b["axis"], 0.0), None, b.span)


# ---- packing and the kernel (the contract: irtlang/plugins/surfaces/__init__.py) ----
def pack(s: Surface) -> dict:
    """par: z1, r1, z2, r2 (m)."""
    p = s.params
    return {"par": (p["z1"], p["r1"], p["z2"], p["r2"])}


def bounds(s: Surface) -> tuple:
    p = s.params
    return (0.0, 0.0, 0.5 * (p["z1"] + p["z2"]), math.hypot(max(p["r1"], p["r2"]), 0.5 * abs(p["z2"] - p["z1"])))


def size(s: Surface) -> float:
    p = s.params
    return max(p["r1"], p["r2"], abs(p["z2"] - p["z1"]))


@numba.njit(cache=True, inline="always")
def hit(f, si, S, j, ox, oy, oz, dx, dy, dz, tmin, leaving):
    t1, t2 = hit_tube(ox, oy, oz, dx, dy, dz, f[j, SF_PAR], f[j, SF_PAR + 1], f[j, SF_PAR + 2], f[j, SF_PAR + 3])
    if leaving:
        t1, t2 = drop_leaving_root(t1, t2)
    return t1, t2, -1


@numba.njit(cache=True, inline="always")
def normal(f, si, S, j, x, y, z, face):
    return tube_normal(x, y, z, f[j, SF_PAR], f[j, SF_PAR + 1], f[j, SF_PAR + 2], f[j, SF_PAR + 3])
