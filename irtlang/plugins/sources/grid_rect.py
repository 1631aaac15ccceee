"""GRID RECT axis position x_min x_max y_min y_max nx ny [RANDOM]

Ray start points on a rectangle in the plane (axis) = position: an nx x ny lattice of cell centres, or
nx*ny random points with RANDOM.  Local x, y follow the cyclic order of PLANE.  Needs a SOURCE direction.

| parameter | unit | meaning |
|---|---|---|
| axis position | X/Y/Z, length | the plane |
| x_min x_max y_min y_max | length | extent in local x and y |
| nx ny | count | points along x and y |
"""
import numba

import math

from ...kernels.layout import SAMPLE_RANDOM, SAMPLE_STRATIFIED, SP_ELLIPSE
from ...core.diagnostics import error
from ...lang.spec import Axis, Form, V, positive
from ...core.units import LENGTH
from ._common import RANDOM

KIND = "GRID RECT"
ROLE = "grid"
FORM = Form((Axis(), V("position", LENGTH), V("x_min", LENGTH), V("x_max", LENGTH), V("y_min", LENGTH),
             V("y_max", LENGTH), V("nx", integer=True, check=positive), V("ny", integer=True, check=positive)),
            (RANDOM,))
EXAMPLE = "GRID RECT Z -100 -10 10 -10 10 101 101\nSOURCE DIRECTION 0 0 1"


def build(b, ctx) -> dict:
    if b["x_min"] > b["x_max"] or b["y_min"] > b["y_max"]:
        raise error(b.span, "GRID RECT needs x_min <= x_max and y_min <= y_max")
    keys = ("axis", "position", "x_min", "x_max", "y_min", "y_max", "nx", "ny")
    return {**{k: b[k] for k in keys}, "random": bool(b.get("random", False)), "rays": b["nx"] * b["ny"]}


# ---- the kernel (the contract: irtlang/plugins/sources/__init__.py) ----
@numba.njit(cache=True, inline="always")
def emit(SRC, s, q, u0, u1):
    """Point q of the nx x ny lattice (or a random point; or one random point in cell q: camera pixels); the
    Lambertian axis of a camera's pixels, on the side par[8] (+-1).  A camera's one elliptical pixel
    (par[SP_ELLIPSE] = 1: a DISK or ELLIPSE aperture) takes the point to the ellipse inscribed in the extent by
    Shirley and Chiu's concentric map, which keeps areas and so the strata."""
    nx = int(SRC.par[s, 4])
    ny = int(SRC.par[s, 5])
    if SRC.random[s] == SAMPLE_RANDOM:
        fx = u0
        fy = u1
    else:
        iy = q // nx
        ix = q - iy * nx
        if SRC.random[s] >= SAMPLE_STRATIFIED:     # stratified: one random point in each lattice cell
            fx = (ix + u0) / nx
            fy = (iy + u1) / ny
        else:
            fx = (ix + 0.5) / nx
            fy = (iy + 0.5) / ny
    if SRC.par[s, SP_ELLIPSE] > 0.0:
        a = 2.0 * fx - 1.0
        b = 2.0 * fy - 1.0
        if a == 0.0 and b == 0.0:
            r = 0.0
            phi = 0.0
        elif abs(a) > abs(b):
            r = a
            phi = 0.25 * math.pi * (b / a)
        else:
            r = b
            phi = 0.5 * math.pi - 0.25 * math.pi * (a / b)
        fx = 0.5 + 0.5 * r * math.cos(phi)
        fy = 0.5 + 0.5 * r * math.sin(phi)
    lx = SRC.par[s, 0] + (SRC.par[s, 1] - SRC.par[s, 0]) * fx
    ly = SRC.par[s, 2] + (SRC.par[s, 3] - SRC.par[s, 2]) * fy
    return lx, ly, 0.0, 0.0, 0.0, SRC.par[s, 8]
