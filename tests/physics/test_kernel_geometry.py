"""Ray-surface intersections against closed forms and geometric properties (foci of conics)."""
import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from irtlang.kernels import geometry as G
from irtlang.kernels.optics import reflect

NOASPH = np.zeros(0)
EPS = np.finfo(float).eps


def sag_ref(r, c, k, asph=()):
    """Independent sag: the conic in its textbook form plus the even polynomial."""
    z = c * r * r / (1.0 + math.sqrt(1.0 - (1.0 + k) * c * c * r * r))
    for i, a in enumerate(asph):
        z += a * r ** (2 * i + 4)
    return z


def quadric_distance(p, c, k):
    """First-order geometric distance of p to the quadric c(x^2+y^2) + (1+k)c z^2 - 2z = 0."""
    x, y, z = p
    f = c * (x * x + y * y) + (1 + k) * c * z * z - 2 * z
    g = 2 * np.linalg.norm([c * x, c * y, (1 + k) * c * z - 1])
    return abs(f) / g


def line_point_distance(p, d, q):
    d = np.asarray(d) / np.linalg.norm(d)
    return np.linalg.norm(np.cross(np.asarray(q) - np.asarray(p), d))


def first_positive(t1, t2, tmin=0.0):
    for t in (t1, t2):
        if t > tmin and t < np.inf:
            return t
    return np.inf


# ------------------------------------------------------------------------------------------------
# plane
# ------------------------------------------------------------------------------------------------
def test_plane():
    assert G.hit_plane(1.0, 2.0, 3.0, 0.0, 0.0, -2.0) == (1.5, np.inf)
    assert G.hit_plane(1.0, 2.0, 3.0, 1.0, 0.0, 0.0) == (np.inf, np.inf)
    assert G.hit_plane(1.0, 2.0, 0.0, 1.0, 0.0, 0.0) == (np.inf, np.inf)  # in the plane
    t, _ = G.hit_plane(0.0, 0.0, 0.0, 0.3, 0.1, 0.5)  # origin on the plane
    assert t == 0.0
    # grazing 1e-9 rad from far away: t = h / sin(theta), full relative precision
    th = 1e-9
    t, _ = G.hit_plane(-5.0, 0.0, 2.0, math.cos(th), 0.0, -math.sin(th))
    assert t == pytest.approx(2.0 / math.sin(th), rel=4 * EPS)


# ------------------------------------------------------------------------------------------------
# conics
# ------------------------------------------------------------------------------------------------
CONICS = [  # (c, k)
    (1 / 2000.0, -1.0),  # paraboloid
    (1 / 2057.4, -1.0),  # Cassegrain primary
    (-1 / 262.9, -((10.207 + 1) / (10.207 - 1)) ** 2),  # Cassegrain secondary (convex hyperboloid)
    (1 / 500.0, -3.2),  # hyperboloid
    (1 / 500.0, -0.5),  # prolate ellipsoid
    (1 / 500.0, 0.0),  # sphere
    (1 / 500.0, 0.7),  # oblate ellipsoid
    (0.0, 0.0),  # plane
    (-1 / 300.0, -1.0),  # convex paraboloid
]


@pytest.mark.parametrize("c,k", CONICS)
def test_conic_hits_satisfy_sag(c, k):
    rng = np.random.default_rng(11)
    n_hit = 0
    for _ in range(400):
        o = rng.uniform(-300, 300, 3)
        o[2] = rng.uniform(-600, 600)
        d = rng.normal(size=3) * rng.uniform(0.01, 100)
        t1, t2 = G.hit_conic(*o, *d, c, k, NOASPH)
        assert not (math.isnan(t1) or math.isnan(t2))
        assert t1 <= t2
        for t in (t1, t2):
            if t == np.inf:
                continue
            n_hit += 1
            p = o + t * d
            scale = np.linalg.norm(o) + abs(t) * np.linalg.norm(d)
            # on the quadric ...
            assert quadric_distance(p, c, k) <= 1e-12 * scale
            # ... on its vertex sheet, i.e. on the sag surface
            assert 1 - (1 + k) * c * p[2] >= -1e-9
            r = math.hypot(p[0], p[1])
            if (1 + k) * c * c * r * r < 0.99:  # away from an ellipsoid's equator the sag is well conditioned
                slope = abs(G.conic_sag_deriv(r * r, c, k, NOASPH)) * 2 * r
                assert abs(p[2] - sag_ref(r, c, k)) <= 1e-12 * scale * (1 + slope)
    assert n_hit > 100


def test_paraboloid_focus_1nm():
    """k = -1, R = 2000 mm: axis-parallel rays reflect through the focus at R/2 to within 1 nm."""
    R = 2000.0
    c = 1.0 / R
    focus = np.array([0.0, 0.0, R / 2])
    worst = 0.0
    for x in np.linspace(-150, 150, 31):
        for y in np.linspace(-150, 150, 31):
            if math.hypot(x, y) > 150 or (x == 0 and y == 0):
                continue
            o = np.array([x, y, 500.0])
            d = np.array([0.0, 0.0, -1.0])
            t = first_positive(*G.hit_conic(*o, *d, c, -1.0, NOASPH))
            assert t == pytest.approx(500.0 - (x * x + y * y) / (2 * R), rel=1e-15, abs=1e-12)
            p = o + t * d
            n = G.conic_normal(p[0], p[1], c, -1.0, NOASPH)
            r = reflect(*d, *n)
            worst = max(worst, line_point_distance(p, r, focus))
    assert worst < 1e-6  # mm
    assert worst < 1e-11  # what double precision actually gives


@pytest.mark.parametrize("R,k", [(500.0, -0.5), (500.0, -0.2), (800.0, -3.2), (262.9, -1.4817),
                                 (-262.9, -1.4817), (-400.0, -0.6)])
def test_conic_focal_property(R, k):
    """Rays from one focus, aimed at sag points: hit at t = 1 exactly, reflect through the other focus.

    Foci of the conic with vertex radius R and eccentricity e = sqrt(-k) lie on the axis at R/(1 + e) and
    R/(1 - e) (the second one virtual for a hyperboloid).
    """
    c = 1.0 / R
    e = math.sqrt(-k)
    f1 = np.array([0.0, 0.0, R / (1 + e)])
    f2 = np.array([0.0, 0.0, R / (1 - e)])
    rmax = 0.35 * abs(R)
    worst = 0.0
    for r in np.linspace(0.01, rmax, 15):
        for phi in np.linspace(0, 2 * math.pi, 7, endpoint=False):
            ps = np.array([r * math.cos(phi), r * math.sin(phi), sag_ref(r, c, k)])
            d = ps - f1
            t1, t2 = G.hit_conic(*f1, *d, c, k, NOASPH)
            t = t1 if abs(t1 - 1) < abs(t2 - 1) else t2
            assert t == pytest.approx(1.0, abs=1e-13)
            n = G.conic_normal(ps[0], ps[1], c, k, NOASPH)
            rr = reflect(*d, *n)
            worst = max(worst, line_point_distance(ps, rr, f2) / abs(f2[2]))
    assert worst < 1e-12


@pytest.mark.parametrize("c,k", [(1 / 500.0, -3.2), (1 / 500.0, -0.5), (1 / 500.0, 0.0)])
def test_conic_rejects_other_sheet(c, k):
    """Along the axis the quadric has a second vertex at z = 2/((1+k)c); it is not on the sag surface."""
    t1, t2 = G.hit_conic(0.0, 0.0, 3000.0, 0.0, 0.0, -1.0, c, k, NOASPH)
    assert t1 == pytest.approx(3000.0, rel=1e-15)
    assert t2 == np.inf
    t1, t2 = G.hit_conic(0.0, 0.0, -3000.0, 0.0, 0.0, 1.0, c, k, NOASPH)
    assert t1 == pytest.approx(3000.0, rel=1e-15) and t2 == np.inf


def test_conic_through_paraboloid_twice():
    c = 1 / 100.0
    # the line x = t, z = 2 crosses z = x^2 / 200 at x = +/- 20
    t1, t2 = G.hit_conic(-50.0, 0.0, 2.0, 1.0, 0.0, 0.0, c, -1.0, NOASPH)
    assert (t1, t2) == pytest.approx((30.0, 70.0), rel=1e-14)


def test_conic_origin_on_surface():
    rng = np.random.default_rng(3)
    for c, k in CONICS:
        for _ in range(50):
            r = rng.uniform(0, 100)
            phi = rng.uniform(0, 2 * math.pi)
            p = np.array([r * math.cos(phi), r * math.sin(phi), sag_ref(r, c, k)])
            d = rng.normal(size=3)
            t1, t2 = G.hit_conic(*p, *d, c, k, NOASPH)
            tmin = G.self_hit_tmin(*p, *d, 150.0)
            # the root at the origin is ~0, well inside tmin
            assert min(abs(t1), abs(t2)) <= tmin
            for t in (t1, t2):
                if t < np.inf and abs(t) > tmin:
                    q = p + t * d
                    assert quadric_distance(q, c, k) < 1e-12 * (np.linalg.norm(p) + abs(t) * np.linalg.norm(d))


def test_conic_scales():
    """Coordinates from 1e-9 to 1e12: axis-parallel rays hit at t = oz - sag(r) to relative precision."""
    for R, r, oz in [(2000.0, 100.0, 1e12), (1e12, 3e11, 2e12), (1e-9, 3e-10, 5e-9), (1e-6, 1e-9, 1e-3)]:
        for k in (-1.0, 0.0, -2.0, -0.4):
            c = 1.0 / R
            if (1 + k) * c * c * r * r > 1:
                continue
            t1, t2 = G.hit_conic(r, 0.0, oz, 0.0, 0.0, -1.0, c, k, NOASPH)
            t = first_positive(t1, t2)
            assert t == pytest.approx(oz - sag_ref(r, c, k), rel=8 * EPS), (R, r, oz, k)
    # a far, oblique ray (1e12 away) still lands on the surface to the rounding of its own origin
    o = np.array([3e11, -2e11, 9e11])
    target = np.array([50.0, 20.0, sag_ref(math.hypot(50, 20), 1 / 2000.0, -1.0)])
    d = (target - o) / np.linalg.norm(target - o)
    t1, t2 = G.hit_conic(*o, *d, 1 / 2000.0, -1.0, NOASPH)
    # this line first crosses the paraboloid's far wall (r ~ 1e4), then reaches the target
    assert 0 < t1 < t2 < np.inf
    assert np.linalg.norm(o + t2 * d - target) < 8 * EPS * np.linalg.norm(o)
    assert quadric_distance(o + t1 * d, 1 / 2000.0, -1.0) < 8 * EPS * np.linalg.norm(o)


def test_conic_grazing_and_tangent():
    # paraboloid z = x^2 / 2048 (c = 2^-10): every number below is exact in binary
    c, k = 2.0 ** -10, -1.0
    # tangent at P = (128, 0, 8) (slope 1/8), origin 64 before P: exact double root at t = 64
    assert G.hit_conic(64.0, 0.0, 0.0, 1.0, 0.0, 0.125, c, k, NOASPH) == (64.0, 64.0)
    # the same line 2^-40 below the tangent misses; 2^-40 above it crosses twice
    assert G.hit_conic(64.0, 0.0, -(2.0 ** -40), 1.0, 0.0, 0.125, c, k, NOASPH) == (np.inf, np.inf)
    t1, t2 = G.hit_conic(64.0, 0.0, 2.0 ** -40, 1.0, 0.0, 0.125, c, k, NOASPH)
    # roots 64 -/+ sqrt(2 * 2^-40 / c) along x
    assert (t1, t2) == pytest.approx((64 - math.sqrt(2.0 ** -29), 64 + math.sqrt(2.0 ** -29)), rel=1e-12)
    # grazing: origin exactly on the surface at P, direction th below the tangent. Roots: 0 and the chord
    # back to the other crossing, t = -2 sin(th) / (c cos(a0) cos(a)^2), a0 = atan(1/8), a = a0 - th.
    # The direction's own rounding (1e-16 rad) limits the chord to a relative 1e-16 / th.
    a0 = math.atan(0.125)
    for th in (1e-9, 1e-6, 1e-3):
        a = a0 - th
        d = np.array([math.cos(a), 0.0, math.sin(a)])
        t1, t2 = G.hit_conic(128.0, 0.0, 8.0, *d, c, k, NOASPH)
        assert np.isfinite(t1) and np.isfinite(t2), th
        assert t2 == 0.0
        exact = -2 * math.sin(th) / (c * math.cos(a0) * math.cos(a) ** 2)
        assert t1 == pytest.approx(exact, rel=4e-16 / th + 1e-12), th
        q = np.array([128.0, 0.0, 8.0]) + t1 * d
        assert quadric_distance(q, c, k) < 1e-14 * 128
        # the same ray started 50 before P: both crossings found, on the surface
        o = np.array([128.0, 0.0, 8.0]) - 50.0 * d
        t1, t2 = G.hit_conic(*o, *d, c, k, NOASPH)
        assert not (math.isnan(t1) or math.isnan(t2))
        for t in (t1, t2):
            if t < np.inf:
                assert quadric_distance(o + t * d, c, k) < 1e-14 * 128
        if th >= 1e-6:
            assert t2 - t1 == pytest.approx(-exact, rel=1e-4)
        # leaving P in the opposite direction (towards the vertex) the chord is ahead; the leaving rule drops
        # the origin's root, the other one is the far crossing
        t1, t2 = G.hit_conic(128.0, 0.0, 8.0, *(-d), c, k, NOASPH)
        t_next, _ = G.drop_leaving_root(t1, t2)
        assert t_next == pytest.approx(-exact, rel=4e-16 / th + 1e-12)


def test_conic_degenerate_inputs():
    assert G.hit_conic(0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.001, -1.0, NOASPH) == (np.inf, np.inf)
    # ray along the axis of a plane-conic (c = 0) but parallel to it
    assert G.hit_conic(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, -1.0, NOASPH) == (np.inf, np.inf)
    assert G.hit_conic(0.0, 0.0, 1.0, 0.0, 0.0, -4.0, 0.0, 0.0, NOASPH) == (0.25, np.inf)
    # ray parallel to a paraboloid's axis hits once
    t1, t2 = G.hit_conic(3.0, 4.0, 10.0, 0.0, 0.0, -1.0, 0.01, -1.0, NOASPH)
    assert t1 == pytest.approx(10 - 25 * 0.01 / 2, rel=1e-15) and t2 == np.inf


def test_conic_sag_normal_domain():
    c, k = 1 / 500.0, -0.5
    for r in (0.0, 10.0, 300.0, 700.0):
        assert G.conic_sag(r * r, c, k, NOASPH) == pytest.approx(sag_ref(r, c, k), rel=1e-15, abs=0)
    rmax = 1 / (c * math.sqrt(1 + k))
    assert G.conic_domain_ok(rmax * 0.999999, c, k) and not G.conic_domain_ok(rmax * 1.000001, c, k)
    assert G.conic_sag((1.01 * rmax) ** 2, c, k, NOASPH) == np.inf
    assert G.conic_domain_ok(1e12, c, -1.0) and G.conic_domain_ok(1e12, c, -5.0)
    # normal at the vertex is +z, finite (horizontal) at the ellipsoid's equator
    assert G.conic_normal(0.0, 0.0, c, k, NOASPH) == (0.0, 0.0, 1.0)
    n = G.conic_normal(rmax, 0.0, c, k, NOASPH)
    assert n == pytest.approx((-1.0, 0.0, 0.0), abs=1e-7)
    # the normal is perpendicular to the sag profile (numerical derivative)
    for c_, k_, asph in [(1 / 500.0, -0.5, NOASPH), (1 / 800.0, -3.0, np.array([1e-9, -2e-14]))]:
        for r in (5.0, 50.0, 150.0):
            h = 1e-5
            dz = (G.conic_sag((r + h) ** 2, c_, k_, asph) - G.conic_sag((r - h) ** 2, c_, k_, asph)) / (2 * h)
            nx, ny, nz = G.conic_normal(r, 0.0, c_, k_, asph)
            assert nx * 1.0 + nz * dz == pytest.approx(0.0, abs=1e-9)
            assert nz > 0


ASPHERES = [
    (1 / 500.0, -0.5, np.array([1e-9, -2e-14])),
    (1 / 2000.0, -1.0, np.array([2e-10, 0.0, 1e-19])),
    (0.0, 0.0, np.array([1e-8])),  # pure polynomial on a plane
    (-1 / 262.9, -1.4817, np.array([3e-9])),
]


@pytest.mark.parametrize("c,k,asph", ASPHERES)
def test_asphere_axis_parallel_exact(c, k, asph):
    for r in np.linspace(0.0, 100.0, 21):
        t1, t2 = G.hit_conic(r, 0.0, 400.0, 0.0, 0.0, -1.0, c, k, asph)
        t = first_positive(t1, t2)
        assert t == pytest.approx(400.0 - sag_ref(r, c, k, asph), rel=4 * EPS)


@pytest.mark.parametrize("c,k,asph", ASPHERES)
def test_asphere_newton_oblique(c, k, asph):
    """Oblique rays vs a bracketing root finder on z(t) - sag(r(t))."""
    rng = np.random.default_rng(17)
    for _ in range(100):
        target = np.array([*rng.uniform(-70, 70, 2), 0.0])
        target[2] = sag_ref(math.hypot(*target[:2]), c, k, asph)
        o = target + np.array([*rng.uniform(-60, 60, 2), 300.0])
        d = (target - o) * rng.uniform(0.1, 10)
        t1, t2 = G.hit_conic(*o, *d, c, k, asph)
        t = first_positive(t1, t2)
        g = lambda s: (o[2] + s * d[2]) - sag_ref(math.hypot(o[0] + s * d[0], o[1] + s * d[1]), c, k, asph)
        t_bren = brentq(g, 0.0, 1.0 / np.linalg.norm(d) * (np.linalg.norm(target - o) + 50), xtol=1e-15,
                        rtol=4 * EPS)
        assert t == pytest.approx(t_bren, rel=1e-12)
        p = o + t * d
        assert abs(p[2] - sag_ref(math.hypot(p[0], p[1]), c, k, asph)) < 1e-12 * np.linalg.norm(o)


# ------------------------------------------------------------------------------------------------
# sphere, ellipsoid, tube
# ------------------------------------------------------------------------------------------------
def sphere_closed_form(o, d, R):
    d = np.asarray(d, float)
    o = np.asarray(o, float)
    dn = np.linalg.norm(d)
    u = d / dn
    b = np.dot(o, u)
    disc = b * b - (np.dot(o, o) - R * R)
    if disc < 0:
        return np.inf, np.inf
    s = math.sqrt(disc)
    return (-b - s) / dn, (-b + s) / dn


def test_sphere_closed_form():
    rng = np.random.default_rng(1)
    for _ in range(500):
        R = rng.uniform(0.1, 10)
        o = rng.uniform(-20, 20, 3)
        target = rng.uniform(-R, R, 3)
        d = (target - o) * rng.uniform(0.1, 10)
        ref = sphere_closed_form(o, d, R)
        got = G.hit_sphere(*o, *d, R)
        if ref[0] == np.inf:
            assert got == (np.inf, np.inf)
        else:
            scale = (np.linalg.norm(o) + R) / np.linalg.norm(d)
            assert abs(got[0] - ref[0]) < 1e-13 * scale and abs(got[1] - ref[1]) < 1e-13 * scale
    assert G.hit_sphere(0.0, 0.0, -10.0, 0.0, 0.0, 1.0, 1.0) == (9.0, 11.0)
    assert G.hit_sphere(0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 1.0) == (-0.5, 0.5)  # from the centre
    assert G.hit_sphere(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0) == (np.inf, np.inf)


def test_sphere_tangent_and_grazing():
    R = 1.0
    # exactly tangent: double root, no NaN
    t1, t2 = G.hit_sphere(R, 0.0, -10.0, 0.0, 0.0, 1.0, R)
    assert t1 == 10.0 and t2 == 10.0
    # just outside: miss
    assert G.hit_sphere(R * (1 + 4 * EPS), 0.0, -10.0, 0.0, 0.0, 1.0, R) == (np.inf, np.inf)
    # origin on the sphere, tangent direction
    t1, t2 = G.hit_sphere(0.0, 0.0, R, 1.0, 0.0, 0.0, R)
    assert (t1, t2) == (0.0, 0.0)
    # grazing: through P = (R, 0, 0) at 1e-9 rad inside the tangent plane; the chord 2 R sin(th) is below
    # what the origin's rounding can resolve, but both roots are finite and on the sphere
    for th in (1e-9, 1e-7, 1e-5):
        d = np.array([-math.sin(th), 0.0, math.cos(th)])
        o = np.array([R, 0.0, 0.0]) - 3.0 * d
        t1, t2 = G.hit_sphere(*o, *d, R)
        assert np.isfinite(t1) and np.isfinite(t2)
        for t in (t1, t2):
            assert abs(np.linalg.norm(o + t * d) - R) < 4 * EPS * 3
        chord = 2 * R * math.sin(th)
        # chord error: sqrt(2 R delta) with delta ~ eps * |o| the perpendicular distance's rounding
        assert abs((t2 - t1) - chord) < 2 * math.sqrt(2 * R * 8 * EPS * 3)
        if th >= 1e-5:
            assert (t2 - t1) == pytest.approx(chord, rel=1e-4)


def test_sphere_scales():
    for R, L in [(1e-9, 1e-8), (1e12, 3e12), (6.371e6, 2.7e10), (1.0, 1e12)]:
        t1, t2 = G.hit_sphere(0.0, 0.0, -L, 0.0, 0.0, 1.0, R)
        assert t1 == pytest.approx(L - R, rel=2 * EPS) and t2 == pytest.approx(L + R, rel=2 * EPS)
        # off-axis, impact parameter 0.6 R: chord 0.8 R each side
        t1, t2 = G.hit_sphere(0.6 * R, 0.0, -L, 0.0, 0.0, 1.0, R)
        assert t1 == pytest.approx(L - 0.8 * R, rel=4 * EPS, abs=4 * EPS * L)
        assert t2 == pytest.approx(L + 0.8 * R, rel=4 * EPS, abs=4 * EPS * L)


def test_sphere_leaving_surface():
    """Origin at a previous hit: one root ~0 (< tmin), the other is the full chord to full precision."""
    rng = np.random.default_rng(2)
    for _ in range(300):
        R = 10 ** rng.uniform(-6, 7)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        p = R * u
        v = rng.normal(size=3)
        d = v / np.linalg.norm(v)
        if np.dot(d, u) > 0:
            d = -d  # going inside
        t1, t2 = G.hit_sphere(*p, *d, R)
        tmin = G.self_hit_tmin(*p, *d, R)
        chord = -2 * np.dot(p, d)
        assert abs(t1) < tmin
        assert t2 == pytest.approx(chord, rel=1e-12)


def test_leaving_root_of_spheres_and_ellipsoids_at_grazing_departures():
    """A ray that starts on a sphere and leaves it at angle theta to the tangent plane (inward > 0): the closed
    form of the chord, 2 R sin(theta), is the oracle; outward and tangent departures meet the sphere no more.
    The quadratic's roots at such a start (hit_sphere) are ~sqrt(eps) R apart by the rounding of the discriminant,
    which for theta = 1e-9 made a spurious hit ~1e-8 R ahead (tests/stress/test_stress_grazing.py's crawling
    rays); the closed form's error is eps R.  Ellipsoids: the root lies on the surface and is positive exactly
    when the ray leaves inward."""
    rng = np.random.default_rng(12)
    for _ in range(400):
        R = 10 ** rng.uniform(-6, 7)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        t = np.cross(u, rng.normal(size=3))
        t /= np.linalg.norm(t)
        p = R * u
        for th in (1e-12, 1e-9, 1e-6, 0.3, 1.5, 0.0, -1e-9, -0.3):
            d = math.cos(th) * t - math.sin(th) * u
            t1, t2 = G.leaving_sphere_root(*p, *d)
            assert t2 == np.inf
            if th > 0:
                assert t1 == pytest.approx(2 * R * math.sin(th), rel=1e-6, abs=8 * EPS * R)
            else:       # tangent or outward: nothing ahead beyond rounding, nothing beyond the self-hit tolerance
                assert t1 == np.inf or t1 <= 8 * EPS * R
                assert not (G.self_hit_tmin(*p, *d, R) < t1 < np.inf)
    a, b, c = 10.0, 6.0, 3.0
    for _ in range(400):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        p = u * np.array([a, b, c])
        n = G.ellipsoid_normal(*p, a, b, c)
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        t1, t2 = G.leaving_ellipsoid_root(*p, *d, a, b, c)
        assert t2 == np.inf
        if np.dot(d, n) < -1e-6:
            q = p + t1 * d
            assert t1 > 0 and abs((q[0] / a) ** 2 + (q[1] / b) ** 2 + (q[2] / c) ** 2 - 1) < 1e-12
        elif np.dot(d, n) > 1e-6:
            assert t1 == np.inf


def test_ellipsoid():
    a, b, c = 1.0, 2.0, 3.0
    assert G.hit_ellipsoid(0.0, 0.0, -10.0, 0.0, 0.0, 1.0, a, b, c) == pytest.approx((7.0, 13.0), rel=1e-15)
    assert G.hit_ellipsoid(-10.0, 0.0, 0.0, 2.0, 0.0, 0.0, a, b, c) == pytest.approx((4.5, 5.5), rel=1e-15)
    rng = np.random.default_rng(4)
    for _ in range(300):
        o = rng.uniform(-10, 10, 3)
        d = rng.uniform(-1, 1, 3) * np.array([a, b, c]) - o
        for t in G.hit_ellipsoid(*o, *d, a, b, c):
            if t < np.inf:
                p = o + t * d
                assert abs((p[0] / a) ** 2 + (p[1] / b) ** 2 + (p[2] / c) ** 2 - 1) < 1e-13
                n = G.ellipsoid_normal(*p, a, b, c)
                # outward and perpendicular to the level set's gradient
                assert np.dot(n, p) > 0
                grad = p / np.array([a, b, c]) ** 2
                assert np.allclose(n, grad / np.linalg.norm(grad), atol=1e-15)
    # tiny and huge axes (Earth-like, metres)
    ae, be = 6378137.0, 6356752.314245
    t1, _ = G.hit_ellipsoid(0.0, 0.0, 2.7e10, 0.0, 0.0, -1.0, ae, ae, be)
    assert t1 == pytest.approx(2.7e10 - be, rel=2 * EPS)


def tube_ref(o, d, z1, r1, z2, r2):
    """Independent: roots of rho(t) - r(z(t)) by bracketing on a fine grid."""
    sl = (r2 - r1) / (z2 - z1)
    f = lambda t: math.hypot(o[0] + t * d[0], o[1] + t * d[1]) - (r1 + sl * (o[2] + t * d[2] - z1))
    ts = np.linspace(-100, 100, 200001)
    x = o[0] + ts * d[0]
    y = o[1] + ts * d[1]
    z = o[2] + ts * d[2]
    vals = np.hypot(x, y) - (r1 + sl * (z - z1))
    roots = []
    for i in np.nonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0]:
        t = brentq(f, ts[i], ts[i + 1], xtol=1e-15, rtol=4 * EPS)
        zt = o[2] + t * d[2]
        if min(z1, z2) <= zt <= max(z1, z2):
            roots.append(t)
    return roots


@pytest.mark.parametrize("z1,r1,z2,r2", [(0.0, 1.0, 2.0, 1.0), (0.0, 1.0, 1.0, 2.0), (-1.0, 3.0, 2.0, 0.5),
                                         (0.0, 0.0, 2.0, 1.0), (2.0, 1.0, 0.0, 2.0)])
def test_tube_vs_root_finder(z1, r1, z2, r2):
    rng = np.random.default_rng(8)
    for _ in range(60):
        o = np.array([*rng.uniform(-5, 5, 2), rng.uniform(-3, 4)])
        target = np.array([*rng.uniform(-2, 2, 2), rng.uniform(min(z1, z2), max(z1, z2))])
        d = (target - o) / np.linalg.norm(target - o)
        got = [t for t in G.hit_tube(*o, *d, z1, r1, z2, r2) if t < np.inf]
        ref = tube_ref(o, d, z1, r1, z2, r2)
        assert len(got) == len(ref), (o, d, got, ref)
        for a, b in zip(sorted(got), sorted(ref)):
            assert a == pytest.approx(b, abs=1e-12)
        for t in got:
            p = o + t * d
            n = G.tube_normal(*p, z1, r1, z2, r2)
            assert abs(np.linalg.norm(n) - 1) < 1e-15
            radial = np.array([p[0], p[1], 0.0])
            assert np.dot(n, radial) >= 0  # outward


def test_tube_closed_forms_and_degenerate():
    # cylinder r = 1: horizontal ray through the axis
    assert G.hit_tube(-10.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 1.0, 2.0, 1.0) == (9.0, 11.0)
    # cone r = 1 -> 2 over z 0 -> 1, at z = 0.5 r = 1.5
    assert G.hit_tube(-10.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 2.0) == (8.5, 11.5)
    # outside the z range: no hit
    assert G.hit_tube(-10.0, 0.0, 2.5, 1.0, 0.0, 0.0, 0.0, 1.0, 2.0, 1.0) == (np.inf, np.inf)
    # ray along the cylinder axis / along the wall: never a hit, no NaN
    assert G.hit_tube(0.0, 0.0, -5.0, 0.0, 0.0, 1.0, 0.0, 1.0, 2.0, 1.0) == (np.inf, np.inf)
    assert G.hit_tube(1.0, 0.0, -5.0, 0.0, 0.0, 1.0, 0.0, 1.0, 2.0, 1.0) == (np.inf, np.inf)
    # tangent to the cylinder: double root
    assert G.hit_tube(-10.0, 1.0, 0.5, 1.0, 0.0, 0.0, 0.0, 1.0, 2.0, 1.0) == (10.0, 10.0)
    # through the cone apex along the axis
    t = G.hit_tube(0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 1.0)
    assert all(not math.isnan(x) for x in t)
    # z1 == z2: degenerate
    assert G.hit_tube(-10.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 2.0) == (np.inf, np.inf)
    # huge and tiny
    for s in (1e-9, 1e12):
        t1, t2 = G.hit_tube(-10 * s, 0.0, 0.5 * s, 1.0, 0.0, 0.0, 0.0, s, 2 * s, s)
        assert t1 == pytest.approx(9 * s, rel=2 * EPS) and t2 == pytest.approx(11 * s, rel=2 * EPS)


# ------------------------------------------------------------------------------------------------
# apertures and frames
# ------------------------------------------------------------------------------------------------
def test_apertures():
    assert G.in_rect(1.0, -2.0, 1.0, 2.0) and not G.in_rect(1.0000001, 0.0, 1.0, 2.0)
    assert G.in_disk(3.0, 4.0, 5.0) and not G.in_disk(3.0, 4.0000001, 5.0)
    assert G.in_annulus(3.0, 4.0, 5.0, 6.0) and not G.in_annulus(0.1, 0.0, 1.0, 2.0)
    assert not G.in_annulus(3.0, 4.0, 1.0, 4.9)
    assert G.in_ellipse(2.0, 0.0, 2.0, 1.0) and G.in_ellipse(0.0, -1.0, 2.0, 1.0)
    assert not G.in_ellipse(1.5, 0.7, 2.0, 1.0)
    assert G.in_disk(1e-300, 1e-300, 1e-299) and G.in_disk(3e200, 4e200, 5e200)


def test_frames_subtract_first():
    R = Rotation.from_euler("zyx", [31, -47, 112], degrees=True).as_matrix()
    T = np.array([2.7e10, -1.3e10, 4.0e9])
    delta = np.array([0.25, -0.5, 0.125])  # exactly representable offset from T
    p = T + delta
    assert np.array_equal(p - T, delta)
    d = np.array([0.0, 0.6, 0.8])
    lx, ly, lz, ldx, ldy, ldz = G.to_local(*p, *d, R, T)
    assert np.allclose([lx, ly, lz], R.T @ delta, rtol=0, atol=4 * EPS)  # rotating first would give ~1e-5
    assert np.allclose([ldx, ldy, ldz], R.T @ d, rtol=0, atol=4 * EPS)
    w = G.to_world(lx, ly, lz, ldx, ldy, ldz, R, T)
    assert np.allclose(w[:3], p, rtol=2 * EPS, atol=0)
    assert np.allclose(w[3:], d, rtol=0, atol=4 * EPS)
    assert np.allclose(G.dir_to_world(*G.dir_to_local(*d, R), R), d, atol=4 * EPS, rtol=0)


def test_self_hit_tmin():
    assert G.self_hit_tmin(0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 150.0) == pytest.approx(1.5e-7)
    assert G.self_hit_tmin(6.4e6, 0.0, 0.0, 0.0, 0.0, 2.0, 1.0) == pytest.approx(3.2e-3)
    assert G.self_hit_tmin(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0) == np.inf


def _exact_norm(x, y, z):
    """The Euclidean norm in 60-digit decimal arithmetic (an oracle independent of the kernels' float code)."""
    from decimal import Decimal, getcontext

    getcontext().prec = 60
    return float((Decimal(x) ** 2 + Decimal(y) ** 2 + Decimal(z) ** 2).sqrt())


@pytest.mark.parametrize("scale", [1e-300, 1e-200, 1e-145, 1e-10, 1.0, 6.4e6, 1e140, 1e200, 1e300])
def test_norms_and_unit_vectors_to_rounding_at_every_magnitude(scale):
    """norm3, normalize3 and the interface optics' and samplers' unit vectors: within 2 ulp of the exact norm
    (decimal arithmetic) on both sides of their fast path's range (1e-280 < |v|^2 < 1e280, where the squares
    neither overflow nor underflow; outside it the vector is scaled first), and the unit vectors of norm 1
    to 3 ulp and along the input."""
    from irtlang.kernels import optics, sampling

    rng = np.random.default_rng(int(-math.log10(scale) * 10) % 1000 + 5)
    for v in rng.normal(size=(200, 3)) * scale:
        x, y, z = (float(c) for c in v)
        exact = _exact_norm(x, y, z)
        assert abs(G.norm3(x, y, z) - exact) <= 2 * math.ulp(exact)
        for ux, uy, uz in (G.normalize3(x, y, z), optics._unit(x, y, z), sampling._unit(x, y, z)):
            assert abs(_exact_norm(ux, uy, uz) - 1.0) <= 3 * EPS
            for a, b in ((ux, x), (uy, y), (uz, z)):
                assert abs(a - b / exact) <= 3 * EPS * (abs(a) + 1e-300)
    # the zero and non-finite vectors keep each caller's answer
    assert G.norm3(0.0, 0.0, 0.0) == 0.0 and G.norm3(math.inf, 1.0, 0.0) == math.inf
    assert G.normalize3(0.0, 0.0, 0.0) == (0.0, 0.0, 1.0) and sampling._unit(0.0, 0.0, 0.0) == (0.0, 0.0, 1.0)
    assert optics._unit(0.0, 0.0, 0.0) == (0.0, 0.0, 0.0)
