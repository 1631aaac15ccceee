"""BICONIC axis vertex (RADIUS Rx Ry | CURVATURE cx cy) [CONIC kx ky] [aperture]

A biconic (Zemax's "Biconic" surface): a conic of its own in each of the local x and y sections, with its
vertex at `vertex` on `axis`:
sag z(x, y) = (cx x^2 + cy y^2) / (1 + sqrt(1 - (1 + kx) cx^2 x^2 - (1 + ky) cy^2 y^2)), cx = 1/Rx, cy = 1/Ry,
defined where (1 + kx) cx^2 x^2 + (1 + ky) cy^2 y^2 <= 1 (the domain).
The clauses are CONIC's with two values each, x then y; local x and y are the aperture's (Z: x, y; X: y, z;
Y: z, x).  As for CONIC, a radius is positive when its centre of curvature lies on the + side of the vertex,
and the normal points along +axis at the vertex.  `CURVATURE cx cy` gives the curvatures instead of the
radii (one of the two clauses, not both): a curvature of 0 makes that section straight, a cylinder
(`CURVATURE 0.01 0`), which a radius cannot say (RADIUS 0 is an error, as for CONIC); a bare curvature is
per `UNITS` unit.  Rx = Ry and kx = ky is a CONIC.

| parameter | unit | meaning |
|---|---|---|
| RADIUS Rx Ry | length | vertex radii of curvature of the x and y sections (this or CURVATURE) |
| CURVATURE cx cy | 1/length | vertex curvatures 1/Rx and 1/Ry; 0: a straight section (this or RADIUS) |
| CONIC kx ky | 1 | conic constants of the x and y sections (default 0 0) |
| aperture | length | RECT, DISK, ANNULUS or ELLIPSE in local x, y; must lie inside the biconic's domain |

Why this syntax: a biconic is "a CONIC per section", so it reuses CONIC's clause names (RADIUS, CONIC) with
an x value and a y value, in the order the aperture gives its x and y (RECT hx hy, ELLIPSE a b); a script
that has a CONIC becomes a biconic by adding the second numbers.  Separate RX/RY clauses would be two-letter
keywords (no abbreviation) and a second spelling of the same idea.  A straight section is the one thing a
radius cannot express; rather than an "infinite" word the language does not have, or Zemax's "radius 0
means flat" (CONIC refuses RADIUS 0, and the two must not disagree), the curvatures may be given instead.

Packed parameters (``pack``): par = (cx, cy, kx, ky), curvatures in 1/m.

Intersection (``biconic_roots``).  Squaring the sag equation z (1 + s) = u, s = sqrt(1 - v),
u = cx x^2 + cy y^2, v = (1 + kx) cx^2 x^2 + (1 + ky) cy^2 y^2, gives
P = u^2 - 2 u z + v z^2 = (z (1 + s) - u) (z (1 - s) - u) = 0: both sheets (for cx = cy the conic's quadric
times the ray's squared distance from the axis).  Along the ray P is a quartic in t: all its real roots are
isolated between the critical points (the roots of P', isolated between the roots of P'', a quadratic) and
found by safeguarded Newton (bisection where Newton leaves the bracket), from the ray's closest approach to
the vertex when the origin is far away (as ``geometry.hit_conic`` does).  Each root then seeds Newton on the
vertex sheet's own residual h(t) = z - sag(x, y), which is well conditioned where P is not (near the axis P
has a factor ~ the squared distance from it); a seed that does not converge onto the vertex sheet is dropped,
and roots that converge to the same point are merged.  A ray leaving the surface (``leaving``) starts on it:
the constant term of P is then set to 0 and divided out (t = 0 is the departure itself), so only the other
crossings are sought.  A line can cross a biconic up to four times; ``hit`` returns the first two beyond tmin,
and when more than two lie beyond tmin, the first two that pass the aperture test (the kernel tests them
again).  Limitations: a tangent (double) root may be lost to rounding, as for any surface; so may a root
exactly on the rim of the domain where the surface is vertical.
"""
import math

import numba
import numpy as np

from ...core.diagnostics import error
from ...core.units import INV_LENGTH, LENGTH, NONE
from ...kernels.geometry import disc, in_aperture, normalize3, solve_quadratic
from ...kernels.layout import SF_AP, SF_PAR, SI_APK
from ...lang.spec import Axis, Clause, Form, V
from ...model.scene import Surface
from ._aperture import CLAUSES, aperture_from, bounding_radius
from .plane import axis_frame

KIND = "BICONIC"
FORM = Form((Axis(), V("vertex", LENGTH)), (
    # labels: not "radius" (the DISK aperture's), see conic.py
    Clause("RADIUS", (V("Rx", LENGTH), V("Ry", LENGTH)), doc="vertex radii of curvature along local x and y"),
    Clause("CURVATURE", (V("cx", INV_LENGTH), V("cy", INV_LENGTH)),
           doc="vertex curvatures along local x and y (instead of RADIUS; 0: a straight section)"),
    Clause("CONIC", (V("kx", NONE), V("ky", NONE)), doc="conic constants along local x and y"),
) + CLAUSES)
EXAMPLE = "SURFACE\n  BICONIC Z 0 RADIUS -400 -600 CONIC -1 -0.5 RECT 50 30\nOBJECT 'anamorphic'"
FEATURE = "biconic"


def _form_range(a: float, b: float, ap) -> tuple:
    """(min, max) of a x^2 + b y^2 over the aperture `ap` (local x, y)."""
    p = ap.params
    if ap.kind == "RECT":
        X, Y = p[0] * p[0], p[1] * p[1]
        return min(a * X, 0.0) + min(b * Y, 0.0), max(a * X, 0.0) + max(b * Y, 0.0)
    if ap.kind == "ELLIPSE":
        X, Y = p[0] * p[0], p[1] * p[1]
        return min(0.0, a * X, b * Y), max(0.0, a * X, b * Y)
    lo, hi = min(a, b), max(a, b)            # the form is r^2 (a cos^2 + b sin^2)
    if ap.kind == "DISK":
        R2 = p[0] * p[0]
        return min(0.0, lo * R2), max(0.0, hi * R2)
    ri2, ro2 = p[0] * p[0], p[1] * p[1]       # ANNULUS
    return (lo * ro2 if lo <= 0.0 else lo * ri2), (hi * ro2 if hi >= 0.0 else hi * ri2)


def build(b, ctx) -> Surface:
    f = ctx.length_factor()
    if "Rx" in b and "cx" in b:
        raise error(b.spans.get("kw:CURVATURE", b.span), "give RADIUS or CURVATURE, not both",
                    "CURVATURE cx cy is 1/Rx 1/Ry; use it when a section is straight (curvature 0)")
    if "Rx" in b:
        for lab in ("Rx", "Ry"):
            if b[lab] == 0:
                raise error(b.span_of(lab), "RADIUS 0 is not a curvature",
                            "for a straight section give CURVATURE cx cy with a curvature of 0")
        cx, cy = 1.0 / b["Rx"], 1.0 / b["Ry"]
    elif "cx" in b:
        cx, cy = b["cx"], b["cy"]
        if cx == 0 and cy == 0:
            raise error(b.spans.get("kw:CURVATURE", b.span), "a BICONIC with both curvatures 0 is flat",
                        "use a PLANE for a flat surface")
    else:
        raise error(b.span, "BICONIC needs its curvature: RADIUS Rx Ry or CURVATURE cx cy",
                    "e.g. BICONIC Z 0 RADIUS -400 -600 CONIC -1 0 RECT 50 30")
    kx, ky = b.get("kx", 0.0), b.get("ky", 0.0)
    ap = aperture_from(b)
    if ap is not None:
        ax, ay = (1 + kx) * cx * cx, (1 + ky) * cy * cy
        vmax = _form_range(ax, ay, ap)[1]
        if vmax > 1.0 + 1e-12:
            ends = [f"|{w}| <= {1.0 / math.sqrt(a) / f:g}" for w, a in (("x", ax), ("y", ay)) if a > 0]
            raise error(ap.span, f"the aperture reaches (1+kx) cx^2 x^2 + (1+ky) cy^2 y^2 = {vmax:.6g}, but this "
                        "biconic only exists where it is <= 1 (on its axes: " + ", ".join(ends) + ")",
                        "shrink the aperture or change RADIUS / CURVATURE / CONIC")
    return Surface(KIND, {"cx": cx, "cy": cy, "kx": kx, "ky": ky}, axis_frame(b["axis"], b["vertex"]), ap, b.span)


# ---- packing and the kernel (the contract: irtlang/plugins/surfaces/__init__.py) ----
def pack(s: Surface) -> dict:
    """par: cx, cy (1/m: the vertex curvatures along local x and y), kx, ky (the conic constants)."""
    p = s.params
    return {"par": (p["cx"], p["cy"], p["kx"], p["ky"])}


def bounds(s: Surface) -> tuple:
    if s.aperture is None:
        return (0.0, 0.0, 0.0, math.inf)
    p = s.params
    cx, cy, kx, ky = p["cx"], p["cy"], p["kx"], p["ky"]
    ulo, uhi = _form_range(cx, cy, s.aperture)
    vhi = _form_range((1 + kx) * cx * cx, (1 + ky) * cy * cy, s.aperture)[1]
    # sag = u / (1 + s) with s >= s_min = sqrt(1 - max v) over the aperture: |sag| <= |u| / (1 + s_min), sign of u
    smin = math.sqrt(max(0.0, 1.0 - vhi))
    lo, hi = min(0.0, ulo / (1.0 + smin)), max(0.0, uhi / (1.0 + smin))
    return (0.0, 0.0, 0.5 * (lo + hi), math.hypot(bounding_radius(s.aperture), 0.5 * (hi - lo)))


def size(s: Surface) -> float:
    return 1.0 / max(abs(s.params["cx"]), abs(s.params["cy"]))


# ---------------------------------------------------------------------------------------------- numerics
_MAXIT = 200            # safeguarded Newton on the quartic (bisection bounds it: ~60 halvings of a double)
_POLISH_IT = 16         # Newton on the sag residual (from a root of P: a few steps)
_SEED = 1e-3            # a seed farther than this (relative) from the vertex sheet is the other sheet's
_FAR = 1e75             # |t| beyond this: no root sought (t^4 would overflow)
_SHIFT_RATIO = 16.0     # as geometry.SHIFT_RATIO: solve from the closest approach when the origin is this far
_ACCEPT = 1e-9          # a polished root's |z - sag|, relative to the coordinates' size times (1 + slope)
_SAME = 1e-10           # roots closer than this (relative) are one root


@numba.njit(cache=True, fastmath=False, inline="always")
def _peval(a4, a3, a2, a1, a0, t):
    """The quartic a4 t^4 + ... + a0 and its derivative at t (Horner)."""
    p = (((a4 * t + a3) * t + a2) * t + a1) * t + a0
    dp = ((4.0 * a4 * t + 3.0 * a3) * t + 2.0 * a2) * t + a1
    return p, dp


@numba.njit(cache=True, fastmath=False, inline="always")
def _sgn(x):
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@numba.njit(cache=True, fastmath=False)
def _sign_at_inf(a4, a3, a2, a1, a0, side):
    """The sign of the polynomial at side * infinity (side = +-1); 0 for the zero polynomial."""
    if a4 != 0.0:
        return _sgn(a4)
    if a3 != 0.0:
        return _sgn(a3) * side
    if a2 != 0.0:
        return _sgn(a2)
    if a1 != 0.0:
        return _sgn(a1) * side
    return _sgn(a0)


@numba.njit(cache=True, fastmath=False)
def _root_in(a4, a3, a2, a1, a0, lo, hi, w, rtol):
    """The root of the polynomial in (lo, hi] (lo may be -inf, hi +inf) where it changes sign, the polynomial
    being monotonic in between; w > 0: a step to look for a finite end from; rtol: the relative accuracy
    wanted.  nan where none."""
    if not (lo < hi) or lo == np.inf or hi == -np.inf:
        return np.nan
    ph = 0.0
    pl = 0.0
    if hi == np.inf:
        shi = _sign_at_inf(a4, a3, a2, a1, a0, 1.0)
    else:
        ph, _ = _peval(a4, a3, a2, a1, a0, hi)
        if ph == 0.0:
            return hi
        shi = _sgn(ph)
    if lo == -np.inf:
        slo = _sign_at_inf(a4, a3, a2, a1, a0, -1.0)
    else:
        pl, _ = _peval(a4, a3, a2, a1, a0, lo)
        slo = _sgn(pl)
    if slo == 0.0 or shi == 0.0 or slo == shi:
        return np.nan           # no sign change (a root at lo belongs to the interval that ends there)
    # make both ends finite
    if lo == -np.inf and hi == np.inf:
        p0, _ = _peval(a4, a3, a2, a1, a0, 0.0)
        if p0 == 0.0:
            return 0.0
        if _sgn(p0) == slo:
            lo = 0.0
            pl = p0
        else:
            hi = 0.0
            ph = p0
    if hi == np.inf or lo == -np.inf:
        # walk out from the finite end, doubling the step, until the sign of the open end is met
        up = hi == np.inf
        a = lo if up else hi
        pa = pl if up else ph
        s_open = shi if up else slo
        step = max(w, abs(a))
        while True:
            x = a + step if up else a - step
            if not (abs(x) < _FAR):
                return np.nan
            px, _ = _peval(a4, a3, a2, a1, a0, x)
            if px == 0.0:
                return x
            if _sgn(px) == s_open:
                break
            a = x
            pa = px
            step *= 2.0
        if up:
            lo, pl, hi, ph = a, pa, x, px
        else:
            lo, pl, hi, ph = x, px, a, pa
    # safeguarded Newton (Numerical Recipes' rtsafe) from the secant point, oriented so that g = o P < 0 at lo
    # and > 0 at hi
    o = -slo
    x = lo - pl * (hi - lo) / (ph - pl)
    if not (x > lo and x < hi):
        x = 0.5 * (lo + hi)
    dxold = hi - lo
    dx = dxold
    g, dg = _peval(a4, a3, a2, a1, a0, x)
    g *= o
    dg *= o
    for _ in range(_MAXIT):
        if g == 0.0:
            return x
        if g < 0.0:
            lo = x
        else:
            hi = x
        if dg != 0.0 and ((x - hi) * dg - g) * ((x - lo) * dg - g) < 0.0 and abs(2.0 * g) <= abs(dxold * dg):
            dxold = dx
            dx = g / dg
            xn = x - dx
        else:
            dxold = dx
            dx = 0.5 * (hi - lo)
            xn = lo + dx
        if xn == x or abs(dx) <= rtol * abs(xn) + 1e-19 * w:
            return xn
        x = xn
        g, dg = _peval(a4, a3, a2, a1, a0, x)
        g *= o
        dg *= o
    return x


@numba.njit(cache=True, fastmath=False, inline="always")
def _sort4(r1, r2, r3, r4):
    if r2 < r1:
        r1, r2 = r2, r1
    if r4 < r3:
        r3, r4 = r4, r3
    if r3 < r1:
        r1, r3 = r3, r1
    if r4 < r2:
        r2, r4 = r4, r2
    if r3 < r2:
        r2, r3 = r3, r2
    return r1, r2, r3, r4


@numba.njit(cache=True, fastmath=False, inline="always")
def _inf_if_nan(x):
    return np.inf if x != x else x


@numba.njit(cache=True, fastmath=False)
def _real_roots(a4, a3, a2, a1, a0, lo, w):
    """The real roots above `lo` (may be -inf) of a polynomial of degree <= 4, sorted, inf where absent (none
    for the zero polynomial); w > 0: a step of the size of the problem."""
    # P'' = 12 a4 t^2 + 6 a3 t + 2 a2: its roots split P' into monotonic pieces (only those above lo matter)
    q1, q2 = solve_quadratic(6.0 * a4, 1.5 * a3, a2, disc(1.5 * a3, 6.0 * a4, a2))
    b3, b2, b1, b0 = 4.0 * a4, 3.0 * a3, 2.0 * a2, a1
    c1 = _inf_if_nan(_root_in(0.0, b3, b2, b1, b0, lo, q1, w, 1e-10))
    c2 = _inf_if_nan(_root_in(0.0, b3, b2, b1, b0, max(q1, lo), q2, w, 1e-10))
    c3 = _inf_if_nan(_root_in(0.0, b3, b2, b1, b0, max(q2, lo), np.inf, w, 1e-10))
    c1, c2, c3, _ = _sort4(c1, c2, c3, np.inf)
    # P' roots split P into monotonic pieces (only as bounds: a rough accuracy is enough; the roots of P are
    # seeds for _polish, whose Newton steps are dearer than these)
    r1 = _inf_if_nan(_root_in(a4, a3, a2, a1, a0, lo, c1, w, 1e-13))
    r2 = _inf_if_nan(_root_in(a4, a3, a2, a1, a0, c1, c2, w, 1e-13))
    r3 = _inf_if_nan(_root_in(a4, a3, a2, a1, a0, c2, c3, w, 1e-13))
    r4 = _inf_if_nan(_root_in(a4, a3, a2, a1, a0, c3, np.inf, w, 1e-13))
    return _sort4(r1, r2, r3, r4)


@numba.njit(cache=True, fastmath=False, inline="always")
def _sag_m(x, y, cx, cy, ax, ay):
    """sag(x, y), s = sqrt(1 - v) (0 outside the domain) and mx, my with s * grad(sag) = (x mx, y my)."""
    v = ax * x * x + ay * y * y
    arg = 1.0 - v
    s = math.sqrt(arg) if arg > 0.0 else 0.0
    u = cx * x * x + cy * y * y
    z = u / (1.0 + s)
    # differentiating z (1 + s) = u: s dz/dx = x (2 cx s + ax z) / (1 + s)
    mx = (2.0 * cx * s + ax * z) / (1.0 + s)
    my = (2.0 * cy * s + ay * z) / (1.0 + s)
    return z, s, mx, my


@numba.njit(cache=True, fastmath=False)
def _polish(px, py, pz, dx, dy, dz, cx, cy, ax, ay, t, pn, dn):
    """Newton on h(t) = z(t) - sag(x(t), y(t)) from t (steps halved to stay inside the domain): the root, or
    inf when it does not converge onto the vertex sheet."""
    for it in range(_POLISH_IT):
        x = px + t * dx
        y = py + t * dy
        sag, s, mx, my = _sag_m(x, y, cx, cy, ax, ay)
        h = pz + t * dz - sag
        if h == 0.0:
            return t
        if it == 0:
            # a seed on the other sheet (|h| ~ the sheets' distance apart): not a crossing of this one
            slope = math.hypot(x * mx, y * my)
            slope = slope / s if slope < 1e3 * s else 1e3
            if abs(h) > _SEED * (pn + abs(t) * dn) * (1.0 + slope):
                return np.inf
        den = s * dz - x * mx * dx - y * my * dy        # s * h'(t)
        step = -s * h / den
        if not math.isfinite(step):
            break
        for _k in range(60):
            xn = px + (t + step) * dx
            yn = py + (t + step) * dy
            if ax * xn * xn + ay * yn * yn <= 1.0:
                break
            step *= 0.5
        t += step
        if abs(step) <= 4e-16 * (pn / dn + abs(t)):
            break
    if not math.isfinite(t):
        return np.inf
    x = px + t * dx
    y = py + t * dy
    if ax * x * x + ay * y * y > 1.0 + 1e-12:
        return np.inf
    sag, s, mx, my = _sag_m(x, y, cx, cy, ax, ay)
    # |h| against its rounding, eps (size) (1 + slope), with the slope capped (it is infinite at the rim)
    slope = math.hypot(x * mx, y * my)
    slope = slope / s if slope < 1e3 * s else 1e3
    if not (abs(pz + t * dz - sag) <= _ACCEPT * (pn + abs(t) * dn) * (1.0 + slope)):
        return np.inf
    return t


@numba.njit(cache=True, fastmath=False)
def biconic_roots(ox, oy, oz, dx, dy, dz, cx, cy, kx, ky, leaving, tlo):
    """The ray's crossings with the biconic's vertex sheet (vertex at the origin, axis +z) beyond tlo (may be
    -inf; a few just below it may come too): (n, t1, t2, t3, t4) sorted, inf where absent.  With `leaving` the
    origin lies on the surface and its own root t = 0 is left out."""
    inf = np.inf
    dn = max(abs(dx), abs(dy), abs(dz))
    if dn == 0.0 or not math.isfinite(dn):
        return 0, inf, inf, inf, inf
    ax = (1.0 + kx) * cx * cx
    ay = (1.0 + ky) * cy * cy
    # solve from the ray's closest approach to the vertex when the origin is far away and approaching (the
    # quartic's coefficients then stay of the size of the problem); a departing ray keeps its exact origin
    t0 = 0.0
    px, py, pz = ox, oy, oz
    if not leaving:
        tc = -(ox * dx + oy * dy + oz * dz) / (dx * dx + dy * dy + dz * dz)
        if tc > 0.0 and math.isfinite(tc):
            qx = ox + tc * dx
            qy = oy + tc * dy
            qz = oz + tc * dz
            if max(abs(ox), abs(oy), abs(oz)) > _SHIFT_RATIO * max(abs(qx), abs(qy), abs(qz)):
                t0, px, py, pz = tc, qx, qy, qz
    # the size of the coordinates: p's own, and the rounding p carries from a far origin (eps |o|)
    pn = max(abs(px), abs(py), abs(pz), 1e-6 * max(abs(ox), abs(oy), abs(oz)))
    # u, v (quadratics) and z (linear) along the ray, then P = u^2 - 2 u z + v z^2
    U2 = cx * dx * dx + cy * dy * dy
    U1 = 2.0 * (cx * px * dx + cy * py * dy)
    U0 = cx * px * px + cy * py * py
    V2 = ax * dx * dx + ay * dy * dy
    V1 = 2.0 * (ax * px * dx + ay * py * dy)
    V0 = ax * px * px + ay * py * py
    Z1 = dz
    Z0 = pz
    a4 = U2 * U2 + Z1 * Z1 * V2
    a3 = 2.0 * U1 * U2 - 2.0 * U2 * Z1 + Z1 * Z1 * V1 + 2.0 * Z0 * Z1 * V2
    a2 = U1 * U1 + 2.0 * U0 * U2 - 2.0 * (U1 * Z1 + U2 * Z0) + Z1 * Z1 * V0 + 2.0 * Z0 * Z1 * V1 + Z0 * Z0 * V2
    a1 = 2.0 * U0 * U1 - 2.0 * (U0 * Z1 + U1 * Z0) + 2.0 * Z0 * Z1 * V0 + Z0 * Z0 * V1
    a0 = U0 * U0 - 2.0 * U0 * Z0 + Z0 * Z0 * V0
    if not (math.isfinite(a4) and math.isfinite(a3) and math.isfinite(a2) and math.isfinite(a1)
            and math.isfinite(a0)):
        return 0, inf, inf, inf, inf
    cm = max(abs(cx), abs(cy))
    w = (pn + (1.0 / cm if cm > 0.0 else 1.0)) / dn        # a step in t of the size of the problem
    lo = tlo - t0
    lo -= 1e-6 * (abs(lo) + w)      # the roots of P are seeds: keep those just below the bound
    if leaving:
        # P(0) = 0: divide by t, the departure's own root
        s1, s2, s3, s4 = _real_roots(0.0, a4, a3, a2, a1, lo, w)
    else:
        s1, s2, s3, s4 = _real_roots(a4, a3, a2, a1, a0, lo, w)
        if s1 == inf and a4 == 0.0 and a3 == 0.0 and a2 == 0.0 and a1 == 0.0 and a0 == 0.0 and dz != 0.0:
            s1 = -pz / dz           # P = 0 identically: the ray runs along the axis; it meets the vertex
    # polish on the vertex sheet's residual; drop what does not converge there
    r1 = inf
    r2 = inf
    r3 = inf
    r4 = inf
    for i in range(4):
        s = s1 if i == 0 else (s2 if i == 1 else (s3 if i == 2 else s4))
        if s == inf:
            continue
        r = _polish(px, py, pz, dx, dy, dz, cx, cy, ax, ay, s, pn, dn)
        if r == inf:
            continue
        if leaving and abs(r) < 0.5 * abs(s):
            continue                # Newton slid back onto the departure point
        r += t0
        if i == 0:
            r1 = r
        elif i == 1:
            r2 = r
        elif i == 2:
            r3 = r
        else:
            r4 = r
    r1, r2, r3, r4 = _sort4(r1, r2, r3, r4)
    # merge roots that polished onto the same point
    o1 = inf
    o2 = inf
    o3 = inf
    o4 = inf
    n = 0
    for i in range(4):
        r = r1 if i == 0 else (r2 if i == 1 else (r3 if i == 2 else r4))
        if r == inf:
            break
        last = o1 if n == 1 else (o2 if n == 2 else (o3 if n == 3 else o4))
        if n > 0 and r - last <= _SAME * (pn / dn + abs(r)):
            continue
        if n == 0:
            o1 = r
        elif n == 1:
            o2 = r
        elif n == 2:
            o3 = r
        else:
            o4 = r
        n += 1
    return n, o1, o2, o3, o4


@numba.njit(cache=True, fastmath=False)
def _pick(r1, r2, r3, r4, tmin, apk, a0, a1, ox, oy, dx, dy):
    """The first two roots beyond tmin; when more than two lie beyond it, the first two inside the aperture."""
    t1 = np.inf
    t2 = np.inf
    m = 0
    for i in range(4):
        r = r1 if i == 0 else (r2 if i == 1 else (r3 if i == 2 else r4))
        if r > tmin and r < np.inf:
            m += 1
    keep = 0
    for i in range(4):
        r = r1 if i == 0 else (r2 if i == 1 else (r3 if i == 2 else r4))
        if not (r > tmin and r < np.inf):
            continue
        if m > 2 and not in_aperture(apk, a0, a1, ox + r * dx, oy + r * dy):
            continue
        if keep == 0:
            t1 = r
        elif keep == 1:
            t2 = r
        keep += 1
    return t1, t2


@numba.njit(cache=True, fastmath=False)
def biconic_normal(x, y, cx, cy, kx, ky):
    """Unit normal of the biconic above (x, y), pointing towards +z at the vertex (as ``conic_normal``): the
    gradient of z - sag times s = sqrt(1 - v) >= 0, (-x mx, -y my, s), finite where s = 0 (clamped to 0
    outside the domain)."""
    _z, s, mx, my = _sag_m(x, y, cx, cy, (1.0 + kx) * cx * cx, (1.0 + ky) * cy * cy)
    return normalize3(-x * mx, -y * my, s)


@numba.njit(cache=True, inline="always")
def hit(f, si, S, j, ox, oy, oz, dx, dy, dz, tmin, leaving):
    _n, r1, r2, r3, r4 = biconic_roots(ox, oy, oz, dx, dy, dz, f[j, SF_PAR], f[j, SF_PAR + 1], f[j, SF_PAR + 2],
                                       f[j, SF_PAR + 3], leaving, tmin)
    t1, t2 = _pick(r1, r2, r3, r4, tmin, si[j, SI_APK], f[j, SF_AP], f[j, SF_AP + 1], ox, oy, dx, dy)
    return t1, t2, -1


@numba.njit(cache=True, inline="always")
def normal(f, si, S, j, x, y, z, face):
    return biconic_normal(x, y, f[j, SF_PAR], f[j, SF_PAR + 1], f[j, SF_PAR + 2], f[j, SF_PAR + 3])
