"""Land, snow, sea-ice and ocean surfaces (irtlang.earth.surfaces) against independent numbers.

* Ross-Li white-sky integrals of the kernels: 0.189184 (RossThick) and -1.377622 (LiSparse-R) (ORACLES.md,
  Lucht et al. 2000): computed here by quadrature of the ROSSLI plugin's kernels.
* Black-sky albedo: the polynomials of Lucht, Schaaf and Strahler (2000, their Table 1; MODIS BRDF/albedo ATBD):
  BSA(theta) = f_iso + f_vol (-0.007574 - 0.070987 t^2 + 0.307588 t^3) + f_geo (-1.284909 - 0.166314 t^2
  + 0.041840 t^3), t in radians, accurate to about 1 %: against the plugin's own albedo table.
* Snow (Kokhanovsky and Breon 2012): non-absorbing snow reflects everything, so the plane albedo of R0 is 1
  (their formula is an approximation: within 1.5 %); with absorption, the plane albedo is
  exp(-sqrt(alpha l) u(mu)) and since 2 int u(mu) mu dmu = 1 the spherical albedo is exp(-sqrt(alpha l)).
* Ocean: at normal incidence the Cox-Munk glint reflects the flat-water Fresnel reflectance
  ((n - 1)/(n + 1))^2 = 0.021110 for n = 1.34, less a little for the tilted facets.
"""
import math

import numpy as np
import pytest

from irtlang.earth import surfaces as S


def _hemisphere(n=48):
    x, w = np.polynomial.legendre.leggauss(n)
    mu = 0.5 * (x + 1)
    ph = math.pi * 0.5 * (x + 1)
    MU, PH = np.meshgrid(mu, ph, indexing="ij")
    W = np.outer(0.5 * w, math.pi * 0.5 * w)
    return MU, PH, W


def _plane_albedo(f, mu_s, n=64):
    """(2/pi) int_0^pi int_0^1 f mu_v dmu_v dphi: the albedo for light from mu_s, f a reflectance factor."""
    MU, PH, W = _hemisphere(n)
    ss = math.sqrt(1 - mu_s * mu_s)
    cxi = mu_s * MU + ss * np.sqrt(1 - MU * MU) * np.cos(PH)
    return 2 / math.pi * (f(mu_s, MU, cxi) * MU * W).sum()


def test_white_sky_integrals_of_the_kernels():
    # WSA of a kernel = 2 int_0^1 BSA(mu) mu dmu; BSA by quadrature of the kernel (no clamping)
    x, w = np.polynomial.legendre.leggauss(24)
    mus = 0.5 * (x + 1)
    for k, want in ((0, S.WSA_VOL), (1, S.WSA_GEO)):
        bsa = [_plane_albedo(lambda a, b, c, k=k: np.reshape(S.rossli_kernels(np.full(b.size, a), b.ravel(),
                                                                              c.ravel())[k], b.shape), m, n=48)
               for m in mus]
        assert 2 * (np.asarray(bsa) * mus * 0.5 * w).sum() == pytest.approx(want, abs=2e-3)


def test_black_sky_albedo_against_the_lucht_polynomials():
    gv = (-0.007574, -0.070987, 0.307588)
    gg = (-1.284909, -0.166314, 0.041840)
    for cls in (1, 7, 12, 16):
        iso, vol, geo = (v[3] for v in S.igbp_kernel_weights(cls))      # 650 nm
        for th in (0.0, 30.0, 50.0, 60.0):
            t = math.radians(th)
            poly = iso + vol * (gv[0] + gv[1] * t * t + gv[2] * t ** 3) + geo * (gg[0] + gg[1] * t * t + gg[2] * t ** 3)
            assert S.directional_albedo(iso, vol, geo, [math.cos(t)])[0] == pytest.approx(poly, abs=0.012 * iso + 1e-4)


def test_land_brdfs_are_non_negative_and_have_a_red_edge():
    ms, mv, cxi = S._angle_grid(75.0, 8, 9)
    kv, kg = S.rossli_kernels(ms, mv, cxi)
    for c in range(1, 17):
        iso, vol, geo = S.igbp_kernel_weights(c)
        for j in range(iso.size):
            assert np.all(iso[j] + vol[j] * kv + geo[j] * kg >= 0), (c, j)
        wsa = S.white_sky_albedo(iso, vol, geo)
        assert np.all((wsa > 0) & (wsa < 1))
        ndvi = (wsa[5] - wsa[3]) / (wsa[5] + wsa[3])            # 850 and 650 nm
        if c in (1, 2, 3, 4, 5, 12, 14):
            assert ndvi > 0.6, c                                   # dense vegetation
        if c == 16:
            assert ndvi < 0.2
    assert S.IGBP_MODEL_NAMES[15] == "snow_ice" and len(S.IGBP_MODEL_NAMES) == 17


def test_kokhanovsky_non_absorbing_snow_reflects_all():
    for mu in (1.0, 0.8, 0.5, 0.3):
        assert _plane_albedo(S.kokhanovsky_r0, mu) == pytest.approx(1.0, abs=0.015)


@pytest.mark.parametrize("wl", [850.0, 950.0])
def test_kokhanovsky_absorbing_snow_plane_albedo(wl):
    s = S.snow_absorption(wl)
    f = lambda a, b, c: S.kokhanovsky_r(a, b, c, wl)  # noqa: E731
    for mu in (0.9, 0.6):
        u = 3 * (1 + 2 * mu) / 7
        # R0's own 1.5 % plus the asymptotic theory's error (order (alpha l)): 2 %
        assert _plane_albedo(f, mu) == pytest.approx(math.exp(-s * u), rel=0.02)


def test_snow_rossli_fit():
    iso, vol, geo = S.snow_rossli()
    rs = np.array([math.exp(-S.snow_absorption(w)) for w in S.HRI_BANDS_NM])
    assert rs[0] > 0.99 and 0.85 < rs[-1] < 0.92              # visible ~1, 950 nm ~0.88 (200 um grains)
    wsa = S.white_sky_albedo(iso, vol, geo)
    assert np.all(wsa <= rs + 1e-9) and np.all(wsa > rs - 0.04)
    mu = np.linspace(0.05, 1.0, 20)
    for j in range(iso.size):
        assert S.directional_albedo(iso[j], vol[j], geo[j], mu).max() <= 0.999 + 1e-9
    # shape: within 8 % (rms) of the scaled Kokhanovsky reflectance for zenith angles up to 60 deg
    ms, mv, cxi = S._angle_grid(60.0, 7, 7)
    kv, kg = S.rossli_kernels(ms, mv, cxi)
    for j, wl in enumerate(S.HRI_BANDS_NM):
        fit = iso[j] + vol[j] * kv + geo[j] * kg
        ref = S.kokhanovsky_r(ms, mv, cxi, wl) * wsa[j] / rs[j]
        assert np.sqrt(np.mean((fit / ref - 1) ** 2)) < 0.08, wl


def test_glint_at_normal_incidence_is_fresnel():
    n = 1.34
    assert S.glint_tis(1.0, 7.0, n) == pytest.approx(((n - 1) / (n + 1)) ** 2, rel=0.01)
    alb = S.ocean_albedo()
    assert np.all(np.diff(alb[:4]) <= 0.03) and alb[0] > alb[-1]      # blue ocean: water-leaving light at 350-450


def test_model_lines_parse_and_cover_every_class():
    from irtlang.lang.interp import Interpreter

    lines = S.landcover_model_lines()
    assert len(lines) == 19
    it = Interpreter(check_only=True)
    it.run_text("WAVELENGTHS 350 450 550 650 750 850 950 NM\n" + "\n".join(lines) + "\n", "t.inr")
    assert not it.diags.items, [d.render() for d in it.diags.items]
    names = set(it.state.models)
    assert {n.upper() for n in S.IGBP_MODEL_NAMES} | {"SEA_ICE", "SNOW"} <= names
    assert S.scatter_map_line("cover").split()[:4] == ["SCATTER", "MAP", "cover", "MODELS"]
    with pytest.raises(ValueError):
        S.igbp_kernel_weights(0)


# ---------------------------------------------------------------- land spectra from earthlib (all 295 lines)
LINES = np.linspace(300.0, 2500.0, 295)


def test_land_spectra_pass_through_the_seven_band_values():
    for c in S.IGBP_ROSSLI:
        iso = S.land_iso_spectrum(c, np.array(S.HRI_BANDS_NM))
        assert np.allclose(iso, S.IGBP_ROSSLI[c][0], rtol=1e-12, atol=1e-15), c
        k0, k1, k2 = S.igbp_kernel_weights(c, LINES)
        assert k0.shape == (295,) and np.all(k0 >= 0) and np.all(k0 < 0.7)
        v, g = S.IGBP_ROSSLI[c][1]
        assert np.allclose(k1, v * k0) and np.allclose(k2, g * k0)


def test_land_spectra_have_the_measured_shape_in_the_infrared():
    """Past 950 nm K0 is the library mix scaled by one number: a green canopy's reflectance falls from the NIR
    plateau into the liquid-water bands (1450 and 1940 nm lie in the library's gaps: 1650 and 2200 nm are the
    windows, Gao 1996: leaf water absorbs more at 2200), soil rises to 1.6-2.2 um (Stoner and Baumgardner 1981)."""
    wl, mean = S.earthlib_endmembers()
    assert wl[0] == 400 and wl[-1] == 2450 and len(wl) == 180
    at = lambda c, x: float(S.land_iso_spectrum(c, [x])[0])  # noqa: E731
    for forest in (1, 2, 4):
        assert at(forest, 1650) < 0.8 * at(forest, 1000) and at(forest, 2200) < at(forest, 1650)
        r = S.land_iso_spectrum(forest, np.array([1100.0, 1650.0, 2200.0])) / S.class_spectrum_shape(
            forest, [1100.0, 1650.0, 2200.0])
        assert np.allclose(r, r[0])                      # one scale beyond 950 nm: the measured shape
    assert at(16, 1650) > at(16, 950) and at(16, 2200) > at(16, 650)
    ndvi = lambda c: (at(c, 850) - at(c, 650)) / (at(c, 850) + at(c, 650))  # noqa: E731
    assert ndvi(2) > 0.6 and ndvi(16) < 0.2


def test_land_spectra_below_400_nm_are_documented_linear():
    for c in (2, 10, 16):
        iso350, k400 = S.IGBP_ROSSLI[c][0][0], float(S.land_iso_spectrum(c, [400.0])[0])
        got = S.land_iso_spectrum(c, np.array([300.0, 340.0, 350.0, 375.0]))
        assert np.allclose(got, [iso350, iso350, iso350, 0.5 * (iso350 + k400)])


def test_shipped_surface_lines_are_the_spectra():
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "examples_scripts" / "earth" / "earth_surfaces.inr").read_text()
    m = re.search(r"^MODEL grassland ROSSLI ISO ([^A-Z]+) VOL", text, re.M)
    iso = np.array(m.group(1).split(), float)
    assert iso.size == 295 and np.allclose(iso, S.land_iso_spectrum(10, LINES), rtol=1e-5)
