"""EXPORT ... SUM: a forward trace's detector image summed over its wavelength lines, one plane, with its standard
error (docs/language.md, EXPORT).

Oracles: the sum itself is arithmetic on the per-line cube of the same run (a regression guard of the bookkeeping,
not physics); its standard errors are checked against the scatter between two seeds (independent runs), which a
wrong combination of the lines' errors fails: with three lines of similar weight, adding the lines' standard
errors instead of their variances overstates the sum's error by about sqrt(3), and the variance ratio below would
be about 1/3 instead of 1 (measured while writing: 1.000 with the variances added, 0.417 with the errors
added, against a tolerance of 5 x 0.044).
"""
import sys
from pathlib import Path

import numpy as np

from irtlang.cli import main

sys.path.insert(0, str(Path(__file__).parent))
from _trace_util import small_cassegrain  # noqa: E402

SCENE = """SYSTEM NEW
UNITS MM
WAVELENGTHS 450 550 650 NM
SEED {seed}
SPECTRUM bb BLACKBODY 3000 K
SURFACE
  PLANE Z 0 RECT 4 4
OBJECT det
  DETECTOR PIXELS 32 32
LEVEL 5
GRID RECT Z 10 -4 4 -4 4 320 320 RANDOM
SOURCE DIRECTION 0 0 -1
FLUX SPECTRUM bb
TRACE
EXPORT det 'cube.npy'
EXPORT det 'sum.npy' SUM
EXPORT det 'sum.fits' SUM
{extra}"""


def _run(tmp_path, capsys, seed, extra=""):
    f = tmp_path / f"s{seed}.inr"
    f.write_text(SCENE.format(seed=seed, extra=extra))
    out = tmp_path / f"o{seed}"
    code = main(["run", str(f), "--out", str(out)])
    cap = capsys.readouterr()
    return code, out, cap.out + cap.err


def test_sum_is_the_cube_summed_and_its_errors_match_the_seed_scatter(tmp_path, capsys):
    runs = []
    for seed in (5, 6):
        code, out, text = _run(tmp_path, capsys, seed)
        assert code == 0, text
        cube, s = np.load(out / "cube.npy"), np.load(out / "sum.npy")
        assert cube.shape == (3, 32, 32) and s.shape == (1, 32, 32)
        # the lines carry different flux (a 3000 K blackbody), so the sum is not one line three times
        per_line = cube.sum(axis=(1, 2))
        assert per_line.max() > 1.5 * per_line.min()
        assert np.allclose(s[0], cube.sum(axis=0), rtol=1e-13, atol=0)
        assert "1 band (its lines summed)" in text
        head = (out / "sum.fits").read_bytes()[:2880 * 2].decode("ascii")
        cards = {head[i:i + 8].strip(): head[i + 10:i + 80] for i in range(0, len(head), 80)}
        assert cards["NAXIS3"].split("/")[0].strip() == "1"
        assert "sum of 3 lines 450-650 nm" in cards["FILT0001"]
        runs.append((s[0], np.load(out / "sum.stderr.npy")[0]))
    (a, ae), (b, be) = runs
    var = ae ** 2 + be ** 2
    m = var > 0
    assert m.sum() == 32 * 32
    z2 = (a - b)[m] ** 2 / var[m]
    # E[z^2] = 1 if the errors are right; the sample mean of z^2 has sd sqrt(2 / M) for Gaussian z
    sd = np.sqrt(2.0 / m.sum())
    assert abs(z2.mean() - 1.0) < 5 * sd, (z2.mean(), sd)


def test_sum_refuses_filter_and_camera_images(tmp_path, capsys):
    # FILTER picks one band already: refused when the script is checked (exit 2, the line and a hint)
    code, _, text = _run(tmp_path, capsys, 7, extra="SPECTRUM f BLACKBODY 5000 K\nEXPORT det 'f.fits' FILTER f SUM\n")
    assert code == 2 and "SUM cannot be combined with FILTER" in text, text
    assert "7.inr:19:" in text and "Traceback" not in text
    # a camera-side image's lines share their rays (their errors do not add): refused when the run gets there
    f = tmp_path / "cam.inr"
    f.write_text("UNITS M\nWAVELENGTHS 500 600 NM\nMODEL paint LAMBERTIAN 0.6\nSURFACE\n  SPHERE 0 0 1e5 100\n"
                 "OBJECT ball\n  INTERFACE ABSORB\n  SCATTER MODEL paint\n" + small_cassegrain() +
                 "EMITTING SPHERE (1e9 * sin(60)) 0 (1e5 - 1e9 * cos(60)) 1e6 RAYS 1\nFLUX TOTAL 1e18 W\n"
                 "TRACE CAMERA fpa AIM secondary RAYS 1 WINDOW 0 2 0 2\nEXPORT fpa 'c.fits' SUM\n")
    code = main(["run", str(f), "--out", str(tmp_path / "cam")])
    text = capsys.readouterr()
    text = text.out + text.err
    assert code == 1 and "a camera-side image's lines share their rays" in text, text
    assert "Traceback" not in text and not (tmp_path / "cam" / "c.fits").exists()


def test_sum_of_a_window_grid(tmp_path, capsys):
    """An object without a DETECTOR exports the WINDOW / PIXELS grid of the rays that ended on it: SUM adds its
    lines the same way (arithmetic on the same run's cube, a regression guard)."""
    text = (SCENE.replace("  DETECTOR PIXELS 32 32\n", "").replace("TRACE\n", "TRACE\nWINDOW X -4 4 Y -4 4\nPIXELS 8 8\n")
            .format(seed=8, extra=""))
    f = tmp_path / "w.inr"
    f.write_text(text)
    assert main(["run", str(f), "--out", str(tmp_path / "o")]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    cube, s = np.load(tmp_path / "o" / "cube.npy"), np.load(tmp_path / "o" / "sum.npy")
    assert cube.shape == (3, 8, 8) and s.shape == (1, 8, 8)
    assert np.allclose(s[0], cube.sum(axis=0), rtol=1e-13, atol=0) and cube.sum() > 0
    assert "WINDOW grid 8x8 x 1 band (its lines summed)" in out
