"""Figures for the analysis results (matplotlib, Agg canvas, no pyplot state). Every function takes arrays (the
results of the pure functions of :mod:`analysis`), writes one image file atomically and returns its path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ._common import atomic_path

__all__ = ["plot_rgb", "plot_defocus", "plot_mtf", "plot_esf", "plot_psf", "plot_spectra", "plot_time_wavelength",
           "plot_despace_maps", "plot_despace_curve"]


def _figure(ncols=1, width=5.0, height=4.0):
    fig = Figure(figsize=(width * ncols, height), layout="constrained")
    FigureCanvasAgg(fig)
    axes = [fig.add_subplot(1, ncols, k + 1) for k in range(ncols)]
    return fig, axes


def _save(fig, path, dpi=120):
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png")
    return path


def plot_rgb(rgb, path, *, title=None):
    """Show an (H, W, 3) uint8 composite with axes in pixels."""
    fig, (ax,) = _figure()
    ax.imshow(rgb, origin="upper", interpolation="nearest")
    ax.set_xlabel("column [px]")
    ax.set_ylabel("row [px]")
    if title:
        ax.set_title(title)
    return _save(fig, path)


def plot_defocus(image, defocus, path, *, edges=None, difference=None, vmax=None):
    """Image (with its edge map in red if given), defocus map (blur sigma, px) and optionally a difference map
    (observation minus simulation, diverging colours), side by side."""
    panels = 2 + (difference is not None)
    fig, axes = _figure(panels, 4.2, 4.0)
    axes[0].imshow(image, cmap="gray", origin="upper")
    if edges is not None:
        overlay = np.zeros(np.shape(edges) + (4,))
        overlay[np.asarray(edges, bool)] = (1.0, 0.1, 0.1, 1.0)
        axes[0].imshow(overlay, origin="upper", interpolation="nearest")
    axes[0].set_title("image" + (" and edges" if edges is not None else ""))
    im = axes[1].imshow(defocus, cmap="viridis", origin="upper", vmin=0, vmax=vmax)
    fig.colorbar(im, ax=axes[1], label="blur sigma [px]")
    axes[1].set_title("defocus map")
    if difference is not None:
        lim = float(np.nanmax(np.abs(difference))) or 1.0
        im = axes[2].imshow(difference, cmap="RdBu_r", origin="upper", vmin=-lim, vmax=lim)
        fig.colorbar(im, ax=axes[2], label="observation - simulation")
        axes[2].set_title("difference")
    return _save(fig, path)


def plot_mtf(freq, mtf, path, *, reference=None, label="measured"):
    """MTF against frequency (cycles/px); ``reference`` an optional (freq, mtf) pair drawn dashed; the MTF50 level
    is marked."""
    fig, (ax,) = _figure()
    ax.plot(freq, mtf, label=label)
    if reference is not None:
        ax.plot(reference[0], reference[1], "--", label="reference")
    ax.axhline(0.5, color="0.6", lw=0.8)
    ax.set_xlabel("frequency [cycles/px]")
    ax.set_ylabel("MTF")
    ax.set_ylim(0, 1.05)
    ax.legend()
    return _save(fig, path)


def plot_esf(distance, esf, path):
    """Super-sampled edge-spread function against distance from the edge (px)."""
    fig, (ax,) = _figure()
    ax.plot(distance, esf, ".-", ms=3)
    ax.set_xlabel("distance from edge [px]")
    ax.set_ylabel("ESF")
    return _save(fig, path)


def plot_psf(radius, profile, path, *, ee_radius=None, ee=None, unit="px"):
    """Azimuthally averaged PSF profile (log scale) and, if given, the encircled-energy curve."""
    fig, axes = _figure(1 + (ee is not None), 4.5, 3.8)
    axes[0].semilogy(radius, np.clip(profile, np.max(profile) * 1e-6, None))
    axes[0].set_xlabel(f"radius [{unit}]")
    axes[0].set_ylabel("mean intensity")
    if ee is not None:
        axes[1].plot(ee_radius, ee)
        axes[1].axhline(0.8, color="0.6", lw=0.8)
        axes[1].set_xlabel(f"radius [{unit}]")
        axes[1].set_ylabel("encircled energy")
        axes[1].set_ylim(0, 1.02)
    return _save(fig, path)


def plot_spectra(wavelengths_nm, spectra, path, *, labels=None, ylabel="flux"):
    """One or more spectra (rows of ``spectra``) against wavelength (nm)."""
    fig, (ax,) = _figure()
    spectra = np.atleast_2d(spectra)
    for k, s in enumerate(spectra):
        ax.plot(wavelengths_nm, s, "o-", ms=3, label=None if labels is None else labels[k])
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel(ylabel)
    if labels is not None:
        ax.legend()
    return _save(fig, path)


def _cell_edges(centres, half_width=0.5):
    """Cell edges around sorted centres: midpoints, the end cells symmetric (one centre: +/- ``half_width``)."""
    c = np.asarray(centres, dtype=np.float64).reshape(-1)
    if c.size == 1:
        return np.array([c[0] - half_width, c[0] + half_width])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[2 * c[0] - mid[0]], mid, [2 * c[-1] - mid[-1]]])


def plot_time_wavelength(values, times_h, wavelengths_nm, path, *, label="relative difference", diverging=True,
                         time_label="time [h]"):
    """Time x wavelength map (rows: times in hours, columns: wavelengths in nm): diverging colours about 0, or
    with ``diverging=False`` a sequential map (viridis) from the smallest to the largest value (e.g. an apparent
    albedo). Each value fills the cell reaching halfway to its neighbours."""
    fig, (ax,) = _figure(1, 6.0, 4.0)
    values = np.asarray(values, dtype=np.float64)
    if diverging:
        lim = float(np.nanmax(np.abs(values))) or 1.0
        cmap, vmin, vmax = "RdBu_r", -lim, lim
    else:
        cmap, vmin, vmax = "viridis", float(np.nanmin(values)), float(np.nanmax(values))
        if vmin == vmax:
            vmin, vmax = vmin - 0.5 * (abs(vmin) or 1.0), vmax + 0.5 * (abs(vmax) or 1.0)
    im = ax.pcolormesh(_cell_edges(wavelengths_nm, 5.0), _cell_edges(times_h, 0.5), values, cmap=cmap, vmin=vmin,
                       vmax=vmax, shading="flat")
    fig.colorbar(im, ax=ax, label=label)
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel(time_label)
    return _save(fig, path)


def plot_time_wavelength_pair(values, times_h, wavelengths_nm, path, *, label="apparent albedo",
                              time_label="time [h]"):
    """Two time x wavelength maps side by side: the values (sequential colours) and their difference from the mean
    over time at each wavelength (diverging colours about 0), the seed's Fig. 9b beside the absolute map."""
    values = np.asarray(values, dtype=np.float64)
    diff = values - values.mean(axis=0, keepdims=True)
    fig, (a0, a1) = _figure(2, 6.0, 4.0)
    xe, ye = _cell_edges(wavelengths_nm, 5.0), _cell_edges(times_h, 0.5)
    vmin, vmax = float(np.nanmin(values)), float(np.nanmax(values))
    if vmin == vmax:
        vmin, vmax = vmin - 0.5 * (abs(vmin) or 1.0), vmax + 0.5 * (abs(vmax) or 1.0)
    im0 = a0.pcolormesh(xe, ye, values, cmap="viridis", vmin=vmin, vmax=vmax, shading="flat")
    fig.colorbar(im0, ax=a0, label=label)
    lim = float(np.nanmax(np.abs(diff))) or 1.0
    im1 = a1.pcolormesh(xe, ye, diff, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="flat")
    fig.colorbar(im1, ax=a1, label=f"{label} - its mean over time")
    for ax, title in ((a0, label), (a1, "difference from the mean")):
        ax.set_xlabel("wavelength [nm]")
        ax.set_ylabel(time_label)
        ax.set_title(title)
    return _save(fig, path)


def plot_mean_spectrum(wavelengths_nm, mean, path, *, stderr=None, spread=None, features=(), ylabel="apparent albedo",
                       title=None):
    """A mean spectrum with its Monte Carlo uncertainty band (+- 2 stderr, dark) and the spread over time (+- 1
    standard deviation, light), and vertical labels at features: (wavelength_nm, text) pairs or
    (lo_nm, hi_nm, text) bands."""
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    m = np.asarray(mean, dtype=np.float64)
    fig, (ax,) = _figure(1, 10.0, 4.5)
    if spread is not None:
        s = np.asarray(spread, dtype=np.float64)
        ax.fill_between(wl, m - s, m + s, color="tab:blue", alpha=0.15, lw=0, label="+-1 std over time")
    if stderr is not None:
        e = np.asarray(stderr, dtype=np.float64)
        ax.fill_between(wl, m - 2 * e, m + 2 * e, color="tab:blue", alpha=0.45, lw=0,
                        label="+-2 standard errors (Monte Carlo)")
    ax.plot(wl, m, color="k", lw=0.9, label="mean over time")
    hi = m + (2 * np.asarray(stderr, dtype=np.float64) if stderr is not None else 0.0)
    if spread is not None:
        hi = np.maximum(hi, m + np.asarray(spread, dtype=np.float64))
    top = float(np.nanmax(hi)) or 1.0
    ax.set_ylim(0.0, top * 1.32)
    k = 0
    for f in features:
        if len(f) == 3:
            lo, hi_, text = f
            ax.axvspan(lo, hi_, color="0.88", zorder=0)
            x = 0.5 * (lo + hi_)
        else:
            x, text = f
            ax.axvline(x, color="0.6", lw=0.6, ls=":", zorder=0)
        if wl.min() <= x <= wl.max():      # labels in two staggered rows so that neighbours do not overlap
            ax.text(x, top * (1.30 if k % 2 == 0 else 1.17), text, rotation=90, ha="center", va="top", fontsize=6.5)
            k += 1
    ax.set_xlim(wl.min() - (5.0 if wl.min() == wl.max() else 0.0), wl.max() + (5.0 if wl.min() == wl.max() else 0.0))
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3, fontsize=7, frameon=False)
    return _save(fig, path)


def plot_despace_maps(images, result, path, *, rows=5):
    """The defocus study's maps, as the seed's Fig. 8: one row for the observation and one per spacing (up to
    ``rows``, spread over the sweep, the best one included): the frame with its Canny edges, the Zhuo & Sim
    defocus (blur sigma, px, at the edges) and the difference observation - scale x simulation.  North up."""
    sweep = images["sweep"]
    spacings = list(images["spacings"])
    if not sweep:
        raise ValueError("no maps to plot (the study ran without maps)")
    best = result["best_spacing_um"]
    pick = sorted(set(np.linspace(0, len(spacings) - 1, max(min(rows, len(spacings)), 2)).round().astype(int).tolist())
                  | {int(np.argmin(np.abs(np.asarray(spacings) - best)))})
    n = len(pick) + 1
    fig = Figure(figsize=(11.0, 3.0 * n), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(n, 3, squeeze=False)
    region = images["region"]
    ys, xs = np.nonzero(region)
    box = (xs.min(), xs.max() + 1, ys.min(), ys.max() + 1) if xs.size else None
    vmax_img = float(np.percentile(images["observed"], 99.7)) or 1.0
    diffs = [sweep[k]["difference"] for k in pick]
    lim = float(np.nanpercentile(np.abs(np.concatenate([d[region] for d in diffs])), 99.5)) or 1.0
    sig = [sweep[k]["defocus"] for k in pick]
    smax = float(np.nanpercentile(np.concatenate([s[np.isfinite(s)] for s in sig] + [np.zeros(1)]), 95)) or 1.0

    def show(ax, img, title, **kw):
        ax.imshow(img, origin="lower", interpolation="nearest", **kw)
        if box is not None:
            ax.set_xlim(box[0], box[1])
            ax.set_ylim(box[2], box[3])
        ax.set_title(title, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])

    def edges_overlay(ax, edges):
        ov = np.zeros(np.shape(edges) + (4,))
        ov[np.asarray(edges, bool)] = (1.0, 0.15, 0.1, 0.9)
        ax.imshow(ov, origin="lower", interpolation="nearest")

    a = axes[0]
    show(a[0], images["observed"], "observation (smoothed) and edges", cmap="gray", vmin=0, vmax=vmax_img)
    if images.get("observed_edges") is not None:
        edges_overlay(a[0], images["observed_edges"])
    for ax in a[1:]:
        ax.axis("off")
    txt = (f"best spacing {best:+.2f} +/- {result['uncertainty_um']:.2f} um"
           + (f"\nrefocus {result['refocus_mm']:.3f} mm toward the primary" if result.get("refocus_mm") is not None
              else "")
           + (f"\n(twin traced at {result['truth_um']:+.3f} um)" if result.get("truth_um") is not None else ""))
    a[1].text(0.0, 0.5, txt, transform=a[1].transAxes, fontsize=11, va="center")
    for r, k in enumerate(pick, start=1):
        m = sweep[k]
        s = spacings[k]
        show(axes[r][0], m["image"], f"{s:+.1f} um: frame and edges", cmap="gray", vmin=0, vmax=vmax_img)
        edges_overlay(axes[r][0], m["edges"])
        d = np.where(np.isfinite(m["defocus"]), m["defocus"], np.nan)
        show(axes[r][1], np.zeros_like(d), "", cmap="gray", vmin=0, vmax=1)
        im = axes[r][1].imshow(d, origin="lower", interpolation="nearest", cmap="viridis", vmin=0, vmax=smax)
        axes[r][1].set_title(f"{s:+.1f} um: defocus at the edges (sigma, px)", fontsize=9)
        fig.colorbar(im, ax=axes[r][1], shrink=0.8)
        show(axes[r][2], np.where(region, m["difference"], np.nan), f"{s:+.1f} um: observation - simulation",
             cmap="RdBu_r", vmin=-lim, vmax=lim)
    return _save(fig, path, dpi=72)


def plot_despace_curve(result, path):
    """The defocus study's mismatch curve: chi2 / dof against the spacing with the parabola of the fit, the best
    spacing and its uncertainty (and the twin's truth), and the median ESF slope along the limb beside it."""
    table = result["table"]
    s = np.array([r["spacing_um"] for r in table])
    red = np.array([r["reduced_chi2"] for r in table])
    fig, (ax, bx) = _figure(2, 5.2, 4.0)
    ax.plot(s, red, "o", color="k", label="sweep frames")
    lo, hi = result["parabola_points"]
    best, unc = result["best_spacing_um"], result["uncertainty_um"]
    if hi - lo == 3:
        c = np.polyfit(s[lo:hi], red[lo:hi], 2)
        xx = np.linspace(s[lo], s[hi - 1], 200)
        ax.plot(xx, np.polyval(c, xx), "-", color="C0", label="parabola through 3 frames")
    ax.axvline(best, color="C3", label=f"best {best:+.2f} um")
    if np.isfinite(unc):
        ax.axvspan(best - unc, best + unc, color="C3", alpha=0.2, label=f"+/- {unc:.2f} um")
    if result.get("truth_um") is not None:
        ax.axvline(result["truth_um"], color="C2", ls="--", label=f"twin traced at {result['truth_um']:+.2f} um")
    ax.set_xlabel("change of the mirror spacing [um]")
    ax.set_ylabel("chi2 / dof (observation vs simulation)")
    ax.legend(fontsize=8, loc="upper center")      # the curve is a valley: its top middle is empty
    ax.set_title("mismatch")
    slope = np.array([r["esf_slope_per_px"] for r in table])
    bx.plot(s, slope, "o-", color="k", label="simulation (median over the limb regions)")
    if np.isfinite(result.get("observed_esf_slope_per_px", np.nan)):
        bx.axhline(result["observed_esf_slope_per_px"], color="C3", label="observation")
    if result.get("esf_slope_spacing_um") is not None:
        bx.axvline(result["esf_slope_spacing_um"], color="C3", ls=":",
                   label=f"match at {result['esf_slope_spacing_um']:+.1f} um")
    bx.set_xlabel("change of the mirror spacing [um]")
    bx.set_ylabel("ESF slope [1/px]")
    bx.legend(fontsize=8)
    bx.set_title("edge-spread slope along the limb")
    return _save(fig, path)
