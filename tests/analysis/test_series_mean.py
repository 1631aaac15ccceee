"""The day's mean disk spectrum (analysis.series.series_mean_spectrum, `irt analyze series --mean-plot
--mean-output`) and the paired time x wavelength maps (absolute and difference from the mean)."""
import json

import numpy as np
import pytest

from analysis import read_spectra_series, series_apparent_albedo
from analysis.cli import main
from analysis.series import EARTH_FEATURES, series_mean_spectrum

from test_disk_series import CLI_GEOMETRY, GEOMETRY, _true_flux, _write_spectrum


def _folder(tmp_path, albedo, rel_se, wl):
    folder = tmp_path / "spectra"
    folder.mkdir()
    for k, a in enumerate(albedo):
        flux = _true_flux(a, wl)
        _write_spectrum(folder / f"20080318T{18 + k:02d}19.csv", wl, flux, rel_se[k] * flux)
    return folder


def test_mean_stderr_and_spread_closed_form(tmp_path):
    wl = np.array([450.0, 550.0, 763.9, 1380.0])
    albedo = np.array([[0.30, 0.25, 0.10, 0.02], [0.34, 0.27, 0.12, 0.03], [0.32, 0.29, 0.11, 0.04]])
    rel = np.array([[0.01, 0.02, 0.03, 0.10], [0.02, 0.02, 0.03, 0.10], [0.03, 0.02, 0.03, 0.10]])
    s = read_spectra_series(_folder(tmp_path, albedo, rel, wl))
    a = series_apparent_albedo(s.flux_W, s.wavelengths_nm, **GEOMETRY)
    m = series_mean_spectrum(s, a)
    np.testing.assert_allclose(m["mean"], albedo.mean(axis=0), rtol=1e-12)
    # independent hours: the mean's standard error is sqrt(sum (rel_t a_t)^2) / T
    np.testing.assert_allclose(m["stderr"], np.sqrt(np.sum((rel * albedo) ** 2, axis=0)) / 3, rtol=1e-10)
    np.testing.assert_allclose(m["spread"], albedo.std(axis=0, ddof=1), rtol=1e-12)


def test_cli_writes_mean_csv_and_both_figures(tmp_path, capsys):
    wl = np.round(np.linspace(300.0, 2500.0, 60), 1)
    t = np.arange(4)[:, None]
    albedo = 0.3 - 0.0001 * (wl[None, :] - 300) / 10 + 0.01 * np.sin(t + wl[None, :] / 300)
    rel = np.full(albedo.shape, 0.02)
    folder = _folder(tmp_path, albedo, rel, wl)
    out, fig, mfig, mcsv = (tmp_path / n for n in ("s.csv", "tw.png", "mean.png", "mean.csv"))
    assert main(["series", str(folder), "-o", str(out), "--plot", str(fig), "--mean-plot", str(mfig),
                 "--mean-output", str(mcsv), *CLI_GEOMETRY, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["median_relative_stderr_of_mean"] == pytest.approx(0.01, rel=0.02)   # 2 % / sqrt(4)
    for f in (fig, mfig):
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rows = mcsv.read_text().splitlines()
    assert rows[0] == "wavelength_nm,mean_apparent_albedo,stderr,spread" and len(rows) == 61
    got = np.array([[float(x) for x in r.split(",")] for r in rows[1:]])
    np.testing.assert_allclose(got[:, 1], albedo.mean(axis=0), rtol=1e-10)
    # a single time: no spread, the plots still come out
    one = tmp_path / "one"
    one.mkdir()
    _write_spectrum(one / "20080318T1819.csv", [550.0], _true_flux(0.3, [550.0]), [0.003])
    assert main(["series", str(one), "-o", str(tmp_path / "o.csv"), "--plot", str(tmp_path / "o.png"),
                 "--mean-plot", str(tmp_path / "om.png"), *CLI_GEOMETRY]) == 0


def test_feature_labels_cover_the_earth_bands():
    names = " ".join(f[-1] for f in EARTH_FEATURES)
    for key in ("Rayleigh", "O3 Chappuis", "O3 Huggins", "O2 A", "O2 B", "H2O 0.94", "H2O 1.38", "red edge"):
        assert key in names
    a_band = [f for f in EARTH_FEATURES if f[-1] == "O2 A"][0]
    assert a_band[0] <= 762.0 <= a_band[1]          # the O2 A band head at 759-762 nm
