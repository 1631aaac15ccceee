"""A MESH sphere (trimesh icosphere, 5 subdivisions: 20480 faces) against the analytic SPHERE, through the
tracer, ray by ray: the same lattice of rays lights a mirror ball made either way.

Bounds come from the mesh itself: its vertices lie on the sphere of radius r and every face is at least
r_in from the centre, so a ray that meets the sphere at incidence angle a meets the mesh within
(r - r_in) / cos(a') of it along the ray (a' the incidence angle on the inner sphere r_in); a face's normal is
within delta of the true normal at any of its points, delta = the largest angle between a face normal and the
directions of its corners, so a reflected direction differs by at most 2 (delta + gap / r).
An analytic oracle on top: a specular sphere lit by a collimated beam reflects uniformly in solid angle, so
the z-component of the reflected directions is uniform on [-1, 1]."""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import INC, REF, binomial_sigma, ledger_gap, row, trace_text  # noqa: E402

R_MM = 10.0
NSIDE = 121
SUBDIV = 5


def _scene(surface: str, catcher: bool) -> str:
    cat = "SURFACE\n  SPHERE 0 0 0 200\nOBJECT dome\n  INTERFACE ABSORB\n" if catcher else ""
    return f"""SYSTEM NEW
UNITS MM
WAVELENGTHS 550 NM
SEED 4
SURFACE
  {surface}
OBJECT ball
  INTERFACE REFLECT
{cat}LEVEL 10
HALT 0
GRID RECT Z 50 -12 12 -12 12 {NSIDE} {NSIDE}
SOURCE DIRECTION 0 0 -1
FLUX TOTAL 1 W
TRACE
"""


@pytest.fixture(scope="module")
def mesh_file(tmp_path_factory):
    trimesh = pytest.importorskip("trimesh")
    m = trimesh.creation.icosphere(subdivisions=SUBDIV, radius=R_MM)
    p = tmp_path_factory.mktemp("mesh") / "ball.stl"
    m.export(str(p))
    # the bounds, from the mesh as written
    m = trimesh.load(str(p), force="mesh")
    v = m.vertices
    r_in = float(np.min(np.abs(np.einsum("ij,ij->i", m.face_normals, m.triangles_center))))
    corners = m.vertices[m.faces] / np.linalg.norm(m.vertices[m.faces], axis=2)[:, :, None]
    cosd = np.einsum("fj,fkj->fk", m.face_normals, corners)
    delta = float(np.arccos(np.clip(cosd.min(), -1, 1)))
    assert np.allclose(np.linalg.norm(v, axis=1), R_MM, rtol=1e-6)
    return p, r_in, delta


@pytest.fixture(scope="module")
def traced(mesh_file, tmp_path_factory):
    path, r_in, delta = mesh_file
    d = tmp_path_factory.mktemp("meshrun")
    out = {}
    for cat in (False, True):
        (d / "ball.stl").write_bytes(path.read_bytes())
        out[("sphere", cat)] = trace_text(d, _scene("SPHERE 0 0 0 10", cat), name=f"s{cat}.inr")
        out[("mesh", cat)] = trace_text(d, _scene("MESH 'ball.stl'", cat), name=f"m{cat}.inr")
    return out, r_in, delta


def _lattice():
    g = (np.arange(NSIDE) + 0.5) / NSIDE * 24.0 - 12.0
    X, Y = np.meshgrid(g, g)
    return np.column_stack([X.ravel(), Y.ravel()])


def test_hit_points_within_the_sagitta(traced):
    res, r_in, delta = traced
    s, m = res[("sphere", False)], res[("mesh", False)]
    rs, rm = s.records, m.records
    assert len(rs["flux"]) == len(rm["flux"]) == NSIDE * NSIDE     # one record per ray, in ray order
    hit_s = rs["object"] == 0
    hit_m = rm["object"] == 0
    xy = _lattice()
    rho = np.hypot(xy[:, 0], xy[:, 1])
    # the records' start points are the lattice (rays that missed end where they started)
    miss = ~hit_s
    assert np.allclose(rs["position"][miss, :2] * 1e3, xy[miss], atol=1e-9)
    # inside the inner sphere's shadow both are hit, outside the sphere's neither
    assert np.all(hit_s[rho < r_in] & hit_m[rho < r_in])
    assert not np.any(hit_s[rho > R_MM] | hit_m[rho > R_MM])
    both = hit_s & hit_m & (rho < 0.9 * r_in)
    gap = R_MM - r_in
    cos_inner = np.sqrt(1.0 - (rho[both] / r_in) ** 2)
    dist = np.linalg.norm(rs["position"][both] - rm["position"][both], axis=1) * 1e3
    assert np.all(dist <= gap / cos_inner * (1 + 1e-9) + 1e-9), (dist.max(), gap)
    # the sphere's hit points are on the sphere
    assert np.allclose(np.linalg.norm(rs["position"][hit_s], axis=1) * 1e3, R_MM, rtol=0, atol=1e-12)
    # the intercepted flux: lattice points inside the silhouette (between pi r_in^2 and pi r^2)
    n = NSIDE * NSIDE
    assert row(s, "ball")[INC] == pytest.approx((rho <= R_MM).sum() / n, rel=1e-12)
    assert (rho <= r_in).sum() / n <= row(m, "ball")[INC] <= (rho <= R_MM).sum() / n + 1e-12
    for r in (s, m):
        assert row(r, "ball")[REF] == pytest.approx(row(r, "ball")[INC], rel=1e-13)
        assert ledger_gap(r) < 1e-12


def test_reflected_directions(traced):
    res, r_in, delta = traced
    s, m = res[("sphere", True)], res[("mesh", True)]
    rs, rm = s.records, m.records
    on_s = (rs["object"] == 1) & (rs["events"] == 2)         # ended on the dome after one reflection
    on_m = (rm["object"] == 1) & (rm["events"] == 2)
    xy = _lattice()
    rho = np.hypot(xy[:, 0], xy[:, 1])
    both = on_s & on_m & (rho < 0.9 * r_in)
    cos_inner = np.sqrt(1.0 - (rho[both] / r_in) ** 2)
    gap = (R_MM - r_in) / cos_inner
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", rs["direction"][both], rm["direction"][both]), -1, 1))
    assert np.all(ang <= 2 * (delta + gap / r_in) + 1e-12), (ang.max(), delta)
    # the analytic sphere: reflected z-component uniform on [-1, 1] for rays uniform over the disk.  On the
    # lattice the four quarters of [-1, 1] hold shares of about 1/4 each; multinomial sigma sqrt(p (1-p)/n)
    # per bin, 5 sigma, plus the lattice's own departure from uniform (area error of the circle's edge
    # cells, about perimeter x cell / area = 2 h / r = 0.04): bins are compared between sphere and mesh
    # instead, which share the lattice: their difference is only the facets'.
    for r, on in ((rs, on_s), (rm, on_m)):
        dz = r["direction"][on, 2]
        n = on.sum()
        for lo in (-1.0, -0.5, 0.0, 0.5):
            share = ((dz >= lo) & (dz < lo + 0.5)).sum() / n
            assert abs(share - 0.25) <= 5 * binomial_sigma(0.25, n) + 2 * 24.0 / NSIDE / R_MM, (lo, share)
    hs = np.histogram(rs["direction"][on_s, 2], bins=8, range=(-1, 1))[0] / on_s.sum()
    hm = np.histogram(rm["direction"][on_m, 2], bins=8, range=(-1, 1))[0] / on_m.sum()
    assert np.max(np.abs(hs - hm)) < 0.01
