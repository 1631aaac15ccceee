"""The real data tier (irtlang.earth.products) on small files the tests write with the products' own dataset
names, types, fill values and grids: MCD43C1, MCD12C1 and MOD10CM on the 0.05 deg CMG (3600 x 7200, compressed
so they stay small), AMSR-E AE_SI12 on the NSIDC 12.5 km polar stereographic grids, MERRA-2 on its 361 x 576
grid.  The MODIS files are written as HDF4 (with pyhdf, where installed) and as HDF5 conversions.

Independent numbers: the corner coordinates NSIDC publishes for its polar stereographic grids (NSIDC,
"Polar Stereographic Projections and Grids"): northern grid upper left 30.98 N 168.35 E, lower right 34.35 N
350.03 E, lower left 33.92 N 279.26 E; southern grid upper left 39.23 S 317.76 E, lower right 41.45 S 135.00 E.
"""
import math

import h5py
import numpy as np
import pytest

from irtlang.earth import products as P
from irtlang.earth.latlon import LatLonGrid, cell_centres
from irtlang.io.maps import check_latlon_file
from irtlang.lang.diagnostics import NO_SPAN

R = np.arange(3600)[:, None]
Q = np.arange(7200)[None, :]


def write_hdf4(path, datasets: dict):
    """datasets: name -> (array, attrs).  Written as the products are: HDF4 SDS, deflate-compressed."""
    SD = pytest.importorskip("pyhdf.SD")
    types = {np.dtype(np.int16): SD.SDC.INT16, np.dtype(np.uint8): SD.SDC.UINT8, np.dtype(np.float32): SD.SDC.FLOAT32,
             np.dtype(np.int32): SD.SDC.INT32}
    f = SD.SD(str(path), SD.SDC.WRITE | SD.SDC.CREATE | SD.SDC.TRUNC)
    for name, (arr, attrs) in datasets.items():
        t = types[arr.dtype]
        s = f.create(name, t, arr.shape)
        s.setcompress(SD.SDC.COMP_DEFLATE, value=1)
        s[:] = arr
        for k, v in attrs.items():
            if isinstance(v, (tuple, list)):
                s.attr(k).set(t, list(v))
            elif isinstance(v, float):
                s.attr(k).set(SD.SDC.FLOAT64, v)
            else:
                s.attr(k).set(t, int(v))
        s.endaccess()
    f.end()


def write_hdf5(path, datasets: dict, group="MOD_Grid/Data Fields"):
    with h5py.File(path, "w") as f:
        g = f.require_group(group) if group else f
        for name, (arr, attrs) in datasets.items():
            d = g.create_dataset(name, data=arr, compression="gzip", compression_opts=1, chunks=True)
            for k, v in attrs.items():
                d.attrs[k] = v


MODIS_ATTRS = {"_FillValue": 32767, "scale_factor": 0.001, "add_offset": 0.0, "valid_range": (0, 32766)}


def mcd43_datasets(band=1):
    iso = (100 + R // 10 + 0 * Q).astype(np.int16)            # iso = 0.1 + 0.001 (row of the 0.5 deg grid)
    vol = (0 * R + (Q // 10) % 500).astype(np.int16)           # vol = 0.001 (column mod 500)
    geo = np.full((3600, 7200), 20, np.int16)
    geo[0:10, 0:10] = 32767                                     # fill: no retrieval in the first 0.5 deg cell
    return {f"BRDF_Albedo_Parameter{k}_Band{band}": (a, MODIS_ATTRS) for k, a in ((1, iso), (2, vol), (3, geo))}


@pytest.fixture(scope="module", params=["hdf4", "hdf5"])
def mcd43(request, tmp_path_factory):
    p = tmp_path_factory.mktemp("mcd43") / ("MCD43C1.A2008078.061.hdf" if request.param == "hdf4" else "MCD43C1.h5")
    (write_hdf4 if request.param == "hdf4" else write_hdf5)(p, mcd43_datasets())
    return p


def test_mcd43c1_kernel_weights(mcd43):
    k = P.read_mcd43c1(mcd43, 1)
    assert set(k) == {"iso", "vol", "geo"}
    iso, vol, geo = k["iso"].data, k["vol"].data, k["geo"].data
    assert iso.shape == (3600, 7200)
    assert iso[0, 0] == pytest.approx(0.100) and iso[-1, 0] == pytest.approx(0.100 + 0.359)
    assert vol[0, 7199] == pytest.approx(0.001 * (719 % 500))
    assert np.isnan(geo[5, 5]) and geo[20, 20] == pytest.approx(0.020)
    assert k["iso"].meta["product"] == "MCD43C1" and k["iso"].meta["proxy"] is False
    # where a latitude / longitude falls: row 0 is 90 .. 89.95 N, column 0 is 180 .. 179.95 W
    assert k["iso"].value_at(-89.99, 0.0) == pytest.approx(0.459)
    coarse = P.read_mcd43c1(mcd43, 1, nlat=360)
    assert coarse["iso"].data.shape == (360, 720)
    assert coarse["iso"].data[123, 7] == pytest.approx(0.1 + 0.123)
    assert np.isnan(coarse["geo"].data[0, 0])
    filled = P.fill_nan(coarse["geo"])
    assert filled.data[0, 0] == pytest.approx(0.020)


def test_mcd43c1_errors(tmp_path, mcd43):
    with pytest.raises(FileNotFoundError, match="no such file"):
        P.read_mcd43c1(tmp_path / "nope.hdf", 1)
    with pytest.raises(P.ProductError, match="no dataset 'BRDF_Albedo_Parameter1_Band2'.*Band1"):
        P.read_mcd43c1(mcd43, 2)
    with pytest.raises(ValueError, match="give 1-7"):
        P.read_mcd43c1(mcd43, 9)
    small = tmp_path / "small.h5"
    write_hdf5(small, {f"BRDF_Albedo_Parameter{k}_Band1": (np.zeros((360, 720), np.int16), MODIS_ATTRS)
                       for k in (1, 2, 3)})
    with pytest.raises(P.ProductError, match=r"shape \(360, 720\), not the 0.05 deg climate-modelling grid"):
        P.read_mcd43c1(small, 1)
    junk = tmp_path / "junk.hdf"
    junk.write_bytes(b"not a product")
    with pytest.raises(P.ProductError, match="not an HDF4"):
        P.read_mcd43c1(junk, 1)


@pytest.mark.parametrize("fmt", ["hdf4", "hdf5"])
def test_mcd12c1_land_cover(tmp_path, fmt):
    lc = ((R // 200 + Q // 400) % 17).astype(np.uint8)
    lc[0:20, 0:20] = 255
    p = tmp_path / f"MCD12C1.{fmt}"
    (write_hdf4 if fmt == "hdf4" else write_hdf5)(p, {"Majority_Land_Cover_Type_1": (lc, {"_FillValue": 255})})
    g = P.read_mcd12c1(p)
    assert g.data.dtype == np.uint8 and g.data[0, 0] == 0 and g.meta["fill_cells"] == 400
    assert g.data[3599, 7199] == (3599 // 200 + 7199 // 400) % 17
    c = P.read_mcd12c1(p, nlat=360)
    assert c.data.shape == (360, 720)
    assert c.data[100, 300] == (1000 // 200 + 3000 // 400) % 17         # block mode of a uniform block
    bad = tmp_path / "bad.h5"
    write_hdf5(bad, {"Majority_Land_Cover_Type_1": (np.full((3600, 7200), 40, np.uint8), {})})
    with pytest.raises(P.ProductError, match="IGBP legend is 0-16"):
        P.read_mcd12c1(bad)


def test_mod10cm_snow_fraction(tmp_path):
    s = np.full((3600, 7200), 254, np.uint8)          # water
    s[:1000] = 100                                     # north of 40 N: snow
    s[1000:1200] = 37
    s[1200:1210] = 250                                 # cloud obscured
    p = tmp_path / "MOD10CM.A2008060.061.h5"
    write_hdf5(p, {"Snow_Cover_Monthly_CMG": (s, {"_FillValue": 255})}, group="MOD_Grid_Snow_CMG/Data Fields")
    g = P.read_mod10cm(p)
    assert g.data[0, 0] == 1.0 and g.data[1100, 5] == pytest.approx(0.37) and g.data[3000, 3000] == 0.0
    assert g.data[1205, 0] == 0.0 and g.meta["flagged_cells"] == 10 * 7200
    assert P.read_mod10cm(p, flagged=0.5).data[1205, 0] == 0.5
    assert g.value_at(60.0, 10.0) == 1.0 and g.value_at(-10.0, 10.0) == 0.0


# ---------------------------------------------------------------- AMSR-E, NSIDC polar stereographic
@pytest.mark.parametrize("hemi, lat, lon, x, y", [
    ("north", 30.98, 168.35, -3850.0, 5850.0), ("north", 34.35, 350.03 - 360, 3750.0, -5350.0),
    ("north", 33.92, 279.26 - 360, -3850.0, -5350.0), ("south", -39.23, 317.76 - 360, -3950.0, 4350.0),
    ("south", -41.45, 135.00, 3950.0, -3950.0)])
def test_polar_stereographic_grid_corners(hemi, lat, lon, x, y):
    # NSIDC prints the corners to 0.01 deg: about 1.1 km in latitude at these radii
    xx, yy = P.polar_xy(lat, lon, hemi)
    assert math.hypot(xx - x, yy - y) < 1.5
    la, lo = P.polar_latlon(x, y, hemi)
    assert la == pytest.approx(lat, abs=0.006)
    assert (lo - lon + 180) % 360 - 180 == pytest.approx(0, abs=0.006)


def amsre_fixture(path, writer):
    out = {}
    for hemi, g in P.POLAR_GRIDS.items():
        rr, cc = np.meshgrid(np.arange(g["shape"][0]), np.arange(g["shape"][1]), indexing="ij")
        la, lo = P.polar_latlon(g["x0"] + (cc + 0.5) * P.CELL_KM, g["y0"] - (rr + 0.5) * P.CELL_KM, hemi)
        v = np.where(np.abs(la) > 75.0, 100, np.where(np.abs(la) > 70.0, 50, 0)).astype(np.int32)
        v[(np.abs(la) > 60) & (np.abs(la) < 62) & (lo > 0) & (lo < 30)] = 120        # a strip of "land"
        v[np.abs(la) > 89.0] = 110                                                    # the pole hole
        out[g["dataset"]] = (v, {})
    writer(path, out)


@pytest.mark.parametrize("fmt", ["hdf4", "hdf5"])
def test_amsre_sea_ice_reprojected(tmp_path, fmt):
    p = tmp_path / f"AMSR_E_L3_SeaIce12km.{fmt}"
    amsre_fixture(p, write_hdf4 if fmt == "hdf4" else (lambda a, b: write_hdf5(a, b, group="SpPolarGrid12km")))
    g = P.read_amsre_seaice(p, nlat=360)
    assert g.data.shape == (360, 720) and g.data.dtype == np.float32
    la = cell_centres(360)[0]
    for hemi in (1, -1):
        rows = lambda a, b: (hemi * la > a) & (hemi * la < b)  # noqa: E731
        assert np.allclose(g.data[rows(76, 89)], 1.0)
        assert np.allclose(g.data[rows(89.5, 90)], 1.0)          # the pole hole, filled from around it
        assert np.allclose(g.data[rows(71, 74)], 0.5)
        assert np.allclose(g.data[rows(0, 69)][:, :360], 0.0)    # west of Greenwich: no strip of land there
    assert g.value_at(61.0, 15.0) == 0.0                         # land counts as no ice
    with pytest.raises(P.ProductError, match="no dataset 'SI_12km_NH_ICECON_ASC'"):
        P.read_amsre_seaice(p, kind="asc")
    with pytest.raises(ValueError, match="DAY, ASC or DSC"):
        P.read_amsre_seaice(p, kind="night")
    bad = tmp_path / "bad.h5"
    write_hdf5(bad, {"SI_12km_NH_ICECON_DAY": (np.zeros((448, 304), np.int32), {}),
                     "SI_12km_SH_ICECON_DAY": (np.zeros((332, 316), np.int32), {})})
    with pytest.raises(P.ProductError, match=r"not the NSIDC 12.5 km northern polar stereographic grid \(896, 608\)"):
        P.read_amsre_seaice(bad)


# ---------------------------------------------------------------- MERRA-2
def merra_field(lat, lon):
    return 0.5 + 0.3 * np.sin(np.radians(lat))[:, None] * np.cos(np.radians(lon))[None, :]


def write_merra(path, lat=None, lon=None, nc3=False, fill_some=False):
    lat = np.linspace(-90, 90, 361) if lat is None else lat
    lon = -180 + 0.625 * np.arange(576) if lon is None else lon
    v = merra_field(lat, lon)[None].astype(np.float32)
    if fill_some:
        v[0, 5, 5] = 1e15
    if nc3:
        from scipy.io import netcdf_file

        with netcdf_file(str(path), "w") as f:
            f.createDimension("time", 1)
            f.createDimension("lat", lat.size)
            f.createDimension("lon", lon.size)
            f.createVariable("lat", "d", ("lat",))[:] = lat
            f.createVariable("lon", "d", ("lon",))[:] = lon
            c = f.createVariable("CLDTOT", "f", ("time", "lat", "lon"))
            c[:] = v
            c._FillValue = np.float32(1e15)
            c.units = "1"
        return
    with h5py.File(path, "w") as f:
        f["lat"] = lat
        f["lon"] = lon
        f["time"] = np.array([0.0])
        d = f.create_dataset("CLDTOT", data=v)
        d.attrs["_FillValue"] = np.float32(1e15)
        d.attrs["units"] = "1"
        d.attrs["long_name"] = "total_cloud_area_fraction"


@pytest.mark.parametrize("nc3", [False, True], ids=["netcdf4", "netcdf3"])
def test_merra2_cloud_fraction_regridded(tmp_path, nc3):
    p = tmp_path / ("MERRA2_300.tavgM_2d_rad_Nx.200803.nc4" if not nc3 else "m.nc")
    write_merra(p, nc3=nc3)
    g = P.read_merra2(p, "CLDTOT", nlat=360)
    la, lo = cell_centres(360)
    want = merra_field(la, lo)
    # bilinear interpolation of a smooth field: error ~ h^2/8 f'' with h = 0.625 deg -> ~ 2e-5
    assert np.max(np.abs(g.data - want)) < 1e-4
    assert g.units == "1" and g.meta["product"] == "MERRA-2"
    out = g.save(tmp_path / "cldtot.npy")
    a = check_latlon_file(out, NO_SPAN)                        # what MAP name LATLON 'cldtot.npy' reads
    assert a.shape == (360, 720)
    assert (tmp_path / "cldtot.json").exists()


def test_merra2_wrong_grids(tmp_path):
    p = tmp_path / "a.nc4"
    write_merra(p, lat=np.linspace(90, -90, 361))
    with pytest.raises(P.ProductError, match="not the global MERRA-2 grid"):
        P.read_merra2(p)
    write_merra(p, lon=np.arange(576) * 0.625)
    with pytest.raises(P.ProductError, match="not the global MERRA-2 grid"):
        P.read_merra2(p)
    write_merra(p, fill_some=True)
    with pytest.raises(P.ProductError, match="fill values"):
        P.read_merra2(p)
    with pytest.raises(P.ProductError, match="no dataset 'TQL'"):
        P.read_merra2(p, "TQL")


def test_saved_grids_carry_their_provenance(tmp_path):
    g = LatLonGrid(np.zeros((4, 8), np.float32), "x", "1", {"source": "test", "proxy": False})
    g.save(tmp_path / "x.npy")
    import json

    info = json.loads((tmp_path / "x.json").read_text())
    assert info["dataset"] == "x" and info["source"] == "test" and info["shape"] == [4, 8]
    with pytest.raises(ValueError, match="not a global LATLON grid"):
        LatLonGrid(np.zeros((4, 4)), "y")
