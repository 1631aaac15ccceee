"""The defocus study of Ryu et al. (2017, section 4.3) on planet images: which change of a telescope's mirror
spacing makes simulated frames look like an observed one.

Inputs: the observed frame and a sweep of simulated frames of the same scene, one per spacing, each with its
per-pixel standard errors (irtlang's EXPORT writes ``NAME.npy`` and ``NAME.stderr.npy``; for a real observation
write its noise model, shot and read noise, as ``NAME.stderr.npy``; without one only the simulation's errors enter
chi2 and the reduced-chi2 scaling of step 3 makes up for the missing part).

The fit (:func:`fit_spacing`), per spacing s_k:

1. the mismatch ``chi2_k = sum_p (O_p - a_k M_kp)^2 / (sigma_Op^2 + a_k^2 sigma_Mkp^2)`` over the region R (the
   lit disk and a margin of ``margin`` px around it, where blur moves light), p running over blocks of ``bin`` x
   ``bin`` pixels (4 x 4 by default, the seed's region size; the frames summed in them): a camera-side pixel's
   variance, estimated from its few samples, is itself noisy and correlated with the pixel's value, and a
   per-pixel chi2 weights the pixels that came out low too much (on the Earth demo it pulled the answer 11 um
   low with a reduced chi2 of 1.24); a block of 16 pixels has a stable variance (reduced chi2 1.04).  The blur
   the study resolves, 1.5 px per 10 um, survives 4 px blocks because every block shares in it.  Along the limb
   a block holds few paths, and its variance estimate can still come out far too small when two rays of a pair
   agree by chance; every block's variance is therefore raised to at least half of what its frame's blocks of
   the same flux typically show (:func:`floored_variance`; ``variance_floor``).  ``a_k`` is the scale that
   minimises it (weighted least squares, one re-weighting; ``free_scale=False`` keeps a_k = 1): an observation's
   calibration never matches a simulation's to the per cent, and a defocus moves light without changing its sum;
2. the parabola through the smallest chi2 and its two neighbours: its vertex is the best spacing s0;
3. its uncertainty, two parts added in quadrature: the statistical one, where the parabola rises by f (f = 1,
   scaled up by the reduced chi2 at the minimum when that exceeds 1: a model that does not fit as well as the
   errors say, from pointing, calibration or scene differences), and the grid's, step/sqrt(12): the vertex of
   three frames is no worse than the nearest frame, whose error is uniform over a step.  On frames of the
   Earth the statistical part is a fraction of a micrometre and the grid's dominates (2.9 um for 10 um steps):
   chi2 is not a parabola over a whole step (it rises faster toward sharper frames), so a finer sweep, not more
   rays, is what sharpens the answer.  Both frames' errors enter chi2; a sweep traced with common random numbers
   (one seed) keeps the curve smooth.

Irtlang's camera-side standard errors are conservative (the per-pixel variance of stratified samples is
estimated as if they were independent), so the reduced chi2 at the minimum is typically below 1 and the stated
uncertainty errs on the large side; tests/physics/test_earth_defocus.py checks that identical twins fall
inside it.

For each spacing the module also builds the seed's maps and numbers, on frames smoothed by a Gaussian of
``smooth`` px (Monte Carlo noise would make every pixel an edge): the Canny edge map, the Zhuo & Sim defocus
map (blur sigma, px; the smoothing adds in quadrature), the difference map (observation - a_k M_k) and the ESF
slope (:func:`analysis.mtf.esf_slope`) in ``n_regions`` regions of ``region`` x ``region`` px along the limb, the
sharpest stretches of the lit disk's edge.  The spacing whose median ESF slope matches the observation's is
reported as a second, independent estimate (``esf_slope_spacing_um``; no uncertainty).

The refocus (:func:`paraxial_refocus_mm`): the shift of the paraxial focus of a two-mirror telescope when its
mirror spacing grows by s (the focal plane must move that far toward the primary to restore focus).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from ._common import AnalysisError

__all__ = ["paraxial_refocus_mm", "sweep_files", "load_frame", "study_region", "mismatch", "bin_frame",
           "three_point_vertex", "fit_spacing", "limb_regions", "despace_study", "typical_variance",
           "floored_variance"]

_SWEEP_NAME = re.compile(r"^spacing_([+-]?\d+(?:\.\d*)?)um\.npy$")


def paraxial_refocus_mm(delta_um, f1_mm, m, back_focus_mm):
    """Paraxial focus shift (mm, positive toward the primary) of a Cassegrain whose mirror spacing grows by
    ``delta_um`` (um), from its design: primary focal length ``f1_mm``, secondary magnification ``m`` and the focus
    ``back_focus_mm`` behind the primary vertex.  With k = (f1 + e)/(m f1 + f1), d0 = f1 (1 - k) and the
    secondary's focal length F = m k f1/(m - 1), the secondary images the primary's focus, p = f1 - d0 - delta in
    front of it, at q = 1/(1/p - 1/F); the focus moves by q0 - q + delta.

    Signature: ``paraxial_refocus_mm(delta_um, f1_mm, m, back_focus_mm) -> float``.
    """
    f1, m, e = float(f1_mm), float(m), float(back_focus_mm)
    if not (f1 > 0 and m > 1 and e > -f1):
        raise AnalysisError(f"design f1 = {f1}, m = {m}, e = {e}: expected f1 > 0 and m > 1 (a Cassegrain)")
    k = (f1 + e) / (m * f1 + f1)
    d0 = f1 * (1.0 - k)
    F = m * k * f1 / (m - 1.0)
    delta = float(delta_um) * 1e-3
    p0, p = f1 - d0, f1 - d0 - delta
    q0 = 1.0 / (1.0 / p0 - 1.0 / F)
    q = 1.0 / (1.0 / p - 1.0 / F)
    return float(q0 - q + delta)


def sweep_files(folder):
    """The sweep's frames in a folder: files named ``spacing_<um>um.npy`` (e.g. ``spacing_+010.000um.npy``),
    sorted by spacing.

    Signature: ``sweep_files(folder) -> list[(spacing_um, Path)]``.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise AnalysisError(f"{folder}: not a folder of sweep frames")
    found = []
    for p in folder.iterdir():
        m = _SWEEP_NAME.match(p.name)
        if m:
            found.append((float(m.group(1)), p))
    if len(found) < 3:
        raise AnalysisError(f"{folder}: {len(found)} sweep frames (spacing_<um>um.npy); a fit needs at least 3")
    found.sort()
    s = [x for x, _ in found]
    if len(set(s)) != len(s):
        raise AnalysisError(f"{folder}: two frames for one spacing")
    return found


def load_frame(path):
    """A frame and its standard errors (``NAME.stderr.npy`` beside ``NAME.npy``; None when absent).

    Signature: ``load_frame(path) -> (image (H, W), stderr (H, W) or None)``.
    """
    from .files import load_image

    path = Path(path)
    img = load_image(str(path))
    se_path = path.with_name(path.stem + ".stderr.npy")
    se = load_image(str(se_path)) if se_path.exists() else None
    if se is not None and se.shape != img.shape:
        raise AnalysisError(f"{se_path}: shape {se.shape}, its frame {img.shape}")
    if not np.all(np.isfinite(img)):
        raise AnalysisError(f"{path}: non-finite pixels")
    return img, se


def study_region(observed, models, *, threshold=0.02, margin=12):
    """Pixels the fit uses: where the observation or any model exceeds ``threshold`` of the observation's 99.5th
    percentile after a 2 px Gaussian smoothing, grown by ``margin`` px.

    Signature: ``study_region(observed, models, *, threshold=0.02, margin=12) -> bool (H, W)``.
    """
    from scipy.ndimage import binary_dilation, gaussian_filter

    ref = float(np.percentile(gaussian_filter(observed, 2.0), 99.5))
    if not ref > 0:
        raise AnalysisError("the observed frame is dark")
    lit = gaussian_filter(observed, 2.0) > threshold * ref
    for m in models:
        lit |= gaussian_filter(m, 2.0) > threshold * ref
    if margin > 0:
        lit = binary_dilation(lit, iterations=int(margin))
    return lit


def mismatch(observed, obs_se, model, model_se, region, *, free_scale=True, variance_floor=0.0):
    """chi2 of the observation against one model over the region, with the best scale (see the module).

    Signature: ``mismatch(observed, obs_se, model, model_se, region, *, free_scale=True, variance_floor=0.0) ->
    (chi2, dof, scale)``.  ``variance_floor``: each frame's variances are raised to at least this fraction of
    what the frame's pixels of the same flux typically show (:func:`floored_variance`).
    """
    o = observed[region]
    vo = obs_se[region] ** 2 if obs_se is not None else np.zeros_like(o)
    vm = model_se[region] ** 2 if model_se is not None else np.zeros_like(o)
    m = model[region]
    if variance_floor > 0:
        vo = floored_variance(o, vo, variance_floor)
        vm = floored_variance(m, vm, variance_floor)
    chi2, used, a = _chi2(o, vo, m, vm, free_scale)
    return chi2, max(used - (1 if free_scale else 0), 1), a


VARIANCE_FLOOR = 0.5
VARIANCE_BINS = 12


def typical_variance(values, variances, bins=VARIANCE_BINS):
    """(alpha, beta) of the variance a frame's pixels (or blocks) of flux v typically show, alpha v + beta v^2:
    a non-negative least-squares fit, in relative terms, to the medians of ``bins`` groups of equal count sorted by
    flux (medians: a lone estimate far below or above its neighbours does not move them).  A Monte Carlo image's
    variance grows as its flux (a count of paths: alpha) and as its square (the paths' spread of weights: beta).
    (0, 0) when fewer than 2 x bins values have both a flux and a variance (no floor then).

    Signature: ``typical_variance(values, variances, bins=12) -> (alpha, beta)``.
    """
    from scipy.optimize import nnls

    v = np.asarray(values, float).ravel()
    var = np.asarray(variances, float).ravel()
    keep = (v > 0) & (var > 0) & np.isfinite(v) & np.isfinite(var)
    v, var = v[keep], var[keep]
    if v.size < 2 * bins:
        return 0.0, 0.0
    order = np.argsort(v)
    groups = np.array_split(order, bins)
    mv = np.array([np.median(v[g]) for g in groups])
    mvar = np.array([np.median(var[g]) for g in groups])
    A = np.stack([mv, mv * mv], axis=1) / mvar[:, None]
    coef, _ = nnls(A, np.ones(bins))
    return float(coef[0]), float(coef[1])


def floored_variance(values, variances, fraction=VARIANCE_FLOOR):
    """The variances raised to at least ``fraction`` times the typical variance at each one's flux
    (:func:`typical_variance`).  A camera-side frame's variance comes from its samples' spread (a pixel's pairs of
    rays): where a block holds a few paths, as along the limb, two of them can agree by chance and the estimate
    falls far below the truth; chi2 then gives that block a weight out of all proportion (on the Earth demo, one
    4 x 4 block at the limb, whose brightest pixel had a 1 % standard error, added 330 to a sweep frame's chi2,
    about all of that frame's excess, and moved the fit by 7 um).  The floor keeps the estimate where it is
    likely (at 0.5 it raises 1.5-2.6 % of the Earth demo's lit blocks: the typical variance is a median, about the
    estimates' middle) and removes the outliers' weight.

    Signature: ``floored_variance(values, variances, fraction=0.5) -> ndarray``.
    """
    variances = np.asarray(variances, float)
    alpha, beta = typical_variance(values, variances)
    v = np.clip(np.asarray(values, float), 0.0, None)
    return np.maximum(variances, fraction * (alpha * v + beta * v * v))


def _chi2(o, vo, mo, vm, free_scale):
    floor = 1e-30 + 1e-12 * float(np.max(np.abs(o)) ** 2)   # pixels where both frames are exactly 0 weigh nothing
    a = 1.0
    for _ in range(2 if free_scale else 0):
        w = 1.0 / (vo + a * a * vm + floor)
        den = float(np.sum(w * mo * mo))
        a = float(np.sum(w * o * mo)) / den if den > 0 else 1.0
    var = vo + a * a * vm
    used = var > 0
    return float(np.sum((o[used] - a * mo[used]) ** 2 / var[used])), int(used.sum()), a


def three_point_vertex(s, c):
    """Vertex and curvature c2 of the parabola c2 (x - x0)^2 + c0 through three points (any spacing).

    Signature: ``three_point_vertex(s, c) -> (x0, c2)``.
    """
    c2, c1, _ = np.polyfit(np.asarray(s, float), np.asarray(c, float), 2)
    return (float(-c1 / (2.0 * c2)) if c2 > 0 else float("nan")), float(c2)


def bin_frame(image, stderr, b):
    """A frame summed in b x b pixel blocks (the last rows and columns that do not fill a block dropped), and
    its standard errors (the blocks' variances summed: the pixels' errors are independent).

    Signature: ``bin_frame(image, stderr, b) -> (image, stderr or None)``.
    """
    if b == 1:
        return image, stderr
    H, W = image.shape
    if H < b or W < b:
        raise AnalysisError(f"a {H} x {W} frame has no {b} x {b} block")

    def s(a):
        return a[:H // b * b, :W // b * b].reshape(H // b, b, W // b, b).sum(axis=(1, 3))

    return s(image), (None if stderr is None else np.sqrt(s(np.asarray(stderr, float) ** 2)))


def fit_spacing(observed, obs_se, spacings, models, model_ses, *, free_scale=True, margin=12, region=None, bin=4,
                variance_floor=VARIANCE_FLOOR):
    """The best spacing and its uncertainty (see the module).

    Signature: ``fit_spacing(observed, obs_se, spacings, models, model_ses, *, free_scale=True, margin=12,
    region=None, bin=4, variance_floor=0.5) -> dict``: ``best_spacing_um``, ``uncertainty_um`` (with its parts
    ``statistical_um`` and ``grid_um``), ``chi2`` (per sweep frame), ``dof``, ``scale``, ``reduced_chi2_min``,
    ``at_edge``, ``parabola_points``, ``region`` (of the full-resolution frame), ``variance_floor``.  ``bin``:
    chi2 is taken over bin x bin pixel blocks (see the module); ``variance_floor``: each frame's block variances
    are raised to at least this fraction of its typical variance at their flux (:func:`floored_variance`; 0: the
    frames' own variances as they are).
    """
    observed = np.asarray(observed, float)
    spacings = np.asarray(spacings, float)
    bin = int(bin)
    if bin < 1:
        raise AnalysisError(f"bin = {bin}: expected a block size >= 1 px")
    if spacings.size < 3:
        raise AnalysisError("a fit needs at least 3 spacings")
    if np.any(np.diff(spacings) <= 0):
        raise AnalysisError("the spacings must increase")
    for m in models:
        if np.shape(m) != observed.shape:
            raise AnalysisError(f"a sweep frame has shape {np.shape(m)}, the observation {observed.shape}: "
                                "trace the sweep with the observation's window")
    if obs_se is None and all(se is None for se in model_ses):
        raise AnalysisError("the frames carry no standard errors: chi2 is undefined (give NAME.stderr.npy files)")
    if region is None:
        region = study_region(observed, models, margin=margin)
    o, ose = bin_frame(observed, obs_se, bin)
    breg = bin_frame(region.astype(float), None, bin)[0] > 0
    rows = [mismatch(o, ose, *bin_frame(np.asarray(m, float), se, bin), breg, free_scale=free_scale,
                     variance_floor=float(variance_floor))
            for m, se in zip(models, model_ses)]
    chi2 = np.array([r[0] for r in rows])
    dof = rows[0][1]
    if not np.all(np.isfinite(chi2)):
        raise AnalysisError("chi2 is not finite: check the frames' standard errors")
    i = int(np.argmin(chi2))
    at_edge = i in (0, spacings.size - 1)
    lo = min(max(i - 1, 0), spacings.size - 3)
    best, c2 = three_point_vertex(spacings[lo:lo + 3], chi2[lo:lo + 3])
    if not np.isfinite(best) or not spacings[lo] <= best <= spacings[lo + 2]:
        best, at_edge = float(spacings[i]), True
    red = float(chi2[i]) / dof
    factor = max(1.0, red)
    stat = math.sqrt(factor / c2) if c2 > 0 else float("nan")
    # the vertex of three frames is no worse than the nearest frame, whose error is uniform over a step
    step = float(np.mean(np.diff(spacings[lo:lo + 3])))
    grid = step / math.sqrt(12.0)
    return {"best_spacing_um": float(best), "uncertainty_um": math.hypot(stat, grid), "statistical_um": stat,
            "grid_um": grid, "chi2": chi2.tolist(), "dof": int(dof), "scale": [r[2] for r in rows],
            "reduced_chi2_min": red, "uncertainty_factor": factor, "at_edge": bool(at_edge),
            "parabola_points": [lo, lo + 3], "region": region, "bin": bin, "variance_floor": float(variance_floor)}


def limb_regions(image, *, n_regions=8, region=16, smooth=1.5):
    """``n_regions`` non-overlapping square regions of ``region`` px centred on the sharpest stretches of the lit
    disk's edge (largest smoothed gradient on the edge of the lit mask): the limb, not the terminator.

    Signature: ``limb_regions(image, *, n_regions=8, region=16, smooth=1.5) -> list[(x, y, w, h)]``.
    """
    from scipy.ndimage import binary_erosion, gaussian_filter, sobel

    sm = gaussian_filter(np.asarray(image, float), smooth)
    lit = sm > 0.1 * float(np.percentile(sm, 99.5))
    edge = lit & ~binary_erosion(lit)
    g = np.hypot(sobel(sm, 0), sobel(sm, 1))
    ys, xs = np.nonzero(edge)
    order = np.argsort(-g[ys, xs])
    H, W = sm.shape
    half = region // 2
    out = []
    for t in order:
        y, x = int(ys[t]), int(xs[t])
        x0, y0 = x - half, y - half
        if x0 < 0 or y0 < 0 or x0 + region > W or y0 + region > H:
            continue
        if any(abs(x0 - a) < region and abs(y0 - b) < region for a, b, _, _ in out):
            continue
        out.append((x0, y0, region, region))
        if len(out) == n_regions:
            break
    return out


def _esf_median(image, regions):
    from .mtf import esf_slope

    vals = []
    for roi in regions:
        try:
            vals.append(esf_slope(image, roi, edge_fit_degree=2))
        except (AnalysisError, ValueError, np.linalg.LinAlgError):
            continue
    return float(np.median(vals)) if vals else float("nan")


def _crossing(s, y, target):
    """Where a curve y(s) first crosses target, by linear interpolation; None if it never does."""
    for k in range(len(s) - 1):
        a, b = y[k] - target, y[k + 1] - target
        if np.isfinite(a) and np.isfinite(b) and a * b <= 0 and a != b:
            return float(s[k] + (s[k + 1] - s[k]) * a / (a - b))
    return None


def despace_study(observed, sweep, *, design=None, truth=None, free_scale=True, margin=12, smooth=1.0,
                  n_regions=8, region=16, maps=True, bin=4, variance_floor=VARIANCE_FLOOR):
    """The whole study on files: the observed frame (path) and the sweep folder (``spacing_<um>um.npy`` frames).

    Signature: ``despace_study(observed, sweep, *, design=None, truth=None, free_scale=True, margin=12, smooth=1.0,
    n_regions=8, region=16, maps=True, bin=4, variance_floor=0.5) -> dict`` with ``best_spacing_um``,
    ``uncertainty_um``, ``refocus_mm`` (with ``design = (f1_mm, m, back_focus_mm)``; else None), ``method``, ``table`` (one row per spacing: chi2, scale,
    median defocus sigma on edges, median ESF slope along the limb, edge pixels), ``esf_slope_spacing_um`` and, for
    the figures, ``_images`` (not JSON).
    """
    from scipy.ndimage import gaussian_filter

    from .defocus import difference_map, edge_map, sparse_defocus_map

    obs, obs_se = load_frame(observed)
    files = sweep_files(sweep)
    spacings = [s for s, _ in files]
    frames = [load_frame(p) for _, p in files]
    fit = fit_spacing(obs, obs_se, spacings, [f[0] for f in frames], [f[1] for f in frames],
                      free_scale=free_scale, margin=margin, bin=bin, variance_floor=variance_floor)
    regions = limb_regions(obs, n_regions=n_regions, region=region)
    smooth_obs = gaussian_filter(obs, smooth) if smooth > 0 else obs
    obs_slope = _esf_median(smooth_obs, regions)
    table, images = [], []
    for k, (s, (img, _)) in enumerate(zip(spacings, frames)):
        sm = gaussian_filter(img, smooth) if smooth > 0 else img
        row = {"spacing_um": s, "chi2": fit["chi2"][k], "reduced_chi2": fit["chi2"][k] / fit["dof"],
               "scale": fit["scale"][k], "esf_slope_per_px": _esf_median(sm, regions)}
        if maps:
            sparse, edges = sparse_defocus_map(sm)
            vals = sparse[np.isfinite(sparse)]
            row["edge_median_sigma_px"] = float(np.median(vals)) if vals.size else None
            row["edge_pixels"] = int(edges.sum())
            images.append({"image": sm, "edges": edge_map(sm), "defocus": sparse,
                           "difference": difference_map(smooth_obs, fit["scale"][k] * sm)})
        table.append(row)
    refocus = (paraxial_refocus_mm(fit["best_spacing_um"], *design) if design is not None else None)
    refocus_unc = None
    if design is not None and math.isfinite(fit["uncertainty_um"]):
        h = max(fit["uncertainty_um"], 1e-6)
        refocus_unc = abs(paraxial_refocus_mm(fit["best_spacing_um"] + h, *design)
                          - paraxial_refocus_mm(fit["best_spacing_um"] - h, *design)) / 2.0
    slopes = [r["esf_slope_per_px"] for r in table]
    res = {
        "best_spacing_um": fit["best_spacing_um"], "uncertainty_um": fit["uncertainty_um"],
        "refocus_mm": refocus, "refocus_uncertainty_mm": refocus_unc,
        "method": (f"chi2 of the observation against each sweep frame in {bin} x {bin} pixel blocks over the lit "
                   f"disk and a {margin} px margin ({int(fit['region'].sum())} px), both frames' standard errors "
                   f"(each block's variance at least {fit['variance_floor']:g} x its frame's typical variance at "
                   "its flux), "
                   + ("a free scale per frame; " if free_scale else "no scale; ")
                   + "vertex of the parabola through the smallest chi2 and its two neighbours; uncertainty: where "
                   f"that parabola rises by {fit['uncertainty_factor']:.3g} (1 x max(1, reduced chi2 at the "
                   f"minimum)): {fit['statistical_um']:.3g} um, and the grid's step/sqrt(12): "
                   f"{fit['grid_um']:.3g} um, in quadrature; refocus: paraxial focal shift of the design "
                   "(analysis.despace)"),
        "statistical_uncertainty_um": fit["statistical_um"], "grid_uncertainty_um": fit["grid_um"],
        "reduced_chi2_min": fit["reduced_chi2_min"], "dof": fit["dof"], "at_edge_of_sweep": fit["at_edge"],
        "parabola_points": fit["parabola_points"],
        "observed": str(observed), "observed_esf_slope_per_px": obs_slope,
        "esf_slope_spacing_um": _crossing(spacings, slopes, obs_slope),
        "limb_regions": [list(r) for r in regions], "smooth_px": smooth,
        "truth_um": truth, "table": table,
        "_images": {"observed": smooth_obs, "observed_edges": edge_map(smooth_obs) if maps else None,
                    "sweep": images, "spacings": spacings, "region": fit["region"]},
    }
    return res
