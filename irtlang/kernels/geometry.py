"""Ray-surface intersection in a surface's LOCAL frame, aperture tests and frame transforms.

Conventions
-----------
* Local frame: the surface axis is +z; the vertex (conic, plane) or the centre (sphere, ellipsoid) is at
  the origin. ``world = R @ local + T`` (R a 3x3 rotation, T the local origin in world coordinates).
  ``to_local`` subtracts T *before* rotating, so a ray far from the world origin (the Earth at 2.7e10 m)
  keeps the precision of its offset from the surface (DESIGN.md, "Precision across scales").
* A ray is ``p(t) = o + t d``. ``d`` need not be unit length: every ``t`` returned is the parameter
  along ``d`` as given (a distance when ``|d| = 1``). ``d = 0`` never hits.
* Every ``hit_*`` returns the two candidate parameters ``(t1, t2)``, sorted ascending, including roots
  with ``t <= 0``; an absent root is ``np.inf``; NaN never comes out (for finite inputs). The caller takes
  the first ``t > tmin`` whose local point passes the aperture test. A tangent ray gives a double root
  (t1 == t2), which the caller may count as a grazing hit.
* Normals: ``conic_normal`` points towards +z at the vertex (for c > 0: towards the centre of curvature);
  ``sphere_normal``, ``ellipsoid_normal`` and ``tube_normal`` point outwards (away from the axis / centre).
  All normals are unit vectors.

Conic (sag) surface
-------------------
``z(r) = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)) + sum_i asph[i] r^(2 i + 4)``, ``asph = [a4, a6, ...]``.
Its conic part is the quadric ``F(p) = c (x^2 + y^2) + (1 + k) c z^2 - 2 z = 0`` through the vertex:
c = 0 is the plane z = 0; k = -1 a paraboloid; k < -1 a hyperboloid; -1 < k < 0 a prolate and k > 0 an
oblate ellipsoid; k = 0 a sphere. Solving F for z, ``z = (1 -/+ sqrt(1 - (1 + k) c^2 r^2)) / ((1 + k) c)``;
the sag formula is the '-' branch, so a point of the quadric is on the *vertex sheet* iff
``s = 1 - (1 + k) c z >= 0`` (s is then the square root above). For a hyperboloid the other sheet has
``s <= -1``; for an ellipsoid, s < 0 is the half beyond the equator, which the sag formula does not describe.
Roots with ``s < -1e-9`` are discarded.

Along the ray F becomes ``A t^2 + 2 B t + C = 0`` with
``A = c (dx^2 + dy^2) + (1 + k) c dz^2``, ``B = c (ox dx + oy dy) + (1 + k) c oz dz - dz``,
``C = c (ox^2 + oy^2) + (1 + k) c oz^2 - 2 oz``.
Quadratics are solved with ``q = -(B + sign(B) sqrt(B^2 - A C))``, ``t = q / A`` and ``t = C / q`` (the
"citardauq" pair: no cancellation; A = 0 degrades to the linear root C / q = -C / (2 B)), and the
discriminant ``B^2 - A C`` is evaluated à la Kahan: when it cancels badly it is recomputed from exact
products (Dekker's TwoProduct with Veltkamp splitting), so grazing and tangent rays keep a correct
discriminant. When the ray approaches from far away (its closest approach to the vertex lies ahead,
t0 > 0, and ``|o|_inf > SHIFT_RATIO = 16`` times the distance of that point), the quadratic is solved from
that closest point and shifted back by t0: the coefficients' rounding grows like c |o|^2, so a far origin
(1e12) would otherwise destroy the discriminant; the shift perturbs the line by ~eps |o|, the size of the
origin's own rounding. The origin is used as is when it is near, moving away, or on the surface
(|C| <= NEAR_SURFACE = 1e-3 times the sum of C's terms): a ray leaving the surface keeps the exact line, so
an origin exactly on the surface gets C = 0 and the root t = 0, while the other root keeps full relative
accuracy, even at grazing departure. ``hit_tube`` does the same about the point (0, 0, (z1 + z2) / 2),
and only when the origin is also SHIFT_RATIO times farther than the frustum's size (a ray through a cone's
apex, a singular double root, is then solved from its own origin).

With aspheric terms, each vertex-sheet conic root (or, when the conic is missed, the plane root) seeds a
Newton iteration on ``g(t) = z(t) - sag(r(t)^2)``; a root that leaves the conic's domain, meets a
tangent direction or does not converge in ``NEWTON_MAX_IT`` steps is dropped (``np.inf``). Limitation: an
aspheric crossing with no conic/plane root near it is not found.

Sphere / ellipsoid / tube
-------------------------
``hit_sphere`` forms the discriminant geometrically, ``B^2 - A C = A (R - |l|)(R + |l|)`` with ``l`` the
perpendicular from the centre to the ray line (Haines et al., Ray Tracing Gems ch. 7), and
``C = (|o| - R)(|o| + R)``. ``hit_ellipsoid`` scales to the unit sphere (``o/(a,b,c)``, ``d/(a,b,c)``); the
ray parameter is unchanged by this scaling, so t is in the caller's metric. ``hit_tube`` is the side wall of a
frustum whose radius goes linearly from r1 at z1 to r2 at z2 (a cylinder when r1 == r2); roots outside
[min(z1, z2), max(z1, z2)] are discarded. The cone's quadric joins both nappes, whose roots crowd together
near the apex, so each tube root gets one Newton step on the nappe's own equation rho(t) - r(z(t)) = 0
(skipped near tangency). Remaining limitation: a ray through the apex itself is a double root, known to
~sqrt(eps) along the ray, like any tangency.

Self-intersection policy
------------------------
A ray leaving a surface starts (to rounding) on it. The hit routines return both roots, including the
~0 one, so the caller must reject it. Two rules, both cheap:
1. every surface: accept only ``t > tmin`` with ``tmin = self_hit_tmin(ox, oy, oz, dx, dy, dz, size)``
   ``= EPS_SELF * max(size, |o|_inf) / |d|_inf``, ``EPS_SELF = 1e-9``, ``size`` the surface's characteristic
   size (e.g. its aperture radius): 1e-9 of the local length scale (0.15 nm on a 150 mm mirror, 6 mm on the
   Earth), 1e7 times the rounding of the positions themselves (~1e-16 |o|, which is why traces are done in
   local frames);
2. the surface the ray has just left: first drop the root of smallest |t| (``drop_leaving_root``), which is
   the origin itself, then apply rule 1 to the other. This stays right at grazing departures, where the
   origin's rounding (~eps |o|) divided by the grazing angle can push the "zero" root past any tmin.
Thanks to the citardauq roots, the *other* root of the surface just left keeps full accuracy (the far side
of a sphere, the second crossing of a paraboloid) -- except near tangency, where both roots crowd at 0 and the
discriminant's rounding (~eps R^2) puts them ~sqrt(eps) R apart: a ray leaving a sphere or an ellipsoid at
grazing incidence found its own surface again ~1e-8 R ahead (9 cm on the Earth's shells, far beyond tmin), was
reflected or scattered there again, and crawled along the surface (up to the event limit in the stress test of
tests/stress/test_stress_grazing.py).  Spheres and ellipsoids therefore take the other root of a ray that starts
on them in closed form, ``t = -2 (o . d) / |d|^2`` (``leaving_sphere_root``; an ellipsoid in its scaled frame),
whose error is that of o . d (~eps R), not its square root: a ray leaving outward or along a tangent meets the
surface no more.
"""
import math

import numba
import numpy as np

from .layout import AP_ANNULUS, AP_DISK, AP_NONE, AP_RECT

__all__ = [
    "EPS_SELF",
    "NEWTON_MAX_IT",
    "hit_plane",
    "hit_conic",
    "hit_conic_plain",
    "conic_sag",
    "conic_sag_deriv",
    "conic_normal",
    "conic_normal_plain",
    "conic_domain_ok",
    "conic_residual",
    "hit_sphere",
    "sphere_normal",
    "inverse_axes",
    "hit_ellipsoid",
    "ellipsoid_normal",
    "hit_tube",
    "tube_normal",
    "in_rect",
    "in_disk",
    "in_annulus",
    "in_ellipse",
    "in_aperture",
    "to_local",
    "to_world",
    "dir_to_local",
    "dir_to_world",
    "self_hit_tmin",
    "drop_leaving_root",
    "leaving_sphere_root",
    "leaving_ellipsoid_root",
    "first_after",
    "solve_quadratic",
    "normalize3",
    "norm3",
    "two_prod",
    "disc",
]

INF = np.inf
EPS_SELF = 1e-9
NEWTON_MAX_IT = 40
SHIFT_RATIO = 16.0
NEAR_SURFACE = 1e-3
_SPLITTER = 134217729.0  # 2**27 + 1 (Veltkamp)
_SPLIT_MAX = 1e145  # above this the split could overflow: skip compensation
_SHEET_TOL = 1e-9


# ----------------------------------------------------------------------------------------------------
# small numerics
# ----------------------------------------------------------------------------------------------------
@numba.njit(cache=True, fastmath=False)
def two_prod(a, b):
    """Dekker's TwoProduct: p + e == a * b exactly (no over/underflow)."""
    p = a * b
    t = _SPLITTER * a
    ah = t - (t - a)
    al = a - ah
    t = _SPLITTER * b
    bh = t - (t - b)
    bl = b - bh
    e = ((ah * bh - p) + ah * bl + al * bh) + al * bl
    return p, e


@numba.njit(cache=True, fastmath=False)
def disc(b, a, c):
    """b*b - a*c with Kahan's test: recompute from exact products when it cancels."""
    p = b * b
    q = a * c
    d = p - q
    if 3.0 * abs(d) >= p + abs(q):
        return d
    if abs(b) > _SPLIT_MAX or abs(a) > _SPLIT_MAX or abs(c) > _SPLIT_MAX:
        return d
    p, dp = two_prod(b, b)
    q, dq = two_prod(a, c)
    return (p - q) + (dp - dq)


# Within this range of x^2 + y^2 + z^2 the sum neither overflows nor loses relative precision to underflow
# (a square below 1e-308 is under 1e-28 of the sum), so the norm is its square root; outside it the vector is
# first scaled by its largest component.  The scaled form costs three or six divisions, which the nearest-hit
# search of a shell atmosphere pays on every surface it tests (docs/architecture.md, "Divisions").
SQ_LO = 1e-280
SQ_HI = 1e280


@numba.njit(cache=True, fastmath=False)
def _norm3_scaled(x, y, z):
    m = max(abs(x), abs(y), abs(z))
    if m == 0.0 or not math.isfinite(m):
        return m
    x /= m
    y /= m
    z /= m
    return m * math.sqrt(x * x + y * y + z * z)


@numba.njit(cache=True, fastmath=False)
def norm3(x, y, z):
    """Euclidean norm without overflow/underflow."""
    s = x * x + y * y + z * z
    if s > SQ_LO and s < SQ_HI:
        return math.sqrt(s)
    return _norm3_scaled(x, y, z)


@numba.njit(cache=True, fastmath=False, inline="always")
def unit_in_range(x, y, z):
    """(True, unit vector along (x, y, z)) where its squared norm is within (SQ_LO, SQ_HI), else (False, x, y,
    z): the callers scale such a vector first (and each keeps its own answer for a zero or non-finite one)."""
    s = x * x + y * y + z * z
    if s > SQ_LO and s < SQ_HI:
        r = 1.0 / math.sqrt(s)
        return True, x * r, y * r, z * r
    return False, x, y, z


@numba.njit(cache=True, fastmath=False, inline="always")
def normalize3(x, y, z):
    """Unit vector along (x, y, z); the zero vector maps to (0, 0, 1)."""
    ok, ux, uy, uz = unit_in_range(x, y, z)
    if ok:
        return ux, uy, uz
    m = max(abs(x), abs(y), abs(z))
    if m == 0.0 or not math.isfinite(m):
        return 0.0, 0.0, 1.0
    x /= m
    y /= m
    z /= m
    n = math.sqrt(x * x + y * y + z * z)
    return x / n, y / n, z / n


@numba.njit(cache=True, fastmath=False, inline="always")
def _finite_or_inf(t):
    if math.isfinite(t):
        return t
    return INF


@numba.njit(cache=True, fastmath=False, inline="always")
def _sort2(t1, t2):
    if t2 < t1:
        return t2, t1
    return t1, t2


@numba.njit(cache=True, fastmath=False, inline="always")
def solve_quadratic(a, b, c, d):
    """Roots of a t^2 + 2 b t + c = 0 given the discriminant d = b^2 - a c; sorted, inf where absent."""
    if not (d >= 0.0):  # also catches NaN
        return INF, INF
    sq = math.sqrt(d)
    q = -(b + math.copysign(sq, b))
    if q == 0.0:
        # b == 0 and d == 0 -> a c == 0
        if a != 0.0:
            return 0.0, 0.0  # c == 0: double root at 0
        return INF, INF  # a == b == 0: no isolated root
    if a != 0.0:
        t1 = _finite_or_inf(q / a)
    else:
        t1 = INF
    t2 = _finite_or_inf(c / q)
    return _sort2(t1, t2)


# ----------------------------------------------------------------------------------------------------
# plane
# ----------------------------------------------------------------------------------------------------
@numba.njit(cache=True, fastmath=False)
def hit_plane(ox, oy, oz, dx, dy, dz):
    """Plane z = 0: (t, inf). A ray parallel to (or inside) the plane gives (inf, inf)."""
    if dz == 0.0:
        return INF, INF
    t = -oz / dz
    return _finite_or_inf(t), INF


# ----------------------------------------------------------------------------------------------------
# conic + polynomial asphere
# ----------------------------------------------------------------------------------------------------
@numba.njit(cache=True, fastmath=False)
def _asph_eval(s, asph):
    """P(s) = sum asph[i] s^(i+2) and dP/ds, s = r^2 (Horner)."""
    n = asph.shape[0]
    if n == 0:
        return 0.0, 0.0
    p = 0.0
    dp = 0.0
    for i in range(n - 1, -1, -1):
        dp = dp * s + p
        p = p * s + asph[i]
    # p = sum a_i s^i, dp = d/ds of that
    return s * s * p, 2.0 * s * p + s * s * dp


@numba.njit(cache=True, fastmath=False)
def conic_domain_ok(r, c, k):
    """True iff radius r lies inside the conic's real domain: (1 + k) c^2 r^2 <= 1."""
    return (1.0 + k) * c * c * r * r <= 1.0


@numba.njit(cache=True, fastmath=False)
def conic_sag(r2, c, k, asph):
    """Sag z at r^2 = r2 (conic + aspheric terms); np.inf outside the conic's domain."""
    arg = 1.0 - (1.0 + k) * c * c * r2
    if arg < 0.0:
        return INF
    z = c * r2 / (1.0 + math.sqrt(arg))
    p, _ = _asph_eval(r2, asph)
    return z + p


@numba.njit(cache=True, fastmath=False)
def conic_sag_deriv(r2, c, k, asph):
    """d(sag)/d(r^2) = c / (2 sqrt(1 - (1+k) c^2 r^2)) + aspheric part; np.inf at/after the domain edge."""
    arg = 1.0 - (1.0 + k) * c * c * r2
    if arg <= 0.0:
        return INF
    _, dp = _asph_eval(r2, asph)
    return c / (2.0 * math.sqrt(arg)) + dp


@numba.njit(cache=True, fastmath=False, inline="always")
def _conic_normal_dp(x, y, c, q, dp):
    m = c + 2.0 * q * dp
    return normalize3(-x * m, -y * m, q)


@numba.njit(cache=True, fastmath=False, inline="always")
def _conic_q(x, y, c, k):
    """r^2 and q = sqrt(1 - (1+k) c^2 r^2), clamped to 0 outside the domain."""
    s = x * x + y * y
    arg = 1.0 - (1.0 + k) * c * c * s
    return s, (math.sqrt(arg) if arg > 0.0 else 0.0)


@numba.njit(cache=True, fastmath=False)
def conic_normal(x, y, c, k, asph):
    """Unit normal of the sag surface above (x, y), pointing towards +z at the vertex.

    The gradient of z - sag(r^2), times q = sqrt(1 - (1+k) c^2 r^2) >= 0, is
    (-x (c + 2 q P'), -y (c + 2 q P'), q): finite even at an ellipsoid's equator (q = 0). Outside the
    domain q is clamped to 0.
    """
    s, q = _conic_q(x, y, c, k)
    _, dp = _asph_eval(s, asph)
    return _conic_normal_dp(x, y, c, q, dp)


@numba.njit(cache=True, fastmath=False, inline="always")
def conic_normal_plain(x, y, c, k):
    """``conic_normal`` of a conic without aspheric terms (bitwise the same result), inlined into its
    callers: no array argument, no call."""
    _s, q = _conic_q(x, y, c, k)
    return _conic_normal_dp(x, y, c, q, 0.0)


@numba.njit(cache=True, fastmath=False)
def conic_residual(x, y, z, c, k, asph):
    """Signed distance-like residual of (x, y, z) to the sag surface: (z - sag) * n_z (first order
    geometric distance, finite near an ellipsoid's equator); np.inf outside the domain."""
    s = x * x + y * y
    arg = 1.0 - (1.0 + k) * c * c * s
    if arg < 0.0 or not math.isfinite(s) or not math.isfinite(z):
        return INF
    q = math.sqrt(arg)
    zc = c * s / (1.0 + q)
    p, dp = _asph_eval(s, asph)
    m = c + 2.0 * q * dp
    if not (math.isfinite(zc) and math.isfinite(p) and math.isfinite(m)):
        return INF
    nz = q / norm3(x * m, y * m, q) if (q != 0.0 or m != 0.0) else 1.0
    if arg == 0.0:
        # on the domain edge the surface is vertical: use the implicit conic residual instead
        f = c * s + (1.0 + k) * c * z * z - 2.0 * z
        g = 2.0 * norm3(c * x, c * y, (1.0 + k) * c * z - 1.0)
        return f / g if g > 0.0 else INF
    return (z - zc - p) * nz


@numba.njit(cache=True, fastmath=False, inline="always")
def _conic_quadric_roots(ox, oy, oz, dx, dy, dz, c, k):
    """Roots of the conic quadric on the vertex sheet, sorted, inf where absent."""
    kk = 1.0 + k
    a = c * (dx * dx + dy * dy) + kk * c * dz * dz
    b = c * (ox * dx + oy * dy) + kk * c * oz * dz - dz
    cc = c * (ox * ox + oy * oy) + kk * c * oz * oz - 2.0 * oz
    d = disc(b, a, cc)
    t1, t2 = solve_quadratic(a, b, cc, d)
    # keep roots on the vertex sheet: s = 1 - (1+k) c z >= 0
    if t1 != INF:
        if 1.0 - kk * c * (oz + t1 * dz) < -_SHEET_TOL:
            t1 = INF
    if t2 != INF:
        if 1.0 - kk * c * (oz + t2 * dz) < -_SHEET_TOL:
            t2 = INF
    return _sort2(t1, t2)


@numba.njit(cache=True, fastmath=False)
def _asph_newton(ox, oy, oz, dx, dy, dz, c, k, asph, t0):
    """Newton on g(t) = z(t) - sag(r(t)^2), started at t0; inf if it fails."""
    kk = 1.0 + k
    t = t0
    dn = max(abs(dx), abs(dy), abs(dz))
    on = max(abs(ox), abs(oy), abs(oz))
    dt = INF
    scale = 0.0
    for _ in range(NEWTON_MAX_IT):
        x = ox + t * dx
        y = oy + t * dy
        z = oz + t * dz
        s = x * x + y * y
        arg = 1.0 - kk * c * c * s
        if arg < 0.0:
            return INF
        q = math.sqrt(arg)
        zc = c * s / (1.0 + q)
        p, dp = _asph_eval(s, asph)
        m = c + 2.0 * q * dp
        # q * grad(z - sag) = (-x m, -y m, q)
        gq = q * (z - zc - p)
        den = -x * m * dx - y * m * dy + q * dz
        if den == 0.0 or not math.isfinite(den):
            return INF
        dt = -gq / den
        if not math.isfinite(dt):
            return INF
        t += dt
        scale = (on + abs(t) * dn) / dn
        if abs(dt) <= 1e-14 * scale:
            return t
    # accept a root whose last step was at rounding level only
    if abs(dt) <= 1e-12 * scale:
        return t
    return INF


@numba.njit(cache=True, fastmath=False, inline="always")
def _closest_approach(ox, oy, oz, dx, dy, dz, cz):
    """Parameter t0 of the ray's closest approach to (0, 0, cz) and the point there."""
    dd = dx * dx + dy * dy + dz * dz
    t0 = -(ox * dx + oy * dy + (oz - cz) * dz) / dd
    if not math.isfinite(t0):
        t0 = 0.0
    return t0, ox + t0 * dx, oy + t0 * dy, oz + t0 * dz


@numba.njit(cache=True, fastmath=False, inline="always")
def _conic_start(ox, oy, oz, dx, dy, dz, c, k):
    """(t0, p): the point the conic's quadratic is solved from (see the module docstring)."""
    # solve from the ray's closest approach to the vertex: keeps the quadratic's coefficients of the
    # size of the problem when the origin is far away (their rounding scales like c |o|^2)
    t0, px, py, pz = _closest_approach(ox, oy, oz, dx, dy, dz, 0.0)
    if t0 > 0.0 and max(abs(ox), abs(oy), abs(oz)) > SHIFT_RATIO * max(abs(px), abs(py), abs(pz)):
        # far, approaching: shift, unless the origin is (algebraically) close to the surface itself
        r2 = ox * ox + oy * oy
        kc = (1.0 + k) * c
        cterm = abs(c) * r2 + abs(kc) * oz * oz + 2.0 * abs(oz)
        if abs(c * r2 + kc * oz * oz - 2.0 * oz) <= NEAR_SURFACE * cterm:
            t0, px, py, pz = 0.0, ox, oy, oz
    else:
        t0, px, py, pz = 0.0, ox, oy, oz  # near enough, or moving away: keep the exact origin
    return t0, px, py, pz


@numba.njit(cache=True, fastmath=False, inline="always")
def hit_conic_plain(ox, oy, oz, dx, dy, dz, c, k):
    """``hit_conic`` of a conic without aspheric terms (bitwise the same roots), inlined into its callers:
    no array argument, no call."""
    if dx == 0.0 and dy == 0.0 and dz == 0.0:
        return INF, INF
    t0, px, py, pz = _conic_start(ox, oy, oz, dx, dy, dz, c, k)
    t1, t2 = _conic_quadric_roots(px, py, pz, dx, dy, dz, c, k)
    if t1 != INF:
        t1 += t0
    if t2 != INF:
        t2 += t0
    return _sort2(t1, t2)


@numba.njit(cache=True, fastmath=False)
def hit_conic(ox, oy, oz, dx, dy, dz, c, k, asph):
    """Conic (+ even asphere) with vertex at the origin, axis +z: (t1, t2) sorted, inf where absent."""
    if dx == 0.0 and dy == 0.0 and dz == 0.0:
        return INF, INF
    t0, px, py, pz = _conic_start(ox, oy, oz, dx, dy, dz, c, k)
    t1, t2 = _conic_quadric_roots(px, py, pz, dx, dy, dz, c, k)
    if asph.shape[0] != 0:
        if t1 == INF and t2 == INF:
            t1, _ = hit_plane(px, py, pz, dx, dy, dz)
            if t1 == INF:
                return INF, INF
        if t1 != INF:
            t1 = _asph_newton(px, py, pz, dx, dy, dz, c, k, asph, t1)
        if t2 != INF:
            t2 = _asph_newton(px, py, pz, dx, dy, dz, c, k, asph, t2)
    if t1 != INF:
        t1 += t0
    if t2 != INF:
        t2 += t0
    return _sort2(t1, t2)


# ----------------------------------------------------------------------------------------------------
# sphere, ellipsoid
# ----------------------------------------------------------------------------------------------------
@numba.njit(cache=True, fastmath=False)
def hit_sphere(ox, oy, oz, dx, dy, dz, R):
    """Sphere of radius R centred at the origin: (t1, t2) sorted, inf where absent."""
    a = dx * dx + dy * dy + dz * dz
    if a == 0.0 or not math.isfinite(a):
        return INF, INF
    b = ox * dx + oy * dy + oz * dz
    ia = 1.0 / a
    f = b * ia
    ln = norm3(ox - f * dx, oy - f * dy, oz - f * dz)
    dpa = (R - ln) * (R + ln)  # (b^2 - a c) / a
    if not (dpa >= 0.0):
        return INF, INF
    on = norm3(ox, oy, oz)
    c = (on - R) * (on + R)
    sq = math.sqrt(a) * math.sqrt(dpa)
    q = -(b + math.copysign(sq, b))
    if q == 0.0:
        # b == 0 and tangent through... only if c == 0 too (origin on sphere, tangent direction)
        return 0.0, 0.0
    t1 = _finite_or_inf(q * ia)
    t2 = c / q
    # the roots are -b/a +- sq/a; c and the geometric discriminant are rounded independently, so when q is
    # as small as the rounding of c (a tangent ray leaving the sphere) c / q is noise over noise and can
    # land anywhere (a spurious hit millimetres away): keep it inside the roots' interval
    mid = -f
    h = sq * ia
    if abs(t2 - mid) > h + 1e-15 * (abs(mid) + h):
        t2 = mid + math.copysign(h, t2 - mid)
    return _sort2(t1, _finite_or_inf(t2))


@numba.njit(cache=True, fastmath=False)
def sphere_normal(x, y, z):
    """Outward unit normal of a sphere centred at the origin."""
    return normalize3(x, y, z)


@numba.njit(cache=True, fastmath=False, inline="always")
def inverse_axes(a, b, c):
    """(1/a, 1/b, 1/c) of an ellipsoid's semi-axes, one division per distinct axis (a spheroid's a = b): the
    scaling that maps it onto the unit sphere."""
    ia = 1.0 / a
    ib = ia if b == a else 1.0 / b
    ic = ia if c == a else 1.0 / c
    return ia, ib, ic


@numba.njit(cache=True, fastmath=False)
def hit_ellipsoid(ox, oy, oz, dx, dy, dz, a, b, c):
    """Ellipsoid x^2/a^2 + y^2/b^2 + z^2/c^2 = 1: (t1, t2) in the caller's ray parameter."""
    ia, ib, ic = inverse_axes(a, b, c)
    return hit_sphere(ox * ia, oy * ib, oz * ic, dx * ia, dy * ib, dz * ic, 1.0)


@numba.njit(cache=True, fastmath=False)
def ellipsoid_normal(x, y, z, a, b, c):
    """Outward unit normal of the ellipsoid at (x, y, z): along (x/a^2, y/b^2, z/c^2)."""
    ia, ib, ic = inverse_axes(a, b, c)
    return normalize3(x * ia * ia, y * ib * ib, z * ic * ic)


# ----------------------------------------------------------------------------------------------------
# tube (cone frustum / cylinder side wall)
# ----------------------------------------------------------------------------------------------------
@numba.njit(cache=True, fastmath=False)
def hit_tube(ox, oy, oz, dx, dy, dz, z1, r1, z2, r2):
    """Side wall of the frustum r(z) = r1 + (r2 - r1)(z - z1)/(z2 - z1), z between z1 and z2."""
    if z2 == z1:
        return INF, INF
    if z2 < z1:
        z1, z2 = z2, z1
        r1, r2 = r2, r1
    sl = (r2 - r1) / (z2 - z1)
    if dx == 0.0 and dy == 0.0 and dz == 0.0:
        return INF, INF
    # solve from the closest approach to the tube's centre (far origins, see hit_conic)
    zc = 0.5 * (z1 + z2)
    t0, px, py, pz = _closest_approach(ox, oy, oz, dx, dy, dz, zc)
    rho0 = math.hypot(ox, oy)
    w0 = abs(r1 + sl * (oz - z1))
    size = max(0.5 * (z2 - z1), abs(r1), abs(r2))
    if (t0 > 0.0
            and max(abs(ox), abs(oy), abs(oz - zc)) > SHIFT_RATIO * max(abs(px), abs(py), abs(pz - zc), size)
            and abs(rho0 - w0) > NEAR_SURFACE * (rho0 + w0)):
        ox, oy, oz = px, py, pz
    else:
        t0 = 0.0
    w = r1 + sl * (oz - z1)  # r(z) at the origin's height (may be negative off the frustum)
    a = dx * dx + dy * dy - sl * sl * dz * dz
    b = ox * dx + oy * dy - w * sl * dz
    rho = math.hypot(ox, oy)
    cc = (rho - w) * (rho + w)
    d = disc(b, a, cc)
    t1, t2 = solve_quadratic(a, b, cc, d)
    size = max(size, abs(zc))
    if t1 != INF:
        t1 = _tube_polish(ox, oy, oz, dx, dy, dz, t1, z1, r1, sl, size)
        z = oz + t1 * dz
        if z < z1 or z > z2:
            t1 = INF
        else:
            t1 += t0
    if t2 != INF:
        t2 = _tube_polish(ox, oy, oz, dx, dy, dz, t2, z1, r1, sl, size)
        z = oz + t2 * dz
        if z < z1 or z > z2:
            t2 = INF
        else:
            t2 += t0
    return _sort2(t1, t2)


@numba.njit(cache=True, fastmath=False)
def _tube_polish(ox, oy, oz, dx, dy, dz, t, z1, r1, sl, size):
    """One Newton step on f(t) = rho(t) - r(z(t)) (the nappe's own, non-polynomial equation).

    The quadric x^2 + y^2 = r(z)^2 joins both nappes of the cone, so near the apex its two roots (one per
    nappe) crowd together and the quadratic loses accuracy like eps * size / (distance to the apex); f is
    well conditioned there. Skipped near tangency (small f') and when the step would not be a polish.
    """
    x = ox + t * dx
    y = oy + t * dy
    z = oz + t * dz
    rho = math.hypot(x, y)
    if rho == 0.0:
        return t
    f = rho - (r1 + sl * (z - z1))
    fp = (x * dx + y * dy) / rho - sl * dz
    dn = norm3(dx, dy, dz)
    if not (abs(fp) > 1e-3 * dn * (1.0 + abs(sl))):
        return t
    step = -f / fp
    if not (abs(step) * dn <= 1e-6 * (abs(t) * dn + norm3(ox, oy, oz) + size)):
        return t
    return t + step


@numba.njit(cache=True, fastmath=False)
def tube_normal(x, y, z, z1, r1, z2, r2):
    """Outward unit normal of the frustum side wall at (x, y, z) (away from the axis)."""
    if z2 < z1:
        z1, z2 = z2, z1
        r1, r2 = r2, r1
    sl = (r2 - r1) / (z2 - z1) if z2 != z1 else 0.0
    rho = math.hypot(x, y)
    if rho == 0.0:
        # apex of a cone: no unique normal, take the axial direction away from the cone
        return 0.0, 0.0, (-1.0 if sl > 0.0 else 1.0)
    return normalize3(x / rho, y / rho, -sl)


# ----------------------------------------------------------------------------------------------------
# apertures (local x, y; boundaries inclusive)
# ----------------------------------------------------------------------------------------------------
@numba.njit(cache=True, fastmath=False)
def in_rect(x, y, hx, hy):
    """|x| <= hx and |y| <= hy."""
    return abs(x) <= hx and abs(y) <= hy


_HYPOT_BAND = 1e-12   # relative band around r^2 inside which the aperture tests ask math.hypot


@numba.njit(cache=True, fastmath=False, inline="always")
def _hypot_side(x, y, r):
    """-1 if math.hypot(x, y) < r for sure, +1 if > r for sure, 0 if x^2 + y^2 is too close to r^2 (or out of
    the safe range) to tell.  x^2 + y^2 and r^2 carry a few ulps of rounding and hypot one ulp, so outside
    the 1e-12 band the answer is the one math.hypot would give (a hypot costs ~20 ns; this, ~1 ns)."""
    s = x * x + y * y
    rr = r * r
    if r >= 0.0 and rr >= 1e-250 and rr < INF:
        if s < rr * (1.0 - _HYPOT_BAND):
            return -1
        if s > rr * (1.0 + _HYPOT_BAND):
            return 1
    return 0


@numba.njit(cache=True, fastmath=False)
def in_disk(x, y, r):
    """math.hypot(x, y) <= r (x^2 + y^2 <= r^2), decided without hypot away from the edge."""
    side = _hypot_side(x, y, r)
    if side != 0:
        return side < 0
    return math.hypot(x, y) <= r


@numba.njit(cache=True, fastmath=False)
def in_annulus(x, y, rin, rout):
    """rin <= math.hypot(x, y) <= rout, decided without hypot away from the two edges."""
    a = _hypot_side(x, y, rin)
    b = _hypot_side(x, y, rout)
    if a < 0 or b > 0:
        return False
    if a > 0 and b < 0:
        return True
    rho = math.hypot(x, y)
    return rin <= rho and rho <= rout


@numba.njit(cache=True, fastmath=False)
def in_ellipse(x, y, a, b):
    """math.hypot(x/a, y/b) <= 1, decided without hypot away from the edge."""
    xa = x / a
    yb = y / b
    side = _hypot_side(xa, yb, 1.0)
    if side != 0:
        return side < 0
    return math.hypot(xa, yb) <= 1.0


# ----------------------------------------------------------------------------------------------------
# frames
# ----------------------------------------------------------------------------------------------------
@numba.njit(cache=True, fastmath=False)
def dir_to_local(vx, vy, vz, R):
    """R^T v (a direction or normal; no translation)."""
    return (R[0, 0] * vx + R[1, 0] * vy + R[2, 0] * vz,
            R[0, 1] * vx + R[1, 1] * vy + R[2, 1] * vz,
            R[0, 2] * vx + R[1, 2] * vy + R[2, 2] * vz)


@numba.njit(cache=True, fastmath=False)
def dir_to_world(vx, vy, vz, R):
    """R v (a direction or normal; no translation)."""
    return (R[0, 0] * vx + R[0, 1] * vy + R[0, 2] * vz,
            R[1, 0] * vx + R[1, 1] * vy + R[1, 2] * vz,
            R[2, 0] * vx + R[2, 1] * vy + R[2, 2] * vz)


@numba.njit(cache=True, fastmath=False)
def to_local(px, py, pz, dx, dy, dz, R, T):
    """World point and direction -> local: (R^T (p - T), R^T d). T is subtracted first."""
    x = px - T[0]
    y = py - T[1]
    z = pz - T[2]
    lx, ly, lz = dir_to_local(x, y, z, R)
    ldx, ldy, ldz = dir_to_local(dx, dy, dz, R)
    return lx, ly, lz, ldx, ldy, ldz


@numba.njit(cache=True, fastmath=False)
def to_world(px, py, pz, dx, dy, dz, R, T):
    """Local point and direction -> world: (R p + T, R d)."""
    wx, wy, wz = dir_to_world(px, py, pz, R)
    wdx, wdy, wdz = dir_to_world(dx, dy, dz, R)
    return wx + T[0], wy + T[1], wz + T[2], wdx, wdy, wdz


@numba.njit(cache=True, fastmath=False)
def drop_leaving_root(t1, t2):
    """For the surface a ray has just left: drop the root nearest 0 (the origin), return (other, inf)."""
    if abs(t1) <= abs(t2):
        return t2, INF
    return t1, INF


@numba.njit(cache=True, fastmath=False)
def leaving_sphere_root(ox, oy, oz, dx, dy, dz):
    """For a ray that starts on a sphere centred at the origin: its other crossing, -2 (o . d) / |d|^2, as
    (t, inf), or (inf, inf) when the ray leaves outward or along a tangent (see the module docstring)."""
    a = dx * dx + dy * dy + dz * dz
    b = ox * dx + oy * dy + oz * dz
    if not (b < 0.0) or a == 0.0 or not math.isfinite(a):
        return INF, INF
    return _finite_or_inf(-2.0 * b / a), INF


@numba.njit(cache=True, fastmath=False)
def leaving_ellipsoid_root(ox, oy, oz, dx, dy, dz, a, b, c):
    """leaving_sphere_root for the ellipsoid x^2/a^2 + y^2/b^2 + z^2/c^2 = 1, in its scaled frame."""
    ia, ib, ic = inverse_axes(a, b, c)
    return leaving_sphere_root(ox * ia, oy * ib, oz * ic, dx * ia, dy * ib, dz * ic)


@numba.njit(cache=True, fastmath=False)
def first_after(t1, t2, tmin):
    """The first of the sorted roots (t1, t2) greater than tmin, or inf (no aperture test)."""
    if t1 > tmin:
        return t1
    if t2 > tmin:
        return t2
    return INF


@numba.njit(cache=True, fastmath=False)
def self_hit_tmin(ox, oy, oz, dx, dy, dz, size):
    """tmin = EPS_SELF * max(size, |o|_inf) / |d|_inf (see module docstring)."""
    dn = max(abs(dx), abs(dy), abs(dz))
    if dn == 0.0:
        return INF
    return EPS_SELF * max(size, abs(ox), abs(oy), abs(oz)) / dn


@numba.njit(cache=True, fastmath=False, inline="always")
def in_aperture(kind, a0, a1, x, y):
    """A packed aperture (kind ``layout.AP_*``, parameters a0, a1) at local (x, y); an ELLIPSE otherwise."""
    if kind == AP_NONE:
        return True
    if kind == AP_RECT:
        return in_rect(x, y, a0, a1)
    if kind == AP_DISK:
        return in_disk(x, y, a0)
    if kind == AP_ANNULUS:
        return in_annulus(x, y, a0, a1)
    return in_ellipse(x, y, a0, a1)
