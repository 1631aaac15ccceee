"""The slab models' albedo tables for many wavelength lines (Earth scripts: 295 lines, 300-2500 nm) are
interpolated in log tau (irtlang.plugins.bsdfs._common.slab_albedo_lines): they must agree with the direct
quadrature line by line."""
import numpy as np
import pytest

from irtlang.plugins.bsdfs import _common as C
from irtlang.plugins.bsdfs import hg, rayleigh

# Rayleigh optical depth of the whole atmosphere, 300-2500 nm (lambda^-4 over 3.7 decades); an aerosol-like
# Angstrom law; thick clouds
CASES = [np.geomspace(1.2, 1.2 * (300 / 2500) ** 4, 295), np.geomspace(0.3, 0.3 * (300 / 2500) ** 1.4, 295),
         np.geomspace(1e-3, 30.0, 295)]


@pytest.mark.parametrize("taus", CASES, ids=["rayleigh", "angstrom", "wide"])
def test_rayleigh_tables_agree_with_direct_quadrature(taus):
    alb = np.linspace(0.9, 1.0, len(taus))
    P = rayleigh.pack({"tau": list(taus), "albedo": list(alb)}, len(taus))
    mu = rayleigh.table_mu_nodes(rayleigh.NT, rayleigh.T0 ** 2)
    avg = rayleigh._phase_avg_factory(P[2, 0])
    idx = [0, 1, 37, 148, 250, 293, 294]
    R, T = C.slab_albedo(avg, taus[idx], alb[idx], mu)
    Rp = P[rayleigh.ROW_R:rayleigh.ROW_R + rayleigh.NT][:, idx].T
    Tp = P[rayleigh.ROW_T:rayleigh.ROW_T + rayleigh.NT][:, idx].T
    assert np.max(np.abs(Rp - R) / R) < 1e-6
    assert np.max(np.abs(Tp - T) / T) < 1e-6


def test_hg_tables_agree_with_direct_quadrature():
    taus = CASES[1]
    P = hg.pack({"g": 0.7, "tau": list(taus), "albedo": 0.95, "orders": 4}, len(taus))
    mu = hg.table_mu_nodes(hg.NT, hg.T0 * hg.T0)
    avg = hg._phase_avg_factory(0.7, hg.order_weights(0.95, 4))
    idx = [0, 99, 200, 294]
    R, T = C.slab_albedo(avg, taus[idx], 0.95, mu)
    assert np.max(np.abs(P[hg.ROW_R:hg.ROW_R + hg.NT][:, idx].T - R) / R) < 1e-6
    assert np.max(np.abs(P[hg.ROW_T:hg.ROW_T + hg.NT][:, idx].T - T) / T) < 1e-6


def test_graded_quadrature_converged():
    """20 levels of grading toward mu_s agree with 40 (the finer reference) to 1e-8."""
    mu = hg.table_mu_nodes(hg.NT, hg.T0 * hg.T0)
    avg = hg._phase_avg_factory(0.7, hg.order_weights(0.95, 1))
    taus = np.array([1e-4, 0.01, 1.0, 30.0])
    R, T = C.slab_albedo(avg, taus, 0.95, mu)
    fine = C._graded_nodes.__wrapped__
    orig = C._graded_nodes
    try:
        C._graded_nodes = lambda ms, n_gl=12, levels=40: fine(ms, n_gl, levels)
        R40, T40 = C.slab_albedo(avg, taus, 0.95, mu)
    finally:
        C._graded_nodes = orig
    assert np.max(np.abs(R - R40) / R40) < 1e-8
    assert np.max(np.abs(T - T40) / T40) < 1e-8
