"""ANALYZE: the analysis package from a script, checked at `irt check` time, run in script order."""
import numpy as np
import pytest

from irtlang.cli import main


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_bad_analysis_options_are_refused_at_check_time(tmp_path, capsys):
    s = _write(tmp_path, "a.inr", "ANALYZE PSF 'psf.npy' PIXL_PITCH 2\n")
    assert main(["check", str(s)]) == 2
    err = capsys.readouterr().err
    assert "a.inr:1:1: error: ANALYZE PSF: unrecognized arguments: --pixl-pitch 2" in err
    assert "Traceback" not in err


def test_analyze_psf_of_a_gaussian_spot(tmp_path, capsys):
    # a Gaussian of sigma 2 px: FWHM = 2 sqrt(2 ln 2) sigma = 4.7096 px (an independent closed form)
    x = np.arange(41)
    X, Y = np.meshgrid(x, x)
    np.save(tmp_path / "spot.npy", np.exp(-((X - 20) ** 2 + (Y - 20) ** 2) / (2 * 2.0 ** 2))[None])
    s = _write(tmp_path, "b.inr", "ANALYZE PSF 'spot.npy' PIXEL_PITCH 1 JSON\n")
    assert main(["run", str(s), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    import json
    import re

    data = json.loads(re.search(r"ANALYZE PSF:\n(\{.*\})", out, re.S).group(1))
    assert data["fwhm"] == pytest.approx(2 * np.sqrt(2 * np.log(2)) * 2.0, rel=0.01)


def test_missing_input_stops_the_run_with_a_located_error(tmp_path, capsys):
    s = _write(tmp_path, "c.inr", "PRINT 'before'\nANALYZE DISK 'nothere.npy'\n")
    # issue 21: irt check finds the missing input (exit 2, before the run), at the string that names it
    assert main(["run", str(s), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "c.inr:2:14: error: ANALYZE input 'nothere.npy' is not written earlier by this script and not found" in err
