"""The Earth benchmark (issue #8, item 1c and target 2c): the flagship examples_scripts/earth.inr.

Run: ``python -m benchmarks.bench_earth [--quick]`` (also part of ``python -m benchmarks``).

* The whole default run (25 hourly frames, the README's main job): wall time and peak memory of the ``irt run``
  process, against the target of 10 minutes on 2 cores.
* One frame (``--set hours=1``): wall time, then time against radiometric error at three Sun-ray counts (the
  relative standard error of the disk-integrated flux through the pupil, its 1/sqrt(N) slope, the figure of
  merit 1 / (err^2 t)), and the median error per line of the disk spectrum against Sun rays per line.

Each is a fresh ``irt run`` process with the warm Numba cache (start-up and packing included).  ``--quick`` skips
all of it (the whole day takes minutes).
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from irtlang.core.stats import lit_pixels

from ._common import ROOT, python_child

SCRIPT = ROOT / "examples_scripts" / "earth.inr"
SETTINGS = ("hours=1",)
TIMEOUT_S = 1800


RAYS = (100, 400, 1600)     # Sun rays per line: time against radiometric error


def earth_frame(script: Path = SCRIPT, settings=SETTINGS, timeout: int = TIMEOUT_S, keep=None,
                seed: int | None = None) -> dict:
    """Wall time of one `irt run` of the Earth script (one frame), the working tree's code, the warm Numba cache
    (`seed`: irt run --seed).  Returns {"s": seconds, "rc": exit status, "tail": the last lines of its output}."""
    args = ["run", str(script)]
    for s in settings:
        args += ["--set", s]
    if seed is not None:
        args += ["--seed", str(seed)]
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        p = python_child("import sys; from irtlang.cli import main; sys.exit(main())", *args, "--out", out,
                         timeout=timeout)
        t = time.perf_counter() - t0
        extra = keep(Path(out)) if keep is not None and p.returncode == 0 else {}
    tail = "\n".join(ln if len(ln) <= 160 else ln[:157] + "..." for ln in (p.stdout + p.stderr).strip().splitlines()[-8:])
    return {"s": t, "rc": p.returncode, "tail": tail, **extra}


def flagship(timeout: int = TIMEOUT_S) -> dict:
    """The README's main job, ``irt run examples_scripts/earth.inr`` with its defaults: wall time, peak RSS of
    the process (MB), the number of files it wrote."""
    code = ("import resource, sys; from irtlang.cli import main; rc = main(); "
            "print('PEAK_RSS_KB', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr); sys.exit(rc)")
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        p = python_child(code, "run", str(SCRIPT), "--out", out, timeout=timeout)
        t = time.perf_counter() - t0
        nfiles = sum(1 for f in Path(out).rglob("*") if f.is_file())
    rss = [ln.split()[1] for ln in p.stderr.splitlines() if ln.startswith("PEAK_RSS_KB")]
    return {"s": t, "rc": p.returncode, "rss_mb": int(rss[-1]) / 1024 if rss else float("nan"), "files": nfiles,
            "tail": "\n".join((p.stdout + p.stderr).strip().splitlines()[-3:])}


def _pupil_flux(out: Path) -> dict:
    """The forward trace's disk-integrated flux through the pupil (all lines) and its standard error, from
    spectra_forward/*.csv (the first frame's)."""
    import csv
    import math

    f = next((out / "spectra_forward").glob("*.csv"))
    rows = list(csv.DictReader(f.open()))
    flux = sum(float(r["flux_W"]) for r in rows)
    se = math.sqrt(sum(float(r["stderr_W"]) ** 2 for r in rows))
    return {"flux_W": flux, "stderr_W": se}


def _line_errors(out: Path, folder: str = "spectra") -> dict:
    """Per-line relative standard errors of the disk spectrum through the pupil (spectra/*.csv: the pupil camera's;
    spectra_forward/*.csv: the forward trace's): the median over 400-1000 nm and over every line with flux."""
    import csv

    import numpy as np

    f = next((out / folder).glob("*.csv"))
    rows = list(csv.DictReader(f.open()))
    lam = np.array([float(r["wavelength_nm"]) for r in rows])
    flux = np.array([float(r["flux_W"]) for r in rows])
    se = np.array([float(r["stderr_W"]) for r in rows])
    ok = flux > 0
    rel = np.where(ok, se / np.where(ok, flux, 1.0), np.nan)
    vis = ok & (lam >= 400) & (lam <= 1000)
    return {"median_rel_err_400_1000": float(np.nanmedian(rel[vis])), "median_rel_err_all": float(np.nanmedian(rel[ok]))}


LINE_RAYS = (800, 3200)            # Sun rays per line (forward): the disk spectrum's error per line against time
LINE_DIRECTIONS = (8, 16, 32)      # the pupil camera's DIRECTIONS m: 2 m^2 rays per line (#16, item 4)
LINE_SETTINGS = ("hours=1", "save_rays=0", "window=16", "spectral_samples=1")   # the image trace made negligible


def line_error_against_time(rays=LINE_RAYS, directions=LINE_DIRECTIONS) -> list:
    """One frame at each setting of each estimator of the disk spectrum: wall time and the median per-line
    relative standard error (issue #16, item 4: target 1 % per line, the whole day in 10 min).  The forward trace
    (Sun rays per line; its spectrum in spectra_forward/, with the pupil camera at its smallest) and the pupil
    camera (DIRECTIONS m; spectra/, with the forward trace at 10 Sun rays per line).  The time includes the
    frame's other traces, the same in every run of an estimator: compare differences of time."""
    out = []
    low_cam, low_fwd = f"pupil_directions={directions[0]}", "sun_rays=10"
    earth_frame(settings=LINE_SETTINGS + (f"sun_rays={rays[0]}", low_cam))    # untimed: these settings' kernels
    for est, values in (("forward", rays), ("pupil camera", directions)):
        for n in values:
            sets = (f"sun_rays={n}", low_cam) if est == "forward" else (low_fwd, f"pupil_directions={n}")
            folder = "spectra_forward" if est == "forward" else "spectra"
            r = earth_frame(settings=LINE_SETTINGS + sets, keep=lambda o, f=folder: _line_errors(o, f))
            row = {"estimator": est, "setting": sets[0] if est == "forward" else sets[1]}
            if r["rc"] != 0:
                out.append({**row, "rc": r["rc"], "tail": r["tail"]})
                continue
            out.append({**row, "s": r["s"], **{k: r[k] for k in ("median_rel_err_400_1000", "median_rel_err_all")}})
    return out


def error_against_time(rays=RAYS) -> list:
    """One frame at each Sun-ray count: wall time, relative standard error of the disk flux, figure of merit
    1 / (err^2 t).  The error must fall as 1/sqrt(N) (the fitted slope of log err against log N near -0.5)."""
    out = []
    # untimed: these settings (no ray records) use another specialized kernel, compiled on its first run
    earth_frame(settings=("hours=1", f"sun_rays={rays[0]}", "save_rays=0"))
    for n in rays:
        r = earth_frame(settings=("hours=1", f"sun_rays={n}", "save_rays=0"), keep=_pupil_flux)
        if r["rc"] != 0:
            out.append({"rays": n, "rc": r["rc"], "tail": r["tail"]})
            continue
        rel = r["stderr_W"] / r["flux_W"]
        out.append({"rays": n, "s": r["s"], "rel_err": rel, "fom": 1.0 / (rel * rel * r["s"]), "flux_W": r["flux_W"]})
    return out


IMAGE_BANDS = (450, 550, 650)
CAMERA_RAYS = (1, 4)        # camera rays per pixel and band line
FORWARD_SUN_RAYS = 800      # the forward trace's default


def _lit_error(out: Path, folder: str) -> dict:
    """Median and root-mean-square per-pixel relative standard error on the lit disk at 450/550/650 nm, and the
    empty lit pixels.  The figures of merit use the root mean square: a camera frame's per-pixel errors come from
    its spectral pairs, each pixel's from a few (unbiased in the mean square, but their median sits below).

    The lit disk is taken from the camera frame of the same hour when there is one (pixels above 2 % of the
    550 nm image's bright level, irtlang.core.stats.lit_pixels), so the forward frames are judged on the same
    pixels; a forward pixel with no sample counts as an error of 1 (100 %)."""
    import numpy as np

    res = {}
    cam = sorted((out / "frames").glob("*_550nm.npy")) if (out / "frames").exists() else []
    for band in IMAGE_BANDS:
        errs, rms, empty, n_lit = [], [], 0, 0
        for f in sorted((out / folder).glob(f"*_{band}nm.npy")):
            img = np.load(f)[0]
            se = np.load(f.with_name(f.stem + ".stderr.npy"))[0]
            ref = np.load(cam[0])[0] if cam else img
            if ref.shape != img.shape:       # forward frames are the whole detector: cut the camera's window
                n = ref.shape[0]
                c0 = img.shape[0] // 2 - n // 2
                img, se = img[c0:c0 + n, c0:c0 + n], se[c0:c0 + n, c0:c0 + n]
            lit = lit_pixels(ref)
            rel = np.where(img > 0, se / np.where(img > 0, img, 1.0), 1.0)
            errs.append(float(np.median(rel[lit])))
            rms.append(float(np.sqrt(np.mean(rel[lit] ** 2))))
            empty += int(np.count_nonzero(img[lit] <= 0))
            n_lit += int(lit.sum())
        if errs:
            res[band] = {"median_rel_err": max(errs), "rms_rel_err": max(rms), "empty_lit_pixels": empty,
                         "lit_pixels": n_lit}
    return res


def image_error_against_time() -> dict:
    """One frame: the per-pixel error of the band images, camera-side (at each CAMERA_RAYS) against the forward
    trace's own images (forward_frames=1), with wall times and the figure of merit 1 / (err^2 t) of the 550 nm
    image.  Each is a whole `irt run` (the forward run also writes camera frames: its time is the forward trace
    alone only approximately, so its figure of merit is an upper bound)."""
    out = {"camera": [], "forward": None}
    earth_frame(settings=("hours=1", "sun_rays=50", "save_rays=0", "camera_rays=1"))      # untimed: compile
    for n in CAMERA_RAYS:
        r = earth_frame(settings=("hours=1", "sun_rays=50", "save_rays=0", f"camera_rays={n}"),
                        keep=lambda o: {"err": _lit_error(o, "frames")})
        if r["rc"] == 0:
            e = r["err"].get(550, {}).get("rms_rel_err", float("nan"))
            out["camera"].append({"rays": n, "s": r["s"], "err": r["err"], "fom": 1.0 / (e * e * r["s"])})
        else:
            out["camera"].append({"rays": n, "rc": r["rc"], "tail": r["tail"]})
    r = earth_frame(settings=("hours=1", f"sun_rays={FORWARD_SUN_RAYS}", "save_rays=0", "forward_frames=1",
                              "camera_rays=1"),
                    keep=lambda o: {"err": _lit_error(o, "frames_forward")})
    if r["rc"] == 0:
        e = r["err"].get(550, {}).get("rms_rel_err", float("nan"))
        out["forward"] = {"rays": FORWARD_SUN_RAYS, "s": r["s"], "err": r["err"], "fom": 1.0 / (e * e * r["s"])}
    return out


#: the camera-side images' true error, from two seeds: the default, and the sampling before 2026-12-03
TRUE_ERROR_SETTINGS = ("hours=1", "sun_rays=10", "save_rays=0", "pupil_directions=1")
TRUE_ERROR_CONFIGS = (("the default (GUIDE 32, camera_cut 0.05, SPECTRAL 7 HERO 7: hero wavelengths)", ()),
                      ("SPECTRAL 14 HERO 7 (7 pairs)", ("spectral_samples=14",)),
                      ("SPECTRAL 14, one line per ray (the default before 2026-12-05)",
                       ("spectral_samples=14", "image_hero=1")),
                      ("uniform, camera_cut 0.2, SPECTRAL 14, one line per ray (the default before 2026-12-03)",
                       ("camera_guide=0", "camera_cut=0.2", "spectral_samples=14", "image_hero=1")))


def _band_frames(out: Path) -> dict:
    import numpy as np

    return {b: (np.load(f)[0], np.load(f.with_name(f.stem + ".stderr.npy"))[0])
            for b in IMAGE_BANDS for f in sorted((out / "frames").glob(f"*_{b}nm.npy"))[:1]}


def image_true_error(configs=TRUE_ERROR_CONFIGS) -> list:
    """The band images' true per-pixel error: what two runs with different seeds disagree by.  Per lit pixel
    (the mean image above 2 % of its bright level, irtlang.core.stats.lit_pixels) |a - b| / sqrt(2) over the
    mean of a and b; its median over the lit pixels / 0.6745 (the median of |N(0, 1)|), beside the median
    printed error (the per-pixel estimate: from the pairs' differences with an even `spectral_samples`, else
    conservative, counting the spread between the stratified spectral samples).  The wall time is the first
    run's whole `irt run` (forward and pupil traces made negligible).  `calibration` is how the printed errors
    explain that scatter: sqrt(sum (a - b)^2 / sum (se_a^2 + se_b^2)) over the lit pixels, each relative to its
    mean (1: honest; below 1: the printed errors are too large).  It is the sums' ratio, not the median of the
    printed errors, because a per-pixel estimate from a few pairs is itself noisy: its median sits below the
    error it estimates even where its mean square is right."""
    import numpy as np

    out = []
    for label, extra in configs:
        runs = [earth_frame(settings=TRUE_ERROR_SETTINGS + tuple(extra), keep=_band_frames, seed=seed)
                for seed in (None, 777)]
        if any(r["rc"] != 0 for r in runs):
            out.append({"config": label, "rc": max(r["rc"] for r in runs), "tail": runs[-1]["tail"]})
            continue
        row = {"config": label, "s": runs[0]["s"], "true": {}, "printed": {}, "calibration": {}}
        a_, b_ = (dict((k, v) for k, v in r.items() if isinstance(k, int)) for r in runs)
        for band in IMAGE_BANDS:
            (a, ae), (b, be) = a_[band], b_[band]
            m = 0.5 * (a + b)
            lit = lit_pixels(m) & (m > 0)
            row["true"][band] = float(np.median(np.abs(a - b)[lit] / np.sqrt(2) / m[lit]) / 0.6745)
            row["printed"][band] = float(np.median(ae[lit] / np.where(a[lit] > 0, a[lit], np.inf)))
            row["calibration"][band] = float(np.sqrt(np.sum(((a - b)[lit] / m[lit]) ** 2)
                                                     / np.sum((ae[lit] ** 2 + be[lit] ** 2) / m[lit] ** 2)))
        row["fom"] = 1.0 / (row["true"][550] ** 2 * row["s"])
        out.append(row)
    return out


def run(quick: bool = False) -> dict:
    if not SCRIPT.exists():
        return {"skipped": f"{SCRIPT.relative_to(ROOT)} does not exist yet (the Earth system model has not landed)"}
    if quick:
        return {"skipped": "not run with --quick (the flagship day and one Earth frame take minutes)"}
    day = flagship()
    r = earth_frame()
    r["day"] = day
    r["settings"] = list(SETTINGS)
    r["series"] = error_against_time()
    r["lines"] = line_error_against_time()
    r["images"] = image_error_against_time()
    r["true_images"] = image_true_error()
    ok = [x for x in r["series"] if "rel_err" in x]
    if len(ok) >= 2:
        import numpy as np

        r["slope"] = float(np.polyfit(np.log([x["rays"] for x in ok]), np.log([x["rel_err"] for x in ok]), 1)[0])
    return r


def report(r: dict) -> str:
    lines = ["## The Earth (benchmarks/bench_earth.py)", ""]
    if "skipped" in r:
        return "\n".join(lines + [f"Skipped: {r['skipped']}.", ""])
    d = r.get("day")
    if d:
        ok = d["rc"] == 0
        fail = "" if ok else f" (failed, exit {d['rc']})"
        lines += ["The flagship run, `irt run examples_scripts/earth.inr` with its defaults (25 hourly frames), one "
                  "process, warm Numba cache:", "",
                  "| wall time | peak RSS | files written | target |", "|---|---|---|---|",
                  f"| {d['s'] / 60:.1f} min{fail} | "
                  f"{d['rss_mb']:,.0f} MB | {d['files']} | <= 10 min: "
                  f"**{'met' if ok and d['s'] <= 600 else 'not met'}** |", ""]
    status = "ok" if r["rc"] == 0 else f"failed (exit {r['rc']})"
    lines += [f"One frame, `irt run examples_scripts/earth.inr --set {' --set '.join(r['settings'])}`: {r['s']:.1f} s, "
              f"{status}.", "", "```", r["tail"], "```", ""]
    if r.get("series"):
        lines += ["Time against radiometric error of the forward trace (one frame, the disk-integrated flux through the "
                  "pupil over all 295 lines; wall time of the whole `irt run`, start-up and packing included):", "",
                  "| Sun rays per line | wall s | relative standard error | figure of merit 1/(err^2 t) |", "|---|---|---|---|"]
        for x in r["series"]:
            if "rel_err" in x:
                lines.append(f"| {x['rays']} | {x['s']:.1f} | {x['rel_err']:.4%} | {x['fom']:.3g} |")
            else:
                lines.append(f"| {x['rays']} | failed (exit {x['rc']}) | | |")
        if "slope" in r:
            lines += ["", f"Fitted slope of log(error) against log(rays): {r['slope']:.3f} (1/sqrt(N): -0.5)."]
        lines.append("")
    ln = [x for x in r.get("lines", []) if "median_rel_err_400_1000" in x]
    if ln:
        lines += ["The disk spectrum's error per line (issue #16, item 4: 1 % per line for the whole day in 10 min): one "
                  "frame (`--set " + " --set ".join(LINE_SETTINGS) + "`: the image trace made negligible), the "
                  "forward trace (Sun rays per line) and the pupil camera (`DIRECTIONS m`: 2 m^2 rays per line), "
                  "median relative standard error per line; the wall time is the whole run's (compare differences):",
                  "",
                  "| estimator | setting | wall s | 400-1000 nm | all lines | rays per line for 1 % (400-1000 nm) |",
                  "|---|---|---|---|---|---|"]
        for x in ln:
            k = int(x["setting"].split("=")[1])
            n = k if x["estimator"] == "forward" else 2 * k * k
            need = n * (x["median_rel_err_400_1000"] / 0.01) ** 2
            lines.append(f"| {x['estimator']} | `{x['setting']}` | {x['s']:.1f} | {x['median_rel_err_400_1000']:.2%} | "
                         f"{x['median_rel_err_all']:.2%} | {need:,.0f} |")
        lines.append("")
    im = r.get("images")
    if im:
        lines += ["Band images of one frame: median (root mean square) per-pixel relative standard error on the lit "
                  "disk (the worst of the hour's frame), empty lit pixels, wall time of the whole `irt run` and the "
                  "figure of merit 1/(err^2 t) at 550 nm, err the root mean square; camera-side (`TRACE CAMERA`, "
                  "rays per pixel and band line) against the forward trace's own images (target: <= 2 % at 450, 550 and 650 nm, no empty lit pixel):", "",
                  "| estimator | rays | wall s | 450 nm | 550 nm | 650 nm | empty lit pixels | FOM (550) |",
                  "|---|---|---|---|---|---|---|---|"]
        rows = [("camera-side", x) for x in im["camera"]] + ([("forward", im["forward"])] if im["forward"] else [])
        for name, x in rows:
            if "err" not in x:
                lines.append(f"| {name} | {x['rays']} | failed (exit {x['rc']}) | | | | | |")
                continue
            e = x["err"]
            cells = " | ".join(f"{e[b]['median_rel_err']:.2%} ({e[b].get('rms_rel_err', float('nan')):.2%})"
                               if b in e else "-" for b in IMAGE_BANDS)
            empty = sum(e[b]["empty_lit_pixels"] for b in e)
            lines.append(f"| {name} | {x['rays']} | {x['s']:.1f} | {cells} | {empty} | {x['fom']:.3g} |")
        lines.append("")
    te = r.get("true_images")
    if te:
        lines += ["The band images' true per-pixel error (issue #14): what two runs of one frame with different seeds "
                  "disagree by (median over the lit pixels; docs/earth.md, \"Where that noise comes from\"), beside "
                  "the printed estimate, the calibration (sqrt of the sums' ratio of the seeds' squared "
                  "difference to the printed variances: 1 when the printed errors are honest), and the figure of "
                  "merit 1/(err^2 t) at 550 nm (t: the whole run):", "",
                  "| image trace | wall s | true 450 / 550 / 650 nm | printed 450 / 550 / 650 nm | calibration "
                  "450 / 550 / 650 nm | FOM (550) |",
                  "|---|---|---|---|---|---|"]
        for x in te:
            if "true" not in x:
                lines.append(f"| {x['config']} | failed (exit {x['rc']}) | | | | |")
                continue
            t = " / ".join(f"{x['true'][b]:.2f}" for b in IMAGE_BANDS)
            p = " / ".join(f"{x['printed'][b]:.2f}" for b in IMAGE_BANDS)
            cal = " / ".join(f"{x['calibration'][b]:.2f}" for b in IMAGE_BANDS) if "calibration" in x else "-"
            lines.append(f"| {x['config']} | {x['s']:.1f} | {t} | {p} | {cal} | {x['fom']:.3g} |")
        lines.append("")
    return "\n".join(lines)


def readme_rows(r: dict) -> list:
    if "skipped" in r or r.get("rc"):
        return []
    rows = []
    d = r.get("day")
    if d and d["rc"] == 0:
        rows.append(("the flagship run, `irt run examples_scripts/earth.inr` (25 frames, whole process)",
                     f"{d['s'] / 60:.1f} min, peak {d['rss_mb']:,.0f} MB", "<= 10 min"))
    rows.append(("one Earth frame, `irt run examples_scripts/earth.inr --set hours=1` (whole process)", f"{r['s']:.0f} s",
                 "-"))
    ok = [x for x in r.get("series", []) if "rel_err" in x]
    if ok and "slope" in r:
        rows.append(("one Earth frame: disk flux error against Sun rays per line",
                     ", ".join(f"{x['rays']}: {x['rel_err']:.2%} in {x['s']:.0f} s" for x in ok)
                     + f"; slope {r['slope']:.3f}", "error ~ 1/sqrt(N) (slope -0.5)"))
    ln = [x for x in r.get("lines", []) if "median_rel_err_400_1000" in x]
    if ln:
        rows.append(("one Earth frame's disk spectrum: median error per line (400-1000 nm) against Sun rays per line",
                     ", ".join(f"{x['rays']}: {x['median_rel_err_400_1000']:.1%} in {x['s']:.0f} s" for x in ln),
                     "<= 1 % per line, the day in 10 min"))
    im = r.get("images") or {}
    cams = [x for x in im.get("camera", []) if "err" in x]
    if cams:
        best = cams[-1]
        fw = im.get("forward")
        rows.append(("one Earth frame's band images: median per-pixel error on the lit disk (450/550/650 nm)",
                     f"camera-side, {best['rays']} ray(s)/pixel/line: "
                     + "/".join(f"{best['err'][b]['median_rel_err']:.1%}" for b in IMAGE_BANDS if b in best['err'])
                     + f" in {best['s']:.0f} s"
                     + (f"; forward: {fw['err'][550]['median_rel_err']:.0%} at 550 nm, FOM ratio "
                        f"{best['fom'] / fw['fom']:.3g}x" if fw and 550 in fw["err"] else ""),
                     "<= 2 %, no empty lit pixel"))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args(argv)
    r = run(a.quick)
    print(report(r))
    return r


if __name__ == "__main__":
    main()
