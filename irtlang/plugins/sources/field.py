"""SOURCE FIELD angle_x angle_y

Collimated rays from the preceding GRID, tilted by field angles from the grid's axis, travelling toward
the plane (axis) = 0 (a grid at z = 1200 sends rays along -z, one at z = -100 along +z; at 0, along +z):
the direction is normalize(tan(angle_x), tan(angle_y), s) in the grid's local frame, s = -1 or +1.

| parameter | unit | meaning |
|---|---|---|
| angle_x angle_y | angle (bare: deg) | field angles along local x and y; a unit after the pair applies to both |
"""
import math

import numba

from ...kernels.layout import DIR_FIELD
from ...lang.spec import Form, Vs
from ...core.units import ANGLE

KIND = "SOURCE FIELD"
ROLE = "direction"
# one list of two, so that a trailing unit applies to both (`SOURCE FIELD 0.05 0.02 mrad`)
FORM = Form((Vs("angles", ANGLE, n=2, check=lambda a: None if abs(a) < 1.57 else "must be within +-90 deg"),))
EXAMPLE = "GRID DISK Z -100 150 RAYS 1000\nSOURCE FIELD 0.05 0.02 deg"


def build(b, ctx) -> dict:
    ax, ay = b["angles"]
    return {"angle_x": ax, "angle_y": ay}


# ---- the kernel (the contract: irtlang/plugins/sources/__init__.py) ----
DIRECTION_CODES = (DIR_FIELD,)


@numba.njit(cache=True, inline="always")
def direction(SRC, s, lx, ly, lz):
    """The field angles par[6], par[7] about the grid's normal, toward the plane's side par[8] (+-1)."""
    tx = math.tan(SRC.par[s, 6])
    ty = math.tan(SRC.par[s, 7])
    m = math.sqrt(tx * tx + ty * ty + 1.0)
    return tx / m, ty / m, SRC.par[s, 8] / m
