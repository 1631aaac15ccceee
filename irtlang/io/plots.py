"""Figures of the engine's analyses (matplotlib, Agg canvas, no pyplot state), written atomically: the path layout
(STATS PATHS), the PST curve (PST) and spot diagrams (SPOTS DIAGRAM).  Every axis carries its unit."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .atomic import atomic_path

COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink", "tab:gray")


def _figure(nrows, ncols, w, h):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w * ncols, h * nrows), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    return fig, axes


def _save(fig, path: Path, dpi=110) -> None:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")


def path_layout(path: Path, shown, unit: str, frame_name: str) -> None:
    """shown: [(label, flux, fraction, x (n,), y (n,))] for the leading paths.  Left: each path's flux (log scale,
    labelled with its object sequence); right: where its rays end, in the detector's local frame (equal axes)."""
    fig, axes = _figure(1, 2, 6.0, 4.8)
    ax0, ax1 = axes[0]
    n = len(shown)
    fl = [max(fx, 1e-300) for _, fx, _, _, _ in shown]
    ax0.barh(range(n), fl, color=[COLORS[k % len(COLORS)] for k in range(n)])
    ax0.set_xscale("log")
    ax0.set_yticks(range(n))
    ax0.set_yticklabels([f"{k + 1}" for k in range(n)])
    ax0.invert_yaxis()
    for k, (label, fx, frac, _, _) in enumerate(shown):
        ax0.annotate(f" {label}  ({frac:.3g})", (min(fl), k), xytext=(2, 0), textcoords="offset points",
                     va="center", fontsize=7)
    ax0.set_xlabel("flux (W)")
    ax0.set_ylabel("path rank")
    ax0.set_title("leading paths (fraction of the total); R reflect, T transmit, S scatter, A absorb", fontsize=8)
    for k, (label, fx, frac, x, y) in enumerate(shown):
        if len(x):
            ax1.plot(x, y, ".", color=COLORS[k % len(COLORS)], ms=3, alpha=0.6, label=f"{k + 1}")
    ax1.set_aspect("equal", adjustable="datalim")
    ax1.set_xlabel(f"x on {frame_name} ({unit})")
    ax1.set_ylabel(f"y on {frame_name} ({unit})")
    ax1.set_title("where each path's rays end (detector frame)", fontsize=9)
    ax1.grid(alpha=0.3)
    if ax1.get_legend_handles_labels()[0]:
        ax1.legend(fontsize=7, title="path", markerscale=3)
    _save(fig, path)


def pst_plot(path: Path, angles_deg, pst, se, *, field_deg=None, title="point source transmittance") -> None:
    """PST(theta) on a log scale with one-standard-error bars; points without flux are marked at the bottom."""
    a, p, e = (np.asarray(x, float) for x in (angles_deg, pst, se))
    fig, axes = _figure(1, 1, 6.5, 4.5)
    ax = axes[0][0]
    pos = p > 0
    ax.errorbar(a[pos], p[pos], yerr=np.minimum(e[pos], 0.999 * p[pos]), fmt="o-", ms=4, capsize=2)
    if (~pos).any():
        floor = p[pos].min() / 10 if pos.any() else 1e-12
        ax.plot(a[~pos], np.full((~pos).sum(), floor), "v", color="tab:red", label="no flux reached the detector")
        ax.legend(fontsize=8)
    ax.set_yscale("log")
    if field_deg is not None:
        ax.axvspan(-field_deg if a.min() < 0 else 0, field_deg, color="0.9", zorder=0, label="field of view")
    ax.set_xlabel("off-axis angle (deg)")
    ax.set_ylabel("PST (detector irradiance / incident irradiance)")
    ax.set_title(title)
    ax.grid(alpha=0.3, which="both")
    _save(fig, path)


def spot_diagram(path: Path, panels, *, nrows, ncols, scale_um, airy_um=None, title=""):
    """panels: row-major list of dicts {x_um, y_um, line (int array), lines_nm, label, rms_um, geo_um, ref}; each
    panel draws the intercepts about its reference, one colour per wavelength, equal axes of half-width scale_um,
    with the Airy circle (radius 1.22 lambda N, per line) when known."""
    fig, axes = _figure(nrows, ncols, 3.0, 3.1)
    for k, ax in enumerate(axes.ravel()):
        if k >= len(panels) or panels[k] is None:
            ax.set_visible(False)
            continue
        pnl = panels[k]
        lines = pnl["lines_nm"]
        for q in np.unique(pnl["line"]):
            m = pnl["line"] == q
            ax.plot(pnl["x_um"][m], pnl["y_um"][m], ".", ms=1.5, color=COLORS[int(q) % len(COLORS)], rasterized=True)
        if airy_um is not None:
            for q, r in enumerate(np.atleast_1d(airy_um)):
                if r > 0 and (pnl["line"] == q).any():
                    t = np.linspace(0, 2 * math.pi, 200)
                    ax.plot(r * np.cos(t), r * np.sin(t), "-", color="k", lw=0.8)
        ax.set_xlim(-scale_um, scale_um)
        ax.set_ylim(-scale_um, scale_um)
        ax.set_aspect("equal")
        ax.axhline(0, color="0.8", lw=0.5, zorder=0)
        ax.axvline(0, color="0.8", lw=0.5, zorder=0)
        ax.set_title(pnl["label"], fontsize=8)
        ax.text(0.03, 0.03, f"RMS {pnl['rms_um']:.3g} um\nGEO {pnl['geo_um']:.3g} um", transform=ax.transAxes,
                fontsize=7, va="bottom")
        ax.tick_params(labelsize=7)
        if k % ncols == 0:
            ax.set_ylabel("y (um)", fontsize=8)
        if k // ncols == nrows - 1 or k + ncols >= len(panels):
            ax.set_xlabel("x (um)", fontsize=8)
    if len(panels) and panels[0] is not None and len(panels[0]["lines_nm"]) > 1:
        from matplotlib.lines import Line2D

        lines = panels[0]["lines_nm"]
        fig.legend([Line2D([], [], ls="", marker="o", color=COLORS[q % len(COLORS)]) for q in range(len(lines))],
                   [f"{lam:g} nm" for lam in lines], loc="outside lower center", ncols=len(lines), fontsize=8)
    if title:
        fig.suptitle(title, fontsize=9)
    _save(fig, path)
