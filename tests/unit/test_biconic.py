"""The BICONIC surface plugin (irtlang/plugins/surfaces/biconic.py), against independent oracles.

The plugin's njit ``hit`` and ``normal`` are called directly on a hand-built ``layout.Surfaces`` table (no trace,
no kernel compilation).  The oracles:

1. cx = cy, kx = ky is a CONIC: hits and normals agree with the closed-form quadric of
   ``geometry.hit_conic_plain`` / ``conic_normal_plain``;
2. a true biconic: rays aimed at a known point of the surface find it, every hit satisfies the closed-form sag,
   and no crossing is missed or invented (a dense scan of the sag residual along the ray); the normal is the
   analytic gradient of the sag, differentiated here independently (quotient rule);
3. kx = ky = -1 is the elliptic paraboloid z = x^2/(2 Rx) + y^2/(2 Ry): an on-axis collimated beam reflected
   from it passes through (0, 0, Rx/2) in the plane y = 0 and through (0, 0, Ry/2) in the plane x = 0;
4. ``leaving``: a ray starting on the surface does not find its own departure point, and finds the second
   crossing of a cylinder's circular section exactly where the chord ends;
5. the language: bad radii, an aperture outside the domain, RADIUS and CURVATURE together or neither are
   refused at the right place; units, frames, pack and bounds of a good one.

Numba compiles only the plugin's small functions (seconds); the functions are cached like the kernel's.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from irtlang.kernels import layout
from irtlang.kernels.geometry import conic_normal_plain, hit_conic_plain, in_aperture
from irtlang.plugins.surfaces import CODES, REGISTRY
from irtlang.plugins.surfaces import biconic as B

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_diagnostics import diagnose  # noqa: E402  (the front end as `irt check` runs it)

INF = math.inf


# ---------------------------------------------------------------------------------------------- helpers
def table(cx, cy, kx, ky, ap=None, a0=0.0, a1=0.0) -> layout.Surfaces:
    """A one-surface ``layout.Surfaces`` for the plugin's hit/normal: par = cx, cy, kx, ky; ap: AP_* code."""
    f = np.zeros((1, layout.SF_N))
    f[0, layout.SF_PAR:layout.SF_PAR + 4] = (cx, cy, kx, ky)
    f[0, layout.SF_AP:layout.SF_AP + 2] = (a0, a1)
    f[0, layout.SF_BS + 3] = INF
    i = np.zeros((1, layout.SI_N), np.int64)
    i[0, layout.SI_KIND] = CODES["BICONIC"]
    i[0, layout.SI_APK] = layout.AP_NONE if ap is None else ap
    i[0, layout.SI_MESH] = -1
    return layout.Surfaces(f=f, i=i, mesh=np.zeros((1, 4), np.int64), bmin=np.zeros((0, 3)), bmax=np.zeros((0, 3)),
                           child=np.zeros((0, 2), np.int64), count=np.zeros(0, np.int64), tris=np.zeros((0, 9)),
                           ids=np.zeros(0, np.int64), fn=np.zeros((0, 3)))


def _fsi(S):
    """The plugin functions' leading arguments: the table's float and int columns, then the table."""
    return S.f, S.i, S


def hits(S, o, d, tmin=-INF, leaving=False):
    t1, t2, face = B.hit(S.f, S.i, S, 0, *map(float, o), *map(float, d), float(tmin), leaving)
    assert face == -1
    assert t1 <= t2
    return [t for t in (t1, t2) if t < INF]


def all_roots(o, d, par, leaving=False):
    n, *r = B.biconic_roots(*map(float, o), *map(float, d), *map(float, par), leaving, -INF)
    r = [t for t in r if t < INF]
    assert n == len(r) and r == sorted(r)
    return r


def sag(x, y, cx, cy, kx, ky):
    """The closed-form sag (numpy), nan outside the domain."""
    arg = 1.0 - (1.0 + kx) * cx * cx * x * x - (1.0 + ky) * cy * cy * y * y
    with np.errstate(invalid="ignore"):
        return np.where(arg >= 0.0, (cx * x * x + cy * y * y) / (1.0 + np.sqrt(np.maximum(arg, 0.0))), np.nan)


def sag_grad(x, y, cx, cy, kx, ky):
    """d sag/dx, d sag/dy by the quotient rule on N / D, N = cx x^2 + cy y^2, D = 1 + sqrt(W),
    W = 1 - (1+kx) cx^2 x^2 - (1+ky) cy^2 y^2 (written out here, not taken from the plugin)."""
    W = 1.0 - (1.0 + kx) * cx ** 2 * x ** 2 - (1.0 + ky) * cy ** 2 * y ** 2
    N = cx * x ** 2 + cy * y ** 2
    D = 1.0 + math.sqrt(W)
    dWdx = -2.0 * (1.0 + kx) * cx ** 2 * x
    dWdy = -2.0 * (1.0 + ky) * cy ** 2 * y
    dDdx = dWdx / (2.0 * math.sqrt(W))
    dDdy = dWdy / (2.0 * math.sqrt(W))
    return (2.0 * cx * x * D - N * dDdx) / D ** 2, (2.0 * cy * y * D - N * dDdy) / D ** 2


def random_params(rng, equal=False):
    """(cx, cy, kx, ky): curvatures of either sign over three decades (one may be 0), conics -4 .. 3."""
    cx = float(rng.choice([-1.0, 1.0]) * 10 ** rng.uniform(-2, 1))
    k = float(rng.uniform(-4, 3))
    if equal:
        return cx, cx, k, k
    cy = float(rng.choice([-1.0, 1.0, 0.0], p=[0.4, 0.4, 0.2]) * 10 ** rng.uniform(-2, 1))
    return cx, cy, k, float(rng.uniform(-4, 3))


def point_inside(rng, par, vmax=0.9, reach=1.5):
    """A point (x, y, sag) of the surface with (1+kx) cx^2 x^2 + (1+ky) cy^2 y^2 <= vmax."""
    cx, cy, kx, ky = par
    L = 1.0 / max(abs(cx), abs(cy))
    while True:
        x, y = rng.uniform(-1, 1, 2) * L * reach * rng.uniform(0.001, 1.0)
        if (1 + kx) * cx * cx * x * x + (1 + ky) * cy * cy * y * y <= vmax:
            return np.array([x, y, float(sag(x, y, *par))])


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def ray_at(rng, target, distance):
    """A ray from `distance` away (random direction), through `target` at t = distance."""
    d = unit(rng.normal(size=3))
    return target - distance * d, d


# ---------------------------------------------------------------------------------------------- registry
def test_registered_last_with_its_contract():
    assert list(REGISTRY)[-1] == "BICONIC" and CODES["BICONIC"] == len(REGISTRY) - 1
    assert B.KIND == "BICONIC" and B.FEATURE == "biconic"
    # its own feature: a scene with conics and no biconic compiles none of its root finder
    from irtlang.compile.pack import Features
    from irtlang.compile.specialize import surface_dispatch
    assert f"_hit_{CODES['BICONIC']}" not in surface_dispatch(Features(conic=True, quadric=True, mesh=True))
    assert f"_hit_{CODES['BICONIC']}" in surface_dispatch(Features(biconic=True))
    assert B.__doc__.splitlines()[0].startswith("BICONIC axis vertex")
    assert "| RADIUS Rx Ry |" in B.__doc__ and "| CONIC kx ky |" in B.__doc__
    assert "BICONIC" in B.EXAMPLE


# ---------------------------------------------------------------------------------------------- 1. CONIC
def test_equal_sections_are_the_conic():
    """cx = cy, kx = ky: the roots (both, any sign) and normals of the closed-form quadric."""
    rng = np.random.default_rng(11)
    worst_t = worst_n = 0.0
    compared = 0
    for trial in range(3000):
        par = random_params(rng, equal=True)
        c, k = par[0], par[2]
        L = 1.0 / abs(c)
        kind = trial % 4
        if kind == 0:       # aimed at the surface, from near or up to 1e3 sizes away
            o, d = ray_at(rng, point_inside(rng, par), L * 10 ** rng.uniform(-2, 3))
        elif kind == 1:     # parallel to the axis, on or off it
            o = np.array([*(rng.normal(size=2) * L * 0.3 * (trial % 3 != 0)), 5 * L])
            d = np.array([0.0, 0.0, -1.0])
        elif kind == 2:     # oblique, anywhere
            o, d = rng.normal(size=3) * 2 * L, unit(rng.normal(size=3))
        else:               # a non-unit direction
            o, d = ray_at(rng, point_inside(rng, par), 3 * L)
            d = d * 10 ** rng.uniform(-3, 3)
        ref = [t for t in hit_conic_plain(*o, *d, c, k) if t < INF]
        got = hits(table(*par), o, d)
        # leave out what is ill-posed for both: a (near-)tangent ray, a root at an ellipsoid's rim
        dn = np.linalg.norm(d)
        skip = False
        for t in ref:
            p = o + t * d
            n = np.array(conic_normal_plain(p[0], p[1], c, k))
            arg = 1 - (1 + k) * c * c * (p[0] ** 2 + p[1] ** 2)
            if abs(n @ d) < 1e-2 * dn or arg < 1e-3:
                skip = True
        if skip:
            continue
        compared += 1
        assert len(got) == len(ref), (par, o, d, got, ref)
        scale = np.abs(o).max() / dn
        for a, b in zip(got, ref):
            worst_t = max(worst_t, abs(a - b) / (scale + abs(b)))
            p = o + a * d
            n_b = np.array(B.normal(*_fsi(table(*par)), 0, *p, -1))
            n_c = np.array(conic_normal_plain(p[0], p[1], c, k))
            worst_n = max(worst_n, np.abs(n_b - n_c).max())
    print(f"conic reduction: {compared} rays, max |dt| / (|o|/|d| + |t|) = {worst_t:.2e}, max |dn| = {worst_n:.2e}")
    assert compared > 2000
    assert worst_t < 1e-12
    assert worst_n < 1e-12


# ---------------------------------------------------------------------------------------------- 2. residual
def test_hits_lie_on_the_biconic_and_find_the_aimed_point():
    """Rays through a known point of the surface, from 0.1 to 1000 times the aperture it needs away.  A far
    origin's own rounding (eps |o|) moves the computed point along the ray: its vertical residual grows with the
    slope, its distance from the surface (|z - sag| n_z) does not."""
    rng = np.random.default_rng(22)
    worst_dist = worst_near = worst_aim = 0.0
    for trial in range(4000):
        par = random_params(rng)
        target = point_inside(rng, par)
        cx, cy = par[:2]
        size = max(abs(target[0]), abs(target[1])) + 1e-6 / max(abs(cx), abs(cy))   # the aperture it needs
        far = size * 10 ** rng.uniform(-1, 3)                                         # up to 1e3 sizes away
        o, d = ray_at(rng, target, far)
        roots = all_roots(o, d, par)
        assert roots, (par, o, d)
        aim = min(abs(t - far) for t in roots)
        # the hit moves along the ray by its rounding over the grazing angle: compare the points, not t
        worst_aim = max(worst_aim, aim / far * abs(unit(B.biconic_normal(*target[:2], *par)) @ d))
        for t in roots:
            p = o + t * d
            res = abs(p[2] - sag(p[0], p[1], *par)) / max(size, np.abs(p).max())
            nz = abs(unit([-g for g in sag_grad(p[0], p[1], *par)] + [1.0])[2]) if res > 0 else 1.0
            worst_dist = max(worst_dist, res * nz)
            if abs(t) * np.linalg.norm(d) <= 10 * size:     # this hit lies within 10 sizes of the origin
                worst_near = max(worst_near, res)
    print(f"biconic: distance from the surface <= {worst_dist:.2e} size, |z - sag| <= {worst_near:.2e} size "
          f"from <= 10 sizes away; the aimed point found to {worst_aim:.2e}")
    assert worst_dist < 1e-12
    assert worst_near < 1e-13
    assert worst_aim < 1e-12


def scan_roots(o, d, par, T, n=200001):
    """Every sign change of z - sag along the ray for |t| <= T (dense scan + bisection): an oracle that knows
    nothing of the quartic."""
    t = np.linspace(-T, T, n)
    h = (o[2] + t * d[2]) - sag(o[0] + t * d[0], o[1] + t * d[1], *par)
    s = np.sign(h)
    out = []
    for i in np.nonzero(s[:-1] * s[1:] < 0)[0]:
        a, b = t[i], t[i + 1]
        ha = h[i]
        for _ in range(100):
            m = 0.5 * (a + b)
            hm = (o[2] + m * d[2]) - float(sag(o[0] + m * d[0], o[1] + m * d[1], *par))
            if np.sign(hm) == np.sign(ha):
                a, ha = m, hm
            else:
                b = m
        out.append(0.5 * (a + b))
    return out


def test_no_crossing_missed_or_invented():
    """Random rays and surfaces (saddles, cylinders, strongly different conics): the same crossings as a dense
    scan of the sag residual, up to four of them."""
    rng = np.random.default_rng(33)
    counts = {}
    for _ in range(400):
        par = random_params(rng)
        L = 1.0 / max(abs(par[0]), abs(par[1]))
        o, d = rng.normal(size=3) * 2 * L, unit(rng.normal(size=3))
        T = 6 * L + np.linalg.norm(o)
        ref = scan_roots(o, d, par, T)
        got = [t for t in all_roots(o, d, par) if abs(t) < T]
        # where the scan's steps straddle the domain's rim (sag undefined there) it may see no sign change: a
        # root there must still lie on the surface
        extra = [t for t in got if min((abs(t - r) for r in ref), default=INF) > 1e-6 * T]
        for t in extra:
            p = o + t * d
            arg = 1 - (1 + par[2]) * par[0] ** 2 * p[0] ** 2 - (1 + par[3]) * par[1] ** 2 * p[1] ** 2
            assert arg < 1e-3 and abs(p[2] - sag(p[0], p[1], *par)) < 1e-9 * L, (par, o, d, got, ref)
        assert len(got) - len(extra) == len(ref), (par, o, d, got, ref)
        for r in ref:
            assert min(abs(t - r) for t in got) < 1e-9 * T, (par, o, d, got, ref)
        counts[len(got)] = counts.get(len(got), 0) + 1
    print("crossings per ray:", dict(sorted(counts.items())))
    assert counts.get(2, 0) > 20 and counts.get(0, 0) > 20


def test_normal_is_the_analytic_gradient():
    rng = np.random.default_rng(44)
    worst = 0.0
    for _ in range(3000):
        par = random_params(rng)
        x, y, _z = point_inside(rng, par, vmax=0.99)
        gx, gy = sag_grad(x, y, *par)
        want = unit([-gx, -gy, 1.0])
        got = np.array(B.normal(*_fsi(table(*par)), 0, x, y, _z, -1))
        worst = max(worst, np.abs(got - want).max())
        assert abs(np.linalg.norm(got) - 1) < 1e-15
    print(f"normal vs analytic gradient: max difference {worst:.2e}")
    assert worst < 1e-12
    # +axis at the vertex, whatever the signs of the curvatures
    for par in ((0.01, -0.02, 0.0, -3.0), (-1.0, -2.0, 1.0, 0.5), (0.5, 0.0, -1.0, 0.0)):
        assert B.normal(*_fsi(table(*par)), 0, 0.0, 0.0, 0.0, -1) == (0.0, 0.0, 1.0)


# ---------------------------------------------------------------------------------------------- 3. optics
@pytest.mark.parametrize("Rx,Ry", [(400.0, 600.0), (-250.0, -90.0), (1e4, 3e3)])
def test_elliptic_paraboloid_focuses_each_section(Rx, Ry):
    """kx = ky = -1: z = x^2/(2 Rx) + y^2/(2 Ry).  A beam along the axis, reflected (d' = d - 2 (d.n) n), passes
    through (0, 0, Rx/2) from the section y = 0 and through (0, 0, Ry/2) from the section x = 0."""
    par = (1 / Rx, 1 / Ry, -1.0, -1.0)
    S = table(*par)
    half = 0.3 * min(abs(Rx), abs(Ry))
    worst = 0.0
    for section, R in (("x", Rx), ("y", Ry)):
        for a in np.linspace(-half, half, 41):
            if a == 0:
                continue
            x, y = (a, 0.0) if section == "x" else (0.0, a)
            o = np.array([x, y, 3 * abs(Rx) + 3 * abs(Ry)])        # far above both foci
            d = np.array([0.0, 0.0, -1.0])
            ts = hits(S, o, d, tmin=0.0)
            assert len(ts) == 1
            p = o + ts[0] * d
            assert abs(p[2] - (p[0] ** 2 / (2 * Rx) + p[1] ** 2 / (2 * Ry))) <= 1e-13 * abs(R)
            n = np.array(B.normal(S.f, S.i, S, 0, *p, -1))
            r = d - 2 * (d @ n) * n
            focus = np.array([0.0, 0.0, R / 2])
            miss = np.linalg.norm(np.cross(focus - p, r))     # distance from the focus to the reflected ray
            worst = max(worst, miss / abs(R))
    print(f"paraboloid Rx={Rx} Ry={Ry}: reflected rays miss their focus by <= {worst:.2e} R")
    assert worst < 1e-9


# ---------------------------------------------------------------------------------------------- 4. leaving
@pytest.mark.parametrize("R", [10.0, -10.0])
def test_leaving_a_cylinder_finds_the_chord_end(R):
    """CURVATURE 1/R 0: the section y = const is the circle x^2 + (z - R)^2 = R^2 (its half through the vertex).
    A ray from one point of it to another, leaving the first, meets the surface at t = 1 (d = P2 - P1), for long
    chords and nearly tangent ones, with any run along the straight y.  The end of a nearly tangent chord is known
    only to the rounding of P1 over the angle between the chord and the surface: that is the tolerance."""
    S = table(1 / R, 0.0, 0.0, 0.0)
    rng = np.random.default_rng(55)
    worst = 0.0
    for _ in range(400):
        th1 = rng.uniform(-1.4, 1.4)
        th2 = th1 + rng.choice([-1, 1]) * 10 ** rng.uniform(-5, 0.2)
        if abs(th2) > 1.45:
            continue
        y1, y2 = rng.normal(size=2) * abs(R)
        P1 = np.array([abs(R) * math.sin(th1), y1, R * (1 - math.cos(th1))])
        P2 = np.array([abs(R) * math.sin(th2), y2, R * (1 - math.cos(th2))])
        d = P2 - P1
        n2 = unit([P2[0], 0.0, P2[2] - R])                      # the circle's normal at P2
        slack = 1e-14 * abs(R) / abs(d @ n2)                  # rounding of P1 (~1e-15 R) over the chord's angle
        tmin = 1e-9 * abs(R) / np.abs(d).max()                # the kernel's self-hit tolerance
        got = hits(S, P1, d, tmin=tmin, leaving=True)
        assert len(got) == 1, (th1, th2, got)
        assert abs(got[0] - 1) <= slack, (th1, th2, got, slack)
        worst = max(worst, abs(got[0] - 1) / slack)
        p = P1 + got[0] * d
        assert abs(p[0] ** 2 + (p[2] - R) ** 2 - R * R) <= 1e-12 * R * R
        # not leaving, the departure point is a root too
        assert min(abs(t) for t in all_roots(P1, d, (1 / R, 0.0, 0.0, 0.0))) <= slack
        # the other way round it goes away from the section's inside: nothing further
        assert hits(S, P1, -d, tmin=tmin, leaving=True) == []
    print(f"cylinder chord ends found to |t - 1| <= {worst:.2f} of the rounding bound")


def test_leaving_a_biconic_skips_only_the_departure():
    rng = np.random.default_rng(66)
    for _ in range(2000):
        par = random_params(rng)
        L = 1.0 / max(abs(par[0]), abs(par[1]))
        P = point_inside(rng, par)
        d = unit(rng.normal(size=3))
        before = all_roots(P, d, par)           # includes ~0, the point itself
        assert min(abs(t) for t in before) < 1e-9 * L
        expect = [t for t in before if abs(t) > 1e-7 * L]
        got = all_roots(P, d, par, leaving=True)
        assert len(got) == len(expect), (par, P, d, got, before)
        for a, b in zip(got, expect):
            assert abs(a - b) <= 1e-9 * (L + abs(b))
        tmin = 1e-9 * max(L, np.abs(P).max())
        two = hits(table(*par), P, d, tmin=tmin, leaving=True)
        want = [t for t in expect if t > tmin][:2]
        assert len(two) == len(want) and all(abs(a - b) <= 1e-9 * (L + abs(b)) for a, b in zip(two, want))


def kernel_pick(S, o, d, tmin, leaving=False):
    """What the trace kernel (trace_kernel._nearest) takes from hit: the first of t1, t2 beyond tmin whose point
    passes the aperture test."""
    t1, t2, _ = B.hit(S.f, S.i, S, 0, *o, *d, tmin, leaving)
    apk, a0, a1 = S.i[0, layout.SI_APK], S.f[0, layout.SF_AP], S.f[0, layout.SF_AP + 1]
    for t in (t1, t2):
        if tmin < t < INF and in_aperture(apk, a0, a1, o[0] + t * d[0], o[1] + t * d[1]):
            return t
    return INF


def test_an_off_axis_segment_hit_from_outside_its_aperture():
    """A ray crossing a strongly curved cylinder section twice, whose nearer crossing lies outside the aperture (an
    off-axis zone): the kernel gets both roots and takes the farther, inside one."""
    R = 10.0
    par = (1 / R, 0.0, 0.0, 0.0)
    th1, th2 = -1.2, 0.9                                   # the chord's ends on the circle x^2 + (z - R)^2 = R^2
    P1 = np.array([R * math.sin(th1), 0.5, R * (1 - math.cos(th1))])
    P2 = np.array([R * math.sin(th2), -0.5, R * (1 - math.cos(th2))])
    d = unit(P2 - P1)
    o = P1 - 3.0 * d                                       # from outside, before P1
    t_far = 3.0 + np.linalg.norm(P2 - P1)
    assert kernel_pick(table(*par), o, d, 0.0) == pytest.approx(3.0, abs=1e-12)
    # an off-axis zone, ANNULUS 3 9: it holds P2 (r = 7.85) but not P1 (r = 9.33)
    ring = table(*par, layout.AP_ANNULUS, 3.0, 9.0)
    assert kernel_pick(ring, o, d, 0.0) == pytest.approx(t_far, abs=1e-12)
    # and the reverse ray: the nearer crossing is inside, the farther one outside
    assert kernel_pick(ring, o + (t_far + 3) * d, -d, 0.0) == pytest.approx(3.0, abs=1e-12)


def test_more_than_two_crossings_prefers_those_in_the_aperture():
    """A non-convex biconic that a ray crosses three times ahead: when the nearer crossings are outside the
    aperture, hit still returns the one inside (the kernel looks at two roots only)."""
    par = (1.0, -0.5188830854900596, -1.8287534909290013, -4.756230428205807)
    o = np.array([-4.403114234013524, 0.19976360044403926, 2.3641690935665856])
    d = np.array([0.17374005455439948, 0.8820660345952854, -0.4846734103640801])
    o = o - 3.0 * d
    roots = [t for t in all_roots(o, d, par) if t > 0]
    assert len(roots) == 3
    rho = [math.hypot(*(o + t * d)[:2]) for t in roots]
    assert max(rho[0], rho[1]) < 0.5 * rho[2]           # the third lies farthest from the axis: a ring takes it alone
    ring = (layout.AP_ANNULUS, 0.5 * (max(rho[0], rho[1]) + rho[2]), 2 * rho[2])
    assert hits(table(*par), o, d, tmin=0.0) == roots[:2]
    assert hits(table(*par, *ring), o, d, tmin=0.0) == [roots[2]]
    assert hits(table(*par, layout.AP_DISK, 1.01 * rho[1]), o, d, tmin=0.0) == roots[:2]


def test_degenerate_rays():
    S = table(0.02, -0.01, 0.5, -2.0)
    assert hits(S, (0, 0, 5), (0, 0, -1)) == [5.0]             # along the axis: the vertex
    for dz in (1.0, -1.0):                                       # leaving the vertex along the axis: nothing more
        assert hits(S, (0, 0, 0), (0, 0, dz), tmin=0.0, leaving=True) == []
    assert hits(S, (1, 2, 3), (0, 0, 0)) == []                 # no direction
    target = np.array([1.0, 2.0, float(sag(1.0, 2.0, 0.02, -0.01, 0.5, -2.0))])
    o = np.array([3e9, -2e9, 5e9])                                # from 6e9 away (1e8 sizes), near the vertex
    t = hits(S, o, target - o, tmin=0.0)
    assert len(t) == 1 and abs(t[0] - 1) < 1e-15


# ---------------------------------------------------------------------------------------------- 5. the language
def _one(text):
    d = diagnose(text)
    assert len(d) == 1, [x.render() for x in d]
    return d[0]


@pytest.mark.parametrize("line,at,msg", [
    ("  BICONIC Z 0 RADIUS 0 100 DISK 5", "0 100", "RADIUS 0 is not a curvature"),
    ("  BICONIC Z 0 RADIUS 100 0 DISK 5", "0 DISK", "RADIUS 0 is not a curvature"),
    ("  BICONIC Z 0 RADIUS 100 50 RECT 40 60", "RECT", "this biconic only exists where it is <= 1"),
    ("  BICONIC Z 0 RADIUS 100 50 CONIC -0.5 3 ELLIPSE 60 30", "ELLIPSE", "this biconic only exists where it is <= 1"),
    ("  BICONIC Z 0 CURVATURE 0.01 0 CONIC 0 0 DISK 101", "DISK", "this biconic only exists where it is <= 1"),
    ("  BICONIC Z 0 RADIUS 1 1 CURVATURE 1 1", "CURVATURE", "give RADIUS or CURVATURE, not both"),
    ("  BICONIC Z 0 CURVATURE 0 0", "CURVATURE", "a BICONIC with both curvatures 0 is flat"),
    ("  BICONIC Z 0 CONIC -1 0 DISK 5", "BICONIC", "BICONIC needs its curvature: RADIUS Rx Ry or CURVATURE cx cy"),
])
def test_bad_biconic_is_refused_where_it_is_wrong(line, at, msg):
    d = _one(f"SURFACE\n{line}\nOBJECT a\n")
    assert msg in d.message and d.hint
    assert (d.span.line, d.span.col) == (2, line.index(at) + 1), d.render()


def test_domain_edge_and_hyperbolic_sections_are_accepted():
    for line in ("BICONIC Z 0 RADIUS 100 50 CONIC 0 0 ELLIPSE 100 50",     # the rim itself
                 "BICONIC Z 0 RADIUS 10 -10 CONIC -3 -1 RECT 500 500",      # no domain limit
                 "BICONIC Z 0 CURVATURE 0.01 0 CONIC 0 0 RECT 100 1e6"):   # a straight section: unlimited along it
        assert diagnose(f"SURFACE\n  {line}\nOBJECT a\n") == []


def _surface(text):
    from irtlang.lang.diagnostics import Source
    from irtlang.lang.interp import Interpreter

    it = Interpreter(check_only=True)
    it.run_source(Source("t.inr", text))
    assert not it.diags.items
    return [o.surfaces[0] for o in it.state.objects.values()]


def test_units_frame_pack_bounds_size():
    s, c = _surface("UNITS MM\nSURFACE\n  BICONIC Z 5 RADIUS -400 -600 CONIC -1 -0.5 RECT 50 30\nOBJECT m\n"
                    "SURFACE\n  BICONIC X 1 CURVATURE 0.01 0 ELLIPSE 20 40\nOBJECT cyl\n")
    assert B.pack(s) == {"par": (-2.5, -1 / 0.6, -1.0, -0.5)}               # 1/m
    assert s.frame.T == (0.0, 0.0, 0.005) and s.aperture.params == (0.05, 0.03)
    assert B.pack(c) == {"par": (10.0, 0.0, 0.0, 0.0)}                      # a bare curvature is per mm
    assert c.frame.R == (0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0)       # X: local x, y = world y, z
    assert B.size(s) == pytest.approx(0.4) and B.size(c) == pytest.approx(0.1)
    # the bounding sphere holds the surface over its aperture (dense sampling, rim included), and is tight
    for surf, (hx, hy), ell in ((s, (0.05, 0.03), False), (c, (0.02, 0.04), True)):
        bx, by, bz, br = B.bounds(surf)
        par = B.pack(surf)["par"]
        x, y = np.meshgrid(np.linspace(-hx, hx, 401), np.linspace(-hy, hy, 401))
        if ell:
            keep = (x / hx) ** 2 + (y / hy) ** 2 <= 1
            x, y = x[keep], y[keep]
        z = sag(x, y, *par)
        dist = np.sqrt((x - bx) ** 2 + (y - by) ** 2 + (z - bz) ** 2)
        assert dist.max() <= br and br < 1.01 * dist.max()
    no_ap, = _surface("SURFACE\n  BICONIC Z 0 RADIUS 10 20\nOBJECT a\n")
    assert B.bounds(no_ap)[3] == INF


def test_the_example_checks():
    assert diagnose(B.EXAMPLE + "\n") == []
