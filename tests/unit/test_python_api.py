"""The Python API (irtlang.run / irtlang.check), results.nc, FITS with a WCS, --seed, installed examples and the
INCLUDE search path, the data tier, progress (docs/python_api.md)."""
import hashlib
import io
import json
import math
import re
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import irtlang
from irtlang.cli import main

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = """\
UNITS MM
WAVELENGTHS 500 600 NM
SEED 7
SURFACE
  CONIC Z 0 RADIUS 2000 CONIC -1 DISK 100
OBJECT mirror
  INTERFACE REFLECT
SURFACE
  PLANE Z 1000 RECT 5 5
OBJECT fpa
  DETECTOR PIXELS 11 9
FOCAL_LENGTH = 1000 MM
GRID DISK Z 500 100 RAYS 2000 RANDOM
SOURCE DIRECTION 0.001 0 -1
TRACE
STATS LEDGER 'ledger.csv'
EXPORT fpa 'fpa.fits'
EXPORT fpa 'fpa.npy'
SPECTRUM OF fpa 'spec.csv'
"""


def _sha(p):
    return hashlib.sha256(Path(p).read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The same script through `irt run --seed 11` and irtlang.run(seed=11), and with SEED 11 in the script."""
    d = tmp_path_factory.mktemp("api")
    (d / "s.inr").write_text(SCRIPT)
    (d / "s11.inr").write_text(SCRIPT.replace("SEED 7", "SEED 11"))
    assert main(["run", str(d / "s.inr"), "--out", str(d / "cli"), "--seed", "11", "--quiet"]) == 0
    res = irtlang.run(d / "s.inr", seed=11, out=d / "api")
    res11 = irtlang.run(str(d / "s11.inr"), out=d / "s11")
    res7 = irtlang.run(d / "s.inr", out=d / "s7")
    return SimpleNamespace(d=d, res=res, res11=res11, res7=res7)


def test_api_writes_what_the_cli_writes(runs):
    cli = json.loads((runs.d / "cli" / "manifest.json").read_text())
    api = runs.res.manifest
    assert [f["path"] for f in cli["files"]] == [f["path"] for f in api["files"]]
    assert {"fpa.fits", "fpa.npy", "fpa.stderr.npy", "ledger.csv", "spec.csv", "results.nc"} <= set(runs.res.files)
    for f in cli["files"]:
        if f["path"] in ("results.nc", "fpa.fits"):   # these carry the time they were written
            continue
        assert f["sha256"] == _sha(runs.res.files[f["path"]]), f["path"]
    xr = pytest.importorskip("xarray")
    with xr.open_dataset(runs.d / "cli" / "results.nc") as a:
        for v in a.data_vars:
            np.testing.assert_array_equal(a[v].values, runs.res.dataset[v].values)
    for k in ("seed", "script_sha256", "rays_traced", "data_tier", "status"):
        assert cli[k] == api[k]
    assert api["seed"] == 11 and api["seed_from"] == "--seed" and api["status"] == "complete"
    for folder in (runs.d / "cli", runs.d / "api"):   # the images' spill folder is gone
        assert not [q for q in folder.iterdir() if q.name.startswith(".irt-results-")]


def test_seed_override_equals_the_script_seed(runs):
    """--seed N gives the run the script gives with SEED N, and another image than its own SEED 7."""
    a = np.load(runs.res.files["fpa.npy"])
    np.testing.assert_array_equal(a, np.load(runs.res11.files["fpa.npy"]))
    assert not np.array_equal(a, np.load(runs.res7.files["fpa.npy"]))
    assert runs.res7.manifest["seed"] == 7 and "seed_from" not in runs.res7.manifest



def test_seed_override_keeps_a_script_s_seeds_apart(tmp_path):
    """A script that moves its SEED between traces (the flagship: a seed per hourly frame) keeps them apart
    under --seed N: the first TRACE uses N, a later one N plus its SEED's offset from the first's.  So with
    --seed 11, SEED 7 then SEED 8 trace as SEED 11 then SEED 12 would."""
    two = SCRIPT.replace("EXPORT fpa 'fpa.npy'", "EXPORT fpa 'fpa.npy'\nSEED 8\nGRID DISK Z 500 100 RAYS 2000 RANDOM\n"
                         "SOURCE DIRECTION 0.001 0 -1\nTRACE\nEXPORT fpa 'fpa2.npy'")
    (tmp_path / "two.inr").write_text(two)
    (tmp_path / "ref.inr").write_text(two.replace("SEED 7", "SEED 11").replace("SEED 8", "SEED 12"))
    got = irtlang.run(tmp_path / "two.inr", seed=11, out=tmp_path / "got")
    ref = irtlang.run(tmp_path / "ref.inr", out=tmp_path / "ref")
    for f in ("fpa.npy", "fpa2.npy"):
        np.testing.assert_array_equal(np.load(got.files[f]), np.load(ref.files[f]))
    assert not np.array_equal(np.load(got.files["fpa.npy"]), np.load(got.files["fpa2.npy"]))

def test_results_nc_is_cf_with_units_errors_and_provenance(runs):
    xr = pytest.importorskip("xarray")
    netCDF4 = pytest.importorskip("netCDF4")
    p = runs.res.files["results.nc"]
    with netCDF4.Dataset(p) as nc:
        assert nc.data_model == "NETCDF4" and nc.Conventions == "CF-1.10"
        for k in ("irtlang_version", "script_sha256", "seed", "data_tier", "rays_traced"):
            assert k in nc.ncattrs()
    with xr.open_dataset(p) as ds:
        img, man = ds["image_fpa"], runs.res.manifest
        assert img.dims == ("wavelength", "y_image_fpa", "x_image_fpa") and img.attrs["units"] == "W"
        np.testing.assert_array_equal(img.values, np.load(runs.res.files["fpa.npy"]))
        assert img.attrs["irtlang_files"] == "fpa.fits fpa.npy" and "image_fpa_2" not in ds   # stored once
        se = ds[img.attrs["ancillary_variables"]]
        np.testing.assert_array_equal(se.values, np.load(runs.res.files["fpa.stderr.npy"]))
        assert se.attrs["units"] == "W"
        np.testing.assert_array_equal(ds["wavelength"].values, [500.0, 600.0])
        assert ds["wavelength"].attrs["units"] == "nm" and ds["wavelength"].attrs["standard_name"] == "radiation_wavelength"
        x = ds["x_image_fpa"]
        assert x.attrs["units"] == "mm"
        np.testing.assert_allclose(x.values, -5 + (np.arange(11) + 0.5) * 10 / 11, rtol=0, atol=1e-12)
        np.testing.assert_allclose(ds["y_image_fpa"].values, -5 + (np.arange(9) + 0.5) * 10 / 9, atol=1e-12)
        # field angles: atan(x / 1000 mm), arcsec
        np.testing.assert_allclose(ds["field_x_image_fpa"].values,
                                   np.degrees(np.arctan(x.values / 1000.0)) * 3600, rtol=1e-12)
        assert ds["field_x_image_fpa"].attrs["units"] == "arcsec"
        # the spectrum and the ledger are the CSV files' numbers
        spec = np.loadtxt(runs.res.files["spec.csv"], delimiter=",", skiprows=1)
        np.testing.assert_array_equal(ds["spectrum_fpa"].values, spec[:, 1])
        np.testing.assert_array_equal(ds["spectrum_fpa_stderr"].values, spec[:, 2])
        assert ds["spectrum_fpa"].attrs["ancillary_variables"] == "spectrum_fpa_stderr"
        rows = [r.split(",") for r in runs.res.files["ledger.csv"].read_text().splitlines()[1:]]
        assert list(ds["ledger_row"].values) == [r[0] for r in rows]
        np.testing.assert_array_equal(ds["ledger"].values, [[float(v) for v in r[1:]] for r in rows])
        # the image's flux on the detector is the ledger's incident flux on fpa (a detector counts what arrives)
        inc = float(ds["ledger"].sel(ledger_row="fpa", ledger_column="incident_W"))
        assert float(img.sum()) == pytest.approx(inc, rel=1e-12)
        assert ds.attrs["seed"] == 11 and ds.attrs["rays_traced"] == man["rays_traced"] == 2000 * 2
        assert ds.attrs["script_sha256"] == man["script_sha256"] and ds.attrs["data_tier"] == "none"


def test_fits_round_trip_with_astropy(runs):
    fits = pytest.importorskip("astropy.io.fits")
    from astropy.wcs import WCS

    img = np.load(runs.res.files["fpa.npy"])
    se = np.load(runs.res.files["fpa.stderr.npy"])
    with fits.open(runs.res.files["fpa.fits"]) as hdul:
        assert [h.name for h in hdul] == ["FLUX", "STDERR"]
        np.testing.assert_array_equal(hdul[0].data, img)
        np.testing.assert_array_equal(hdul["STDERR"].data, se)
        h = hdul[0].header
        assert h["BUNIT"] == "W" and hdul["STDERR"].header["BUNIT"] == "W"
        assert h["SEED"] == 11 and h["SCRSHA"] == runs.res.manifest["script_sha256"]
        assert h["IRTVER"] == irtlang.__version__ and h["RAYS"] == 4000 and h["DATATIER"] == "none"
        w = WCS(h)
        x, y, lam = w.pixel_to_world_values(np.arange(11), np.zeros(11), np.zeros(11))
        np.testing.assert_allclose(x, -5 + (np.arange(11) + 0.5) * 10 / 11, atol=1e-12)
        _, y, lam = w.pixel_to_world_values(0, np.arange(9), [0, 1, 0, 0, 0, 0, 0, 0, 0])
        np.testing.assert_allclose(y, -5 + (np.arange(9) + 0.5) * 10 / 9, atol=1e-12)
        np.testing.assert_allclose(lam[:2], [500e-9, 600e-9], rtol=1e-12)   # WAVE in SI (m)
        assert [str(u) for u in w.wcs.cunit][:2] == ["mm", "mm"]
        wa = WCS(h, key="A")   # field angles: tan(angle) = x / f, degrees
        ax, ay, _ = wa.pixel_to_world_values(np.arange(11), np.full(11, 4), np.zeros(11))
        ax = (ax + 180) % 360 - 180
        np.testing.assert_allclose(ax, np.degrees(np.arctan((-5 + (np.arange(11) + 0.5) * 10 / 11) / 1000)),
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(ay, 0.0, atol=1e-12)   # row 4 of 9 is centred on y = 0
        w2 = WCS(hdul["STDERR"].header)
        np.testing.assert_allclose(w2.pixel_to_world_values(0, 0, 0)[0], x[0])


def test_frames_with_epoch_and_filter_bands_stack_on_time_and_band(tmp_path):
    """Two hourly frames x two filter bands: the Earth run's layout in small."""
    xr = pytest.importorskip("xarray")
    # step filters with the step at 550 nm, the boundary between the two lines' bins (a TABLE is averaged over
    # each line's bin): red passes only the 600 nm line, blue only the 500 nm line, up to a 1e-5 leak
    (tmp_path / "red.csv").write_text("wavelength_nm,value\n400,0\n550,0\n550.001,1\n800,1\n")
    (tmp_path / "blue.csv").write_text("wavelength_nm,value\n400,1\n550,1\n550.001,0\n800,0\n")
    script = """\
UNITS MM
WAVELENGTHS 500 600 NM
SPECTRUM red TABLE 'red.csv'
SPECTRUM blue TABLE 'blue.csv'
SURFACE
  PLANE Z 0 RECT 2 2
OBJECT fpa
  DETECTOR PIXELS 4 4 FILTERS red blue
DO hour = 0, 1
  EPOCH '2008-03-18T18:19' PLUS (hour * 1 H)
  GRID RECT Z 10 -1 1 -1 1 5 5
  SOURCE DIRECTION 0 0 -1
  FLUX TOTAL (1 + hour)
  TRACE
  EXPORT fpa 'f_{hour}_red.npy' FILTER red
  EXPORT fpa 'f_{hour}_blue.npy' FILTER blue
  SPECTRUM OF fpa
END DO
"""
    (tmp_path / "bands.inr").write_text(script)
    res = irtlang.run(tmp_path / "bands.inr", out=tmp_path / "o")
    ds = res.dataset
    img = ds["image_fpa"]
    assert img.dims == ("time", "band", "y_image_fpa", "x_image_fpa")
    assert list(ds["band"].values) == ["red", "blue"]
    np.testing.assert_allclose(ds["band_wavelength"].values, [600.0, 500.0], rtol=0, atol=1e-3)
    assert [str(t)[:16] for t in ds["time"].values] == ["2008-03-18T18:19", "2008-03-18T19:19"]
    for h in (0, 1):
        for b, band in enumerate(("red", "blue")):
            np.testing.assert_array_equal(img.values[h, b], np.load(res.files[f"f_{h}_{band}.npy"])[0])
    assert ds["spectrum_fpa"].dims == ("time", "wavelength")
    assert list(ds["frame"].values) == [0, 1] and list(ds["rays_per_frame"].values) == [50, 50]
    # the second frame emits twice the flux: each band image of it holds twice the flux (exact: the same rays)
    np.testing.assert_allclose(img.values[1], 2 * img.values[0], rtol=1e-12)
    netCDF4 = pytest.importorskip("netCDF4")
    with netCDF4.Dataset(res.files["results.nc"]) as nc:
        t = nc["time"]
        assert t.units.replace("T", " ") == "hours since 2008-03-18 18:19:00" and t.standard_name == "time"
        np.testing.assert_allclose(t[:], [0.0, 1.0])


def test_check_returns_diagnostic_objects(tmp_path):
    diags = irtlang.check("UNITS MM\nSURFACE\n  PLANE Z 0 RECT 5 5\nOBJECT fpa\n  DETECTOR PIXELS 0 10\n")
    assert len(diags) >= 1
    d = diags[0]
    assert d.span.line == 5 and d.severity == "error" and d.message
    assert re.match(r"script:5:\d+: error: ", d.render())
    (tmp_path / "ok.inr").write_text(SCRIPT)
    assert irtlang.check(tmp_path / "ok.inr") == []
    assert irtlang.check(str(tmp_path / "nope.inr"))[0].message.startswith("no such file")


def test_run_reports_input_errors_and_failures(tmp_path):
    from irtlang.lang.diagnostics import IrtError

    assert irtlang.IrtError is IrtError
    with pytest.raises(IrtError) as e:
        irtlang.run("UNITS MM\nTRACE\n", out=tmp_path / "o1")
    assert "TRACE has no source" in str(e.value.render())
    with pytest.raises(irtlang.RunError) as e:
        irtlang.run("UNITS MM\nSTATS LEDGER\n", out=tmp_path / "o2")
    assert e.value.status.startswith("failed") and (tmp_path / "o2" / "manifest.json").exists()
    assert (tmp_path / "o2" / "results.nc").exists()


def test_set_and_variables(tmp_path):
    res = irtlang.run("DEFAULT n 2\nDEFAULT word 'x'\nr = n * 1 MM\nPRINT 'n={n} {word}'\n",
                      set={"n": 5, "word": "'hello'"}, out=tmp_path / "o")
    assert res.variables["n"] == 5 and res.variables["word"] == "hello"
    assert res.variables["r"] == pytest.approx(5e-3)      # a length, in metres
    assert "n=5 hello" in res.output and res.status == "complete"


def test_import_irtlang_is_cheap():
    import subprocess

    code = ("import sys, irtlang; heavy = [m for m in ('numpy', 'xarray', 'numba', 'lark', 'irtlang.api') "
            "if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                         env={**__import__("os").environ, "PYTHONPATH": str(ROOT)}).stdout.strip()
    assert out == "[]"


# ------------------------------------------------------------------------------------ examples and INCLUDE
def test_irt_examples_lists_and_copies(tmp_path, capsys):
    assert main(["examples"]) == 0
    out = capsys.readouterr().out
    assert "earth.inr" in out and "cassegrain.inr" in out
    assert main(["examples", "telescope_spots", "--copy", str(tmp_path / "ex")]) == 0
    ex = tmp_path / "ex"
    assert (ex / "telescope_spots.inr").exists() and not (ex / "earth.inr").exists()
    assert (ex / "cassegrain.inr").exists() and (ex / "cassegrain_design.inr").exists()   # what it INCLUDEs
    assert (ex / "earth" / "earth_maps.inr").exists() and (ex / "data" / "hri_vis_filter_550.csv").exists()
    assert not (ex / "__init__.py").exists()
    assert main(["examples", "telescope_spots", "--copy", str(ex)]) == 2    # no silent overwrite
    assert "exists" in capsys.readouterr().err
    assert main(["examples", "nosuch", "--copy", str(ex)]) == 2


def test_include_finds_the_installed_examples(tmp_path, monkeypatch):
    """INCLUDE 'cassegrain_design.inr' from a folder of one's own: found on the search path."""
    (tmp_path / "mine.inr").write_text("UNITS MM\nspacing_delta = 0\nINCLUDE 'cassegrain_design.inr'\nPRINT 'efl {efl}'\n")
    assert irtlang.check(tmp_path / "mine.inr") == []
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "mylib.inr").write_text("answer = 42\n")
    (tmp_path / "use.inr").write_text("INCLUDE 'mylib.inr'\nPRINT '{answer}'\n")
    d = irtlang.check(tmp_path / "use.inr")
    assert d and "file not found" in d[0].message and "INCLUDE search path" in d[0].message
    assert "$IRT_PATH" in d[0].render()
    monkeypatch.setenv("IRT_PATH", str(tmp_path / "lib"))
    assert irtlang.check(tmp_path / "use.inr") == []


# ------------------------------------------------------------------------------------ data tier, progress
def test_data_tier_from_the_scene_maps(tmp_path):
    from irtlang.engine import data_tier
    from irtlang.model.scene import MapDef

    def scene(*maps):
        return SimpleNamespace(maps={m.name: m for m in maps})

    assert data_tier(scene()) == "none"
    assert data_tier(scene(MapDef("cover", "LATLON", None, "LANDCOVER"))) == "default"
    f = tmp_path / "m.npy"
    np.save(f, np.zeros((2, 4)))
    assert data_tier(scene(MapDef("m", "LATLON", str(f), None))) == "user"
    (tmp_path / "m.npy.json").write_text(json.dumps({"tier": "real"}))
    assert data_tier(scene(MapDef("m", "LATLON", str(f), None), MapDef("c", "LATLON", None, "SNOW"))) == "default+real"
    assert data_tier(scene(), "default") == "default"     # a run keeps the tiers of its earlier traces


def test_earth_script_reports_the_default_tier():
    """The flagship's maps are MAP ... DEFAULT: its scene says data tier 'default' (it said 'none')."""
    from irtlang.engine import data_tier
    from irtlang.lang.interp import check_file

    it = check_file(ROOT / "examples_scripts" / "earth.inr", ["hours=1"])
    scene = [s for s in it.steps if s.kind == "TRACE"][0].scene
    assert data_tier(scene) == "default"


def test_progress_only_on_a_terminal_or_when_asked(capsys):
    from irtlang.progress import RunProgress

    assert RunProgress().enabled is False          # pytest's stdout is not a terminal
    buf = io.StringIO()
    p = RunProgress(frames=3, enabled=True, stream=buf)
    q = p.start(1000)
    for k in range(0, 1001, 250):
        q.update(k)
    q.update(1000, force=True)     # as the tracer ends a TRACE
    q.close()
    assert p.frame == 1
    # not a terminal but asked for (--progress into a log): plain lines, frame k of n, rays, rate, time left
    assert re.search(r"irt: frame 1/3: 1,000/1,000 rays, [0-9.]+ Mrays/s, 0 s left", buf.getvalue()), buf.getvalue()
    off = RunProgress(enabled=False)
    off.start(10).update(5)
    off.close()
    assert capsys.readouterr().err == ""


def test_cli_seed_and_quiet_flags_parse():
    from irtlang.cli import build_parser

    a = build_parser(["run", "x.inr", "--seed", "5", "--quiet"]).parse_args(["run", "x.inr", "--seed", "5", "--quiet"])
    assert a.seed == 5 and a.quiet and not a.progress
    with pytest.raises(SystemExit):
        build_parser().parse_args(["run", "x.inr", "--quiet", "--progress"])


def test_python_api_doc_runs(tmp_path, monkeypatch):
    """Every python block of docs/python_api.md, in order, as one notebook in an empty folder."""
    pytest.importorskip("astropy")
    text = (ROOT / "docs" / "python_api.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) >= 4
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    for b in blocks:
        exec(compile(b, "docs/python_api.md", "exec"), ns)
    res = ns["res"]
    assert res.status == "complete" and abs(float(ns["spot_x"].values[0]) - 1.0) < 0.1   # within a pixel
    assert math.isclose(ns["x_mm"], float(ns["ds"]["x_image_fpa"].values[0]), rel_tol=1e-12)
