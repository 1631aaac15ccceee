"""SOURCE POSITION x y z [CONVERGE]

Gives each ray of the preceding GRID the direction from the point (x, y, z) through its start point:
the rays diverge from the point.  With CONVERGE they run from their start point toward it instead.

| parameter | unit | meaning |
|---|---|---|
| x y z | length | the point |
| CONVERGE | flag | rays converge to the point instead of diverging from it |
"""
import math

import numba

from ...kernels.layout import DIR_CONVERGE, DIR_DIVERGE
from ...lang.spec import Clause, Form, Vs
from ...core.units import LENGTH

KIND = "SOURCE POSITION"
ROLE = "direction"
FORM = Form((Vs("point", LENGTH, n=3),), (Clause("CONVERGE", (), doc="converge to the point"),))
EXAMPLE = "GRID RECT Z 0 -1 1 -1 1 3 3\nSOURCE POSITION 0 0 500 CONVERGE"


def build(b, ctx) -> dict:
    return {"point": tuple(b["point"]), "converge": bool(b.get("converge", False))}


# ---- the kernel (the contract: irtlang/plugins/sources/__init__.py) ----
DIRECTION_CODES = (DIR_DIVERGE, DIR_CONVERGE)


@numba.njit(cache=True, inline="always")
def direction(SRC, s, lx, ly, lz):
    """From the point par[6:9] through the ray's start (DIVERGE), or toward it (CONVERGE)."""
    vx = lx - SRC.par[s, 6]
    vy = ly - SRC.par[s, 7]
    vz = lz - SRC.par[s, 8]
    if SRC.dir[s] == DIR_CONVERGE:
        vx, vy, vz = -vx, -vy, -vz
    m = math.sqrt(vx * vx + vy * vy + vz * vz)
    if m == 0.0:
        return 0.0, 0.0, 1.0
    return vx / m, vy / m, vz / m
