"""`series`: hourly SPECTRUM OF files -> one table with the apparent albedo; the solar band irradiance of a line
against an independent integration of the reference spectrum and against irtlang's own FLUX SPECTRUM."""

import csv
import json
import math
from importlib import resources

import numpy as np
import pytest

from analysis import AnalysisError, read_spectra_series, series_apparent_albedo, solar_band_irradiance
from analysis.cli import main

GEOMETRY = dict(tsi=1360.8, sun_distance_au=0.9956, distance_km=2.75e7, phase_deg=57.7, radius_km=6371.0,
                area_m2=0.196)
CLI_GEOMETRY = ["--tsi", "1360.8", "--sun-distance-au", "0.9956", "--distance-km", "2.75e7", "--phase-deg", "57.7",
                "--radius-km", "6371", "--area-m2", "0.196"]
G173_TOTAL = 1366.1          # W/m2, all wavelengths (ASTM G173-03)
G173_280_4000 = 1347.93      # W/m2 of it within the table's 280-4000 nm (Gueymard 2004; the CSV header)


def _g173():
    """The reference table, read here with the csv module (not through irtlang's reader)."""
    text = resources.files("irtlang.data").joinpath("solar_astm_g173_etr.csv").read_text()
    rows = [r for r in csv.reader(ln for ln in text.splitlines() if not ln.startswith("#"))][1:]
    return np.array([[float(a), float(b)] for a, b in rows]).T


def _band_integral(lo, hi, n=40001):
    """Integral of the piecewise-linear G173 spectrum over [lo, hi] nm (dense trapezoid; W/m2 at 1366.1 total)."""
    w, v = _g173()
    x = np.linspace(lo, hi, n)
    y = np.interp(x, w, v)
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)))


def _lambert_phase(a_deg):
    a = math.radians(a_deg)
    return (math.sin(a) + (math.pi - a) * math.cos(a)) / math.pi


def test_band_irradiance_is_the_band_integral():
    # bands reach halfway to the neighbouring lines; the end bands are symmetric about their line
    lines = [350.0, 450.0, 550.0, 700.0, 900.0]
    edges = [(300, 400), (400, 500), (500, 625), (625, 800), (800, 1000)]
    tsi = 1361.0
    want = np.array([_band_integral(lo, hi) for lo, hi in edges]) * tsi / G173_TOTAL
    got = solar_band_irradiance(lines, tsi=tsi)
    np.testing.assert_allclose(got, want, rtol=2e-6)
    # lines given in any order keep their own bands; the irradiance falls as 1/D^2
    np.testing.assert_allclose(solar_band_irradiance(lines[::-1], tsi=tsi), got[::-1], rtol=1e-14)
    np.testing.assert_allclose(solar_band_irradiance(lines, tsi=tsi, sun_distance_au=2.0), got / 4, rtol=1e-14)
    # one line: the spectrum at the line, per nm (FLUX SPECTRUM's convention)
    w, v = _g173()
    assert solar_band_irradiance([550.0], tsi=tsi)[0] == pytest.approx(np.interp(550.0, w, v) * tsi / G173_TOTAL,
                                                                      rel=1e-12)


def test_band_irradiance_sums_to_the_tsi_within_the_reference_coverage():
    lines = 280.0 + 10.0 * (np.arange(372) + 0.5)            # bands tile 280-4000 nm exactly
    total = solar_band_irradiance(lines, tsi=1360.8).sum()
    assert total == pytest.approx(1360.8 * G173_280_4000 / G173_TOTAL, rel=1e-5)
    visible = solar_band_irradiance(400.0 + 20.0 * (np.arange(15) + 0.5), tsi=1360.8).sum()
    assert visible == pytest.approx(1360.8 / G173_TOTAL * _band_integral(400, 700), rel=1e-6)


def test_band_irradiance_equals_irtlangs_flux_spectrum():
    """EMITTING SPHERE ... FLUX SPECTRUM sun emits per line the irradiance at 1 AU times 4 pi AU^2."""
    from irtlang.compile.pack import pack
    from irtlang.lang.interp import Interpreter

    it = Interpreter(check_only=True)
    it.run_text("UNITS KM\nWAVELENGTHS 350 450 550 700 900 NM\nSPECTRUM sun SOLAR TSI 1361 W/m2\n"
                "SURFACE\n  PLANE Z 0 DISK 1\nOBJECT plate\n"
                "EMITTING SPHERE 1.5e8 0 0 6.957e5 RAYS 100 TOWARD plate\nFLUX SPECTRUM sun\n", "flux.inr")
    assert not it.diags.items
    pk = pack(it.state.scene())
    per_m2 = pk.emitted_W / (4 * math.pi * 1.495978707e11 ** 2)
    np.testing.assert_allclose(solar_band_irradiance(pk.lines_nm, tsi=1361.0), per_m2, rtol=1e-13, atol=0)


def test_band_irradiance_errors():
    with pytest.raises(AnalysisError, match="280-4000 nm"):
        solar_band_irradiance([250.0, 350.0], tsi=1360.8)
    with pytest.raises(AnalysisError, match="distinct"):
        solar_band_irradiance([450.0, 450.0], tsi=1360.8)
    with pytest.raises(AnalysisError, match="tsi"):
        solar_band_irradiance([450.0], tsi=-1)


def _write_spectrum(path, wl, flux, se=None, header="wavelength_nm,flux_W,stderr_W"):
    se = np.zeros_like(flux) if se is None else se
    path.write_text(header + "\n" + "".join(f"{w:.6g},{float(f)!r},{float(e)!r}\n" for w, f, e in zip(wl, flux, se)))


def _true_flux(albedo, wl, g=GEOMETRY):
    """A Lambert sphere of albedo A seen by an aperture: A * area * (2/3) E_line (R/d)^2 Phi(a)."""
    e = solar_band_irradiance(wl, tsi=g["tsi"], sun_distance_au=g["sun_distance_au"])
    return albedo * g["area_m2"] * (2.0 / 3.0) * e * (g["radius_km"] / g["distance_km"]) ** 2 \
        * _lambert_phase(g["phase_deg"])


def test_lambert_sphere_spectrum_gives_back_its_albedo():
    wl = np.array([350.0, 450.0, 550.0, 650.0, 750.0, 850.0, 950.0])
    a_true = np.array([[0.31, 0.25, 0.22, 0.20, 0.24, 0.27, 0.26], [0.5, 0.4, 0.3, 0.2, 0.1, 0.05, 0.9]])
    got = series_apparent_albedo(_true_flux(a_true, wl), wl, **GEOMETRY)
    np.testing.assert_allclose(got, a_true, rtol=1e-12)
    # at 90 deg phase Phi = 1/pi (closed form)
    g = dict(GEOMETRY, phase_deg=90.0)
    e = solar_band_irradiance(wl, tsi=g["tsi"], sun_distance_au=g["sun_distance_au"])
    flux = 0.3 * g["area_m2"] * (2 / 3) * e * (g["radius_km"] / g["distance_km"]) ** 2 / math.pi
    np.testing.assert_allclose(series_apparent_albedo(flux, wl, **g), 0.3, rtol=1e-12)
    with pytest.raises(AnalysisError, match="must exceed"):
        series_apparent_albedo(flux, wl, **dict(g, distance_km=6000.0))


def test_cli_writes_the_sorted_table_and_plot(tmp_path, capsys):
    folder = tmp_path / "spectra"
    folder.mkdir()
    wl = np.array([450.0, 550.0, 650.0, 750.0])
    tags = ["20080319T0019", "20080318T1819", "20080318T2319"]      # written out of time order
    albedo = {t: 0.2 + 0.01 * k + 0.001 * np.arange(4) for k, t in enumerate(tags)}
    for t in tags:
        order = [2, 0, 3, 1]                                         # rows out of wavelength order
        flux = _true_flux(albedo[t], wl)
        _write_spectrum(folder / f"{t}.csv", wl[order], flux[order], 0.01 * flux[order])
    (folder / "notes.txt").write_text("not a spectrum")               # other files are ignored
    out, fig = tmp_path / "disk_spectra.csv", tmp_path / "tw.png"
    assert main(["series", str(folder), "-o", str(out), "--plot", str(fig), *CLI_GEOMETRY, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["times"] == 3
    assert (res["first_utc"], res["last_utc"]) == ("2008-03-18T18:19:00Z", "2008-03-19T00:19:00Z")
    assert res["wavelength_nm"] == [450.0, 550.0, 650.0, 750.0]
    text = out.read_text().splitlines()
    assert text[0] == "time_utc,wavelength_nm,flux_W,stderr_W,apparent_albedo"
    rows = [r.split(",") for r in text[1:]]
    assert len(rows) == 12
    assert [r[0] for r in rows[::4]] == ["2008-03-18T18:19:00Z", "2008-03-18T23:19:00Z", "2008-03-19T00:19:00Z"]
    assert [float(r[1]) for r in rows] == list(wl) * 3
    for k, t in enumerate(["20080318T1819", "20080318T2319", "20080319T0019"]):
        block = np.array([[float(x) for x in r[1:]] for r in rows[4 * k:4 * k + 4]])
        np.testing.assert_allclose(block[:, 3], albedo[t], rtol=1e-12)
        np.testing.assert_allclose(block[:, 2], 0.01 * block[:, 1], rtol=1e-12)
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["disk_spectra.csv", "spectra", "tw.png"]  # no temp files
    # plain output: a short summary
    assert main(["series", str(folder), "-o", str(out), *CLI_GEOMETRY]) == 0
    assert "first_utc: 2008-03-18T18:19:00Z" in capsys.readouterr().out


def test_one_time_one_line(tmp_path):
    folder = tmp_path / "s"
    folder.mkdir()
    _write_spectrum(folder / "20080318T1819.csv", [550.0], _true_flux(0.3, [550.0]))
    series = read_spectra_series(folder)
    assert series.flux_W.shape == (1, 1) and series.hours_since_midnight()[0] == pytest.approx(18 + 19 / 60)
    assert main(["series", str(folder), "-o", str(tmp_path / "o.csv"), "--plot", str(tmp_path / "o.png"),
                 *CLI_GEOMETRY]) == 0


@pytest.mark.parametrize("case, message", [
    ("empty", "holds no spectrum file"),
    ("name", "not a time tag"),
    ("date", "not a valid date"),
    ("lines", "differ from those of 20080318T1819.csv"),
    ("columns", "missing column(s) stderr_W"),
    ("number", "not a number"),
    ("nofolder", "no such folder"),
])
def test_bad_folders_are_clear_errors(tmp_path, capsys, case, message):
    folder = tmp_path / "spectra"
    if case != "nofolder":
        folder.mkdir()
    wl = np.array([450.0, 550.0])
    if case not in ("empty", "nofolder"):
        _write_spectrum(folder / "20080318T1819.csv", wl, [1e-7, 2e-7])
    if case == "name":
        _write_spectrum(folder / "frame_1.csv", wl, [1e-7, 2e-7])
    elif case == "date":
        _write_spectrum(folder / "20081318T1819.csv", wl, [1e-7, 2e-7])
    elif case == "lines":
        _write_spectrum(folder / "20080318T1919.csv", [450.0, 560.0], [1e-7, 2e-7])
    elif case == "columns":
        _write_spectrum(folder / "20080318T1919.csv", wl, [1e-7, 2e-7], header="wavelength_nm,flux_W,sigma")
    elif case == "number":
        (folder / "20080318T1919.csv").write_text("wavelength_nm,flux_W,stderr_W\n450,abc,0\n")
    with pytest.raises(AnalysisError) as exc:
        read_spectra_series(folder)
    assert message in str(exc.value)
    assert main(["series", str(folder), "-o", str(tmp_path / "o.csv"), *CLI_GEOMETRY]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err
    assert not (tmp_path / "o.csv").exists()


def test_analyze_series_in_a_script(tmp_path, capsys):
    from irtlang.cli import main as irt

    folder = tmp_path / "spectra"
    folder.mkdir()
    wl = np.array([450.0, 550.0, 650.0])
    for k, t in enumerate(["20080318T1819", "20080318T1919"]):
        _write_spectrum(folder / f"{t}.csv", wl, _true_flux(0.25 + 0.05 * k, wl))
    script = tmp_path / "series.inr"
    script.write_text("ANALYZE SERIES 'spectra' OUTPUT 'disk_spectra.csv' PLOT 'time_wavelength.png' TSI 1360.8 &\n"
                      "    SUN_DISTANCE_AU 0.9956 DISTANCE_KM 2.75e7 PHASE_DEG 57.7 RADIUS_KM 6371 AREA_M2 0.196\n")
    assert irt(["run", str(script), "--out", str(tmp_path / "out")]) == 0
    assert "ANALYZE SERIES:" in capsys.readouterr().out
    table = np.loadtxt(tmp_path / "out" / "disk_spectra.csv", delimiter=",", skiprows=1, usecols=(1, 4))
    np.testing.assert_allclose(table[:, 1], [0.25] * 3 + [0.3] * 3, rtol=1e-9)
    assert (tmp_path / "out" / "time_wavelength.png").exists()
    # a missing option is refused by `irt check`
    script.write_text("ANALYZE SERIES 'spectra' OUTPUT 'd.csv' TSI 1360.8\n")
    assert irt(["check", str(script)]) == 2
    assert "the following arguments are required: --sun-distance-au" in capsys.readouterr().err
