"""Maps on the Earth: geodetic latitude (WGS84), the LATLON grid conventions, and SCATTER MAP in traced scenes
(class maps choose a model per class, a one-model float map gives probabilistic coverage, several SCATTER
specs on one object are tried in order).

The traced scenes share one kernel feature set (a sphere, scatter models, maps).  They use an Earth-sized
sphere (radius 6371 km, centred at the origin; maps are looked up at the geodetic latitude of the hit
point, which has the sign of z) lit by a collimated beam from the direction s = (cos b cos l, cos b sin l,
sin b) (the Sun at latitude b, longitude l).  The beam's cross-section is sampled uniformly (GRID RECT on the
plane x = 2e4 km, wide enough to hold the sphere's whole shadow; a uniform grid on that plane is uniform
across the oblique beam), so hit points are uniform over the sphere's projected disk.

Share of the hits in the hemisphere z > 0 with the Sun at latitude b: on the projected disk (u along y,
v along the projection of z), a hit point has z = v cos b + sqrt(1 - u^2 - v^2) sin b.  For v >= 0 it is
> 0; for v < 0 it is > 0 inside the ellipse u^2 + v^2 / sin^2 b < 1, whose lower half has area pi sin b / 2.
So P(z > 0) = (1 + sin b) / 2: 3/4 for b = 30 deg.  The same argument about the plane y = 0 gives
P(y > 0) = (1 + sin l) / 2 (east of Greenwich: longitude > 0) for a Sun in the equator plane at longitude l.

Monte Carlo error: every hit carries the same weight w0 (HALT 0) and scatters the albedo A of the model
that applies there, so scattered / incident is the mean of A over the N_hit hits, a discrete random
variable: sigma = sd(A) / sqrt(N_hit); 5 sigma allowed.
"""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _trace_util import INC, SCA, ledger_gap, row, trace_text  # noqa: E402

from irtlang.kernels.trace_kernel import geodetic, map_value  # noqa: E402

# WGS84, written out here (NIMA TR8350.2): a and 1/f; e^2 = f (2 - f)
A_WGS = 6378137.0
F_WGS = 1.0 / 298.257223563
E2 = F_WGS * (2.0 - F_WGS)
B_WGS = A_WGS * (1.0 - F_WGS)


def to_ecef(lat, lon, h):
    """Geodetic (lat, lon, h) to Earth-centred coordinates: the forward transform, closed form."""
    n = A_WGS / math.sqrt(1.0 - E2 * math.sin(lat) ** 2)
    return ((n + h) * math.cos(lat) * math.cos(lon), (n + h) * math.cos(lat) * math.sin(lon),
            (n * (1.0 - E2) + h) * math.sin(lat))


# ------------------------------------------------------------------------------------------- geodetic latitude
def test_geodetic_on_the_ellipsoid_from_the_parametric_latitude():
    """A point on the ellipsoid at parametric (reduced) latitude beta is (a cos beta, b sin beta); its geodetic
    latitude is atan2(a sin beta, b cos beta) (tan phi = (a / b) tan beta).  To 1e-12 rad."""
    for beta_deg in np.linspace(-90.0, 90.0, 721):
        beta = math.radians(beta_deg)
        for lon_deg in (-179.5, -90.0, 0.0, 37.0, 135.0, 180.0):
            lon = math.radians(lon_deg)
            p, z = A_WGS * math.cos(beta), B_WGS * math.sin(beta)
            lat, lo = geodetic(p * math.cos(lon), p * math.sin(lon), z)
            assert abs(lat - math.atan2(A_WGS * math.sin(beta), B_WGS * math.cos(beta))) <= 1e-12, (beta_deg, lon_deg)
            if abs(beta_deg) < 90.0:
                assert abs(math.remainder(lo - lon, 2 * math.pi)) <= 1e-12


@pytest.mark.parametrize("h", [-1.0e5, -5.0e3, 0.0, 8848.0, 1.0e5, 1.0e6, 3.6e7])
def test_geodetic_at_altitude_inverts_the_forward_transform(h):
    """Points built from (lat, lon, h) by the closed-form forward transform come back at lat to 1e-12 rad,
    from 100 km below the ellipsoid to geostationary altitude, poles and equator included."""
    for lat_deg in np.concatenate([np.linspace(-90.0, 90.0, 361), [-89.999, 1e-9, 89.999]]):
        lat = math.radians(lat_deg)
        lon = math.radians(-123.4)
        got, lo = geodetic(*to_ecef(lat, lon, h))
        assert abs(got - lat) <= 1e-12, (h, lat_deg, got - lat)
        if abs(lat_deg) < 90.0:
            assert abs(lo - lon) <= 1e-12


def test_geodetic_deep_inside_lies_on_the_normal():
    """Deep inside (a small test globe centred at the origin), 60-600 km from the centre, just outside the
    ellipsoid's evolute (within ~43 km of the centre the latitude is not unique), the point lies on the
    ellipsoid's normal at the foot of the latitude returned: (P - F) x n = 0 to 1e-6 m."""
    for rad in (60e3, 300e3, 600e3):
        for ang_deg in (-80.0, -60.0, -10.0, 0.0, 25.0, 70.0, 89.0):
            a = math.radians(ang_deg)
            pr, z = rad * math.cos(a), rad * math.sin(a)
            lat, lo = geodetic(pr * math.cos(0.7), pr * math.sin(0.7), z)
            n = A_WGS / math.sqrt(1.0 - E2 * math.sin(lat) ** 2)
            fp, fz = n * math.cos(lat), n * (1.0 - E2) * math.sin(lat)
            cross = (pr - fp) * math.sin(lat) - (z - fz) * math.cos(lat)
            assert abs(cross) <= 1e-6, (rad, ang_deg, cross)
            assert abs(lo - 0.7) <= 1e-12


# ------------------------------------------------------------------------------------------- grid conventions
def test_map_value_rows_from_north_columns_from_minus_180():
    """LATLON grid nlat x nlon (row-major, at an offset in the flat array): the centre of cell (r, q) is at
    latitude 90 - (r + 1/2) 180 / nlat and longitude -180 + (q + 1/2) 360 / nlon; the poles and the
    antimeridian fall in the first / last row and column."""
    nlat, nlon, off = 3, 6, 5
    data = np.concatenate([np.full(off, -1.0), np.arange(nlat * nlon, dtype=float)])
    for r in range(nlat):
        for q in range(nlon):
            lat = math.radians(90.0 - (r + 0.5) * 180.0 / nlat)
            lon = math.radians(-180.0 + (q + 0.5) * 360.0 / nlon)
            assert map_value(data, off, nlat, nlon, lat, lon) == r * nlon + q
    assert map_value(data, off, nlat, nlon, math.pi / 2, -math.pi) == 0
    assert map_value(data, off, nlat, nlon, -math.pi / 2, math.pi) == nlat * nlon - 1
    assert map_value(data, off, nlat, nlon, math.radians(45.0), math.radians(-1.0)) == 2    # row 0, column 2
    assert map_value(data, off, nlat, nlon, math.radians(-45.0), math.radians(1.0)) == 2 * nlon + 3


# ------------------------------------------------------------------------------------------- traced scenes
N = 400_000
R_KM = 6371.0
ALB = {"dark": 0.1, "white": 0.9, "grey": 0.5}


def earth_script(maps: dict, scatter_lines: list, sun_lat: float = 0.0, sun_lon: float = 0.0,
                 n: int = N, seed: int = 21) -> str:
    b, l = math.radians(sun_lat), math.radians(sun_lon)
    s = (math.cos(b) * math.cos(l), math.cos(b) * math.sin(l), math.sin(b))
    x0 = 20000.0
    # the shadow cylinder of the sphere crosses x = x0 around (x0 s_y / s_x, x0 s_z / s_x) as an ellipse of
    # semi-axes at most R / s_x in y and z (cos of the beam against the plane's normal is s_x)
    yc, zc, half = x0 * s[1] / s[0], x0 * s[2] / s[0], 1.001 * R_KM / s[0]
    lines = ["UNITS KM", "WAVELENGTHS 550 NM", f"SEED {seed}"]
    lines += [f"MODEL {k} LAMBERTIAN {v!r}" for k, v in ALB.items()]
    lines += [f"MAP {k} LATLON '{v}'" for k, v in maps.items()]
    lines += ["SURFACE", f"  SPHERE 0 0 0 {R_KM!r}", "OBJECT earth", "  INTERFACE ABSORB"]
    lines += ["  " + x for x in scatter_lines]
    lines += [f"GRID RECT X {x0!r} {yc - half!r} {yc + half!r} {zc - half!r} {zc + half!r} {n} 1 RANDOM",
              f"SOURCE DIRECTION {-s[0]!r} {-s[1]!r} {-s[2]!r}", "FLUX TOTAL 1 W", "LEVEL 10", "HALT 0", "TRACE"]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    d = tmp_path_factory.mktemp("maps")
    # class maps: 1 (white) on the northern / eastern half, 0 (dark) elsewhere
    north = np.zeros((90, 180), np.int32)
    north[:45] = 1
    east = np.zeros((2, 4), np.int32)
    east[:, 2:] = 1
    np.save(d / "north.npy", north)
    np.save(d / "east.npy", east)
    np.save(d / "snow.npy", np.full((18, 36), 0.3))          # a fraction map: 30 % everywhere
    return d


def _mix_check(res, values, probs):
    """scattered / incident against sum p A, sigma = sd(A) / sqrt(N_hit) (module docstring)."""
    earth = row(res, "earth")
    w0 = 1.0 / N
    n_hit = earth[INC] / w0
    assert n_hit == pytest.approx(round(n_hit), abs=1e-6 * n_hit) and n_hit > 0.6 * N   # pi s_x / 4 of the rays hit
    mean = float(np.dot(probs, values))
    sd = math.sqrt(float(np.dot(probs, np.square(values))) - mean * mean)
    share = earth[SCA] / earth[INC]
    assert abs(share - mean) <= 5 * sd / math.sqrt(n_hit), (share, mean, sd / math.sqrt(n_hit))
    assert ledger_gap(res) < 1e-12
    return share, mean


def test_hemisphere_class_map_by_latitude(tmp_path, maps):
    """Class 1 (white, 0.9) north of the equator, class 0 (dark, 0.1) south; the Sun at latitude 30 deg: 3/4
    of the hits are northern, scattered share 0.75 * 0.9 + 0.25 * 0.1 = 0.7 (rows counted from the south
    would give 0.3: the test tells the two apart by 160 sigma)."""
    res = trace_text(tmp_path, earth_script({"cover": maps / "north.npy"}, ["SCATTER MAP cover MODELS dark white"],
                                            sun_lat=30.0), records=False)
    p = 0.5 * (1 + math.sin(math.radians(30.0)))
    _mix_check(res, [ALB["white"], ALB["dark"]], [p, 1 - p])


def test_hemisphere_class_map_by_longitude(tmp_path, maps):
    """A 2 x 4 class map, white on the two eastern columns (longitudes 0 .. 180), the Sun at longitude 30 deg
    on the equator: 3/4 of the hits are east of Greenwich, share 0.7 (columns from 0 deg instead of -180
    would put white on 0 .. 180 too but at columns 0, 1: share 0.3)."""
    res = trace_text(tmp_path, earth_script({"cover": maps / "east.npy"}, ["SCATTER MAP cover MODELS dark white"],
                                            sun_lon=30.0), records=False)
    p = 0.5 * (1 + math.sin(math.radians(30.0)))
    _mix_check(res, [ALB["white"], ALB["dark"]], [p, 1 - p])


def test_fraction_map_gives_probabilistic_coverage(tmp_path, maps):
    """A float map with one model is a coverage fraction: with f = 0.3 everywhere a hit scatters with the
    grey model (0.5) with probability f and is absorbed otherwise (no other SCATTER spec): share f * 0.5."""
    res = trace_text(tmp_path, earth_script({"snow": maps / "snow.npy"}, ["SCATTER MAP snow MODELS grey"]),
                     records=False)
    f = 0.3
    _mix_check(res, [ALB["grey"], 0.0], [f, 1 - f])


def test_scatter_specs_are_tried_in_order(tmp_path, maps):
    """Fraction map first (grey with probability 0.3), then the latitude class map for the rest:
    share = f 0.5 + (1 - f) (p 0.9 + (1 - p) 0.1), p = 3/4 with the Sun at latitude 30 deg."""
    res = trace_text(tmp_path, earth_script({"snow": maps / "snow.npy", "cover": maps / "north.npy"},
                                            ["SCATTER MAP snow MODELS grey", "SCATTER MAP cover MODELS dark white"],
                                            sun_lat=30.0), records=False)
    f, p = 0.3, 0.75
    _mix_check(res, [ALB["grey"], ALB["white"], ALB["dark"]], [f, (1 - f) * p, (1 - f) * (1 - p)])
