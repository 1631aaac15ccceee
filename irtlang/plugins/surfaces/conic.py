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

import numba
import numpy as np

from ...core.diagnostics import error
from ...kernels.geometry import conic_normal, conic_normal_plain, drop_leaving_root, hit_conic, hit_conic_plain
from ...kernels.layout import N_ASPH, SF_ASPH, SF_PAR, SI_NASPH
from ...lang.spec import Axis, Clause, Form, V, Vs
from ...core.units import LENGTH, NONE
from ...model.scene import Surface
from ._aperture import CLAUSES, aperture_from, bounding_radius, outer_radius
from .plane import axis_frame

KIND = "CONIC"
FORM = Form((Axis(), V("vertex", LENGTH)), (
    # label "R", not "radius": the DISK aperture's parameter is "radius" and would overwrite it
    Clause("RADIUS", (V("R", LENGTH),), required=True, doc="vertex radius of curvature"),
    Clause("CONIC", (V("k", NONE),), doc="conic constant"),
    Clause("ASPHERE", (Vs("coefficients", NONE),), doc="even asphere terms a4 a6 ..."),
) + CLAUSES)
EXAMPLE = "SURFACE\n  CONIC Z 0 RADIUS -4200 CONIC -1 ANNULUS 45 150\nOBJECT 'M1'"
FEATURE = "conic"
BOUNDS_PAD = (1e-6, 1e-12)      # the sag is summed from terms: a wider margin than the closed forms'


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
    if len(asph) > N_ASPH:
        raise error(b.span_of("coefficients"), f"at most {N_ASPH} ASPHERE terms (a4 .. a{2 + 2 * N_ASPH})")
    return Surface(KIND, {"c": c, "k": k, "asphere": asph}, axis_frame(b["axis"], b["vertex"]), ap, b.span)


# ---- packing and the kernel (the contract: irtlang/plugins/surfaces/__init__.py) ----
def pack(s: Surface) -> dict:
    """par: c (1/m), k; asph: a4 .. (metres)."""
    return {"par": (s.params["c"], s.params["k"]), "asph": tuple(s.params["asphere"])}


def bounds(s: Surface) -> tuple:
    if s.aperture is None:
        return (0.0, 0.0, 0.0, math.inf)
    r = bounding_radius(s.aperture)
    c, k, a = s.params["c"], s.params["k"], s.params["asphere"]
    # the sag is monotonic in r on the vertex sheet: its extremes over the aperture are at 0 and r
    arg = 1 - (1 + k) * c * c * r * r
    sag = c * r * r / (1 + math.sqrt(max(arg, 0.0))) + sum(ai * r ** (4 + 2 * i) for i, ai in enumerate(a))
    if a:
        rs = np.linspace(0.0, r, 257)
        arg = 1 - (1 + k) * c * c * rs * rs
        sags = c * rs * rs / (1 + np.sqrt(np.maximum(arg, 0.0))) + sum(ai * rs ** (4 + 2 * i) for i, ai in enumerate(a))
        lo, hi = float(sags.min()), float(sags.max())
    else:
        lo, hi = min(0.0, sag), max(0.0, sag)
    return (0.0, 0.0, 0.5 * (lo + hi), math.hypot(r, 0.5 * (hi - lo)))


def size(s: Surface) -> float:
    return abs(1.0 / s.params["c"]) if s.params["c"] else 1.0


@numba.njit(cache=True, inline="always")
def hit(f, si, S, j, ox, oy, oz, dx, dy, dz, tmin, leaving):
    cq = f[j, SF_PAR]
    kq = f[j, SF_PAR + 1]
    n = si[j, SI_NASPH]
    if leaving and n == 0:
        # leaving this conic: the origin is on the quadric, so the other root is -2B/A (no sqrt)
        kk = 1.0 + kq
        a_ = cq * (dx * dx + dy * dy) + kk * cq * dz * dz
        b_ = cq * (ox * dx + oy * dy) + kk * cq * oz * dz - dz
        t1 = -2.0 * b_ / a_ if a_ != 0.0 else np.inf
        if not (t1 > 0.0) or not math.isfinite(t1) or 1.0 - kk * cq * (oz + t1 * dz) < -1e-9:
            t1 = np.inf
        return t1, np.inf, -1
    if n == 0:
        t1, t2 = hit_conic_plain(ox, oy, oz, dx, dy, dz, cq, kq)     # inlined: no array, no call
    else:
        t1, t2 = hit_conic(ox, oy, oz, dx, dy, dz, cq, kq, f[j, SF_ASPH:SF_ASPH + n])
    if leaving:
        t1, t2 = drop_leaving_root(t1, t2)
    return t1, t2, -1


@numba.njit(cache=True, inline="always")
def normal(f, si, S, j, x, y, z, face):
    n = si[j, SI_NASPH]
    if n == 0:
        return conic_normal_plain(x, y, f[j, SF_PAR], f[j, SF_PAR + 1])
    return conic_normal(x, y, f[j, SF_PAR], f[j, SF_PAR + 1], f[j, SF_ASPH:SF_ASPH + n])
