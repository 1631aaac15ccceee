"""Command line: python -m analysis SUBCOMMAND, exit codes and error messages."""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _analysis_synth import render_edge, render_ellipse

from analysis import write_rays_v1
from analysis.cli import build_parser, main, run

REPO = Path(__file__).resolve().parents[2]


def _gaussian_psf(s=3.0, n=41):
    yy, xx = np.mgrid[:n, :n]
    return np.exp(-((xx - 20.2) ** 2 + (yy - 19.7) ** 2) / (2 * s**2))


def _python_m(*args, cwd):
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "analysis", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=120)


def test_python_m_analysis_psf(tmp_path):
    np.save(tmp_path / "some.npy", _gaussian_psf())
    res = _python_m("psf", "some.npy", "--pixel-pitch", "21", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    values = dict(line.split(": ", 1) for line in res.stdout.strip().splitlines())
    # pixel-centre sampling of a Gaussian: FWHM = 2.3548 sigma (1 %, as in test_psf)
    assert float(values["fwhm"]) == pytest.approx(2.3548 * 3.0 * 21, rel=0.01)
    assert values["strehl"] == "n/a"


def test_bad_file_exits_2_without_traceback(tmp_path):
    (tmp_path / "bad.npy").write_text("this is not an array")
    res = _python_m("psf", "bad.npy", "--pixel-pitch", "21", cwd=tmp_path)
    assert res.returncode == 2
    assert res.stderr.startswith("error: ") and "Traceback" not in res.stderr
    res = _python_m("psf", "missing.npy", cwd=tmp_path)
    assert res.returncode == 2 and "no such file" in res.stderr and "Traceback" not in res.stderr


def test_zero_image_is_an_error(tmp_path, capsys):
    np.save(tmp_path / "zero.npy", np.zeros((8, 8)))
    assert main(["psf", str(tmp_path / "zero.npy")]) == 2
    assert "all zero" in capsys.readouterr().err


def test_mtf_esf_json(tmp_path, capsys):
    np.save(tmp_path / "edge.npy", render_edge((80, 80), 1.0))
    assert main(["mtf", str(tmp_path / "edge.npy"), "--json", "-o", str(tmp_path / "mtf.csv"),
                 "--plot", str(tmp_path / "mtf.png")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mtf50_cycles_per_px"] == pytest.approx(0.1800, abs=0.01)
    table = np.loadtxt(tmp_path / "mtf.csv", delimiter=",", skiprows=1)
    assert table.shape[1] == 2 and table[0, 1] == pytest.approx(1.0)
    assert (tmp_path / "mtf.png").stat().st_size > 0
    assert main(["esf", str(tmp_path / "edge.npy"), "--roi", "0", "0", "80", "80", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["esf_width_10_90_px"] > 2.5
    assert main(["esf", str(tmp_path / "edge.npy"), "--roi", "70", "0", "20", "20"]) == 2
    assert "outside the image" in capsys.readouterr().err


def test_disk_rgb_defocus(tmp_path, capsys):
    disk = render_ellipse((96, 96), (48.3, 47.6), (30.0, 30.0), 0.0)
    np.save(tmp_path / "disk.npy", disk)
    assert main(["disk", str(tmp_path / "disk.npy"), "--radius-km", "6378.137", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["equatorial_diameter_px"] == pytest.approx(60.0, abs=0.5)
    assert out["km_per_px"] == pytest.approx(6378.137 / 30.0, rel=0.02)
    np.savetxt(tmp_path / "g.csv", disk, delimiter=",")
    assert main(["rgb", str(tmp_path / "disk.npy"), str(tmp_path / "g.csv"), str(tmp_path / "disk.npy"),
                 "-o", str(tmp_path / "c.png")]) == 0
    assert (tmp_path / "c.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()
    np.save(tmp_path / "edge.npy", render_edge((64, 64), 2.0))
    assert main(["defocus", str(tmp_path / "edge.npy"), "--method", "guided", "-o", str(tmp_path / "d.npy"),
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["edge_median_sigma_px"] == pytest.approx(2.0, rel=0.02)
    assert np.load(tmp_path / "d.npy").shape == (64, 64)


def test_ray_file_inputs(tmp_path, capsys):
    rng = np.random.default_rng(1)
    n = 4000
    pos = np.column_stack([rng.normal(0, 0.01, n), rng.normal(0, 0.01, n), np.full(n, 5.0)])
    cube = rng.uniform(0, 1, (3, 10, 12))
    write_rays_v1(tmp_path / "run.h5", wavelengths_nm=[450, 550, 650], objects=["fp"], position=pos,
                  direction=np.tile([0, 0, 1.0], (n, 1)), flux=np.full(n, 1e-3), object=np.zeros(n),
                  detectors={"fp": {"sum": cube, "sum2": cube / 100, "x_range": (-1, 1), "y_range": (-1, 1),
                                    "pixel_size": (0.2, 0.2)}})
    assert main(["psf", str(tmp_path / "run.h5"), "--rays", "--object", "fp", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n_rays"] == n
    assert abs(out["ee80_diameter"] - 0.02 * np.sqrt(2 * np.log(5))) < 4 * out["ee80_diameter_se"]
    assert main(["spectrum", str(tmp_path / "run.h5"), "--json", "-o", str(tmp_path / "s.csv")]) == 0
    out = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(out["flux"], cube.sum(axis=(1, 2)))
    np.testing.assert_allclose(out["stderr"], np.sqrt((cube / 100).sum(axis=(1, 2))))
    assert out["wavelength_nm"] == [450, 550, 650]
    assert main(["psf", str(tmp_path / "run.h5") + ":fp:1", "--json"]) == 0
    capsys.readouterr()
    assert main(["psf", str(tmp_path / "run.h5") + ":nope"]) == 2
    assert "no detector 'nope'" in capsys.readouterr().err


def test_wiring_into_another_program(capsys, tmp_path):
    # How `irt analyze ...` uses it.
    parser = argparse.ArgumentParser(prog="irt")
    sub = parser.add_subparsers(dest="command", required=True)
    analyze = sub.add_parser("analyze")
    build_parser(analyze.add_subparsers(dest="analysis_command", required=True))
    np.save(tmp_path / "p.npy", _gaussian_psf())
    args = parser.parse_args(["analyze", "psf", str(tmp_path / "p.npy"), "--json"])
    assert run(args) == 0
    assert "fwhm" in json.loads(capsys.readouterr().out)


def test_fits_and_csv_images(tmp_path):
    from analysis import load_image

    img = _gaussian_psf()
    np.savetxt(tmp_path / "p.csv", img, delimiter=",")
    np.testing.assert_allclose(load_image(tmp_path / "p.csv"), img)
    fits = pytest.importorskip("astropy.io.fits")
    fits.PrimaryHDU(img).writeto(tmp_path / "p.fits")
    np.testing.assert_allclose(load_image(tmp_path / "p.fits"), img)
