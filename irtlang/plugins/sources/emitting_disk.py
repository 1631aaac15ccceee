"""EMITTING DISK axis position radius RAYS n [CONE half_angle] [TOWARD target]

A Lambertian disk in the plane (axis) = position, centred on the axis, emitting toward +axis; with CONE
only within that half-angle of the normal (which carries a share sin^2 of the Lambertian flux).

| parameter | unit | meaning |
|---|---|---|
| axis position | X/Y/Z, length | the disk's plane |
| radius | length | radius |
| RAYS | count | rays per wavelength line |
| CONE | angle (bare: deg) | emission half-angle (default 90) |
| TOWARD | object | importance target |
"""
import math

import numba

from ...kernels.sampling import cosine_hemisphere, lambert_cone, uniform_disk
from ...lang.spec import Axis, Form, V, positive
from ...core.units import LENGTH
from ._common import CONE, RAYS, TOWARD

KIND = "EMITTING DISK"
ROLE = "emitter"
FORM = Form((Axis(), V("position", LENGTH), V("radius", LENGTH, check=positive)), (RAYS, CONE, TOWARD))
EXAMPLE = "EMITTING DISK Z 0 5 RAYS 1000 CONE 10"


def build(b, ctx) -> dict:
    return {"axis": b["axis"], "position": b["position"], "radius": b["radius"], "rays": b["rays"],
            "cone": b.get("cone", 1.5707963267948966), "toward": b.get("toward")}


# ---- the kernel (the contract: irtlang/plugins/sources/__init__.py) ----
@numba.njit(cache=True, inline="always")
def emit(SRC, s, q, u0, u1):
    """A uniform point of the disk (radius par[0]); Lambertian about +z."""
    x, y = uniform_disk(u0, u1)
    r = SRC.par[s, 0]
    return r * x, r * y, 0.0, 0.0, 0.0, 1.0


@numba.njit(cache=True, inline="always")
def lambert(SRC, s, u2, u3):
    """Cosine-weighted within the CONE half-angle par[1]: the weight keeps the flux per area (sin^2 of it)."""
    if SRC.par[s, 1] < 1.5707963267948966:
        sm = math.sin(SRC.par[s, 1])
        x, y, z = lambert_cone(u2, u3, sm)
        return x, y, z, sm * sm
    x, y, z = cosine_hemisphere(u2, u3)
    return x, y, z, 1.0


@numba.njit(cache=True, inline="always")
def toward(SRC, s, c, omega):
    """The weight of a direction drawn uniformly in a cone of solid angle omega: cos / pi times omega, zero
    outside the CONE."""
    if c <= math.cos(SRC.par[s, 1]):
        return 0.0
    return c * omega / math.pi
