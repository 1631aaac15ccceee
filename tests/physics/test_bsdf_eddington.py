"""EDDINGTON: a thick scattering layer with the delta-Eddington two-stream energy partition.

Oracles: the conservative-scattering formula of Joseph, Wiscombe and Weinman (1976, their eq. for w = 1:
R = [(1 - g') tau' + (2/3 - mu0)(1 - exp(-tau'/mu0))] / [4/3 + (1 - g') tau']), written here independently of the
module's Meador-Weaver form; energy conservation; the single-scattering limit of a thin isotropic layer
(R = tau / (2 mu0)); and the reflectance of a thick cloud computed exactly (all orders, Monte Carlo) with
irtlang's VOLUME medium, itself checked against DISORT (tests/physics/test_scatter_volume.py).  The delta-Eddington
approximation is good to a few per cent of R for thick clouds (Joseph et al. 1976, King and Harshvardhan 1986):
the comparison allows 5 % plus 5 standard errors.
"""
import math

import pytest

from irtlang.plugins.bsdfs import eddington as E

from _trace_util import ledger_gap, trace_text


def jww_conservative(g, tau, mu0):
    f = g * g
    gs, ts = g / (1 + g), (1 - f) * tau
    e = math.exp(-ts / mu0)
    return ((1 - gs) * ts + (2 / 3 - mu0) * (1 - e)) / (4 / 3 + (1 - gs) * ts)


@pytest.mark.parametrize("g,tau,mu0", [(0.85, 16, 0.7), (0.85, 4, 0.3), (0.0, 1, 1.0), (0.7, 100, 0.5)])
def test_conservative_limit_and_energy(g, tau, mu0):
    R, T, e = E.two_stream(g, tau, 1.0, mu0)
    assert R == pytest.approx(jww_conservative(g, tau, mu0), rel=1e-12)
    assert R + T + e == pytest.approx(1.0, abs=1e-12)
    # nearly conservative scattering joins the limit continuously (an absorption of 1e-8 per scattering, over
    # about tau'^2 scatterings in a thick layer, takes at most ~1e-5 of the light)
    R2, T2, e2 = E.two_stream(g, tau, 1 - 1e-8, mu0)
    assert R2 == pytest.approx(R, rel=1e-4) and T2 == pytest.approx(T, rel=1e-4) and R2 <= R


def test_absorption_and_thin_limit():
    R, T, e = E.two_stream(0.85, 16, 0.99, 0.7)
    assert 0 < R < E.two_stream(0.85, 16, 1.0, 0.7)[0] and R + T + e < 0.95      # absorbing droplets darken it
    R, T, e = E.two_stream(0.0, 1e-3, 1.0, 1.0)
    assert R == pytest.approx(1e-3 / 2, rel=2e-3) and T == pytest.approx(1e-3 / 2, rel=2e-3)


def test_zero_depth_is_transparent():
    assert E.two_stream(0.85, 0.0, 1.0, 0.5) == (0.0, 0.0, 1.0)


TAU, G, MU0 = 16.0, 0.85, 0.5
N = 200_000


def cloud_script(kind: str, n: int) -> str:
    """A cloud of optical depth 16 (g = 0.85, w = 1) lit at 60 deg: as an EDDINGTON slab, or as a VOLUME medium
    1 km thick; the reflected flux is what reaches the absorbing plane above the source."""
    layer = {"hg": f"""MODEL deck HG G {G} TAU {TAU} ALBEDO 1 ORDERS 4
SURFACE
  PLANE Z 0 RECT 1e7 1e7
OBJECT cloud
  INTERFACE TRANSMIT VACUUM VACUUM
  SCATTER MODEL deck
""", "slab": f"""MODEL deck EDDINGTON G {G} TAU {TAU} ALBEDO 1
SURFACE
  PLANE Z 0 RECT 1e7 1e7
OBJECT cloud
  INTERFACE TRANSMIT VACUUM VACUUM
  SCATTER MODEL deck
""", "volume": f"""MEDIUM cloud_air INDEX 1 VOLUME EXTINCTION ({TAU} / 1000 m) ALBEDO 1 PHASE HG G {G}
SURFACE
  PLANE Z 0 RECT 1e7 1e7
OBJECT cloud_top
  INTERFACE TRANSMIT cloud_air VACUUM
SURFACE
  PLANE Z -1000 RECT 1e7 1e7
OBJECT cloud_base
  INTERFACE TRANSMIT VACUUM cloud_air
"""}[kind]
    return f"""UNITS M
WAVELENGTHS 550 NM
SEED 11
{layer}SURFACE
  PLANE Z 3000 RECT 1e8 1e8
OBJECT sky
  INTERFACE ABSORB
SURFACE
  PLANE Z -3000 RECT 1e8 1e8
OBJECT below
  INTERFACE ABSORB
GRID RECT Z 2000 -10 10 -10 10 {n} 1 RANDOM
SOURCE DIRECTION (-sin(60)) 0 (-cos(60))
FLUX TOTAL 1 W
LEVEL 100000
HALT 0
TRACE
"""


def _reflectance(res):
    names = [n.upper() for n in res.rows]
    return res.flux_on(names.index("SKY"))


def test_thick_cloud_against_exact_multiple_scattering(tmp_path):
    slab = trace_text(tmp_path, cloud_script("slab", N), name="slab.inr", records=False)
    vol = trace_text(tmp_path, cloud_script("volume", N), name="volume.inr", records=False)
    (rs, ss), (rv, sv) = _reflectance(slab), _reflectance(vol)
    assert rs == pytest.approx(E.two_stream(G, TAU, 1.0, MU0)[0], abs=5 * ss + 1e-3)
    assert abs(rs - rv) <= 0.05 * rv + 5 * math.hypot(ss, sv), (rs, rv)
    # both conserve energy: sky + below (+ escaped) = 1 W (no absorption; the slab's R and T tables are interpolated over
    # cos_i, to about 1e-8), and the ledgers close
    for res in (slab, vol):
        names = [n.upper() for n in res.rows]
        tot = (res.flux_on(names.index("SKY"))[0] + res.flux_on(names.index("BELOW"))[0]
               + res.ledger[names.index("ESCAPED"), 4].sum())      # a few volume paths leave past the planes' edges
        assert tot == pytest.approx(1.0, rel=1e-6)
        assert ledger_gap(res) < 1e-12
    # the single-scattering HG slab (Pfeiffer-Chapman phase) is no cloud: it reflects a few per cent and books
    # most of the light as absorbed (why earth.inr's clouds are EDDINGTON layers by default)
    hg = trace_text(tmp_path, cloud_script("hg", N // 10), name="hg.inr", records=False)
    assert _reflectance(hg)[0] < 0.2 * rv
