"""GRID DISK axis position radius RAYS n [RANDOM]

Ray start points on a disk of `radius` centred on the axis in the plane (axis) = position: a regular
square lattice of about n points clipped to the disk, or n random points (uniform in area) with RANDOM.

| parameter | unit | meaning |
|---|---|---|
| axis position | X/Y/Z, length | the plane |
| radius | length | disk radius |
| RAYS | count | number of rays (approximate for the lattice) |
"""
import numba

from ...kernels.layout import SAMPLE_RANDOM
from ...kernels.sampling import uniform_disk
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


# ---- the kernel (the contract: irtlang/plugins/sources/__init__.py) ----
@numba.njit(cache=True, inline="always")
def emit(SRC, s, q, u0, u1):
    """A random point of the disk, or point q of its lattice: the row table (irtlang.compile.pack.
    disk_lattice_rows: per row its first point and its y index, then an end marker) gives q's row."""
    if SRC.random[s] == SAMPLE_RANDOM:
        x, y = uniform_disk(u0, u1)
        return SRC.par[s, 0] * x, SRC.par[s, 0] * y, 0.0, 0.0, 0.0, 1.0
    r0 = SRC.pts_off[s]
    lo = 0
    hi = int(SRC.par[s, 2])        # rows; entry hi is the end marker
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if SRC.pts[r0 + mid, 0] <= q:
            lo = mid
        else:
            hi = mid
    start = SRC.pts[r0 + lo, 0]
    amax = (SRC.pts[r0 + lo + 1, 0] - start - 1.0) * 0.5
    h = SRC.par[s, 1]
    return (q - start - amax) * h, SRC.pts[r0 + lo, 1] * h, 0.0, 0.0, 0.0, 1.0
