from ...lang.spec import Clause, Name, V, positive
from ...core.units import ANGLE

RAYS = Clause("RAYS", (V("rays", integer=True, check=positive),), required=True, doc="number of rays")
RANDOM = Clause("RANDOM", (), doc="random positions instead of a regular lattice")
TOWARD = Clause("TOWARD", (Name("toward"),), doc="emit only toward this object, with exact weights")
CONE = Clause("CONE", (V("cone", ANGLE, check=lambda x: None if 0 < x <= 1.5707963267948966 + 1e-12 else "must be in (0, 90] deg"),),
              doc="restrict emission to a cone of this half-angle about the normal")
