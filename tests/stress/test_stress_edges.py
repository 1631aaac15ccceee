"""Stress: rays through mesh vertices and edges, aperture rims, and rays that start exactly on a surface
(docs/tracer.md, "Stress tests").  Besides the common invariants (tests/stress/_stress_util.py):
* a closed mirror mesh is watertight: a ray aimed exactly at one of its vertices or at a point of one of its
  edges (where two or more triangles meet) is reflected exactly once, never slips through a crack;
* a ray that starts on a vertex of a closed mirror mesh and goes inward stays trapped inside it;
* aperture rims are part of the aperture: a ray that meets a RECT corner, a DISK or ANNULUS rim exactly
  lands on that object.
"""
import numpy as np
import pytest
from _stress_util import DATA, check_run, head, hits_per_source, outputs, ray, records

ICO = DATA / "icosphere_r10.stl"


def _mesh(path):
    trimesh = pytest.importorskip("trimesh")
    return trimesh.load(str(path), force="mesh")


def _box(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    p = tmp_path / "box.stl"
    trimesh.creation.box(extents=(2.0, 2.0, 2.0)).export(str(p))
    return p


def _aim_points(m, min_nz=0.3):
    """Vertices and edge points of the faces that a ray going down (-z) meets from outside: vertices whose
    faces all face up, and points at 1/4, 1/2, 3/4 of each edge between two such faces."""
    fn = m.face_normals
    verts = [m.vertices[i] for i in range(len(m.vertices))
             if all(fn[f][2] > min_nz for f in m.vertex_faces[i] if f >= 0)]
    edges = []
    for (f1, f2), (a, b) in zip(m.face_adjacency, m.face_adjacency_edges):
        if fn[f1][2] > min_nz and fn[f2][2] > min_nz:
            for t in (0.25, 0.5, 0.75):
                edges.append(m.vertices[a] + t * (m.vertices[b] - m.vertices[a]))
    return verts, edges


def _mesh_scene(path, rays, extra=""):
    return head() + f"""SURFACE
  MESH '{path}'
OBJECT ball
  INTERFACE REFLECT
SURFACE
  SPHERE 0 0 0 1000
OBJECT dome
{extra}{rays}TRACE
""" + outputs()


@pytest.mark.parametrize("mesh", ["icosphere", "box"])
def test_rays_through_mesh_vertices_and_edges(runner, tmp_path, mesh):
    path = ICO if mesh == "icosphere" else _box(tmp_path)
    m = _mesh(path)
    verts, edges = _aim_points(m)
    assert len(edges) >= 3 and (mesh == "box" or len(verts) > 10)   # a box's top has no vertex of its own
    for what, pts in (("vertices", verts), ("edges", edges)):
        if not pts:
            continue
        rays = "".join(ray((p[0], p[1], 50.0), (0, 0, -1)) for p in pts)
        r = check_run(runner.run(tmp_path / what, _mesh_scene(path, rays), f"{mesh}_{what}"))
        hits = hits_per_source(records(r), "ball")
        assert np.all(hits == 1), f"{mesh} {what}: {int((hits == 0).sum())} rays slipped through"
        assert r.row("ball")[0] == pytest.approx(r.row("EMITTED")[0], rel=1e-12)


def test_box_rims_and_diagonals(runner, tmp_path):
    """A trimesh box: rays down its face diagonals (the shared edge of a face's two triangles), along its
    top edges and down its vertical edges (in the plane of two faces at once), and exactly at its corners."""
    path = _box(tmp_path)
    rays = ""
    for t in (-0.75, -0.25, 0.0, 0.5, 0.9):
        rays += ray((t, t, 5), (0, 0, -1)) + ray((t, -t, 5), (0, 0, -1))      # face diagonals
        rays += ray((1, t, 5), (0, 0, -1)) + ray((t, -1, 5), (0, 0, -1))      # top edges / side faces
        rays += ray((5, t, 1), (-1, 0, 0)) + ray((t, 5, -1), (0, -1, 0))      # edges from the side
    for x in (-1, 1):
        for y in (-1, 1):
            rays += ray((x, y, 5), (0, 0, -1)) + ray((x * 5, y * 5, 5), (-x, -y, -1))   # corners
    r = check_run(runner.run(tmp_path, _mesh_scene(path, rays), "box_rims"))
    rec = records(r)
    assert np.all(hits_per_source(rec, "ball") <= 2)


@pytest.mark.parametrize("mesh", ["icosphere", "box"])
def test_start_on_mesh_vertices(runner, tmp_path, mesh):
    """From every vertex, one ray outward (it must not hit the mesh it starts on) and one inward, toward a
    generic inner point (trapped in the closed mirror until LEVEL; not through the opposite vertex: a ray that
    meets a box exactly at a corner has no defined reflection)."""
    path = ICO if mesh == "icosphere" else _box(tmp_path)
    V = _mesh(path).vertices
    p0 = 0.1 * np.abs(V).max() * np.array([0.31, 0.17, -0.23])
    rays = "".join(ray(v, v) for v in V) + "".join(ray(v, p0 - v) for v in V)
    level = 200
    r = check_run(runner.run(tmp_path, _mesh_scene(path, rays, extra=f"LEVEL {level}\nHALT 0\n"), mesh))
    rec = records(r)
    outward = rec["source"] < len(V)
    assert np.all(hits_per_source(rec, "ball")[outward] == 0)
    assert np.all(rec["events"][~outward] == level)
    assert np.all(hits_per_source(rec, "dome")[~outward] == 0)
    n = len(V)
    assert r.row("dome")[0] == pytest.approx(n, rel=1e-12)          # 1 W per source
    assert r.row("HALTED")[4] == pytest.approx(n, rel=1e-12)


def test_aperture_rims(runner, tmp_path):
    """Rays exactly at RECT corners and edges, DISK, ANNULUS (inner and outer) and ELLIPSE rims, and at the
    rim of a hemispherical CONIC whose aperture is its whole domain (the surface is vertical there).  The
    apertures are clear (COATING clear TRANSMIT 1), so each ray meets every rim on its line."""
    rays = ""
    rim = [(5, 3), (-5, 3), (5, -3), (-5, -3), (5, 0), (0, 3), (-5, 1.5)]
    for x, y in rim:
        rays += ray((x, y, -10), (0, 0, 1))
    # points exactly on the circles r = 5 and r = 2.5 (x^2 + y^2 = r^2 exactly in binary)
    circ = [(5, 0), (0, 5), (-5, 0), (0, -5), (3, 4), (-4, 3), (4, -3),
            (2.5, 0), (0, -2.5), (1.5, 2), (-2, 1.5), (-1.5, -2)]
    for x, y in circ:
        rays += ray((x, y, -10), (0, 0, 1))
    ell = [(4, 0), (-4, 0), (0, 2), (0, -2)]
    for x, y in ell:
        rays += ray((x, y, -10), (0, 0, 1))
    text = head() + f"""COATING clear TRANSMIT 1
SURFACE
  PLANE Z 0 RECT 5 3
OBJECT rect
  INTERFACE COATING clear AIR AIR
  DETECTOR PIXELS 10 6
SURFACE
  PLANE Z 2 DISK 5
OBJECT disk
  INTERFACE COATING clear AIR AIR
  DETECTOR PIXELS 8 8
SURFACE
  PLANE Z 4 ANNULUS 2.5 5
OBJECT ann
  INTERFACE COATING clear AIR AIR
  DETECTOR PIXELS 8 8
SURFACE
  PLANE Z 6 ELLIPSE 4 2
OBJECT ell
  INTERFACE COATING clear AIR AIR
  DETECTOR PIXELS 8 4
SURFACE
  CONIC Z 10 RADIUS 4 DISK 4
OBJECT cup
  INTERFACE COATING clear AIR AIR
SURFACE
  PLANE Z 20 RECT 5 3
OBJECT turned
  INTERFACE COATING clear AIR AIR
  ROTATE Z 90 ABOUT 0 0 20
  DETECTOR PIXELS 6 10
SURFACE
  SPHERE 0 0 0 1000
OBJECT dome
{rays}TRACE
""" + outputs("rect", "disk", "ann", "ell", "turned")
    r = check_run(runner.run(tmp_path, text, "rims"))
    rec = records(r)
    src = rec["source"]
    nr, nc = len(rim), len(circ)
    assert np.all(hits_per_source(rec, "rect")[src < nr] == 1)
    on_circ = (src >= nr) & (src < nr + nc)
    assert np.all(hits_per_source(rec, "disk")[on_circ] == 1)
    assert np.all(hits_per_source(rec, "ann")[on_circ] == 1)
    assert np.all(hits_per_source(rec, "ell")[src >= nr + nc] == 1)
    # the detectors' images hold exactly the flux of the rays that met them
    for d in ("rect", "disk", "ann", "ell", "turned"):
        img = np.load(r.folder / f"img_{d}.npy")
        assert img.sum() == pytest.approx(r.row(d)[0], rel=1e-12), d


def test_start_on_surfaces(runner, tmp_path):
    """Rays starting exactly on a plane, at a conic's vertex, on a sphere (EMITTING SPHERE on the sphere of the
    same radius) and on an ellipsoid's poles, leaving along the normal, into the surface, along the tangent and
    1e-9 rad off it, on mirrors, glass and a half-silvered coating."""
    rays = ""
    for d in ((0, 0, 1), (0, 0, -1), (1, 0, 0), (0.3, 0.2, 1e-9), (0.3, 0.2, -1e-9)):
        rays += ray((1, 2, 0), d) + ray((0, 0, 0), d) + ray((0, 0, 30), d) + ray((30, 0, 40), d)
    text = head() + f"""MEDIUM glass INDEX 1.5
COATING half REFLECT 0.5 TRANSMIT 0.5
SURFACE
  PLANE Z 0 RECT 5 5
OBJECT plate
  INTERFACE TRANSMIT AIR glass
SURFACE
  CONIC Z 0 RADIUS 30 CONIC -1 DISK 5
OBJECT cup
  INTERFACE REFLECT
SURFACE
  SPHERE 0 0 40 10
OBJECT ball
  INTERFACE COATING half AIR AIR
SURFACE
  ELLIPSOID 30 20 10 AT 0 0 40
OBJECT ell
  INTERFACE TRANSMIT AIR glass
SURFACE
  SPHERE 0 0 0 1000
OBJECT dome
{rays}EMITTING SPHERE 0 0 40 10 RAYS 300
EMITTING DISK Z 0 5 RAYS 300
LEVEL 300
TRACE
""" + outputs(spectra=("plate", "cup", "ball", "ell"))
    check_run(runner.run(tmp_path, text, "on_surfaces"))


@pytest.mark.slow
def test_fine_mesh_vertices_and_edges_long(runner, tmp_path):
    """The long form: a 4-times subdivided icosphere (2562 vertices, 5120 faces), every upward vertex and
    three points on every upward edge."""
    trimesh = pytest.importorskip("trimesh")
    path = tmp_path / "fine.stl"
    trimesh.creation.icosphere(subdivisions=4, radius=10.0).export(str(path))
    verts, edges = _aim_points(_mesh(path))
    for what, pts in (("vertices", verts), ("edges", edges)):
        rays = "".join(ray((p[0], p[1], 50.0), (0, 0, -1)) for p in pts)
        r = check_run(runner.run(tmp_path / what, _mesh_scene(path, rays), f"fine_{what}"))
        hits = hits_per_source(records(r), "ball")
        assert np.all(hits == 1), f"fine {what}: {int((hits == 0).sum())} rays slipped through"
