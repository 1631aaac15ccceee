"""Triangle-mesh BVH: icosphere vs the analytic sphere, watertightness at vertices and edges, O(log n)."""
import math
import time

import numba
import numpy as np
import pytest
import trimesh

from irtlang.kernels import bvh as B
from irtlang.kernels.geometry import hit_sphere


@pytest.fixture(scope="module")
def ico6():
    m = trimesh.creation.icosphere(subdivisions=6, radius=1.0)  # 81,920 faces
    arrays = B.build_bvh(m.vertices, m.faces)
    return m, arrays


def _unit(v):
    return v / np.linalg.norm(v)


def _sagitta_depth(m):
    """max over faces of R - (distance of the face plane from the centre): the mesh lies in that shell."""
    v0 = m.vertices[m.faces[:, 0]]
    n = np.cross(m.vertices[m.faces[:, 1]] - v0, m.vertices[m.faces[:, 2]] - v0)
    n /= np.linalg.norm(n, axis=1)[:, None]
    d = np.abs(np.einsum("ij,ij->i", n, v0))
    return 1.0 - d.min()


@numba.njit(cache=True)
def _trace_many(o, d, arrays6_0, arrays6_1, arrays6_2, arrays6_3, arrays6_4, arrays6_5):
    n = o.shape[0]
    t = np.empty(n)
    f = np.empty(n, np.int64)
    uv = np.empty((n, 2))
    visits = np.empty(n, np.int64)
    for i in range(n):
        t[i], f[i], uv[i, 0], uv[i, 1], visits[i] = B.hit_mesh_count(
            o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2], 0.0,
            arrays6_0, arrays6_1, arrays6_2, arrays6_3, arrays6_4, arrays6_5)
    return t, f, uv, visits


def test_icosphere_vs_sphere(ico6):
    m, arrays = ico6
    assert len(m.faces) == 81920
    depth = _sagitta_depth(m)  # ~ l^2 / (8 R), l the edge length
    assert 1e-5 < depth < 1e-4
    rng = np.random.default_rng(0)
    n = 3000
    o = np.empty((n, 3))
    d = np.empty((n, 3))
    b = np.empty(n)
    for i in range(n):
        u = _unit(rng.normal(size=3))
        o[i] = 4.0 * u
        # aim at impact parameter b <= 0.9
        w = _unit(np.cross(u, rng.normal(size=3)))
        b[i] = 0.9 * math.sqrt(rng.uniform())
        d[i] = (b[i] * w - o[i]) * rng.uniform(0.5, 2.0)
    t, f, uv, _ = _trace_many(o, d, *arrays[:6])
    assert np.all(np.isfinite(t)) and np.all(f >= 0)
    rmin = 1.0 - depth
    for i in range(n):
        ts, _ = hit_sphere(*o[i], *d[i], 1.0)
        dn = np.linalg.norm(d[i])
        # the mesh lies inside the sphere and outside radius rmin: along this ray it is hit between the
        # sphere and the shell's inner radius
        gap_max = (math.sqrt(1 - b[i] ** 2) - math.sqrt(rmin ** 2 - b[i] ** 2)) / dn
        assert -1e-12 <= t[i] - ts <= gap_max + 1e-12
        # the barycentric point is the ray point, and the face normal is outward
        p = o[i] + t[i] * d[i]
        tri = m.vertices[m.faces[f[i]]]
        q = (1 - uv[i, 0] - uv[i, 1]) * tri[0] + uv[i, 0] * tri[1] + uv[i, 1] * tri[2]
        assert np.allclose(p, q, atol=1e-13)
        assert uv[i].min() >= 0 and uv[i].sum() <= 1
        nrm = np.array(B.mesh_normal(f[i], arrays[6]))
        assert np.dot(nrm, p) > 0.99
    # misses: rays that pass outside the sphere
    t2, f2, _, _ = B.hit_mesh(2.0, 0.0, -5.0, 0.0, 0.0, 1.0, 0.0, *arrays[:6])
    assert t2 == np.inf and f2 == -1


def test_build_time_100k():
    m = trimesh.creation.icosphere(subdivisions=7)  # 327,680 faces
    B.build_bvh(m.vertices[:3], np.array([[0, 1, 2]]))  # compile outside the timing
    sub = trimesh.creation.icosphere(subdivisions=6)
    # ~100k: the 81,920-face sphere plus a displaced copy of part of it
    v = np.vstack([sub.vertices, sub.vertices[:, ::-1] * 0.5 + 3.0])
    f = np.vstack([sub.faces, sub.faces[:20000] + len(sub.vertices)])
    t0 = time.perf_counter()
    B.build_bvh(v, f)
    assert time.perf_counter() - t0 < 3.0
    t0 = time.perf_counter()
    B.build_bvh(m.vertices, m.faces)
    assert time.perf_counter() - t0 < 3.0 * 327680 / 100000


def test_visits_grow_logarithmically():
    rng = np.random.default_rng(5)
    n = 2000
    o = np.empty((n, 3))
    d = np.empty((n, 3))
    for i in range(n):
        u = _unit(rng.normal(size=3))
        o[i] = 5 * u
        d[i] = 0.5 * _unit(rng.normal(size=3)) * rng.uniform() - o[i]  # targets inside: every ray hits
    sizes = []
    visits = []
    for sub in (3, 4, 5, 6):  # 1,280 .. 81,920 faces
        m = trimesh.creation.icosphere(subdivisions=sub)
        arrays = B.build_bvh(m.vertices, m.faces)
        t, _, _, v = _trace_many(o, d, *arrays[:6])
        assert np.all(np.isfinite(t))
        sizes.append(len(m.faces))
        visits.append(v.mean())
    sizes = np.array(sizes, float)
    visits = np.array(visits)
    # 64x more triangles: a linear scan would visit 64x more, sqrt(n) 8x; log n about log2(81920)/log2(1280)
    ratio = visits[-1] / visits[0]
    assert ratio < math.log(sizes[-1]) / math.log(sizes[0]), (visits, ratio)
    # per factor of 10 in triangles, far less than 10x: fitted exponent of visits ~ n^a
    a = np.polyfit(np.log(sizes), np.log(visits), 1)[0]
    assert a < 0.2, a
    # and the increments per 4x are roughly constant (logarithmic), not growing
    inc = np.diff(visits)
    assert inc.max() < 2.0 * inc.min() + 1.0


def _icosphere_edges(m):
    e = np.sort(m.edges_unique, axis=1)
    return e


def test_rays_through_vertices_and_edges_hit_exactly_once(ico6):
    """A closed convex mesh: every ray from outside through it crosses exactly twice (in, out).

    Counted by brute force over all 81,920 triangles and by the BVH's all-crossings traversal. Rays are
    aimed exactly at vertices and at points on edges (midpoints and random points), including axis-aligned
    rays whose projected vertex coordinates are exactly zero.
    """
    m, arrays = ico6
    tris = arrays[4]
    rng = np.random.default_rng(9)
    verts = m.vertices
    edges = _icosphere_edges(m)
    rays = []
    # axis-aligned rays through vertices (exact zeros in the watertight test)
    for vi in rng.choice(len(verts), 40, replace=False):
        v = verts[vi]
        for axis in range(3):
            if abs(v[axis]) < 0.3:
                continue  # the axis-aligned line through v would (nearly) graze the sphere at v
            d = np.zeros(3)
            d[axis] = 1.0 if rng.uniform() < 0.5 else -1.0
            o = v.copy()
            o[axis] = -3.0 * d[axis]
            rays.append((o, d))
    # random directions within 60 deg of the inward normal, through vertices
    for vi in rng.choice(len(verts), 60, replace=False):
        v = verts[vi]
        while True:
            d = _unit(-v + 0.9 * rng.normal(size=3))
            if np.dot(d, -_unit(v)) > 0.5:
                break
        rays.append((v - 3.0 * d, d))
    # edges: midpoints (axis-aligned and oblique) and random points along them
    for ei in rng.choice(len(edges), 80, replace=False):
        a, b = verts[edges[ei, 0]], verts[edges[ei, 1]]
        for s in (0.5, rng.uniform()):
            p = a + s * (b - a)
            d = _unit(-p + 0.5 * rng.normal(size=3))
            if np.dot(d, -_unit(p)) < 0.5:
                d = -_unit(p)
            rays.append((p - 3.0 * d, d))
        p = 0.5 * (a + b)
        axis = int(np.argmax(np.abs(p)))
        d = np.zeros(3)
        d[axis] = -np.sign(p[axis])
        o = p.copy()
        o[axis] = p[axis] - 3.0 * d[axis]
        rays.append((o, d))
    n_bad_bvh = 0
    n_bad_brute = 0
    for o, d in rays:
        nb = B.brute_force_crossings(*o, *d, 0.0, np.inf, tris)
        nv = B.mesh_crossings(*o, *d, 0.0, np.inf, *arrays[:6])
        t, f, u, v = B.hit_mesh(*o, *d, 0.0, *arrays[:6])
        assert np.isfinite(t) and f >= 0 and np.isfinite(u) and np.isfinite(v)
        n_bad_brute += nb != 2
        n_bad_bvh += nv != 2
        # nearest hit, then the exit from just beyond it
        t2, f2, _, _ = B.hit_mesh(*o, *d, t * (1 + 1e-12), *arrays[:6])
        assert np.isfinite(t2) and t2 > t
    assert len(rays) > 350
    assert n_bad_brute == 0 and n_bad_bvh == 0


def test_shared_edges_and_fan_vertex_exactly_once():
    """Planar fan of 6 triangles around a centre vertex, with mixed winding: any ray through the fan's
    interior (vertex, spokes, generic points) hits exactly one triangle."""
    ang = np.linspace(0, 2 * math.pi, 7)[:-1]
    ring = np.stack([np.cos(ang), np.sin(ang), np.zeros(6)], axis=1)
    verts = np.vstack([[0.0, 0.0, 0.0], ring])
    faces = np.array([[0, 1 + i, 1 + (i + 1) % 6] for i in range(6)])
    faces[1] = faces[1][[0, 2, 1]]  # one face wound the other way
    faces[4] = faces[4][[1, 0, 2]]
    arrays = B.build_bvh(verts, faces, leaf_size=1)
    tris = arrays[4]
    rng = np.random.default_rng(2)
    targets = [np.zeros(3)] + [0.5 * ring[i] for i in range(6)] + [ring[i] * rng.uniform() for i in range(6)]
    targets += [np.array([*rng.uniform(-0.4, 0.4, 2), 0.0]) for _ in range(50)]
    dirs = [np.array([0.0, 0.0, -1.0]), np.array([0.0, 0.0, 1.0])]
    dirs += [_unit(np.array([*rng.normal(size=2) * 0.7, -1.0])) for _ in range(20)]
    for p in targets:
        for d in dirs:
            o = p - 2.0 * d
            assert B.brute_force_crossings(*o, *d, 0.0, np.inf, tris) == 1, (p, d)
            assert B.mesh_crossings(*o, *d, 0.0, np.inf, *arrays[:6]) == 1
            t, f, _, _ = B.hit_mesh(*o, *d, 0.0, *arrays[:6])
            assert t == pytest.approx(2.0, rel=1e-14)


def test_ray_triangle_basics():
    v0 = np.array([0.0, 0.0, 0.0])
    v1 = np.array([1.0, 0.0, 0.0])
    v2 = np.array([0.0, 1.0, 0.0])
    t, u, v = B.ray_triangle(0.2, 0.3, 1.0, 0.0, 0.0, -2.0, v0, v1, v2, 0.0, np.inf)
    assert (t, u, v) == pytest.approx((0.5, 0.2, 0.3), rel=1e-15)
    # back side: two-sided
    t, u, v = B.ray_triangle(0.2, 0.3, -1.0, 0.0, 0.0, 1.0, v0, v1, v2, 0.0, np.inf)
    assert t == pytest.approx(1.0)
    # outside, parallel, degenerate direction, tmin / tmax windows
    assert B.ray_triangle(0.8, 0.3, 1.0, 0.0, 0.0, -1.0, v0, v1, v2, 0.0, np.inf)[0] == np.inf
    assert B.ray_triangle(0.2, 0.3, 0.0, 1.0, 0.0, 0.0, v0, v1, v2, -np.inf, np.inf)[0] == np.inf
    assert B.ray_triangle(0.2, 0.3, 1.0, 0.0, 0.0, 0.0, v0, v1, v2, 0.0, np.inf)[0] == np.inf
    assert B.ray_triangle(0.2, 0.3, 1.0, 0.0, 0.0, -1.0, v0, v1, v2, 1.0, np.inf)[0] == np.inf
    assert B.ray_triangle(0.2, 0.3, 1.0, 0.0, 0.0, -1.0, v0, v1, v2, 0.0, 0.5)[0] == np.inf
    # grazing 1e-9 rad onto the triangle's plane and huge / tiny scales
    th = 1e-9
    t, u, v = B.ray_triangle(-1.0, 0.3, math.sin(th) * 1.2, math.cos(th), 0.0, -math.sin(th), v0, v1, v2,
                             0.0, np.inf)
    assert t == pytest.approx(1.2, rel=1e-6)
    for s in (1e-9, 1e12):
        t, u, v = B.ray_triangle(0.2 * s, 0.3 * s, s, 0.0, 0.0, -1.0, v0 * s, v1 * s, v2 * s, 0.0, np.inf)
        assert t == pytest.approx(s, rel=1e-15) and (u, v) == pytest.approx((0.2, 0.3), rel=1e-14)


def test_normals_orientation():
    m = trimesh.creation.icosphere(subdivisions=2)
    cen = m.triangles_center
    for faces in (m.faces, m.faces[:, ::-1]):  # outward and inward winding: normals come out outward
        arrays = B.build_bvh(m.vertices, faces)
        fn = arrays[6]
        assert np.all(np.einsum("ij,ij->i", fn, cen) > 0)
        assert np.allclose(np.linalg.norm(fn, axis=1), 1.0, atol=1e-15)
    # an open mesh keeps its winding
    verts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    fn = B.build_bvh(verts, np.array([[0, 2, 1]]))[6]
    assert np.allclose(fn[0], [0, 0, -1])


def test_mesh_inside_parity_and_degenerate_meshes():
    m = trimesh.creation.box(extents=(2.0, 2.0, 2.0))  # axis-aligned: rays along its faces' planes
    arrays = B.build_bvh(m.vertices, m.faces)
    rng = np.random.default_rng(4)
    for _ in range(200):
        p = rng.uniform(-1.5, 1.5, 3)
        d = rng.normal(size=3)
        inside = np.all(np.abs(p) < 1.0)
        n = B.mesh_crossings(*p, *d, 0.0, np.inf, *arrays[:6])
        assert (n % 2 == 1) == inside
    # axis-aligned rays exactly through the box's corner and along an edge line: no NaN, no leak
    t, f, u, v = B.hit_mesh(1.0, 1.0, -5.0, 0.0, 0.0, 1.0, 0.0, *arrays[:6])
    assert not math.isnan(t)
    t, f, u, v = B.hit_mesh(0.0, 0.0, -5.0, 0.0, 0.0, 1.0, 0.0, *arrays[:6])
    assert t == 4.0
    # empty and single-triangle meshes
    arrays = B.build_bvh(np.zeros((0, 3)), np.zeros((0, 3), int))
    assert B.hit_mesh(0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, *arrays[:6])[0] == np.inf
    # many identical triangles (all centroids equal)
    verts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    arrays = B.build_bvh(verts, np.tile([0, 1, 2], (100, 1)))
    assert B.mesh_crossings(0.2, 0.2, 1.0, 0.0, 0.0, -1.0, 0.0, np.inf, *arrays[:6]) == 100
