"""The Earth model as script text (irtlang.earth.models): the include files parse, and their numbers are the
physics modules' numbers.

* Atmosphere: each layer's TAU is the Rayleigh optical depth (Bodhaine et al. 1999 eq. 30 times the layer's
  pressure share, USSA 1976) plus the gas absorption; summed over the layers at 550 nm the Rayleigh part is the
  column 0.097065 (ORACLES.md) times (1 - p(100 km)/p0); ALBEDO is the Rayleigh share.
* A whole Earth with the generated models traced (slow): the ledger closes, and the disk albedo with no
  atmosphere lies between the ocean's and the land's.
"""
import sys
from pathlib import Path

import numpy as np
import pytest

from irtlang.earth import gas, models
from irtlang.earth.atmosphere import P0, ussa1976
from irtlang.lang.interp import check_file

sys.path.insert(0, str(Path(__file__).resolve().parent))

BANDS = (350.0, 450.0, 550.0, 650.0, 750.0, 850.0, 950.0)


def _values(line, key):
    toks = line.split()
    i = toks.index(key)
    out = []
    for t in toks[i + 1:]:
        try:
            out.append(float(t))
        except ValueError:
            break
    return np.array(out)


def test_atmosphere_layers_are_rayleigh_plus_gas():
    lines = models.atmosphere_layer_lines(BANDS)
    assert len(lines) == len(models.PAPER_LEVELS_KM) - 1 == 15
    tau = np.array([_values(l, "TAU") for l in lines])
    alb = np.array([_values(l, "ALBEDO") for l in lines])
    t_r = tau * alb
    frac = 1 - ussa1976(100e3)[1] / P0     # atmosphere=None: USSA 1976 pressures (the AFGL belts: test_earth_spectra)
    assert t_r[:, 2].sum() == pytest.approx(0.097065 * frac, abs=2e-6)
    absorb = gas.layer_absorption(models.PAPER_LEVELS_KM, BANDS)["total"]
    assert np.all(np.abs((tau - t_r) - absorb) <= 1e-5 * tau)     # 6 significant digits: 5e-6 relative each
    assert np.all((alb > 0) & (alb <= 1))
    assert alb[0, 1] > 0.99 and alb[0, 6] < 0.5                 # 450 nm clear, 950 nm water band near the ground
    no_gas = models.atmosphere_layer_lines(BANDS, gas_absorption=False)
    assert all(np.all(_values(l, "ALBEDO") == 1) for l in no_gas)


def test_cloud_and_aerosol_lines():
    c = models.cloud_lines(BANDS)
    assert [l.split()[1] for l in c] == ["cloud_low", "cloud_low_hg", "cloud_middle", "cloud_middle_hg",
                                         "cloud_high", "cloud_high_hg"]
    assert [l.split()[2] for l in c] == ["EDDINGTON", "HG"] * 3
    assert all(np.array_equal(_values(c[i], "TAU"), _values(c[i + 1], "TAU")) for i in (0, 2, 4))   # one cloud, two models
    c = c[0::2]
    t550 = [_values(l, "TAU")[2] for l in c]
    assert 10 < t550[0] < 25 and 3 < t550[1] < 15 and 0.3 < t550[2] < 3
    a = models.aerosol_lines(BANDS)
    n_layers = sum(1 for z in models.PAPER_LEVELS_KM if z <= 12.0) - 1
    assert len(a) == 5 * n_layers
    assert a[0].startswith("MODEL aer_maritime_clean_1 HG")


def test_include_files_make_a_valid_earth_script(tmp_path):
    paths = models.write_earth_includes(tmp_path, BANDS)
    assert set(paths) == {"earth_surfaces.inr", "earth_atmosphere.inr", "earth_clouds.inr", "earth_aerosols.inr",
                          "earth_maps.inr", "earth_media.inr", "atmosphere_belts.npy",
                          "atmosphere_belts.npy.json"}
    maps = (tmp_path / "earth_maps.inr").read_text()
    for layer in ("LOW", "MIDDLE", "HIGH"):
        assert f"LATLON DEFAULT CLOUD_{layer}" in maps
    assert "MAP aerosol LATLON DEFAULT AEROSOL_TYPE" in maps
    script = tmp_path / "earth_check.inr"
    script.write_text("UNITS KM\nWAVELENGTHS 350 450 550 650 750 850 950 NM\n"
                      + "".join(f"INCLUDE '{n}'\n" for n in paths if n.endswith(".inr"))
                      + "SURFACE\n  SPHERE 0 0 0 6371\nOBJECT earth\n  INTERFACE ABSORB\n"
                      + "  SCATTER MAP snow MODELS snow\n  SCATTER MAP seaice MODELS sea_ice\n"
                      + "  SCATTER MAP cover MODELS " + " ".join(models.surfaces.IGBP_MODEL_NAMES) + "\n"
                      + "SURFACE\n  SPHERE 0 0 0 6372\nOBJECT low_clouds\n  INTERFACE TRANSMIT AIR AIR\n"
                      + "  SCATTER MAP cloud_low MODELS cloud_low\n"
                      + "SURFACE\n  SPHERE 0 0 0 6372.5\nOBJECT air_1\n  INTERFACE TRANSMIT AIR AIR\n"
                      + "  SCATTER MAP atmosphere MODELS air_1_trop air_1_mls air_1_mlw air_1_sas air_1_saw\n")
    it = check_file(script)
    assert not it.diags.items, [d.render() for d in it.diags.items]
    assert it.state.maps["ATMOSPHERE"].path.endswith("atmosphere_belts.npy")
    assert "CLOUD_LOW" in it.state.maps and it.state.maps["COVER"].dataset == "LANDCOVER"


@pytest.mark.slow
def test_a_traced_earth_with_the_generated_models(tmp_path):
    from _trace_util import INC, SCA, ledger_gap, row, trace_text
    from irtlang.earth.surfaces import scatter_map_line

    models.write_earth_includes(tmp_path, BANDS)
    res = trace_text(tmp_path, "UNITS KM\nWAVELENGTHS 350 450 550 650 750 850 950 NM\nSEED 3\n"
                     "INCLUDE 'earth_surfaces.inr'\nINCLUDE 'earth_maps.inr'\n"
                     "SURFACE\n  SPHERE 0 0 0 6371\nOBJECT earth\n  INTERFACE ABSORB\n"
                     "  SCATTER MAP snow MODELS snow\n  SCATTER MAP seaice MODELS sea_ice\n  " + scatter_map_line()
                     + "\nGRID RECT X 20000 -6400 6400 -6400 6400 40000 1 RANDOM\nSOURCE DIRECTION -1 0 0\n"
                     "FLUX TOTAL 1 W\nLEVEL 10\nHALT 0\nTRACE\n")
    assert ledger_gap(res) < 1e-12
    names = [n.upper() for n in res.rows]
    led = res.ledger[names.index("EARTH")]
    alb = led[SCA] / led[INC]
    assert np.all(alb > 0.03) and np.all(alb < 0.35)
    assert alb[5] > alb[3]                       # the red edge of the land shows in the disk (Africa, Europe)
