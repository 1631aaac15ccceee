"""GRID DISK axis position radius RAYS n [RANDOM]

Ray start points on a disk of `radius` centred on the axis in the plane (axis) = position: a regular
square lattice of about n points clipped to the disk, or n random points (uniform in area) with RANDOM.

| parameter | unit | meaning |
|---|---|---|
| axis position | X/Y/Z, length | the plane |
| radius | length | disk radius |
| RAYS | count | number of rays (approximate for the lattice) |
"""
from ...lang.spec import Axis, Form, V, positive
from ...core.units import LENGTH
from ._common import RANDOM, RAYS

KIND = "GRID DISK"
ROLE = "grid"
FORM = Form((Axis(), V("position", LENGTH), V("radius", LENGTH, check=positive)), (RAYS, RANDOM))
EXAMPLE = "GRID DISK Z -100 150 RAYS 1000 RANDOM\nSOURCE DIRECTION 0 0 1"


def build(b, ctx) -> dict:
    return {"axis": b["axis"], "position": b["position"], "radius": b["radius"], "rays": b["rays"],
            "random": bool(b.get("random", False))}
