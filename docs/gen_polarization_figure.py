"""The polarization figures of docs/tracer.md and docs/earth.md.  Run:
``python docs/gen_polarization_figure.py [cds] [planet] [earth|earth-clear [--from DIR]]``.

* docs/img/polarization_cds.png: irtlang's polarized (and scalar) trace of a Rayleigh layer against the
  Coulson-Dave-Sekera tables (Natraj et al. 2009); the scenes are tests/physics/test_polarization.py's (about a
  minute once the kernels are compiled);
* docs/img/polarization_planet.png: examples_scripts/polarized_planet.inr with 16 million rays (a few minutes):
  the disk's I, degree and angle of linear polarization;
* docs/img/earth_polarization.png: one frame of examples_scripts/earth.inr with ``--set polarization=1`` (the
  forward trace's Stokes maps on a 128 x 128 grid over the focal plane): I at 450 nm, the degree of linear
  polarization at 450 and 650 nm and its angle, pixels whose degree has a standard error above 0.05 left blank
  (about 10 minutes); and docs/img/earth_polarization_spectrum.png, the disk's degree of linear polarization per
  line from the entrance pupil's Stokes spectrum;
* docs/img/earth_polarization_clear.png (``earth-clear``): the same frame with a clear sky (``--set clouds='none'``)
  on a 256 x 256 grid with 25,600 Sun rays per line (about 12 minutes): the glint and the Rayleigh limb."""
from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "physics"))
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

import test_polarization as T  # noqa: E402
from _trace_util import trace_text  # noqa: E402

PHI = [0, 30, 60, 90, 120, 150, 180]
MU0, ALBEDO, N = 0.6, 0.0, 1_000_000


def cds(out: Path = ROOT / "docs" / "img" / "polarization_cds.png") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tmp = tempfile.mkdtemp()
    fig, axs = plt.subplots(1, 3, figsize=(12, 3.8), dpi=110)
    for mu, col in ((0.4, "C0"), (0.84, "C3")):
        tab = {s: T.cds_table(s, "UP")[(ALBEDO, MU0, mu)] for s in "IQU"}
        pol, sca = [], []
        for phi in PHI:
            text = T.layer_script(ALBEDO, MU0, mu, phi, True, N)
            (i, q, u, v), (si, sq, su, sv) = T.eye_stokes(trace_text(tmp, text, records=False), MU0, mu)
            pol.append((i, q, -u, si, sq, su))
            res = trace_text(tmp, text.replace("POLARIZATION\n", ""), records=False)
            f, se = res.flux_on([n.upper() for n in res.rows].index("EYE"))
            k = math.pi * MU0 / (mu * T.OMEGA)
            sca.append((f * k, se * k))
        pol, sca = np.array(pol), np.array(sca)
        for k, (ax, s) in enumerate(zip(axs, "IQU")):
            ax.plot(PHI, tab[s], "-", color=col, lw=1.2, label=f"table, mu = {mu}")
            ax.errorbar(PHI, pol[:, k], yerr=2 * pol[:, 3 + k], fmt="o", ms=4, color=col,
                        label=f"irtlang POLARIZATION, mu = {mu}")
            if s == "I":
                ax.errorbar(PHI, sca[:, 0], yerr=2 * sca[:, 1], fmt="x", ms=5, color=col,
                            label=f"irtlang scalar, mu = {mu}")
        print(f"mu {mu}: scalar I off the table by "
              + ", ".join(f"{100 * (a / b - 1):+.1f}%" for a, b in zip(sca[:, 0], tab["I"])))
    for ax, s in zip(axs, "IQU"):
        ax.set_xlabel("relative azimuth phi (deg)")
        ax.set_ylabel(f"{s} (pi L / E0)")
        ax.set_xticks(PHI)
        ax.grid(alpha=0.3)
    axs[0].legend(fontsize=7)
    fig.suptitle(f"Rayleigh layer, tau = 0.5, black ground, mu0 = {MU0}: reflected I, Q, U "
                 "(Coulson-Dave-Sekera, Natraj et al. 2009) vs irtlang (2 sigma bars)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out)
    print(out)


def planet(out: Path = ROOT / "docs" / "img" / "polarization_planet.png", rays: int = 16_000_000) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from irtlang.cli import main as irt

    d = Path(tempfile.mkdtemp())
    assert irt(["run", str(ROOT / "examples_scripts" / "polarized_planet.inr"), "--out", str(d), "--quiet",
                "--set", f"rays={rays}"]) == 0
    i, q, u = (np.load(d / f"planet_{k}.npy")[0] for k in "IQU")
    lit = i > 0.02 * i.max()
    dolp = np.where(lit, np.hypot(q, u) / np.where(lit, i, 1), np.nan)
    aolp = np.where(lit, np.degrees(0.5 * np.arctan2(u, q)), np.nan)
    ext = (-1.1, 1.1, -1.1, 1.1)
    fig, axs = plt.subplots(1, 3, figsize=(13, 4.2), dpi=110)
    for ax, a, title, kw in ((axs[0], i / i.max(), "I (relative)", dict(cmap="gray", vmin=0, vmax=1)),
                             (axs[1], dolp, "degree of linear polarization", dict(cmap="viridis", vmin=0, vmax=1)),
                             (axs[2], aolp, "angle of polarization (deg from x)", dict(cmap="twilight", vmin=-90,
                                                                                       vmax=90))):
        im = ax.imshow(a, origin="lower", extent=ext, **kw)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("x on the detector (m)")
        fig.colorbar(im, ax=ax, shrink=0.85)
    axs[0].set_ylabel("y on the detector (m)")
    tot = math.hypot(q.sum(), u.sum()) / i.sum()
    fig.suptitle(f"polarized_planet.inr: Rayleigh atmosphere (tau 0.25) over a glint ocean at 90 deg phase, "
                 f"{rays / 1e6:.0f} M rays; the disk's degree {tot:.3f}, E normal to the scattering plane", fontsize=10)
    fig.tight_layout()
    fig.savefig(out)
    print(out, f"disk degree {tot:.4f}, U/I {u.sum() / i.sum():+.4f}")


def earth(out: Path = ROOT / "docs" / "img" / "earth_polarization.png", sun_rays: int = 12800,
          folder: str | None = None, clouds: str = "eddington", pixels: int = 128, spectrum: bool = True) -> None:
    """folder: the output folder of such a run already made (only the picture is drawn again); clouds, pixels:
    earth_scene.inr's `clouds` and earth.inr's `pol_pixels`; spectrum: also draw the disk's spectrum."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from irtlang.cli import main as irt

    d = Path(folder) if folder else Path(tempfile.mkdtemp())
    if not folder:
        assert irt(["run", str(ROOT / "examples_scripts" / "earth.inr"), "--out", str(d), "--quiet",
                    "--set", "hours=1", "--set", "polarization=1", "--set", f"sun_rays={sun_rays}",
                    "--set", f"clouds='{clouds}'", "--set", f"pol_pixels={pixels}", "--set", "window=16",
                    "--set", "spectral_samples=1", "--set", "save_rays=0"]) == 0
    tag = next((d / "polarization").glob("*_450nm_I.npy")).name[:-len("_450nm_I.npy")]

    b = max(1, pixels // 128)       # drawn on a 128 x 128 grid: b x b map pixels summed (their tallies add up)

    def binned(a, square=False):
        a = a.reshape(a.shape[0] // b, b, a.shape[1] // b, b)
        return np.sqrt((a * a).sum(axis=(1, 3))) if square else a.sum(axis=(1, 3))

    def load(band):
        s = {k: binned(np.load(d / "polarization" / f"{tag}_{band}nm_{k}.npy")[0]) for k in "IQU"}
        # summed pixels' errors combined as independent (they come from the same rays: only for the blanking)
        e = {k: binned(np.load(d / "polarization" / f"{tag}_{band}nm_{k}.stderr.npy")[0], True) for k in "IQU"}
        return s, e

    maps = {}
    for band in (450, 650):
        s, e = load(band)
        i, q, u = s["I"], s["Q"], s["U"]
        lit = i > 0.0
        ii = np.where(lit, i, 1.0)
        dolp = np.hypot(q, u) / ii
        # the degree's standard error by the delta method, I, Q and U taken as independent (an approximation:
        # they come from the same rays); used only to blank the noisy pixels of the picture
        p = np.maximum(dolp, 1e-12)
        sd = np.sqrt(((q * e["Q"]) ** 2 + (u * e["U"]) ** 2) / (ii * ii * p) ** 2 + (dolp * e["I"] / ii) ** 2)
        ok = lit & (sd < 0.06)
        maps[band] = dict(i=i, lit=lit, ok=ok, dolp=np.where(ok, dolp, np.nan),
                          aolp=np.where(ok, np.degrees(0.5 * np.arctan2(u, q)), np.nan),
                          disk=math.hypot(q[lit].sum(), u[lit].sum()) / i[lit].sum(), sd=np.nanmedian(sd[lit]))
    rows, cols = np.nonzero(maps[450]["i"] > 0)
    r0, r1, c0, c1 = rows.min() - 3, rows.max() + 4, cols.min() - 3, cols.max() + 4
    crop = (slice(max(r0, 0), r1), slice(max(c0, 0), c1))
    fig, axs = plt.subplots(1, 3, figsize=(14, 4.6), dpi=110)
    ib = 450 if clouds == "eddington" else 650        # a clear sky: the glint shows at 650 nm
    pics = ((np.sqrt(maps[ib]["i"] / maps[ib]["i"].max()),
             f"sqrt of I at {ib} nm; E's direction (length: 6 px x degree)",
             dict(cmap="gray", vmin=0, vmax=1)),
            (maps[450]["dolp"], f"degree of linear polarization, 450 nm (disk {maps[450]['disk']:.3f})",
             dict(cmap="viridis", vmin=0, vmax=0.7)),
            (maps[650]["dolp"], f"degree of linear polarization, 650 nm (disk {maps[650]['disk']:.3f})",
             dict(cmap="viridis", vmin=0, vmax=0.7)))
    for ax, (a, title, kw) in zip(axs, pics):
        # as the RGB frames are drawn: the focal plane's row 0 on top, which puts north up (earth_scene.inr)
        im = ax.imshow(a[crop], origin="upper", interpolation="nearest", **kw)
        ax.set_title(title, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
        fig.colorbar(im, ax=ax, shrink=0.85)
    # the electric vector's direction (the angle from the detector's x) scaled by the degree, where it is known
    m = maps[ib]
    yy, xx = np.nonzero(m["ok"][crop])
    ang = np.radians(m["aolp"][crop][yy, xx])
    ln = 6.0 * m["dolp"][crop][yy, xx]
    axs[0].quiver(xx, yy, ln * np.cos(ang), ln * np.sin(ang), color="C1", angles="xy", scale_units="xy", scale=1,
                  headwidth=0, headlength=0, headaxislength=0, pivot="middle", width=0.006)
    sky = "" if clouds == "eddington" else f" --set clouds='{clouds}'"
    grid = f"{pixels} x {pixels}" + (f" summed to {pixels // b} x {pixels // b}" if b > 1 else "")
    fig.suptitle(f"earth.inr --set polarization=1{sky}, {tag} UTC: forward Stokes maps ({grid}), {sun_rays} Sun "
                 "rays per line, north up (blank: the degree's standard error > 0.06)", fontsize=9)
    fig.tight_layout()
    fig.savefig(out)
    print(out, {b: (round(m["disk"], 4), round(float(m["sd"]), 4)) for b, m in maps.items()})
    if not spectrum:
        return
    # the disk-integrated Stokes spectrum at the entrance pupil (SPECTRUM OF pupil ... STOKES): the degree of
    # linear polarization per line with its standard error (delta method, I, Q and U taken as independent)
    rows = np.genfromtxt(d / "polarization" / f"{tag}_disk.csv", delimiter=",", names=True)
    lam, I, Q, U = rows["wavelength_nm"], rows["I_W"], rows["Q_W"], rows["U_W"]
    sI, sQ, sU = rows["stderr_I_W"], rows["stderr_Q_W"], rows["stderr_U_W"]
    ok = I > 0
    p = np.hypot(Q[ok], U[ok]) / I[ok]
    sp = np.sqrt((Q[ok] * sQ[ok]) ** 2 + (U[ok] * sU[ok]) ** 2) / (I[ok] ** 2 * np.maximum(p, 1e-12))
    sp = np.hypot(sp, p * sI[ok] / I[ok])
    fig, ax = plt.subplots(figsize=(10, 3.8), dpi=110)
    ax.fill_between(lam[ok], p - 2 * sp, p + 2 * sp, color="C0", alpha=0.25, lw=0, label="+/- 2 standard errors")
    ax.plot(lam[ok], p, "-", color="C0", lw=1, label="degree of linear polarization, per line")
    for x, name in ((687, "O2 B"), (761, "O2 A"), (940, "H2O"), (1135, "H2O"), (1380, "H2O"), (1870, "H2O")):
        ax.axvline(x, color="0.6", lw=0.6, ls=":")
        ax.text(x, 0.97, name, transform=ax.get_xaxis_transform(), fontsize=7, ha="center", va="top")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("degree of linear polarization")
    ax.set_ylim(0, min(1.0, float(np.nanmax(p + 2 * sp)) * 1.1))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    ax.set_title(f"the whole disk at the entrance pupil, {tag} UTC, 57.7 deg phase ({sun_rays} Sun rays per line)",
                 fontsize=10)
    fig.tight_layout()
    spec = out.with_name(out.stem + "_spectrum.png")
    fig.savefig(spec)
    m4, m6 = (lam >= 400) & (lam <= 500), (lam >= 600) & (lam <= 700)
    print(spec, "disk degree 400-500 nm", np.hypot(Q[m4].sum(), U[m4].sum()) / I[m4].sum(), "600-700 nm",
          np.hypot(Q[m6].sum(), U[m6].sum()) / I[m6].sum())


if __name__ == "__main__":
    which = sys.argv[1:] or ["cds", "planet"]
    if "cds" in which:
        cds()
    if "planet" in which:
        planet()
    given = sys.argv[sys.argv.index("--from") + 1] if "--from" in sys.argv else None
    if "earth" in which:
        earth(folder=given)
    if "earth-clear" in which:      # a clear sky: the glint and the Rayleigh limb
        earth(ROOT / "docs" / "img" / "earth_polarization_clear.png", sun_rays=25600, folder=given, clouds="none",
              pixels=256, spectrum=False)
