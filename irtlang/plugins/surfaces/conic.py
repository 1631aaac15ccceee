"""CONIC axis vertex RADIUS R [CONIC k] [ASPHERE a4 a6 ...] [aperture]

A rotationally symmetric conic (optionally even-aspheric) with its vertex at `vertex` on `axis`:
sag z(r) = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)) + a4 r^4 + a6 r^6 + ..., c = 1/R.
R > 0 when the centre of curvature lies on the + side of the vertex. The normal points along +axis at the
vertex.  k = 0 sphere, -1 paraboloid, < -1 hyperboloid, between -1 and 0 prolate ellipsoid.

| parameter | unit | meaning |
|---|---|---|
| RADIUS | length | vertex radius of curvature (required) |
| CONIC | 1 | conic constant k (default 0) |
| ASPHERE | length^(1-2i) | even asphere coefficients a4, a6, ... for r in the script's length unit |
| aperture | length | RECT, DISK, ANNULUS or ELLIPSE in local x, y; must lie inside the conic's domain |
"""
import math

from ...core.diagnostics import error
from ...lang.spec import Axis, Clause, Form, V, Vs
from ...core.units import LENGTH, NONE
from ...model.scene import Surface
from ._aperture import CLAUSES, aperture_from, outer_radius
from .plane import axis_frame

KIND = "CONIC"
FORM = Form((Axis(), V("vertex", LENGTH)), (
    # label "R", not "radius": the DISK aperture's parameter is "radius" and would overwrite it
    Clause("RADIUS", (V("R", LENGTH),), required=True, doc="vertex radius of curvature"),
    Clause("CONIC", (V("k", NONE),), doc="conic constant"),
    Clause("ASPHERE", (Vs("coefficients", NONE),), doc="even asphere terms a4 a6 ..."),
) + CLAUSES)
EXAMPLE = "SURFACE\n  CONIC Z 0 RADIUS -4200 CONIC -1 ANNULUS 45 150\nOBJECT 'M1'"


def build(b, ctx) -> Surface:
    R = b["R"]
    if R == 0:
        raise error(b.span_of("R"), "RADIUS 0 is not a curvature", "use a PLANE for a flat surface")
    k = b.get("k", 0.0)
    # an asphere coefficient a_n multiplies r^n with r in the script's unit: convert to metres
    f = ctx.length_factor()
    asph = tuple(a * f ** (1 - (4 + 2 * i)) for i, a in enumerate(b.get("coefficients", ())))
    ap = aperture_from(b)
    c = 1.0 / R
    if ap is not None and (1 + k) > 0:
        rmax = 1.0 / (abs(c) * math.sqrt(1 + k))
        if outer_radius(ap) > rmax:
            raise error(ap.span, f"the aperture reaches r = {outer_radius(ap) / f:g} but this conic only exists "
                        f"for r <= {rmax / f:g} (1 - (1+k) c^2 r^2 < 0 beyond)",
                        "shrink the aperture or change RADIUS / CONIC")
    return Surface(KIND, {"c": c, "k": k, "asphere": asph}, axis_frame(b["axis"], b["vertex"]), ap, b.span)
