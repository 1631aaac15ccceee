"""Hypothesis fuzzing: random rays (any scale from 1e-9 to 1e12, unnormalised directions, origins on the
surface, grazing and tangent constructions) never produce NaN, and every reported hit lies on its surface."""
import math

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from irtlang.kernels import geometry as G
from irtlang.kernels.optics import fresnel_unpolarized, reflect, refract
from irtlang.kernels.sampling import hg_sample, onb

SETTINGS = settings(max_examples=300, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow])

# components are 0 or of magnitude 1e-12 .. 1 (the scale factor below spans 1e-9 .. 1e12); smaller
# non-zero components only produce hits beyond 1e200, where a squared coordinate overflows the check itself
unit = st.one_of(st.just(0.0), st.floats(1e-12, 1.0), st.floats(-1.0, -1e-12))
vec = st.tuples(unit, unit, unit)
scale_exp = st.integers(-9, 12)
dir_mag = st.sampled_from([1e-3, 1.0, 7.3, 1e3])
conic_k = st.sampled_from([-5.0, -1.4817, -1.0, -0.5, 0.0, 0.7, 3.0])


def _check_pair(t1, t2):
    assert not math.isnan(t1) and not math.isnan(t2)
    assert t1 <= t2


def _ray(o, d, s, mag):
    o = np.array(o) * s * 3.0
    d = np.array(d)
    assume(np.linalg.norm(d) > 1e-3)
    return o, d * mag


curvature = st.one_of(st.just(0.0), st.floats(1e-4, 2.0), st.floats(-2.0, -1e-4))


@SETTINGS
@given(vec, vec, scale_exp, dir_mag, curvature, conic_k, st.booleans())
def test_fuzz_conic(o, d, e, mag, cr, k, with_asph):
    s = 10.0 ** e
    o, d = _ray(o, d, s, mag)
    c = cr / s
    asph = np.array([1e-3 / s ** 3, -1e-4 / s ** 5]) if with_asph else np.zeros(0)
    t1, t2 = G.hit_conic(*o, *d, c, k, asph)
    _check_pair(t1, t2)
    for t in (t1, t2):
        if t == np.inf:
            continue
        p = o + t * d
        scale = np.linalg.norm(o) + abs(t) * np.linalg.norm(d)
        res = G.conic_residual(*p, c, k, asph)
        assert not math.isnan(res)
        assert abs(res) <= 1e-11 * scale, (res, scale)
        n = G.conic_normal(p[0], p[1], c, k, asph)
        assert all(np.isfinite(n)) and abs(np.linalg.norm(n) - 1) < 1e-14


@SETTINGS
@given(st.floats(0.05, 0.95), st.floats(0.0, 2 * math.pi), scale_exp, conic_k, st.floats(0.2, 2.0),
       st.sampled_from([0.0, 1e-9, 1e-6, 1e-3, 0.3]), st.booleans())
def test_fuzz_conic_from_surface_and_grazing(rf, phi, e, k, cr, th, towards):
    """Origin on the sag surface, direction th rad off the tangent plane (th = 0: tangent)."""
    s = 10.0 ** e
    c = cr / s
    rmax = 1.0 / (abs(c) * math.sqrt(1 + k)) if k > -1 else 1.0 / abs(c)
    r = rf * min(rmax, 1.0 / abs(c))
    p = np.array([r * math.cos(phi), r * math.sin(phi), 0.0])
    p[2] = G.conic_sag(r * r, c, k, np.zeros(0))
    n = np.array(G.conic_normal(p[0], p[1], c, k, np.zeros(0)))
    t1x, t1y, t1z, _, _, _ = onb(*n)
    tang = np.array([t1x, t1y, t1z]) * (1 if towards else -1)
    d = math.cos(th) * tang - math.sin(th) * n
    ta, tb = G.hit_conic(*p, *d, c, k, np.zeros(0))
    _check_pair(ta, tb)
    for t in (ta, tb):
        if t < np.inf:
            q = p + t * d
            assert abs(G.conic_residual(*q, c, k, np.zeros(0))) <= 1e-11 * (np.linalg.norm(p) + abs(t))


@SETTINGS
@given(vec, vec, scale_exp, dir_mag, st.floats(0.1, 2.0))
def test_fuzz_sphere(o, d, e, mag, rr):
    s = 10.0 ** e
    o, d = _ray(o, d, s, mag)
    R = rr * s
    t1, t2 = G.hit_sphere(*o, *d, R)
    _check_pair(t1, t2)
    for t in (t1, t2):
        if t < np.inf:
            p = o + t * d
            scale = np.linalg.norm(o) + abs(t) * np.linalg.norm(d) + R
            assert abs(np.linalg.norm(p) - R) <= 1e-13 * scale


@SETTINGS
@given(vec, vec, scale_exp, dir_mag, st.tuples(*[st.floats(0.05, 3.0)] * 3))
def test_fuzz_ellipsoid(o, d, e, mag, axes):
    s = 10.0 ** e
    o, d = _ray(o, d, s, mag)
    a, b, c = (x * s for x in axes)
    t1, t2 = G.hit_ellipsoid(*o, *d, a, b, c)
    _check_pair(t1, t2)
    for t in (t1, t2):
        if t < np.inf:
            p = o + t * d
            g = np.array([p[0] / a, p[1] / b, p[2] / c])
            scale = (np.linalg.norm(o) + abs(t) * np.linalg.norm(d)) / min(a, b, c) + 1
            assert abs(np.linalg.norm(g) - 1) <= 1e-13 * scale
            assert all(np.isfinite(G.ellipsoid_normal(*p, a, b, c)))


@SETTINGS
@given(vec, vec, scale_exp, dir_mag, st.floats(-1.0, 1.0), st.floats(0.0, 1.5), st.floats(0.1, 2.0),
       st.floats(0.0, 1.5))
def test_fuzz_tube(o, d, e, mag, z1, r1, dz, r2):
    assume(max(r1, r2) >= 0.05)  # a zero-radius tube is a line: every hit is a tangency
    s = 10.0 ** e
    o, d = _ray(o, d, s, mag)
    z1, r1, z2, r2 = z1 * s, r1 * s, (z1 + dz) * s, r2 * s
    t1, t2 = G.hit_tube(*o, *d, z1, r1, z2, r2)
    _check_pair(t1, t2)
    sl = (r2 - r1) / (z2 - z1)
    # a ray through a cone's apex (r = 0 at z1 or z2) meets it in a double root at a singular point, where
    # the position along the ray is only known to ~sqrt(eps) (as for any double root) and, unlike at a
    # smooth tangency, the distance to the surface is first order in that error
    apex_tol = 1e-12
    if sl != 0.0:
        za = z1 - r1 / sl
        if z1 - 1e-6 * s <= za <= z2 + 1e-6 * s:
            ap = np.array([0.0, 0.0, za])
            dist = np.linalg.norm(np.cross(ap - o, d)) / np.linalg.norm(d)
            if dist < 1e-6 * (np.linalg.norm(o) + s):
                apex_tol = 3e-8
    for t in (t1, t2):
        if t < np.inf:
            p = o + t * d
            scale = np.linalg.norm(o) + abs(t) * np.linalg.norm(d) + abs(z1) + abs(z2) + r1 + r2
            assert z1 - 1e-15 * scale <= p[2] <= z2 + 1e-15 * scale
            rz = r1 + sl * (p[2] - z1)
            assert abs(math.hypot(p[0], p[1]) - rz) <= apex_tol * scale * (1 + abs(sl))
            assert all(np.isfinite(G.tube_normal(*p, z1, r1, z2, r2)))


@SETTINGS
@given(vec, vec, scale_exp, dir_mag)
def test_fuzz_plane_and_apertures(o, d, e, mag):
    s = 10.0 ** e
    o, d = _ray(o, d, s, mag)
    t1, t2 = G.hit_plane(*o, *d)
    _check_pair(t1, t2)
    if t1 < np.inf:
        z = o[2] + t1 * d[2]
        assert abs(z) <= 1e-15 * (abs(o[2]) + abs(t1 * d[2]))
    x, y = o[0], o[1]
    for f, args in [(G.in_rect, (s, 2 * s)), (G.in_disk, (s,)), (G.in_annulus, (0.5 * s, s)),
                    (G.in_ellipse, (s, 0.5 * s))]:
        assert f(x, y, *args) in (True, False)


@SETTINGS
@given(vec, vec, st.floats(1.0, 3.0), st.floats(1.0, 3.0))
def test_fuzz_interface_optics(d, n, n1, n2):
    d = np.array(d)
    n = np.array(n)
    assume(np.linalg.norm(d) > 1e-6 and np.linalg.norm(n) > 1e-6)
    tx, ty, tz, tir = refract(*d, *n, n1, n2)
    assert all(np.isfinite([tx, ty, tz])) and abs(math.sqrt(tx * tx + ty * ty + tz * tz) - 1) < 1e-14
    r = reflect(*d, *n)
    assert all(np.isfinite(r))
    cos_i = abs(np.dot(d, n)) / (np.linalg.norm(d) * np.linalg.norm(n))
    R = fresnel_unpolarized(cos_i, n1, n2)
    assert 0.0 <= R <= 1.0


@SETTINGS
@given(st.floats(0.0, 1.0), st.floats(-1.0, 1.0))
def test_fuzz_hg(u, g):
    mu = hg_sample(u, g)
    assert -1.0 <= mu <= 1.0
