"""Fit of the telescope's mirror spacing by matching an observed image's sharpness."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._common import AnalysisError, as_image, check_roi, same_shape
from .defocus import sparse_defocus_map
from .mtf import esf_slope

__all__ = ["SpacingFit", "image_metric", "fit_mirror_spacing"]


@dataclass(frozen=True)
class SpacingFit:
    """Result of :func:`fit_mirror_spacing`.

    best_spacing: the refined best spacing (unit of ``spacings``); grid_best: the grid point with the smallest
    mismatch; refined: whether the parabolic refinement was applied; spacings, metric_values and mismatch: the
    scanned curve; observed_value: the observed image's metric.
    """

    best_spacing: float
    grid_best: float
    refined: bool
    spacings: np.ndarray
    metric_values: np.ndarray
    mismatch: np.ndarray
    observed_value: float


def image_metric(image, metric="esf_slope", roi=None, **kwargs):
    """Scalar sharpness metric of an image (region).

    ``"esf_slope"``: :func:`analysis.esf_slope` in ``roi`` (1/px); ``"defocus"``: median of the Zhuo & Sim sparse
    blur (:func:`analysis.sparse_defocus_map`) over the edges inside ``roi`` (px); or a callable ``image -> float``.
    Extra keyword arguments go to the metric function.

    Signature: ``image_metric(image, metric="esf_slope", roi=None, **kwargs) -> float``.
    """
    if callable(metric):
        return float(metric(image, **kwargs))
    if metric == "esf_slope":
        return esf_slope(image, roi, **kwargs)
    if metric == "defocus":
        rows, cols = check_roi(roi, np.shape(image))
        sparse, _ = sparse_defocus_map(image, **kwargs)
        values = sparse[rows, cols]
        values = values[np.isfinite(values)]
        if values.size == 0:
            raise AnalysisError("no usable edge inside the region for the defocus metric")
        return float(np.median(values))
    raise AnalysisError(f"metric must be 'esf_slope', 'defocus' or a callable, got {metric!r}")


def fit_mirror_spacing(observed, simulate, spacings=None, *, metric="esf_slope", roi=None, metric_kwargs=None):
    """Mirror spacing whose simulated image best matches an observed one.

    Signature: ``fit_mirror_spacing(observed, simulate, spacings=None, *, metric="esf_slope", roi=None,
    metric_kwargs=None) -> SpacingFit``.

    ``simulate`` is a callable ``spacing -> image`` or a dict ``{spacing: image}`` (then ``spacings`` defaults to
    its sorted keys). For every spacing the metric (:func:`image_metric`) of the simulated image is compared with
    the observed one's; the mismatch is ``(metric(sim) - metric(obs))^2``. Parabolic refinement around the grid
    minimum: the metric is interpolated by the parabola through the best grid point and its two neighbours, and
    the refined spacing minimises the mismatch of that parabola between the neighbours (sampled at 4001 points);
    exact when the metric is quadratic in the spacing there. At an end of the grid no refinement is made.
    Defocus is symmetric about best focus, so scan one side of it: two spacings can match equally.
    """
    obs = as_image(observed, "observed")
    kwargs = dict(metric_kwargs or {})
    if isinstance(simulate, dict):
        table = simulate
        spacings = sorted(table) if spacings is None else spacings

        def simulate(s):  # noqa: F811 - the dict becomes a lookup
            try:
                return table[s]
            except KeyError:
                raise AnalysisError(f"no simulated image for spacing {s!r}") from None
    elif not callable(simulate):
        raise AnalysisError("simulate must be a callable spacing -> image or a dict {spacing: image}")
    if spacings is None:
        raise AnalysisError("spacings are required with a callable simulate")
    grid = np.asarray(spacings, dtype=np.float64).reshape(-1)
    if grid.size < 3 or np.any(np.diff(grid) <= 0):
        raise AnalysisError("need at least 3 strictly increasing spacings")
    target = image_metric(obs, metric, roi, **kwargs)
    values = []
    for s in grid:
        img = as_image(simulate(float(s)), f"simulated image at spacing {s}")
        same_shape(img, obs, (f"simulated image at spacing {s}", "observed image"))
        values.append(image_metric(img, metric, roi, **kwargs))
    values = np.array(values)
    mismatch = (values - target) ** 2
    i = int(np.argmin(mismatch))
    best, refined = float(grid[i]), False
    if 0 < i < grid.size - 1:
        # parabola through the metric at the best grid point and its neighbours; the refined spacing minimises
        # the squared difference between that parabola and the observed metric inside the bracket
        coeffs = np.polyfit(grid[i - 1:i + 2], values[i - 1:i + 2], 2)
        fine = np.linspace(grid[i - 1], grid[i + 1], 4001)
        best, refined = float(fine[np.argmin((np.polyval(coeffs, fine) - target) ** 2)]), True
    return SpacingFit(best, float(grid[i]), refined, grid, values, mismatch, float(target))
