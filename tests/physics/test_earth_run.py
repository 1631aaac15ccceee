"""The flagship run, examples_scripts/earth.inr: a whole Earth seen by the EPOXI HRI on 18-19 March 2008.

Oracles (../shared/ORACLES.md): a 21 um pixel at 10.5 m is 2.000 urad, so at 0.1838 AU a pixel is 55.0 km and the
Earth's polar diameter (2 x 6356.752 km) is 231 px; the illuminated fraction at 57.7 deg phase is
(1 + cos a) / 2 = 0.767; EPOXI's Lambert-fit geometric albedos were 0.14 (950 nm) to 0.35 (350 nm), i.e. apparent
albedos (flux over that of an albedo-1 Lambert sphere = 1.5 p) of 0.21 to 0.53, with the disk blue below 600 nm
and a vegetation red edge.

The fast tier runs the script itself with few rays: one frame of the bare Lambert ellipsoid (`earth_model =
'lambert'`: the same ephemeris, observer, telescope and focal plane, a fast geometry check) and one frame each of
the full Earth over the Pacific (hour 0 of the run).  The slow tier runs the default 25-frame day (the red edge:
land-dominated hours against ocean-dominated ones).
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.ndimage as ndi

from analysis.disk import disk_metrics
from irtlang.cli import main as irt_main
from irtlang.earth.ephemeris import sun_position
from irtlang.lang.diagnostics import IrtError
from irtlang.lang.interp import Interpreter

ROOT = Path(__file__).resolve().parents[2]
EARTH = ROOT / "examples_scripts" / "earth.inr"
BANDS = (350, 450, 550, 650, 750, 850, 950)
A_WGS84, C_WGS84 = 6378.137, 6356.752
EPOXI_APPARENT = (1.5 * 0.14, 1.5 * 0.35)      # apparent albedo range from the Lambert-fit geometric albedos


def run_earth(out: Path, *sets: str) -> Path:
    code = irt_main(["run", str(EARTH), "--out", str(out), *sum((["--set", s] for s in sets), [])])
    assert code == 0, f"irt run earth.inr {sets} exited with {code}"
    return out


def frame(out: Path, tag: str, band: int, window: int = 256) -> np.ndarray:
    a = np.load(out / "frames" / f"{tag}_{band}nm.npy")
    # the camera-side frames: the window x window pixels about the detector's centre (TRACE CAMERA ... WINDOW)
    assert a.shape == (1, window, window) and np.all(np.isfinite(a)) and np.all(a >= 0)
    return a[0]


def spectra(out: Path) -> dict:
    rows = list(csv.DictReader((out / "disk_spectra.csv").open()))
    assert rows and list(rows[0]) == ["time_utc", "wavelength_nm", "flux_W", "stderr_W", "apparent_albedo"]
    by_time: dict = {}
    for r in rows:
        by_time.setdefault(r["time_utc"], []).append([float(r[k]) for k in list(r)[1:]])
    return {t: np.array(v) for t, v in by_time.items()}


def band_mean(s: np.ndarray, lo: float, hi: float) -> tuple[float, float]:
    """Mean apparent albedo over lines in [lo, hi] nm and its standard error (albedo error ~ flux error)."""
    m = (s[:, 0] >= lo) & (s[:, 0] <= hi)
    a = s[m, 3]
    rel = s[m, 2] / np.where(s[m, 1] > 0, s[m, 1], np.inf)
    return float(a.mean()), float(np.sqrt(np.sum((a * rel) ** 2)) / m.sum())


def ledger_gap(path: Path) -> float:
    rows = list(csv.DictReader(path.open()))
    emitted = next(float(r["incident_W"]) for r in rows if r["object"] == "EMITTED")
    return abs(sum(float(r["absorbed_W"]) for r in rows) - emitted) / emitted


# ------------------------------------------------------------------------------------------- script level
def test_shipped_includes_are_what_the_generator_writes(tmp_path):
    from irtlang.earth.models import write_earth_includes

    lines = np.linspace(300.0, 2500.0, 295)
    files = write_earth_includes(tmp_path, lines, clamp=True)
    for name, p in files.items():
        assert (EARTH.parent / "earth" / name).read_bytes() == p.read_bytes(), \
            f"examples_scripts/earth/{name} is stale: run python examples_scripts/earth/make_includes.py"


def _interp(text: str, tmp_path) -> Interpreter:
    f = tmp_path / "t.inr"
    f.write_text(text)
    it = Interpreter(check_only=True)
    it.run_file(f)
    if it.diags:
        raise IrtError(it.diags.items)
    return it


def test_epoch_sets_the_ephemeris(tmp_path):
    import datetime as dt

    it = _interp("EPOCH '2008-03-18T18:19' PLUS (3 * 1 H)\n", tmp_path)
    sp = sun_position(dt.datetime(2008, 3, 18, 21, 19))
    d = math.pi / 180
    assert it.lookup("EPOCH_TAG") == "20080318T2119"
    assert it.lookup("EPOCH_UTC") == "2008-03-18T21:19:00"
    assert it.lookup("GAST").value == pytest.approx(sp.gast_deg * d, abs=1e-12)
    assert it.lookup("SUN_RA").value == pytest.approx(sp.ra_deg * d, abs=1e-12)
    assert it.lookup("SUN_DEC").value == pytest.approx(sp.dec_deg * d, abs=1e-12)
    assert it.lookup("SUN_DIST").value == pytest.approx(sp.distance_au * 1.495978707e11, rel=1e-12)
    # the March equinox of 2008 was on 20 March 05:48 UTC: two days before, the Sun is 0.8 deg south
    assert -0.9 < sp.dec_deg < -0.5


@pytest.mark.parametrize("text, message", [
    ("EPOCH '1700-03-18T18:19'\n", "outside the solar ephemeris' range (years 1800-2200)"),
    ("EPOCH '2200-12-31T23:00' PLUS 2 H\n", "EPOCH 2201-01-01 01:00 is outside the solar ephemeris' range"),
    ("EPOCH '18 March 2008'\n", "is not a date and time"),
])
def test_epoch_bad_input(tmp_path, text, message):
    with pytest.raises(IrtError) as e:
        _interp(text, tmp_path)
    assert message in e.value.diagnostics[0].message


def test_data_file_missing_or_on_the_wrong_grid(tmp_path):
    with pytest.raises(IrtError) as e:
        _interp("MAP clouds LATLON 'no_such_clouds.npy'\n", tmp_path)
    assert "file not found: 'no_such_clouds.npy'" in e.value.diagnostics[0].message
    np.save(tmp_path / "bad.npy", np.zeros((180, 180), np.float32))
    with pytest.raises(IrtError) as e:
        _interp("MAP clouds LATLON 'bad.npy'\n", tmp_path)
    assert "has shape (180, 180)" in e.value.diagnostics[0].message


def test_band_outside_the_spectral_range(tmp_path):
    """The HRI filter and QE tables reach 290-2600 nm: lines beyond them are refused at the SPECTRUM line; an
    EXPORT of a filter the detector does not have is refused too."""
    (tmp_path / "data").symlink_to(EARTH.parent / "data")
    for f in ("cassegrain.inr", "cassegrain_design.inr"):
        (tmp_path / f).symlink_to(EARTH.parent / f)
    with pytest.raises(IrtError) as e:
        _interp("WAVELENGTHS RANGE 300 3000 50 NM\nspacing_delta = 0\nband = 'all'\nINCLUDE 'cassegrain.inr'\n",
                tmp_path)
    assert "covers 290-2600 nm but the wavelength lines need" in e.value.diagnostics[0].message
    with pytest.raises(IrtError) as e:
        _interp("WAVELENGTHS 450 550 NM\nspacing_delta = 0\nband = 'all'\nINCLUDE 'cassegrain.inr'\n"
                "SPECTRUM other TABLE 'data/hri_vis_filter_clear.csv'\nEXPORT fpa 'x.npy' FILTER other\n", tmp_path)
    assert "object fpa has no filter other" in e.value.diagnostics[0].message


def test_earth_model_choice_is_checked(tmp_path):
    assert irt_main(["check", str(EARTH), "--set", "earth_model='marble'"]) == 2
    assert irt_main(["check", str(EARTH), "--set", "clouds='fog'"]) == 2


def test_clear_sky_has_no_cloud_shells(tmp_path):
    """`--set clouds='none'` (docs/earth.md, the clear-sky polarized frame): the same scene without the three
    cloud shells."""
    text = "band = 'all'\nINCLUDE '{}'\nCALL earth_at 0\n"
    names = {}
    for clouds in ("none", "eddington"):
        it = _interp(f"clouds = '{clouds}'\n" + text.format(EARTH.with_name("earth_scene.inr")), tmp_path)
        names[clouds] = {o.name.upper() for o in it.state.objects.values()}
    assert names["eddington"] - names["none"] == {"CLOUD_LOW", "CLOUD_MIDDLE", "CLOUD_HIGH"}, names
    assert names["none"] < names["eddington"]


def test_relief_levels(tmp_path):
    """The ground at its height (docs/earth.md, "Relief"): eight ground levels, each 5 m above an air layer's top
    and in that layer's upper medium, present where ELEVATION rounds to that top; their ranges tile [200 m, inf)
    without gap or overlap, and `relief=0` leaves only the sea-level ground.  The levels' choice is checked
    against published altitudes of four places, each well inside its level's range: the Chang Tang plateau
    (34 N 86 E, about 4.9 km), the Greenland ice sheet's summit (72.6 N 38.5 W, 3216 m), the Tanezrouft in the
    Sahara (23 N 0 E, about 400 m; plain at 350-450 m) and the Amazon at Manaus (3.1 S 60 W, 92 m)."""
    from irtlang.earth.data import load_dataset

    text = "band = 'all'\nrelief = {}\nINCLUDE '{}'\nCALL earth_at 0\n"
    scene = {}
    for relief in (0, 1):
        it = _interp(text.format(relief, EARTH.with_name("earth_scene.inr")), tmp_path)
        scene[relief] = it.state.objects
    assert not any(o.where for o in scene[0].values())
    objs = scene[1]
    levels = sorted((o.where[1], o) for o in objs.values() if o.where is not None)
    assert len(levels) == 8
    lo_hi = [(o.where[1], o.where[2]) for _, o in levels]
    assert lo_hi[0][0] == 200.0 and all(a[1] == b[0] for a, b in zip(lo_hi, lo_hi[1:])) and lo_hi[-1][1] > 8848
    for _, o in levels:
        k = int(o.name.split("_")[1])
        top = objs[f"AIR_{k}_TOP"]
        assert o.surfaces[0].params["a"] - top.surfaces[0].params["a"] == pytest.approx(5.0, abs=1e-6)   # metres
        assert o.interface.back == o.interface.front == top.interface.front
        assert o.scatter and [s.models for s in o.scatter] == [s.models for s in objs["GROUND"].scatter]
    elev = load_dataset("ELEVATION")
    nlat, nlon = elev.shape

    def level_at(lat, lon):
        v = elev[int((90 - lat) / 180 * nlat), int((lon + 180) / 360 * nlon)]
        hits = [o.name for _, o in levels if o.where[1] <= v < o.where[2]]
        assert len(hits) <= 1
        return hits[0] if hits else "ground"

    assert level_at(34.0, 86.0) == "ground_8"          # 5 km: [4250, inf)
    assert level_at(72.6, -38.5) == "ground_6"         # 3 km: [2500, 3250)
    assert level_at(23.0, 0.0) == "ground_1"           # 0.4 km: [200, 600)
    assert level_at(-3.1, -60.0) == "ground"           # sea level: below 200 m


# ------------------------------------------------------------------------------------------- geometry
@pytest.fixture(scope="module")
def lambert_run(tmp_path_factory):
    return run_earth(tmp_path_factory.mktemp("earth_lambert"), "hours=1", "sun_rays=4000", "save_rays=0",
                     "earth_model='lambert'")


def test_disk_size_scale_and_phase(lambert_run):
    """The lit disk in the seven bands' sum (smoothed by 1 px against the Monte Carlo noise; lit = above 2 % of the
    maximum).  North is up, so the lit pixels span the polar diameter in rows (both poles lie on the lit limb at
    equinox); the scale follows from the known polar axis; the lit area over the disk's (pi a b in px) is the
    illuminated fraction, short of the faint terminator band below the threshold (at most 2 x 0.02 / pi = 0.013
    for a Lambert sphere, ORACLES.md / docs/analysis.md)."""
    img = ndi.gaussian_filter(sum(frame(lambert_run, "20080318T1819", b) for b in BANDS), 1.0)
    lit = img > 0.02 * img.max()
    rows = np.nonzero(lit.any(axis=1))[0]
    polar_px = rows[-1] - rows[0] + 1
    assert polar_px == pytest.approx(231.0, abs=3.0)
    km_per_px = 2 * C_WGS84 / polar_px
    assert km_per_px == pytest.approx(55.0, abs=0.5)
    a_px, c_px = A_WGS84 / km_per_px, C_WGS84 / km_per_px
    assert lit.sum() / (math.pi * a_px * c_px) == pytest.approx(0.76, abs=0.02)


def test_lambert_ellipsoid_albedo(lambert_run):
    """The bare ellipsoid of albedo 0.3 seen through the whole pipeline (Sun, ephemeris, observer, pupil, series):
    its apparent albedo is 0.3 within its standard error (5 sigma) plus the ellipsoid's departure from the
    sphere of radius sqrt(a c) (0.2 %)."""
    s = next(iter(spectra(lambert_run).values()))
    m = (s[:, 0] >= 400) & (s[:, 0] <= 900)
    a, se = band_mean(s, 400, 900)
    assert a == pytest.approx(0.3, abs=5 * se + 0.3 * 0.004)
    assert ledger_gap(lambert_run / "ledger_first_frame.csv") < 1e-12
    assert np.all(s[m, 2] > 0)


# ------------------------------------------------------------------------------------------- the full Earth
@pytest.fixture(scope="module")
def pacific(tmp_path_factory):
    """Hour 0 of the run: the Pacific in view (sub-observer longitude about -150 deg)."""
    return run_earth(tmp_path_factory.mktemp("earth_pacific"), "hours=1", "sun_rays=2000")


def test_outputs_and_provenance(pacific):
    tag = "20080318T1819"
    for b in BANDS:
        frame(pacific, tag, b)
        assert (pacific / "frames" / f"{tag}_{b}nm.stderr.npy").exists()
    assert (pacific / "rgb" / f"{tag}.png").stat().st_size > 0
    assert (pacific / "spectra" / f"{tag}.csv").exists()
    assert (pacific / "disk_spectra_time_wavelength.png").exists()
    assert (pacific / "disk_spectrum_mean.png").stat().st_size > 0
    assert (pacific / "disk_spectrum_mean.csv").read_text().startswith("wavelength_nm,mean_apparent_albedo,stderr,")
    import h5py

    for which in ("toa", "pupil"):
        with h5py.File(pacific / "rays" / f"{tag}_{which}.h5", "r") as h:
            assert len(h.attrs) > 0
    man = json.loads((pacific / "manifest.json").read_text())
    # the forward trace's Sun rays, then the camera trace's rays (256 x 256 pixels x the lines of the bands)
    assert man["seed"] == 20080318 and man["rays_traced"] > 2000 * 295
    assert man["data_tier"] == "default"     # its maps are MAP ... DEFAULT or built-in files (said "none")
    listed = {f["path"] for f in man["files"]}
    assert {"disk_spectra.csv", f"frames/{tag}_450nm.npy", f"rays/{tag}_toa.h5"} <= listed
    s = spectra(pacific)["2008-03-18T18:19:00Z"]
    assert s.shape == (295, 4) and s[0, 0] == pytest.approx(300.0) and s[-1, 0] == pytest.approx(2500.0)
    assert np.all(np.isfinite(s)) and np.all(s[:, 2] >= 0)


def test_ledger_closes(pacific):
    assert ledger_gap(pacific / "ledger_first_frame.csv") < 1e-12


def test_blue_disk_and_albedo_in_the_epoxi_range(pacific):
    s = next(iter(spectra(pacific).values()))
    a450, e450 = band_mean(s, 400, 500)
    a550, e550 = band_mean(s, 500, 600)
    # bluer at 450 than at 550 nm: a one-sided claim, decided at 3 standard errors of the difference (with 2000
    # rays per line the difference is about 3.6 of them; 5 would need 4x the rays in the fast tier)
    assert a450 - a550 > 3 * math.hypot(e450, e550), (a450, e450, a550, e550)
    vis, evis = band_mean(s, 450, 650)
    assert EPOXI_APPARENT[0] + 5 * evis <= vis <= EPOXI_APPARENT[1] - 5 * evis, (vis, evis)


def test_o2_a_band_and_ice_water_absorption_in_the_disk_spectrum(pacific):
    """Issue 16: the O2 A band line (763.9 nm: gas per line, docs/earth.md) lies below its neighbours 15 nm away,
    and the disk is darker at 2.1-2.2 um than at 550 nm (ice and liquid water absorb); one-sided claims decided at
    3 standard errors of the difference (with 2000 rays the A band stands about 8 of them below, the 2.2 um
    deficit about 10)."""
    s = next(iter(spectra(pacific).values()))
    a, e = s[:, 3], s[:, 3] * s[:, 2] / s[:, 1]
    j = int(np.argmin(abs(s[:, 0] - 763.9)))
    side = 0.5 * (a[j - 2] + a[j + 2])
    assert side - a[j] > 3 * math.hypot(e[j], 0.5 * math.hypot(e[j - 2], e[j + 2])), (a[j - 2:j + 3], e[j - 2:j + 3])
    a550, e550 = band_mean(s, 500, 600)
    a2200, e2200 = band_mean(s, 2100, 2250)
    assert a550 - a2200 > 3 * math.hypot(e550, e2200), (a550, e550, a2200, e2200)


def test_frame_errors_explain_two_seeds(tmp_path):
    """The flagship's per-pixel standard errors explain the scatter between two runs with different seeds,
    through the whole Earth (guided camera rays, clouds, maps, the atmosphere's shells): over the lit pixels of
    the 450, 550 and 650 nm images, sum (a - b)^2 / sum (se_a^2 + se_b^2) is 1 within 5 sigma (Gaussian
    differences: sigma = sqrt(2 sum v^2) / sum v).  The default since 2026-12-05: 7 rays per pixel, each carrying
    a line of each of the 7 spectral strata (HERO 7), the errors from the spread between the rays, each ray's
    lines summed per image before squaring (docs/tracer.md, "Standard errors per pixel").  Measured then on the
    full 256 x 256 window: the square root of the ratio 0.98-0.99.  (Earlier, 14 samples in 7 pairs: 0.99 +- 0.03;
    15 unpaired samples without HERO gave 0.39 +- 0.03, the spread between strata counted as noise.)  The oracle is
    the second run, an independent estimate of the same frame."""
    from irtlang.core.stats import lit_pixels

    small = ("hours=1", "sun_rays=10", "save_rays=0", "window=64", "pupil_directions=1")
    outs = []
    for key, seed in (("a", None), ("b", 777)):
        out = tmp_path / key
        args = ["run", str(EARTH), "--out", str(out), *sum((["--set", s] for s in small), [])]
        assert irt_main(args + (["--seed", str(seed)] if seed is not None else [])) == 0
        outs.append(out)
    num = den = den2 = 0.0
    for band in (450, 550, 650):
        (a, ae), (b, be) = ((frame(o, "20080318T1819", band, 64),
                             np.load(o / "frames" / f"20080318T1819_{band}nm.stderr.npy")[0]) for o in outs)
        m = 0.5 * (a + b)
        lit = lit_pixels(m) & (m > 0)
        assert lit.sum() > 2000, lit.sum()      # the centre 64 x 64 pixels lie on the lit disk
        v = ae[lit] ** 2 + be[lit] ** 2
        num += float(((a - b)[lit] ** 2).sum())
        den += float(v.sum())
        den2 += float((v * v).sum())
        assert not np.array_equal(a, b)
    ratio, sd = num / den, math.sqrt(2.0 * den2) / den
    assert abs(ratio - 1.0) < 5.0 * sd, (ratio, sd)


def test_same_seed_same_images(tmp_path):
    """Two runs of an Earth frame in one process, with the same seed, give the same bits: camera-side frames and
    spectra (the second run also takes the image trace's pilot from the first's cache).  Recorded as a known
    failure on 2026-12-01: in one full-suite run the camera-side frames differed.  The likely cause, fixed the
    same evening, was the slab models' albedo tables, whose SciPy barycentric weights came from NumPy's global
    random state (test_earth_reproducible.py).  It has passed in every full-suite run since (2026-12-02 to
    2026-12-03), so it is a plain test again: a failure here is a reproducibility bug."""
    small = ("hours=1", "sun_rays=40", "save_rays=0", "window=96", "spectral_samples=7")   # 96 px about the centre
    a = run_earth(tmp_path / "a", *small)
    b = run_earth(tmp_path / "b", *small)
    for band in (450, 850):
        fa, fb = frame(a, "20080318T1819", band, 96), frame(b, "20080318T1819", band, 96)
        assert fa.sum() > 0 and np.array_equal(fa, fb)
    assert (a / "disk_spectra.csv").read_text() == (b / "disk_spectra.csv").read_text()


# ------------------------------------------------------------------------------------------- the day
@pytest.mark.slow
def test_the_default_day(tmp_path):
    """`irt run examples_scripts/earth.inr` as it is: 25 frames, the animation, the day's spectra."""
    out = run_earth(tmp_path / "day")
    sp = spectra(out)
    assert len(sp) == 25
    assert (out / "earth.gif").stat().st_size > 0
    for t, s in sp.items():
        a450, _ = band_mean(s, 420, 480)
        a550, _ = band_mean(s, 520, 580)
        assert a450 > a550, t
        vis, _ = band_mean(s, 450, 650)
        assert EPOXI_APPARENT[0] <= vis <= EPOXI_APPARENT[1], (t, vis)



def _nir_red(s):
    nir, en = band_mean(s, 720, 1000)
    red, er = band_mean(s, 590, 690)
    return nir / red, nir / red * math.hypot(en / nir, er / red)


@pytest.mark.slow
def test_red_edge_over_land_dominated_hours(tmp_path):
    """The near-infrared (720-1000 nm) to red (590-690 nm) ratio of the disk is larger while Africa and Europe are
    in view (hours 10-14 of the day: sub-observer longitude 0-60 E) than over the Pacific (hours 0-2: about
    -150 to -120 E), by more than 3 standard errors of the difference.  The default day (800 rays per line) sees
    the difference at about 1.6 standard errors; these runs use 4x the rays on the hours compared."""
    ocean = run_earth(tmp_path / "ocean", "hours=3", "sun_rays=3200", "save_rays=0")
    land = run_earth(tmp_path / "land", "hours=5", "sun_rays=3200", "save_rays=0", "start_utc='2008-03-19T04:19'")
    ro = [_nir_red(s) for s in spectra(ocean).values()]
    rl = [_nir_red(s) for s in spectra(land).values()]
    d = np.mean([x for x, _ in rl]) - np.mean([x for x, _ in ro])
    sd = math.hypot(math.sqrt(sum(e * e for _, e in rl)) / len(rl), math.sqrt(sum(e * e for _, e in ro)) / len(ro))
    assert d > 3 * sd, (d, sd)


def test_polarized_frame(tmp_path):
    """`--set polarization=1` (issue 19): one forward frame traced with Stokes vectors.  The disk-integrated
    Stokes spectrum at the entrance pupil (a one-pixel detector: exact standard errors; lines are independent rays,
    so band sums add their variances) against what single Rayleigh scattering predicts, a physical expectation
    rather than a number from a peer code (the numbers are checked in test_polarization.py): the Sun and the
    observer lie near the equatorial plane, so the scattering plane is the pupil's x axis (east-west) and the
    electric vector stands normal to it: Q < 0 and |U| << |Q|; and the degree is larger in the blue (more Rayleigh
    light) than in the red.  Each decided at 5 standard errors (the ratio's by the delta method with Q and I taken
    as independent, which overstates it: they are anticorrelated here).  Also: the Stokes maps are written and the
    ledger of the polarized frame closes."""
    out = run_earth(tmp_path, "hours=1", "polarization=1", "sun_rays=800", "window=16", "spectral_samples=1")
    tag = "20080318T1819"
    rows = list(csv.DictReader((out / "polarization" / f"{tag}_disk.csv").open()))
    a = np.array([[float(r[k]) for k in ("wavelength_nm", "I_W", "Q_W", "U_W", "stderr_I_W", "stderr_Q_W",
                                         "stderr_U_W")] for r in rows])
    assert a.shape == (295, 7)

    def band(lo, hi):
        m = (a[:, 0] >= lo) & (a[:, 0] <= hi)
        I, Q, U = (a[m, k].sum() for k in (1, 2, 3))
        sI, sQ, sU = (math.sqrt((a[m, k] ** 2).sum()) for k in (4, 5, 6))
        return I, Q, U, sI, sQ, sU

    deg = {}
    for lo, hi in ((400, 500), (600, 700)):
        I, Q, U, sI, sQ, sU = band(lo, hi)
        assert Q + 5 * sQ < 0, (lo, Q, sQ)
        assert abs(U) <= 0.05 * abs(Q) + 5 * sU, (lo, U, sU, Q)
        q = -Q / I
        deg[lo] = (q, math.hypot(sQ / I, q * sI / I))
    (q4, s4), (q6, s6) = deg[400], deg[600]
    assert q4 - q6 > 5 * math.hypot(s4, s6), deg
    for b in (450, 550, 650):
        for k in ("I", "Q", "U", "V", "DOLP", "AOLP"):
            m = np.load(out / "polarization" / f"{tag}_{b}nm_{k}.npy")
            assert m.shape == (1, 128, 128) and np.all(np.isfinite(m))
    assert ledger_gap(out / "ledger_first_frame.csv") < 1e-12
