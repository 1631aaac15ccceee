"""Geometry that cannot be built is refused with a clear diagnostic at the offending command's line, by
`irt check` and by `irt run` before any ray is traced (exit code 2, no TRACE output)."""
import re

import pytest

from irtlang.cli import main

TAIL = "GRID DISK Z 100 5 RAYS 100\nSOURCE DIRECTION 0 0 -1\nTRACE\n"

# (name, script body, line, column or None, message regex)
CASES = [
    ("conic_disk_outside_domain", "UNITS MM\nSURFACE\n  CONIC Z 0 RADIUS 10 DISK 12\nOBJECT lens\n", 3, 23,
     r"aperture reaches r = 12 but this conic only exists for r <= 10"),
    ("conic_rect_corner_outside_domain", "UNITS MM\nSURFACE\n  CONIC Z 0 RADIUS 10 RECT 8 8\nOBJECT lens\n", 3, 23,
     r"aperture reaches r = 11\.31\d* but this conic only exists for r <= 10"),
    ("prolate_conic_annulus", "UNITS MM\nSURFACE\n  CONIC Z 0 RADIUS -10 CONIC -0.5 ANNULUS 1 14.5\nOBJECT m\n",
     3, None, r"only exists for r <= 14\.14"),
    ("mesh_missing", "UNITS MM\nSURFACE\n  MESH 'nope.stl'\nOBJECT m\n", 3, 8, r"file not found: 'nope\.stl'"),
    ("mesh_garbage", "UNITS MM\nSURFACE\n  MESH 'garbage.stl'\nOBJECT m\n", 3, 8,
     r"mesh 'garbage\.stl' has no triangles|cannot read mesh 'garbage\.stl'"),
    ("mesh_truncated", "UNITS MM\nSURFACE\n  MESH 'truncated.stl'\nOBJECT m\n", 3, 8,
     r"mesh 'truncated\.stl' has no triangles|cannot read mesh 'truncated\.stl'"),
    ("mesh_empty", "UNITS MM\nSURFACE\n  MESH 'empty.stl'\nOBJECT m\n", 3, 8,
     r"mesh 'empty\.stl' has no triangles|cannot read mesh 'empty\.stl'"),
    ("mesh_unknown_format", "UNITS MM\nSURFACE\n  MESH 'shape.xyz123'\nOBJECT m\n", 3, 8, r"cannot read mesh 'shape\.xyz123'"),
    ("mesh_is_a_folder", "UNITS MM\nSURFACE\n  MESH 'afolder'\nOBJECT m\n", 3, 8, r"'afolder' is a folder"),
    ("detector_zero_nx", "UNITS MM\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT d\n  DETECTOR PIXELS 0 10\n", 5, 19,
     r"a detector needs at least 1 pixel, got 0"),
    ("detector_zero_ny", "UNITS MM\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT d\n  DETECTOR PIXELS 10 0\n", 5, 22,
     r"a detector needs at least 1 pixel, got 0"),
    ("detector_without_aperture", "UNITS MM\nSURFACE\n  SPHERE 0 0 0 1\nOBJECT d\n  DETECTOR PIXELS 10\n", 5, 3,
     r"no flat aperture to tile with pixels"),
    ("group_placed_inside_itself", "UNITS MM\nGROUP g\nSURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT d\nPLACE g AT 0 0 1\n"
     "END GROUP\n", 6, None, r"GROUP g cannot be placed inside itself"),
    ("group_placed_inside_its_child", "UNITS MM\nGROUP outer\nGROUP inner\nPLACE outer AT 0 0 1\nEND GROUP\n"
     "END GROUP\n", 4, None, r"GROUP outer cannot be placed inside itself"),
]


@pytest.fixture()
def folder(tmp_path):
    (tmp_path / "garbage.stl").write_bytes(bytes(range(256)) * 3)
    (tmp_path / "truncated.stl").write_text("solid x\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0\n")
    (tmp_path / "empty.stl").write_text("")
    (tmp_path / "shape.xyz123").write_text("x\n")
    (tmp_path / "afolder").mkdir()
    return tmp_path


@pytest.mark.parametrize("name,body,line,col,msg", CASES, ids=[c[0] for c in CASES])
def test_bad_geometry_is_refused_at_its_line(folder, capsys, name, body, line, col, msg):
    f = folder / f"{name}.inr"
    f.write_text(body + TAIL)
    assert main(["check", str(f)]) == 2
    err = capsys.readouterr().err
    colpat = str(col) if col else r"\d+"
    where = re.escape(f.name) + f":{line}:" + colpat + ": error: "
    assert re.search(where + r".*(" + msg + ")", err), err
    # and a run stops before tracing anything
    assert main(["run", str(f), "--out", str(folder / "out")]) == 2
    cap = capsys.readouterr()
    assert "TRACE:" not in cap.out
    assert re.search(msg, cap.err)
