"""The language side of the instrument: ERROR, the instrument's refusals of bad parameters, DETECTOR's QE check,
and the errors of PSF and EXPORT ... DIFFRACTION."""
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _instrument import EXAMPLES  # noqa: E402

from irtlang.cli import main
from irtlang.lang.diagnostics import IrtError
from irtlang.lang.interp import check_file


def _check(tmp_path, text, name="s.inr"):
    f = tmp_path / name
    f.write_text(text)
    try:
        check_file(f)
    except IrtError as e:
        return [d.message for d in e.diagnostics]
    return []


def _inst(band="550", sd="0", waves="500 550 600 NM"):
    return f"WAVELENGTHS {waves}\nspacing_delta = {sd}\nband = {band}\nINCLUDE '{EXAMPLES / 'cassegrain.inr'}'\n"


def test_error_command_reports_and_stops(tmp_path):
    """ERROR reports its interpolated message at its line and ends the script: nothing after it is checked."""
    f = tmp_path / "e.inr"
    f.write_text("x = 3\nIF (x > 2) ERROR 'x = {x} is too big' (2 * x)\nNO_SUCH_COMMAND 1\n")
    with pytest.raises(IrtError) as ei:
        check_file(f)
    (d,) = ei.value.diagnostics
    assert d.message == "x = 3 is too big 6" and d.span.line == 2
    f.write_text("x = 1\nIF (x > 2) ERROR 'x = {x} is too big'\nPRINT 'fine'\n")
    check_file(f)


def test_error_command_exit_code(tmp_path, capsys):
    f = tmp_path / "e.inr"
    f.write_text("ERROR 'refused'\n")
    assert main(["run", str(f), "--out", str(tmp_path / "o")]) == 2
    assert "e.inr:1:1: error: refused" in capsys.readouterr().err


@pytest.mark.parametrize("band", ["350", "450", "550", "650", "750", "850", "950", "'clear'", "'CLEAR'"])
def test_every_band_has_its_curve(tmp_path, band):
    assert _check(tmp_path, _inst(band=band, waves="400 NM")) == []


@pytest.mark.parametrize("band,shown", [("500", "500"), ("'red'", "red"), ("550 nm", "0.00055")])
def test_a_band_without_a_filter_curve_is_refused(tmp_path, band, shown):
    msgs = _check(tmp_path, _inst(band=band))
    assert msgs == [f"band = {shown}: there is no filter curve for it; the HRI-VIS bands are 350 450 550 650 750 "
                    "850 950 (nm), clear and all"]


def test_a_spacing_that_puts_the_secondary_into_the_primary_is_refused(tmp_path):
    """spacing_delta = -906 mm puts the secondary's vertex at z = 4.14 mm, below the primary's rim (5.468 mm)."""
    msgs = _check(tmp_path, _inst(sd="-906000"))
    assert len(msgs) == 1 and "puts the secondary" in msgs[0] and "into the primary" in msgs[0]
    assert "rim is at z = 5.468 mm" in msgs[0]


def test_a_spacing_that_puts_the_secondary_onto_the_baffle_is_refused(tmp_path):
    msgs = _check(tmp_path, _inst(sd="-400000"))
    assert len(msgs) == 1 and "onto the central baffle" in msgs[0]


@pytest.mark.parametrize("qe", ["1.2", "-0.1", "0.5 1.01 0.5"])
def test_detector_qe_outside_0_1_is_refused(tmp_path, qe):
    msgs = _check(tmp_path, f"WAVELENGTHS 500 550 600 NM\nSURFACE\n PLANE Z 0 RECT 1 1\nOBJECT fpa\n"
                            f" DETECTOR PIXELS 8 QE {qe}\n")
    assert len(msgs) == 1 and "must be" in msgs[0]


def test_a_qe_table_above_1_is_refused(tmp_path):
    (tmp_path / "qe.csv").write_text("wavelength_nm,qe\n400,0.5\n540,1.2\n700,1.2\n")
    msgs = _check(tmp_path, "WAVELENGTHS 500 550 600 NM\nSPECTRUM q TABLE 'qe.csv'\nSURFACE\n PLANE Z 0 RECT 1 1\n"
                            "OBJECT fpa\n DETECTOR PIXELS 8 QE SPECTRUM q\n")
    assert len(msgs) == 1 and "must be" in msgs[0]


@pytest.mark.parametrize("line,msg", [("PSF 'a.txt'", "PSF cannot write '.txt' files"),
                                      ("PSF SIZE 4", "must be an odd whole number"),
                                      ("PSF PAD 1", "must be in [2, 64]"),
                                      ("PSF ON nothing", "undefined object 'nothing'")])
def test_psf_arguments(tmp_path, line, msg):
    msgs = _check(tmp_path, "SURFACE\n PLANE Z 0 RECT 1 1\nOBJECT fpa\n DETECTOR PIXELS 8\n" + line + "\n")
    assert len(msgs) == 1 and msg in msgs[0], msgs


SCENE = """UNITS MM
SURFACE
  CONIC Z 0 RADIUS 2000 CONIC -1 DISK 50
OBJECT mirror
  INTERFACE REFLECT
SURFACE
  PLANE Z 1000 RECT 0.5 0.5
OBJECT det
  DETECTOR PIXELS 11
"""


@pytest.mark.parametrize("source,msg", [
    ("GRID RECT Z 1100 -50 50 -50 50 32 32 RANDOM\nSOURCE DIRECTION 0 0 -1", "regular GRID RECT"),
    ("GRID DISK Z 1100 50 RAYS 1000\nSOURCE DIRECTION 0 0 -1", "regular GRID RECT"),
    ("GRID RECT Z 1100 -50 50 -50 50 32 32\nSOURCE DIRECTION 0 0 1", "no unscattered ray"),
])
def test_psf_needs_a_lit_pupil_lattice(tmp_path, capsys, source, msg):
    f = tmp_path / "p.inr"
    f.write_text(SCENE + source + "\nTRACE\nPSF\n")
    assert main(["run", str(f), "--out", str(tmp_path / "o")]) == 1
    assert msg in capsys.readouterr().err


def test_export_diffraction_needs_a_psf(tmp_path, capsys):
    f = tmp_path / "x.inr"
    f.write_text(SCENE + "GRID RECT Z 1100 -50 50 -50 50 32 32\nSOURCE DIRECTION 0 0 -1\nTRACE\n"
                 "EXPORT det 'd.npy' DIFFRACTION\n")
    assert main(["run", str(f), "--out", str(tmp_path / "o")]) == 1
    assert "needs a PSF first" in capsys.readouterr().err


def test_export_diffraction_convolves(tmp_path, capsys):
    """After PSF, EXPORT ... DIFFRACTION writes the detector image convolved per line with the aberration-free
    kernel: same shape, the flux times the kernel's energy (printed), spread over more pixels."""
    import numpy as np

    f = tmp_path / "x.inr"
    f.write_text(SCENE.replace("DETECTOR PIXELS 11", "DETECTOR PIXELS 51") +
                 "GRID RECT Z 1100 -50 50 -50 50 64 64\nSOURCE DIRECTION 0 0 -1\nTRACE\nPSF SIZE 21\n"
                 "EXPORT det 'g.npy'\nEXPORT det 'd.npy' DIFFRACTION\n")
    assert main(["run", str(f), "--out", str(tmp_path / "o")]) == 0, capsys.readouterr()
    out = capsys.readouterr().out
    kept = float(out.split("convolved with the diffraction kernel (")[1].split(" ")[0])
    g, d = np.load(tmp_path / "o" / "g.npy"), np.load(tmp_path / "o" / "d.npy")
    assert g.shape == d.shape == (1, 51, 51)
    assert d.sum() == pytest.approx(g.sum() * kept, rel=1e-3)
    assert (d > 1e-3 * d.max()).sum() > (g > 1e-3 * g.max()).sum()
