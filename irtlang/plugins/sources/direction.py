"""SOURCE DIRECTION dx dy dz

Gives the rays of the preceding GRID one direction (collimated).  The vector need not be normalized.

| parameter | unit | meaning |
|---|---|---|
| dx dy dz | 1 | direction cosines (any length > 0) |
"""
import numba

from ...kernels.layout import DIR_COLLIMATED
import math

from ...core.diagnostics import error
from ...lang.spec import Form, Vs

KIND = "SOURCE DIRECTION"
ROLE = "direction"
FORM = Form((Vs("direction", n=3),))
EXAMPLE = "GRID RECT Z 0 -1 1 -1 1 3 3\nSOURCE DIRECTION 0 0 1"


def build(b, ctx) -> dict:
    d = b["direction"]
    m = max(abs(x) for x in d)
    if m == 0 or not math.isfinite(m):
        raise error(b.span_of("direction"), "SOURCE DIRECTION needs a non-zero vector")
    d = [x / m for x in d]      # to O(1) first: 1e300 would overflow the squares, 1e-310 lose its digits
    n = math.hypot(*d)
    return {"direction": tuple(x / n for x in d)}


# ---- the kernel (the contract: irtlang/plugins/sources/__init__.py) ----
DIRECTION_CODES = (DIR_COLLIMATED,)


@numba.njit(cache=True, inline="always")
def direction(SRC, s, lx, ly, lz):
    """The source-frame direction par[6:9], the same for every ray (the kernel computes it once per batch)."""
    return SRC.par[s, 6], SRC.par[s, 7], SRC.par[s, 8]
