"""Mirror-spacing fit by matching a sharpness metric."""

import numpy as np
import pytest
from _analysis_synth import render_edge

from analysis import AnalysisError, fit_mirror_spacing

S_FOCUS = 0.0  # um of spacing change at best focus
S_TRUE = 23.0  # observed spacing (one side of focus)
STEP = 10.0


def _simulate(spacing):
    # blur grows linearly with the focus error away from a 0.8 px floor (pixel-integrated Gaussian edge)
    sigma = np.hypot(0.8, 0.08 * (spacing - S_FOCUS))
    return render_edge((64, 64), sigma)


def test_fit_recovers_spacing_with_parabolic_refinement():
    grid = np.arange(0.0, 61.0, STEP)
    fit = fit_mirror_spacing(_simulate(S_TRUE), _simulate, grid, roi=(0, 0, 64, 64))
    assert fit.grid_best == 20.0 and fit.refined
    # The parabola through three metric values is exact for a quadratic metric; the blur curve here has a cubic
    # part, so require the refinement to beat the grid point (3 um off) by at least a factor of 3.
    assert abs(fit.best_spacing - S_TRUE) < 1.0
    assert fit.mismatch.min() == fit.mismatch[2]


def test_fit_from_a_dict_and_with_the_defocus_metric():
    grid = np.arange(0.0, 61.0, STEP)
    table = {float(s): _simulate(s) for s in grid}
    obs = _simulate(S_TRUE)
    fit = fit_mirror_spacing(obs, table, roi=(0, 0, 64, 64))
    assert abs(fit.best_spacing - S_TRUE) < 1.0
    fit_d = fit_mirror_spacing(obs, table, metric="defocus", roi=(8, 8, 48, 48))
    assert abs(fit_d.best_spacing - S_TRUE) < 1.0


def test_fit_input_checks():
    grid = [0.0, 10.0, 20.0]
    with pytest.raises(AnalysisError, match="different shapes"):
        fit_mirror_spacing(np.ones((8, 8)), lambda s: np.ones((9, 9)), grid, metric=lambda im: im.mean())
    with pytest.raises(AnalysisError, match="increasing"):
        fit_mirror_spacing(np.ones((8, 8)), lambda s: np.ones((8, 8)), [0.0, 0.0, 1.0], metric=lambda im: im.mean())
    with pytest.raises(AnalysisError, match="no simulated image"):
        fit_mirror_spacing(np.ones((8, 8)), {0.0: np.ones((8, 8))}, grid, metric=lambda im: im.mean())
