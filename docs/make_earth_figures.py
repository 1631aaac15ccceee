"""The figures of docs/earth.md from a run folder of examples_scripts/earth.inr.

    python docs/make_earth_figures.py irt-out/earth docs/img [correlated_run]

writes earth_contact_sheet.png (the day's RGB frames, labelled with their UTC time), earth_frame_error.png (one
frame's 550 nm image and its per-pixel relative standard error), earth_relief_levels.png (the ground level
each 0.5 deg cell of ELEVATION puts the ground on, by the rule of examples_scripts/earth_scene.inr) and
earth_pupil_spectra.png (the first frame's disk spectrum from the pupil's camera-side trace against the forward
trace's, and with a run of `--set pupil_correlated=1` its correlated-lines spectrum).

    python docs/make_earth_figures.py --clear CLOUDY_RUN CLEAR_RUN docs/img

writes earth_clear_sky.png: the first frame's RGB image beside the same frame of a run with `--set clouds='none'`
(the glint, the land and the sea ice that the clouds hide).
"""
from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from irtlang.core.stats import lit_pixels  # noqa: E402


def _save(fig, p: Path, dpi: int) -> Path:
    fig.tight_layout()
    fig.savefig(p, dpi=dpi)
    plt.close(fig)
    return p


def contact_sheet(run: Path, out: Path, cols: int = 5) -> Path:
    frames = sorted((run / "rgb").glob("*.png"))
    rows = (len(frames) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(2.2 * cols, 2.35 * rows), squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, f in zip(axes.ravel(), frames):
        ax.imshow(plt.imread(f), origin="upper")
        t = f.stem
        ax.set_title(f"{t[:4]}-{t[4:6]}-{t[6:8]} {t[9:11]}:{t[11:13]}", fontsize=8)
    fig.suptitle("examples_scripts/earth.inr: the day's RGB frames (650/550/450 nm, I/F, one stretch)", fontsize=10)
    return _save(fig, out / "earth_contact_sheet.png", 110)


def frame_error(run: Path, out: Path) -> Path:
    f = sorted((run / "frames").glob("*_550nm.npy"))[0]
    img = np.load(f)[0]
    se = np.load(f.with_name(f.stem + ".stderr.npy"))[0]
    rel = np.where(img > 0, se / np.where(img > 0, img, 1), np.nan)
    lit = lit_pixels(img)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.6))
    a = ax[0].imshow(img * 1e12, origin="lower", cmap="gray", vmin=0,
                     vmax=np.percentile(img[lit] * 1e12, 99.5))   # a few bright outliers would set the scale
    fig.colorbar(a, ax=ax[0], label="pW per pixel")
    ax[0].set_title(f"{f.stem[:13]}: 550 nm band", fontsize=10)
    b = ax[1].imshow(np.where(lit, rel * 100, np.nan), origin="lower", cmap="viridis", vmin=0,
                     vmax=np.nanpercentile(rel[lit] * 100, 99))
    fig.colorbar(b, ax=ax[1], label="relative standard error (%)")
    ax[1].set_title(f"relative standard error, lit disk (median {np.nanmedian(rel[lit]):.1%}, "
                    f"rms {np.sqrt(np.nanmean(rel[lit] ** 2)):.1%})", fontsize=10)
    for x in ax:
        x.set_xlabel("pixel (window column)")
        x.set_ylabel("pixel (window row)")
    return _save(fig, out / "earth_frame_error.png", 100)


# the ground levels of earth_scene.inr (km) and their lower bounds in ELEVATION (m); below 200 m: sea level
RELIEF_LEVELS = (0.0, 0.4, 0.8, 1.0, 1.5, 2.0, 3.0, 3.5, 5.0)
RELIEF_FROM = (200, 600, 900, 1250, 1750, 2500, 3250, 4250)


def relief_levels(out: Path) -> Path:
    from matplotlib.colors import BoundaryNorm, ListedColormap

    from irtlang.earth.data import load_dataset

    elev = load_dataset("ELEVATION")
    lev = np.digitize(elev, RELIEF_FROM)           # 0: sea level, k: level k
    fig, ax = plt.subplots(figsize=(10, 5))
    cmap = ListedColormap(plt.get_cmap("terrain")(np.linspace(0.22, 0.95, len(RELIEF_LEVELS))))
    a = ax.imshow(lev, extent=(-180, 180, -90, 90), cmap=cmap,
                  norm=BoundaryNorm(np.arange(len(RELIEF_LEVELS) + 1) - 0.5, len(RELIEF_LEVELS)))
    cb = fig.colorbar(a, ax=ax, ticks=range(len(RELIEF_LEVELS)), shrink=0.8)
    cb.ax.set_yticklabels([f"{z:g} km" for z in RELIEF_LEVELS])
    cb.set_label("ground level (ELEVATION rounded to a layer top)")
    ax.set_xlabel("longitude (deg)")
    ax.set_ylabel("latitude (deg)")
    ax.set_title("examples_scripts/earth_scene.inr: the ground's level per 0.5 deg cell (relief = 1)", fontsize=10)
    return _save(fig, out / "earth_relief_levels.png", 90)


def _first_spectrum(folder: Path) -> np.ndarray:
    return np.loadtxt(sorted(folder.glob("*.csv"))[0], delimiter=",", skiprows=1)


def pupil_spectra(run: Path, out: Path, correlated: Path | None = None) -> Path:
    cam = _first_spectrum(run / "spectra")
    fwd = _first_spectrum(run / "spectra_forward")
    rows = 3 if correlated is not None else 2
    fig, axes = plt.subplots(rows, 1, figsize=(10, 3.1 * rows), sharex=True)
    ax = axes[0]
    for s, name, c in ((fwd, "forward trace, 800 Sun rays per line", "tab:gray"),
                       (cam, "pupil camera, DIRECTIONS 16 (512 rays per line)", "tab:blue")):
        ax.fill_between(s[:, 0], (s[:, 1] - s[:, 2]) * 1e9, (s[:, 1] + s[:, 2]) * 1e9, color=c, alpha=0.3, lw=0)
        ax.plot(s[:, 0], s[:, 1] * 1e9, color=c, lw=0.8, label=f"{name}: median {np.median(s[s[:, 1] > 0, 2] / s[s[:, 1] > 0, 1]):.1%} per line")
    ax.set_ylabel("flux through the pupil (nW)")
    ax.legend(fontsize=8)
    ax.set_title("examples_scripts/earth.inr, first frame: the disk spectrum two ways (+-1 standard error)", fontsize=10)
    ax = axes[1]
    pull = (cam[:, 1] - fwd[:, 1]) / np.hypot(cam[:, 2], fwd[:, 2])
    ok = np.isfinite(pull) & (np.hypot(cam[:, 2], fwd[:, 2]) > 0)
    ax.plot(cam[ok, 0], pull[ok], ".", ms=3, color="k")
    ax.axhline(0, color="k", lw=0.5)
    for k in (-2, 2):
        ax.axhline(k, color="tab:red", lw=0.5, ls="--")
    ax.set_ylabel("(camera - forward) / sigma")
    ax.set_title(f"difference per line in standard errors: chi-square per line {np.mean(pull[ok] ** 2):.2f} over "
                 f"{ok.sum()} lines", fontsize=9)
    if correlated is not None:
        cor = _first_spectrum(correlated / "spectra")
        ax = axes[2]
        ax.fill_between(cor[:, 0], (cor[:, 1] - cor[:, 2]) * 1e9, (cor[:, 1] + cor[:, 2]) * 1e9, color="tab:green",
                        alpha=0.3, lw=0)
        ax.plot(cor[:, 0], cor[:, 1] * 1e9, color="tab:green", lw=0.8,
                label="pupil camera, DIRECTIONS 16 CORRELATED: each line's level +-1 standard error as before; "
                      "the lines move together")
        ax.set_ylabel("flux through the pupil (nW)")
        ax.legend(fontsize=8)
    axes[-1].set_xlabel("wavelength (nm)")
    return _save(fig, out / "earth_pupil_spectra.png", 90)


def clear_sky(cloudy: Path, clear: Path, out: Path) -> Path:
    fig, axes = plt.subplots(1, 2, figsize=(9, 4.8))
    for ax, run, what in ((axes[0], cloudy, "the default clouds"), (axes[1], clear, "clouds = 'none'")):
        f = sorted((run / "rgb").glob("*.png"))[0]
        ax.imshow(plt.imread(f), origin="upper", interpolation="nearest")
        t = f.stem
        ax.set_title(f"{t[:4]}-{t[4:6]}-{t[6:8]} {t[9:11]}:{t[11:13]} UTC, {what}", fontsize=9)
        ax.axis("off")
    fig.suptitle("examples_scripts/earth.inr, first frame (650/550/450 nm, I/F)", fontsize=10)
    return _save(fig, out / "earth_clear_sky.png", 110)


if __name__ == "__main__" and sys.argv[1] == "--clear":
    print(clear_sky(Path(sys.argv[2]), Path(sys.argv[3]), Path(sys.argv[4])))
elif __name__ == "__main__":
    run, out = Path(sys.argv[1]), Path(sys.argv[2])
    out.mkdir(parents=True, exist_ok=True)
    if (run / "rgb").is_dir() and len(list((run / "rgb").glob("*.png"))) > 1:
        print(contact_sheet(run, out))
        print(frame_error(run, out))
        print(relief_levels(out))
    print(pupil_spectra(run, out, Path(sys.argv[3]) if len(sys.argv) > 3 else None))
