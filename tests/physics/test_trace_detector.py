"""Detector pixel mapping and the EXPORT conventions of LANGUAGE.md section 10: a .npy is float64
(n_lines, ny, nx); [k, j, i] is line k, row j (j = 0 at the detector's lowest local y), column i (i = 0 at its
lowest local x); a DETECTOR's pixels tile its aperture's bounding rectangle in the surface's local x, y (for
PLANE Z: global x, y; PLANE X: y, z; PLANE Y: z, x).  A thin beam is aimed at one pixel; all its flux must land
there."""
import numpy as np
import pytest

from irtlang.cli import main


def _run(tmp_path, capsys, geometry, beam, extra=""):
    text = f"""SYSTEM NEW
UNITS MM
WAVELENGTHS 500 600 NM
SEED 1
{geometry}
LEVEL 5
{beam}
FLUX TOTAL 2 W
TRACE
{extra}EXPORT det 'img.npy'
EXPORT det 'img.fits'
"""
    f = tmp_path / "det.inr"
    f.write_text(text)
    code = main(["run", str(f), "--out", str(tmp_path / "out")])
    cap = capsys.readouterr()
    assert code == 0, cap.out + cap.err
    img = np.load(tmp_path / "out" / "img.npy")
    assert img.dtype == np.float64
    return img, (tmp_path / "out" / "img.fits").read_bytes()


def _only(img, k, j, i):
    assert img.shape[0] == 2
    assert img[k, j, i] == pytest.approx(1.0, rel=1e-12)          # 1 W per line
    rest = img.copy()
    rest[k, j, i] = 0.0
    assert rest[k].sum() == 0.0


BEAM_Z = "GRID RECT Z 10 3.49 3.51 -1.51 -1.49 2 2\nSOURCE DIRECTION 0 0 -1"


@pytest.mark.parametrize("geometry,beam,ji", [
    # PLANE Z: local x, y = global x, y; the beam at (3.5, -1.5) on an 8 x 4 grid over [-4, 4] x [-2, 2]
    ("SURFACE\n  PLANE Z 0 RECT 4 2\nOBJECT det\n  DETECTOR PIXELS 8 4", BEAM_Z, (0, 7)),
    # the same plane turned 90 deg about Z: local x = global y, local y = -global x; the beam at global
    # (1.5, 3.5) is at local (3.5, -1.5)
    ("SURFACE\n  PLANE Z 0 RECT 4 2\nOBJECT det\n  DETECTOR PIXELS 8 4\n  ROTATE Z 90",
     "GRID RECT Z 10 1.49 1.51 3.49 3.51 2 2\nSOURCE DIRECTION 0 0 -1", (0, 7)),
    # PLANE X: RECT half-widths along y then z; local x = global y, local y = global z.  Beam at y = -3.5,
    # z = 1.5: column 0, row 3
    ("SURFACE\n  PLANE X 0 RECT 4 2\nOBJECT det\n  DETECTOR PIXELS 8 4",
     "GRID RECT X 10 -3.51 -3.49 1.49 1.51 2 2\nSOURCE DIRECTION -1 0 0", (3, 0)),
    # PLANE Y: local x = global z, local y = global x.  Beam at z = 0.5, x = -0.5: column 4, row 1
    ("SURFACE\n  PLANE Y 0 RECT 4 2\nOBJECT det\n  DETECTOR PIXELS 8 4",
     "GRID RECT Y 10 0.49 0.51 -0.51 -0.49 2 2\nSOURCE DIRECTION 0 -1 0", (1, 4)),
], ids=["plane_z", "plane_z_rotated", "plane_x", "plane_y"])
def test_detector_pixel_mapping(tmp_path, capsys, geometry, beam, ji):
    img, fits = _run(tmp_path, capsys, geometry, beam)
    assert img.shape == (2, 4, 8)
    for k in range(2):
        _only(img, k, *ji)
    head = fits[:2880].decode("ascii")
    cards = {head[i:i + 8].strip(): head[i + 10:i + 30].strip() for i in range(0, 2880, 80)}
    assert (cards["NAXIS1"], cards["NAXIS2"], cards["NAXIS3"]) == ("8", "4", "2")


def test_window_grid_export_follows_the_same_convention(tmp_path, capsys):
    """An object without a DETECTOR exports the WINDOW / PIXELS grid of the rays that ended on it: the same
    (n_lines, ny, nx) layout, row 0 at the window's low end of its second axis."""
    geometry = "SURFACE\n  PLANE Z 0 RECT 4 2\nOBJECT det"
    img, _ = _run(tmp_path, capsys, geometry, BEAM_Z, extra="WINDOW X -4 4 Y -2 2\nPIXELS 8 4\n")
    assert img.shape == (2, 4, 8)
    for k in range(2):
        _only(img, k, 0, 7)
