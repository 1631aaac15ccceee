"""GRID RECT axis position x_min x_max y_min y_max nx ny [RANDOM]

Ray start points on a rectangle in the plane (axis) = position: an nx x ny lattice of cell centres, or
nx*ny random points with RANDOM.  Local x, y follow the cyclic order of PLANE.  Needs a SOURCE direction.

| parameter | unit | meaning |
|---|---|---|
| axis position | X/Y/Z, length | the plane |
| x_min x_max y_min y_max | length | extent in local x and y |
| nx ny | count | points along x and y |
"""
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
