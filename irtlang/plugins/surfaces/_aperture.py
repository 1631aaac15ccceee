"""Apertures shared by PLANE and CONIC: RECT hx hy, DISK r, ANNULUS r_in r_out, ELLIPSE a b (local x, y)."""
import math

from ...core.diagnostics import error
from ...lang.spec import Clause, V, positive, nonneg
from ...core.units import LENGTH
from ...model.scene import Aperture

CLAUSES = (
    Clause("RECT", (V("half_x", LENGTH, check=positive), V("half_y", LENGTH, check=positive)),
           doc="rectangle of half-widths along local x and y"),
    Clause("DISK", (V("disk_radius", LENGTH, check=positive),), doc="disk of radius r"),
    Clause("ANNULUS", (V("r_in", LENGTH, check=nonneg), V("r_out", LENGTH, check=positive)),
           doc="ring between r_in and r_out"),
    Clause("ELLIPSE", (V("semi_x", LENGTH, check=positive), V("semi_y", LENGTH, check=positive)),
           doc="ellipse of semi-axes along local x and y"),
)
_LABELS = {"RECT": ("half_x", "half_y"), "DISK": ("disk_radius",), "ANNULUS": ("r_in", "r_out"),
           "ELLIPSE": ("semi_x", "semi_y")}


def aperture_from(b) -> Aperture | None:
    given = [k for k in _LABELS if "kw:" + k in b.spans]
    if not given:
        return None
    if len(given) > 1:
        raise error(b.spans["kw:" + given[1]], f"one aperture per surface: {given[0]} and {given[1]} both given")
    k = given[0]
    vals = tuple(b[l] for l in _LABELS[k])
    if k == "ANNULUS" and vals[0] >= vals[1]:
        raise error(b.spans["kw:ANNULUS"], "ANNULUS needs r_in < r_out")
    return Aperture(k, vals, b.spans["kw:" + k])


def bounding_radius(ap: Aperture) -> float:
    """outer_radius, with a RECT's corner distance as math.hypot rounds it (the bounding spheres TOWARD aims
    at have always used hypot: the same bits as before the surface plugins packed their own bounds)."""
    if ap.kind == "RECT":
        return math.hypot(ap.params[0], ap.params[1])
    return outer_radius(ap)


def outer_radius(ap: Aperture) -> float:
    """The largest distance from the axis inside the aperture."""
    if ap.kind == "RECT":
        return (ap.params[0] ** 2 + ap.params[1] ** 2) ** 0.5
    if ap.kind == "DISK":
        return ap.params[0]
    if ap.kind == "ANNULUS":
        return ap.params[1]
    return max(ap.params)
