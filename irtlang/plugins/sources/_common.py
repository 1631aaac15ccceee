import math

import numba

from ...kernels.sampling import cosine_hemisphere
from ...lang.spec import Clause, Name, V, positive
from ...core.units import ANGLE

RAYS = Clause("RAYS", (V("rays", integer=True, check=positive),), required=True, doc="number of rays")
RANDOM = Clause("RANDOM", (), doc="random positions instead of a regular lattice")
TOWARD = Clause("TOWARD", (Name("toward"),), doc="emit only toward this object, with exact weights")
CONE = Clause("CONE", (V("cone", ANGLE, check=lambda x: None if 0 < x <= 1.5707963267948966 + 1e-12 else "must be in (0, 90] deg"),),
              doc="restrict emission to a cone of this half-angle about the normal")


# ---- the kernel's defaults for a Lambertian emitter without its own ``lambert`` / ``toward`` ----
@numba.njit(cache=True, inline="always")
def lambert(SRC, s, u2, u3):
    """Cosine-weighted over the hemisphere about the axis."""
    x, y, z = cosine_hemisphere(u2, u3)
    return x, y, z, 1.0


@numba.njit(cache=True, inline="always")
def toward(SRC, s, c, omega):
    """A direction drawn uniformly in a cone of solid angle omega: weight cos / pi times omega (0 behind)."""
    if c <= 0.0:
        return 0.0
    return c * omega / math.pi
