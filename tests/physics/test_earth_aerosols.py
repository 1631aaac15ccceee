"""OPAC aerosol types (irtlang.earth.aerosols) against the numbers printed by Hess, Koepke and Schult (1998).

* Their Table 4 prints, per type, the ground extinction coefficient sigma_e and the column optical depth tau at
  550 nm.  The column is the mixing layer (sigma_e exp(-h/Z) from 0 to H: sigma_e Z (1 - exp(-H/Z))), the free
  troposphere and the stratosphere.  With the two constants irtlang fits for the last two (sigma_FT0, tau_strat),
  the profile must give every printed tau back to within the rounding of the printed sigma_e (3 digits: up to
  0.0005 Z (1 - exp(-H/Z)) = 0.0009 for Z = 8 km): 0.001.
* An independent OPAC 3.1 run for continental polluted aerosol at 80 % RH gives 0.1746 km^-1, omega 0.8925,
  g 0.6977, tau 0.327: the table's rounded row.
* The Angstrom law: sigma(lambda1) / sigma(lambda2) = (lambda1 / lambda2)^-alpha.
"""
import math

import numpy as np
import pytest

from irtlang.earth import aerosols as A

VERIFIED = [t for t in A.OPAC_TYPES if t != "antarctic"]


@pytest.mark.parametrize("name", VERIFIED)
def test_profile_reproduces_the_printed_column_optical_depth(name):
    s, w, g, tau, a1, a2, H, Z = A.OPAC_TYPES[name]
    assert A.column_tau_550(name) == pytest.approx(tau, abs=0.001)
    ml = s * Z * (1 - math.exp(-H / Z))
    assert A.layer_tau_550(name, [0.0, H])[0] == pytest.approx(ml, rel=1e-12)


def test_continental_polluted_row_is_opac_output():
    s, w, g, tau, *_ = A.OPAC_TYPES["continental polluted"]
    assert (s, w, g, tau) == (round(0.1746, 3), round(0.8925, 3), round(0.6977, 3), 0.327)


def test_layers_add_up_to_the_column():
    levels = [0, 0.4, 0.8, 1, 1.5, 2, 3, 3.5, 5, 6, 10, 12, 25, 35, 50, 100]
    for name in A.OPAC_TYPES:
        t = A.layer_tau_550(name, levels)
        assert np.all(t >= 0)
        assert t.sum() == pytest.approx(A.column_tau_550(name), rel=1e-12)
        assert t[-1] == 0.0                                   # nothing above 50 km
    with pytest.raises(ValueError, match="increase"):
        A.layer_tau_550("urban", [0, 2, 1])


def test_angstrom_law():
    for name in A.OPAC_TYPES:
        *_, a1, a2, _, _ = A.OPAC_TYPES[name]
        f = A.spectral_factor(name, [350.0, 450.0, 500.0, 550.0, 800.0, 950.0])
        assert f[3] == pytest.approx(1.0)
        assert f[4] / f[2] == pytest.approx((800 / 500) ** -a2, rel=1e-12)
        assert f[0] / f[2] == pytest.approx((350 / 500) ** -a1, rel=1e-12)
        assert f[5] / f[3] == pytest.approx((950 / 550) ** -a2, rel=1e-12)


def test_layer_optics_and_model_line():
    tau, w, g = A.layer_optics("desert", [0, 2, 6, 12], [450.0, 550.0, 850.0])
    assert tau.shape == (3, 3)
    assert np.all(w == 0.888) and np.all(g == 0.729)
    line = A.aerosol_model_line("aer_1", "maritime clean", 0.0, 0.4, [550.0])
    assert line.startswith("MODEL aer_1 HG G 0.772 TAU ")
    t = float(line.split("TAU ")[1].split()[0])
    assert t == pytest.approx(0.090 * 1.0 * (1 - math.exp(-0.4)), rel=1e-5)


def test_aerosol_type_map_follows_the_land_cover():
    lc = np.zeros((4, 8), np.uint8)
    lc[1, :4] = 16
    lc[2, :4] = 12
    m = A.aerosol_type_map(lc)
    assert A.EARTH_TYPES[m[1, 0]] == "desert" and A.EARTH_TYPES[m[2, 0]] == "continental average"
    assert A.EARTH_TYPES[m[1, 5]] == "maritime clean"
    assert A.EARTH_TYPES[m[0, 0]] == "arctic" and A.EARTH_TYPES[m[3, 7]] == "arctic"   # poleward of 60 deg
