"""EMITTING POINT x y z RAYS n [CONE half_angle [AXIS dx dy dz]] [TOWARD target]

An isotropic point source; with CONE only within that half-angle of AXIS (default +z); with TOWARD only
toward the target, weighted by the solid angle it subtends.

| parameter | unit | meaning |
|---|---|---|
| x y z | length | position |
| RAYS | count | rays per wavelength line |
| CONE | angle (bare: deg) | emission half-angle about AXIS (default 180: all directions) |
| AXIS | 1 | cone axis (default 0 0 1) |
| TOWARD | object | importance target |
"""
import numba

from ...kernels.sampling import uniform_cone
import math

from ...core.diagnostics import error
from ...lang.spec import Clause, Form, V, Vs
from ...core.units import ANGLE, LENGTH
from ._common import RAYS, TOWARD

KIND = "EMITTING POINT"
ROLE = "emitter"
FORM = Form((V("x", LENGTH), V("y", LENGTH), V("z", LENGTH)),
            (RAYS, Clause("CONE", (V("cone", ANGLE, check=lambda x: None if 0 < x <= 3.14159265358979 + 1e-12 else "must be in (0, 180] deg"),)),
             Clause("AXIS", (Vs("axis", n=3),)), TOWARD))
EXAMPLE = "EMITTING POINT 0 0 0 RAYS 1000 CONE 5 AXIS 0 0 1"


def build(b, ctx) -> dict:
    ax = tuple(b.get("axis", (0.0, 0.0, 1.0)))
    m = max(abs(x) for x in ax)
    if m == 0 or not math.isfinite(m):
        raise error(b.span_of("axis"), "AXIS needs a non-zero vector")
    ax = tuple(x / m for x in ax)   # to O(1) first: 1e300 would overflow the squares, 1e-310 lose its digits
    n = math.hypot(*ax)
    return {"position": (b["x"], b["y"], b["z"]), "rays": b["rays"], "cone": b.get("cone", 3.141592653589793),
            "axis": tuple(x / n for x in ax), "toward": b.get("toward")}


# ---- the kernel (the contract: irtlang/plugins/sources/__init__.py) ----
@numba.njit(cache=True, inline="always")
def emit(SRC, s, q, u0, u1):
    """The point itself; its AXIS (par[2:5]) is the emission cone's axis."""
    return 0.0, 0.0, 0.0, SRC.par[s, 2], SRC.par[s, 3], SRC.par[s, 4]


@numba.njit(cache=True, inline="always")
def lambert(SRC, s, u2, u3):
    """Isotropic within the CONE half-angle par[1] (not cosine-weighted: a point has no surface)."""
    x, y, z = uniform_cone(u2, u3, math.cos(SRC.par[s, 1]))
    return x, y, z, 1.0


@numba.njit(cache=True, inline="always")
def toward(SRC, s, c, omega):
    """Uniform emission in the CONE: omega over the cone's solid angle, zero outside it."""
    cmin = math.cos(SRC.par[s, 1])
    if c < cmin:
        return 0.0
    return omega / (2.0 * math.pi * (1.0 - cmin))
