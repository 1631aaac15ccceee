"""Clouds hour by hour: the generated field's evolution (irtlang.earth.data.cloud_weather) against its own
stated model, and the MERRA-2 hourly loader wired into scripts (MAP ... MERRA2) on files with the real structure
of M2T1NXRAD (MERRA-2 tavg1_2d_rad_Nx: one file a day, 24 hourly means stamped at HH:30, 361 x 576 grid,
float32 CLDLOW/CLDMID/CLDHGH/CLDTOT with _FillValue 1e15, `time` in 'minutes since YYYY-MM-DD 00:30:00'),
which the tests write themselves (nothing is downloaded).

Oracles: the model's correlation cos(2 pi dt / 96 h) in the frame moving with the wind, checked at 6, 12 and 24 h
within 5 standard errors of a sample correlation over the field's effective number of independent samples
(the sphere's area over 2 pi l^2); the zonal drift; the climatology kept at every hour (GEWEX: 0.68 +- 0.03);
the MERRA-2 map against read_merra2 of the same step, quantized to the ten levels by hand.
"""
import datetime as dt
import math

import numpy as np
import pytest

from irtlang.earth import data as D
from irtlang.earth.latlon import area_weighted_mean, cell_centres, read_sidecar
from irtlang.earth.products import ProductError, merra2_step, merra2_times, read_merra2

NLAT = 90     # a 2 deg grid keeps the random fields quick


@pytest.fixture(scope="module")
def fields():
    return D.cloud_base_fields(NLAT, seed=11)


def test_hour_zero_is_the_default_field(fields):
    assert np.array_equal(D.cloud_weather("low", fields["low"], 0.0), fields["low"][0])


def test_weather_is_the_rotated_pair_moved_by_the_wind(fields):
    za, zb = fields["middle"]
    t = 7.0
    z = D.cloud_weather("middle", fields["middle"], t)
    lat, _ = cell_centres(NLAT)
    u = np.interp(lat, D.CLOUD_LAT_NODES, D.CLOUD_WIND_M_S["middle"])
    shift = np.degrees(u * 3.6 * t / (D.EARTH_RADIUS_KM * np.cos(np.radians(lat))))
    w = 2 * math.pi * t / D.CLOUD_PERIOD_H
    back = D.advect_zonal(z, -shift)                           # undo the drift: the pair itself
    want = math.cos(w) * za + math.sin(w) * zb
    inner = slice(5, NLAT - 5)                                  # interpolating twice smooths a little
    assert np.corrcoef(back[inner].ravel(), want[inner].ravel())[0, 1] > 0.995


def test_advection_moves_a_row_by_whole_cells_exactly():
    z = np.random.default_rng(1).standard_normal((4, 8))
    assert np.array_equal(D.advect_zonal(z, np.full(4, 90.0)), np.roll(z, 2, axis=1))
    assert np.allclose(D.advect_zonal(z, np.full(4, -45.0)), np.roll(z, -1, axis=1))


@pytest.mark.parametrize("hours", [6.0, 12.0, 24.0])
def test_correlation_in_the_moving_frame_is_the_model(fields, hours):
    corr = []
    for layer in ("low", "middle", "high"):
        z0 = D.cloud_weather(layer, fields[layer], 0.0)
        zt = D.cloud_weather(layer, fields[layer], hours)
        lat, _ = cell_centres(NLAT)
        u = np.interp(lat, D.CLOUD_LAT_NODES, D.CLOUD_WIND_M_S[layer])
        shift = np.degrees(u * 3.6 * hours / (D.EARTH_RADIUS_KM * np.cos(np.radians(lat))))
        back = D.advect_zonal(zt, -shift)
        inner = slice(10, NLAT - 10)
        want = math.cos(2 * math.pi * hours / D.CLOUD_PERIOD_H)
        n_eff = 4 * math.pi * D.EARTH_RADIUS_KM ** 2 / (2 * math.pi * D.CLOUD_CORRELATION_KM[layer] ** 2)
        se = math.sqrt((1 + want ** 2) / n_eff)             # var of a sample correlation of jointly Gaussian fields
        got = np.corrcoef(back[inner].ravel(), z0[inner].ravel())[0, 1]
        assert got == pytest.approx(want, abs=5 * se + 0.01), layer
        corr.append(got)
    assert corr  # every layer checked


def test_the_clouds_move_and_keep_their_climatology():
    lf = D.load_dataset("LAND_FRACTION")
    lm = D.load_dataset("LAND_MASK")
    p0 = D.hourly_cloud_path("CLOUD_FRACTION", 0.0)
    assert p0 == D.ensure("CLOUD_FRACTION")
    for h in (6.0, 18.0):
        tot = np.load(D.hourly_cloud_path("CLOUD_FRACTION", h))
        assert area_weighted_mean(tot) == pytest.approx(0.68, abs=0.03)
        assert 0.50 < area_weighted_mean(tot, lm == 1) < 0.63
        assert not np.array_equal(tot, np.load(p0))
        assert len(np.unique(tot)) == 10
        low = np.load(D.hourly_cloud_path("CLOUD_LOW", h))
        assert np.array_equal(low, D.cloud_fraction_maps(lf, hour=h)["low"])
        info = read_sidecar(D.hourly_cloud_path("CLOUD_LOW", h))
        assert info.get("parameters", {}).get("hour") == h and info.get("proxy") is True
    with pytest.raises(D.DatasetUnavailable, match="does not change with time"):
        D.hourly_cloud_path("LANDCOVER", 3.0)


# ---------------------------------------------------------------- MERRA-2 M2T1NXRAD
VARS = ("CLDLOW", "CLDMID", "CLDHGH", "CLDTOT")


def write_m2t1nxrad(path, day: dt.date, seed: int):
    """A file with the structure of MERRA2_300.tavg1_2d_rad_Nx.YYYYMMDD.nc4 (netCDF-4 / HDF5)."""
    import h5py

    rng = np.random.default_rng(seed)
    lat = np.linspace(-90.0, 90.0, 361)
    lon = -180.0 + 0.625 * np.arange(576)
    LA, LO = np.meshgrid(np.radians(lat), np.radians(lon), indexing="ij")
    with h5py.File(path, "w") as f:
        f.attrs["ShortName"] = "M2T1NXRAD"
        f.attrs["LongName"] = "MERRA2 tavg1_2d_rad_Nx: 2d,1-Hourly,Time-Averaged,Single-Level,Assimilation,Radiation Diagnostics"
        f.attrs["RangeBeginningDate"] = day.isoformat()
        for name, v, units in (("lat", lat, "degrees_north"), ("lon", lon, "degrees_east")):
            d = f.create_dataset(name, data=v)
            d.attrs["units"] = units
            d.make_scale(name)
        t = f.create_dataset("time", data=np.arange(0, 1440, 60, dtype=np.int32))
        t.attrs["units"] = f"minutes since {day.isoformat()} 00:30:00"
        t.attrs["begin_date"] = np.int32(int(day.strftime("%Y%m%d")))
        t.attrs["begin_time"] = np.int32(3000)
        t.attrs["time_increment"] = np.int32(10000)
        t.make_scale("time")
        for k, name in enumerate(VARS):
            a, b = rng.uniform(0, 2 * math.pi, 2)
            hours = np.arange(24)[:, None, None]
            field = 0.5 + 0.45 * np.sin(3 * LA + a + 0.1 * hours) * np.cos(2 * LO + b - 0.2 * hours)
            d = f.create_dataset(name, data=field.astype(np.float32), chunks=(1, 91, 144), compression="gzip")
            d.attrs["_FillValue"] = np.float32(1e15)
            d.attrs["units"] = "1"
            d.attrs["long_name"] = f"cloud_area_fraction_{name}"
            for i, s in enumerate(("time", "lat", "lon")):
                d.dims[i].attach_scale(f[s])


@pytest.fixture(scope="module")
def merra_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("merra")
    for k, day in enumerate((dt.date(2008, 3, 18), dt.date(2008, 3, 19))):
        write_m2t1nxrad(d / f"MERRA2_300.tavg1_2d_rad_Nx.{day:%Y%m%d}.nc4", day, seed=k)
    return d


def test_merra2_times_and_steps(merra_dir):
    files = sorted(merra_dir.glob("*.nc4"))
    ts = merra2_times(files[0])
    assert len(ts) == 24 and ts[0] == dt.datetime(2008, 3, 18, 0, 30) and ts[-1] == dt.datetime(2008, 3, 18, 23, 30)
    assert merra2_step(files, "2008-03-18T18:19:00") == (files[0], 18)      # the 18:00-19:00 mean, stamped 18:30
    assert merra2_step(files, dt.datetime(2008, 3, 18, 23, 59)) == (files[0], 23)
    assert merra2_step(files, dt.datetime(2008, 3, 19, 0, 0)) == (files[1], 0)
    with pytest.raises(ProductError, match="no MERRA-2 step covers 2008-03-20 00:00"):
        merra2_step(files, dt.datetime(2008, 3, 20, 0, 0))


SCRIPT = """UNITS KM
EPOCH '2008-03-18T18:19' PLUS ({h} * 1 H)
MAP low LATLON MERRA2 '{pattern}' CLDLOW
MAP mid LATLON MERRA2 '{pattern}' CLDMID
MAP gen LATLON DEFAULT CLOUD_HIGH AT ({h} * 1 H)
"""


@pytest.mark.parametrize("h, day, idx", [(0, 0, 18), (6, 1, 0), (24, 1, 18)])
def test_script_reads_the_merra2_step_of_the_epoch(merra_dir, tmp_path, h, day, idx):
    from irtlang.lang.interp import check_file

    f = tmp_path / "s.inr"
    f.write_text(SCRIPT.format(h=h, pattern=str(merra_dir / "MERRA2_300.tavg1_2d_rad_Nx.2008031*.nc4")))
    it = check_file(f)
    src = sorted(merra_dir.glob("*.nc4"))[day]
    for mname, var in (("LOW", "CLDLOW"), ("MID", "CLDMID")):
        got = np.load(it.state.maps[mname].path)
        ref = read_merra2(src, var, 360, time_index=idx).data
        want = np.round(np.clip(ref, 0, 1) * 9) / 9          # the ten levels 0, 1/9, ..., 1
        assert got.shape == (360, 720) and np.allclose(got, want, atol=1e-6)
        assert len(np.unique(got)) == 10
    gen = np.load(it.state.maps["GEN"].path)
    assert np.array_equal(gen, np.load(D.hourly_cloud_path("CLOUD_HIGH", float(h))))


@pytest.mark.parametrize("text, msg", [
    ("MAP low LATLON MERRA2 '{pattern}' CLDLOW\n", "no EPOCH has been set"),
    ("EPOCH '2008-03-21T12:00'\nMAP low LATLON MERRA2 '{pattern}' CLDLOW\n", "no MERRA-2 step covers 2008-03-21 12:00"),
    ("EPOCH '2008-03-18T12:00'\nMAP low LATLON MERRA2 '{pattern}' CLDLOWX\n", "has no dataset 'CLDLOWX'"),
    ("EPOCH '2008-03-18T12:00'\nMAP low LATLON MERRA2 'nothing_*.nc4' CLDLOW\n", "no MERRA-2 file matches"),
    ("MAP c LATLON DEFAULT LANDCOVER AT (3 * 1 H)\n", "does not change with time"),
])
def test_bad_merra2_and_at_input_is_a_located_error(merra_dir, tmp_path, text, msg):
    from irtlang.lang.diagnostics import IrtError
    from irtlang.lang.interp import check_file

    f = tmp_path / "bad.inr"
    f.write_text("UNITS KM\n" + text.format(pattern=str(merra_dir / "*.nc4")))
    with pytest.raises(IrtError) as e:
        check_file(f)
    assert msg in str(e.value) and "bad.inr:" in str(e.value)


def test_the_earth_script_takes_the_clouds_of_each_hour(merra_dir):
    """examples_scripts/earth.inr: the generated clouds of hour k by default, MERRA-2's step of each frame's EPOCH
    with --set clouds_file=... (frames at 18:19 and 19:19 UTC: the 18:30 and 19:30 means)."""
    from pathlib import Path

    from irtlang.lang.interp import check_file

    script = Path(__file__).resolve().parents[2] / "examples_scripts" / "earth.inr"
    base = ["hours=2", "sun_rays=10", "save_rays=0"]
    pattern = str(merra_dir / "MERRA2_300.tavg1_2d_rad_Nx.2008031*.nc4")
    for extra, names in (([], ["CLOUD_LOW.npy", "CLOUD_LOW_T+0001.000H.npy"]),
                         ([f"clouds_file='{pattern}'"], ["MERRA2_300.tavg1_2d_rad_Nx.20080318_CLDLOW_18.npy",
                                                         "MERRA2_300.tavg1_2d_rad_Nx.20080318_CLDLOW_19.npy"])):
        it = check_file(script, base + extra)
        # the image traces, one per frame (the forward trace runs in the first frame only)
        traces = [s for s in it.steps if s.kind == "TRACE" and (s.params.get("camera") or {}).get("camera") == "FPA"]
        assert len(traces) == 2
        for st, want in zip(traces, names):
            assert Path(st.scene.maps["CLOUD_LOW"].path).name == want
        if extra:
            high = traces[1].scene.maps["CLOUD_HIGH"].path
            assert Path(high).name.endswith("_CLDHGH_19.npy")
