"""Cloud optics (irtlang.earth.clouds) against independent numbers.

Mie theory (the basis of the liquid-water table):
* Bohren and Huffman (1983), appendix A example: m = 1.55, radius 0.525 um, wavelength 0.6328 um
  (x = 5.21282): Q_ext = Q_sca = 3.10543.
* Wiscombe (1979, NCAR TN-140, MIEV0 test cases): m = 1.5, x = 10: Q_ext = 2.8820; m = 1.5, x = 100:
  Q_ext = 2.0944; m = 1.33 + 1e-5 i, x = 100: Q_ext = 2.1013, Q_sca = 2.0966.
* Rayleigh limit: Q_sca = (8/3) x^4 |(m^2 - 1)/(m^2 + 2)|^2.
* Anomalous diffraction (van de Hulst) for m -> 1, x >> 1: Q_ext = 2 - (4/rho) sin rho + (4/rho^2)(1 - cos rho),
  rho = 2 x (m - 1).

Liquid clouds: the geometric-optics limit (extinction efficiency 2 for drops much larger than the wavelength):
beta = 3 LWC Q / (4 rho_w r_e) = 1.5 LWC / r_e; the Hu & Stamnes-form table against fresh Mie values.
Ice clouds (Fu 1996): his a1 against the geometric-optics value 4 sqrt(3) / (3 rho_ice) = 2.5184.
"""
import math

import pytest

from irtlang.earth import clouds as C


def test_mie_bohren_huffman_example():
    x = 2 * math.pi * 0.525 / 0.6328
    qe, qs, g = C.mie(1.55, 0.0, x)
    assert qe == pytest.approx(3.10543, abs=1e-5)
    assert qs == pytest.approx(qe, rel=1e-12)             # no absorption
    assert 0 < g < 1


@pytest.mark.parametrize("m, k, x, qext, qsca", [
    (1.5, 0.0, 10.0, 2.8820, 2.8820), (1.5, 0.0, 100.0, 2.0944, 2.0944), (1.33, 1e-5, 100.0, 2.1013, 2.0966)])
def test_mie_wiscombe_cases(m, k, x, qext, qsca):
    qe, qs, _ = C.mie(m, k, x)
    assert qe == pytest.approx(qext, abs=1e-4)
    assert qs == pytest.approx(qsca, abs=1e-4)


def test_mie_rayleigh_limit():
    for m, x in ((1.5, 0.01), (1.33, 0.005)):
        qs = C.mie(m, 0.0, x)[1]
        assert qs == pytest.approx(8 / 3 * x ** 4 * ((m * m - 1) / (m * m + 2)) ** 2, rel=1e-4)


@pytest.mark.parametrize("x", [2000.0, 4000.0])
def test_mie_anomalous_diffraction_limit(x):
    m = 1.001
    rho = 2 * x * (m - 1)
    ada = 2 - 4 / rho * math.sin(rho) + 4 / rho ** 2 * (1 - math.cos(rho))
    assert C.mie(m, 0.0, x)[0] == pytest.approx(ada, rel=2e-3)


def test_water_index_at_550nm():
    m = C.water_index(550.0)
    assert m.real == pytest.approx(1.333) and 1e-9 < m.imag < 3e-9


# ---------------------------------------------------------------- liquid water clouds
@pytest.mark.parametrize("wl", C.HRI_BANDS_NM)
def test_hu_stamnes_table_against_fresh_mie(wl):
    for r in (4.0, 9.0, 17.0, 26.0, 44.0):         # not the fit's radii
        b, w, g = C.mie_liquid_bulk(wl, r)
        bb, ww, gg = C.liquid_optics(1.0, r, wl)
        assert bb == pytest.approx(b, rel=0.01), r
        assert gg == pytest.approx(g, rel=0.01), r
        assert ww == pytest.approx(w, abs=5e-5), r


@pytest.mark.parametrize("r_e", [30.0, 50.0])
def test_geometric_optics_limit_for_large_drops(r_e):
    # beta = 3 LWC Q / (4 rho_w r_e) with Q -> 2: 1.5 LWC / r_e (m^-1 for LWC in g/m3, r_e in um) -- Q_eff is
    # 2 plus an edge term of order x^(-2/3) (about 1 % here)
    lwc = 0.3
    beta_km = C.liquid_optics(lwc, r_e, 550.0)[0]
    assert beta_km / 1e3 == pytest.approx(1.5 * lwc / r_e, rel=0.03)
    assert beta_km / 1e3 > 1.5 * lwc / r_e                 # the edge term only adds


def test_liquid_cloud_is_nearly_conservative_and_forward_scattering():
    for wl in C.HRI_BANDS_NM:
        _, w, g = C.liquid_optics(0.2, 10.0, wl)
        assert 0.999 < w <= 1.0 and 0.82 < g < 0.88
    # absorption by water grows toward the near-infrared (Hale & Querry k: 2e-9 at 550, 3e-6 at 950 nm)
    assert 1 - C.liquid_optics(0.2, 10.0, 950.0)[1] > 100 * (1 - C.liquid_optics(0.2, 10.0, 550.0)[1])


def test_liquid_optics_domain():
    with pytest.raises(ValueError, match="2.5-60 um"):
        C.liquid_optics(0.1, 1.0, 550.0)
    with pytest.raises(ValueError, match="outside the table"):
        C.liquid_optics(0.1, 10.0, 1200.0)


# ---------------------------------------------------------------- ice clouds
def test_fu_extinction_has_the_geometric_optics_limit():
    geo = 4 * math.sqrt(3) / (3 * C.RHO_ICE) * 1e6        # m^-1 per (g/m3) per (1/um)
    assert geo == pytest.approx(2.5184, abs=1e-4)
    for b in (1, 2):
        assert C.FU96[b]["a"][1] == pytest.approx(geo, rel=2e-3)     # 2.5193 and 2.5213
        assert abs(C.FU96[b]["a"][0]) < 1e-4
    beta = C.ice_optics(0.02, 60.0, 550.0)[0]
    assert beta == pytest.approx(0.02 * geo / 60.0 * 1e3, rel=2e-3)   # km^-1


def test_fu_single_scattering_in_the_solar_bands():
    for d in (20.0, 60.0, 130.0):
        _, w1, g1 = C.ice_optics(0.01, d, 550.0)
        _, w2, g2 = C.ice_optics(0.01, d, 850.0)
        assert w1 > 0.9999 and 0.99 < w2 < 1.0
        assert 0.74 < g1 < 0.86 and 0.74 < g2 < 0.86
    # delta scaling keeps the scattered share outside the forward peak: tau' omega' (1 - g') ... and g' < g
    b, w, g = C.ice_optics(0.01, 60.0, 550.0)
    bd, wd, gd = C.ice_optics(0.01, 60.0, 550.0, delta_scaled=True)
    assert bd < b and gd < g and wd <= w
    assert bd * (1 - wd) == pytest.approx(b * (1 - w), rel=1e-9)      # absorption is not scaled away


def test_cloud_model_line_is_valid_script():
    from irtlang.lang.interp import Interpreter

    line = C.cloud_model_line("cloud_low", C.HRI_BANDS_NM, thickness_km=0.5, lwc_g_m3=0.2, r_eff_um=10.0)
    tau550 = float(line.split("TAU ")[1].split()[2])
    assert tau550 == pytest.approx(C.liquid_optics(0.2, 10.0, 550.0)[0] * 0.5)
    assert tau550 == pytest.approx(1.5 * 0.2 / 10.0 * 500 * 1.04, rel=0.03)   # Q_eff ~ 2.08 at r_e = 10 um
    it = Interpreter(check_only=True)
    it.run_text("WAVELENGTHS 350 450 550 650 750 850 950 NM\n" + line + "\n", "t.inr")
    assert not it.diags.items
    mixed = C.cloud_model_line("m", [550.0], thickness_km=1.0, lwc_g_m3=0.05, iwc_g_m3=0.01)
    assert "HG G" in mixed
