"""Command line of the analysis package: ``irt analyze SUBCOMMAND ...`` or ``python -m analysis SUBCOMMAND ...``.

Wiring into another argparse program::

    analyze = subparsers.add_parser("analyze", help="analyse images, spectra and ray files")
    analysis.cli.build_parser(analyze.add_subparsers(dest="analysis_command", required=True))
    ...
    return analysis.cli.run(args)
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from ._common import AnalysisError

__all__ = ["build_parser", "run", "main"]

_IMAGE_HELP = "image file: .npy, .csv, .txt, .fits or a ray file FILE.h5[:DETECTOR[:LINE]]"


def _print(result, as_json):
    def plain(v):
        if isinstance(v, (np.floating, np.integer)):
            return v.item()
        if isinstance(v, np.ndarray):
            return v.tolist()
        if isinstance(v, tuple):
            return [plain(x) for x in v]
        return v

    result = {k: plain(v) for k, v in result.items()}
    if as_json:
        print(json.dumps(result, indent=2))
        return
    for key, value in result.items():
        if value is None:
            text = "n/a"
        elif isinstance(value, list):
            text = ", ".join(f"{x:.6g}" if isinstance(x, float) else str(x) for x in value)
        elif isinstance(value, float):
            text = f"{value:.6g}"
        else:
            text = str(value)
        print(f"{key}: {text}")


def _float_or_name(names):
    def parse(text):
        if text in names:
            return None if text == "none" else text
        try:
            return float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected one of {', '.join(names)} or a number, got {text!r}")
    return parse


def _cmd_rgb(args):
    from .color import rgb_composite, save_png
    from .files import load_image

    rgb = rgb_composite(load_image(args.red), load_image(args.green), load_image(args.blue),
                        solar_irradiance=args.solar, stretch=args.stretch, percentile=args.percentile,
                        gamma=args.gamma)
    save_png(rgb, args.output)
    return {"output": str(args.output), "shape": list(rgb.shape)}


def _cmd_psf(args):
    from .psf import psf_metrics, psf_metrics_rays

    if args.rays:
        from .rayfile import read_rays

        rf = read_rays(args.image)
        if rf.n_rays == 0:
            raise AnalysisError(f"{args.image}: the ray file holds no ray records")
        keep = np.ones(rf.n_rays, dtype=bool)
        if args.object is not None:
            if args.object not in rf.objects:
                raise AnalysisError(f"no object {args.object!r} in the ray file; present: {', '.join(rf.objects)}")
            keep &= rf.object == rf.objects.index(args.object)
        if args.line is not None:
            keep &= rf.line == args.line
        if not keep.any():
            raise AnalysisError("no ray records match the selection")
        pos = rf.position[keep]
        n_traced = int(rf.attrs.get("rays_traced", 0)) or None
        frames = rf.object_frames
        if args.axes is None and args.object is not None and frames is not None and \
                np.all(np.isfinite(frames[rf.objects.index(args.object)])):
            # the detector's own frame: positions relative to its origin along its local x and y
            o, ex, ey, _ = frames[rf.objects.index(args.object)]
            res = psf_metrics_rays((pos - o) @ ex, (pos - o) @ ey, rf.flux[keep], n_traced=n_traced)
            res["frame"] = f"{args.object} local x, y ({rf.attrs.get('length_unit', '')})"
            return res
        ax = ["xyz".index(c) for c in (args.axes or "xy")]
        res = psf_metrics_rays(pos[:, ax[0]], pos[:, ax[1]], rf.flux[keep], n_traced=n_traced)
        res["frame"] = f"world {args.axes or 'xy'} ({rf.attrs.get('length_unit', '')})"
        return res
    from .files import load_image

    reference = None
    if args.reference is not None:
        reference = load_image(args.reference)
    return psf_metrics(load_image(args.image), args.pixel_pitch, reference=reference, center=args.center,
                       total=args.total)


def _cmd_mtf(args):
    from .files import load_image
    from .mtf import mtf50, slanted_edge_mtf

    freq, mtf = slanted_edge_mtf(load_image(args.image), args.roi, oversample=args.oversample,
                                 edge_fit_degree=args.edge_fit_degree)
    if args.output:
        _save_csv(args.output, np.column_stack([freq, mtf]), "frequency_cycles_per_px,mtf")
    if args.plot:
        from .plots import plot_mtf

        plot_mtf(freq, mtf, args.plot)
    return {"mtf50_cycles_per_px": mtf50(freq, mtf), "mtf_at_nyquist": float(np.interp(0.5, freq, mtf))}


def _cmd_esf(args):
    from .files import load_image
    from .mtf import esf_slope, esf_width_10_90

    img = load_image(args.image)
    kw = {"oversample": args.oversample, "edge_fit_degree": args.edge_fit_degree}
    return {"esf_slope_per_px": esf_slope(img, args.roi, half_span=args.half_span, **kw),
            "esf_width_10_90_px": esf_width_10_90(img, args.roi, **kw)}


def _cmd_defocus(args):
    from .defocus import defocus_map, sparse_defocus_map
    from .files import load_image

    img = load_image(args.image)
    dmap = defocus_map(img, method=args.method, sigma0=args.sigma0)
    sparse, edges = sparse_defocus_map(img, sigma0=args.sigma0)
    if args.output:
        from ._common import atomic_path

        with atomic_path(args.output) as tmp, open(tmp, "wb") as fh:
            np.save(fh, dmap)
    if args.plot:
        from .plots import plot_defocus

        plot_defocus(img, dmap, args.plot, edges=edges)
    edge_values = sparse[np.isfinite(sparse)]
    return {"median_sigma_px": float(np.median(dmap)),
            "edge_median_sigma_px": float(np.median(edge_values)) if edge_values.size else None,
            "edge_pixels": int(edge_values.size)}


def _cmd_disk(args):
    from .disk import disk_metrics
    from .files import load_image

    return disk_metrics(load_image(args.image), threshold=args.threshold, shape=args.shape,
                        radius_km=args.radius_km)


def _cmd_spectrum(args):
    from .disk import disk_averaged_spectrum
    from .files import load_array, load_cube

    cube, wl, sum2 = load_cube(args.cube)
    if args.wavelengths is not None:
        wl = np.asarray(load_array(args.wavelengths), dtype=np.float64).reshape(-1)
    mask = None if args.mask is None else np.asarray(load_array(args.mask)) != 0
    wl, flux, se = disk_averaged_spectrum(cube, wl, mask=mask, sum2=sum2)
    if args.output:
        cols = [wl, flux] + ([se] if se is not None else [])
        _save_csv(args.output, np.column_stack(cols), "wavelength_nm,flux" + (",stderr" if se is not None else ""))
    return {"wavelength_nm": wl, "flux": flux, "stderr": se}


def _cmd_series(args):
    from .series import (EARTH_FEATURES, format_time_utc, read_spectra_series, series_apparent_albedo,
                         series_mean_spectrum, write_mean_csv, write_series_csv)

    series = read_spectra_series(args.spectra_dir)
    albedo = series_apparent_albedo(series.flux_W, series.wavelengths_nm, tsi=args.tsi,
                                    sun_distance_au=args.sun_distance_au, distance_km=args.distance_km,
                                    phase_deg=args.phase_deg, radius_km=args.radius_km, area_m2=args.area_m2)
    write_series_csv(args.output, series, albedo)
    day = series.times[0]
    if args.plot:
        from .plots import plot_time_wavelength_pair

        plot_time_wavelength_pair(albedo, series.hours_since_midnight(), series.wavelengths_nm, args.plot,
                                  label="apparent albedo", time_label=f"UTC hour [h from {day:%Y-%m-%d} 00:00]")
    mean = series_mean_spectrum(series, albedo)
    if args.mean_output:
        write_mean_csv(args.mean_output, series.wavelengths_nm, mean)
    if args.mean_plot:
        from .plots import plot_mean_spectrum

        plot_mean_spectrum(series.wavelengths_nm, mean["mean"], args.mean_plot, stderr=mean["stderr"],
                           spread=mean["spread"], features=EARTH_FEATURES if args.features == "earth" else (),
                           title=f"disk-integrated spectrum, mean of {len(series.times)} time(s) from "
                                 f"{format_time_utc(day)}")
    return {"output": str(args.output), "plot": None if not args.plot else str(args.plot),
            "times": len(series.times), "first_utc": format_time_utc(series.times[0]),
            "last_utc": format_time_utc(series.times[-1]), "wavelength_nm": series.wavelengths_nm,
            "mean_apparent_albedo": albedo.mean(axis=0), "min_apparent_albedo": float(albedo.min()),
            "max_apparent_albedo": float(albedo.max()),
            "mean_plot": None if not args.mean_plot else str(args.mean_plot),
            "median_relative_stderr_of_mean": float(np.median(mean["stderr"] / np.where(mean["mean"] > 0, mean["mean"],
                                                                                         np.inf)))}


def _cmd_despace(args):
    from .despace import despace_study

    res = despace_study(args.observed, args.sweep, design=args.design, truth=args.truth,
                        free_scale=not args.fixed_scale, margin=args.margin, smooth=args.smooth,
                        maps=bool(args.plot), bin=args.bin, variance_floor=args.variance_floor)
    images = res.pop("_images")
    if args.output:
        from ._common import atomic_path

        with atomic_path(args.output) as tmp:
            Path(tmp).write_text(json.dumps(res, indent=2) + "\n")
    if args.plot:
        from .plots import plot_despace_maps

        plot_despace_maps(images, res, args.plot)
    if args.curve_plot:
        from .plots import plot_despace_curve

        plot_despace_curve(res, args.curve_plot)
    return {"best_spacing_um": res["best_spacing_um"], "uncertainty_um": res["uncertainty_um"],
            "refocus_mm": res["refocus_mm"], "reduced_chi2_min": res["reduced_chi2_min"],
            "at_edge_of_sweep": res["at_edge_of_sweep"], "esf_slope_spacing_um": res["esf_slope_spacing_um"],
            "truth_um": res["truth_um"], "spacings_um": [r["spacing_um"] for r in res["table"]],
            "chi2": [r["chi2"] for r in res["table"]]}


def _cmd_animate(args):
    from .animate import animate_folder

    return animate_folder(args.frames_dir, args.output, fps=args.fps)


def _save_csv(path, table, header):
    from ._common import atomic_path

    with atomic_path(path) as tmp:
        np.savetxt(tmp, table, delimiter=",", header=header, comments="")


def build_parser(subparsers):
    """Add the analysis subcommands (rgb, psf, mtf, esf, defocus, disk, spectrum, series, animate) to an argparse
    subparsers action; each sets ``args._analysis_handler`` for :func:`run`."""

    def add(name, handler, help_text):
        p = subparsers.add_parser(name, help=help_text, description=help_text)
        p.set_defaults(_analysis_handler=handler)
        p.add_argument("--json", action="store_true", help="print the result as JSON")
        return p

    def roi(p, required=False):
        p.add_argument("--roi", nargs=4, type=int, metavar=("X", "Y", "W", "H"), required=required,
                       help="region: column and row of the top-left pixel, width, height (px)")

    def edge_opts(p):
        p.add_argument("--oversample", type=int, default=4, help="ESF bins per pixel (default 4)")
        p.add_argument("--edge-fit-degree", type=int, default=1, help="polynomial degree of the edge (2 for a limb)")

    p = add("rgb", _cmd_rgb, "true-colour composite of three band images (I/F, one stretch, sRGB) to PNG")
    for band in ("red", "green", "blue"):
        p.add_argument(band, help=_IMAGE_HELP)
    p.add_argument("-o", "--output", required=True, help="output PNG")
    p.add_argument("--solar", nargs=3, type=float, metavar=("E_R", "E_G", "E_B"),
                   help="solar irradiance per band (white balance); omit if the bands are reflectance")
    p.add_argument("--stretch", type=_float_or_name(("percentile", "max", "none")), default="percentile",
                   help="common stretch: percentile (default), max, none or a white reflectance")
    p.add_argument("--percentile", type=float, default=99.5, help="percentile for --stretch percentile")
    p.add_argument("--gamma", type=_float_or_name(("srgb", "linear")), default="srgb",
                   help="encoding: srgb (default), linear or an exponent")

    p = add("psf", _cmd_psf, "PSF metrics: FWHM, 80%% encircled-energy diameter, RMS radius, ring, Strehl")
    p.add_argument("image", help=_IMAGE_HELP + "; with --rays a ray file")
    p.add_argument("--pixel-pitch", type=float, default=1.0, help="pixel pitch; lengths are printed in its unit")
    p.add_argument("--center", nargs=2, type=float, metavar=("X", "Y"), help="centre in px (default centroid)")
    p.add_argument("--total", type=float, help="total energy for normalisation (default the image sum)")
    p.add_argument("--reference", help="diffraction-limited PSF image for the Strehl ratio")
    p.add_argument("--rays", action="store_true", help="use the ray records of a ray file")
    p.add_argument("--object", help="with --rays: keep rays whose last object is this one")
    p.add_argument("--line", type=int, help="with --rays: keep one wavelength line")
    p.add_argument("--axes", choices=("xy", "xz", "yz"), default=None,
                   help="with --rays: world position columns (default: the --object's own frame when the file has "
                        "it, else xy)")

    p = add("mtf", _cmd_mtf, "slanted-edge MTF (ISO 12233) and MTF50")
    p.add_argument("image", help=_IMAGE_HELP)
    roi(p)
    edge_opts(p)
    p.add_argument("-o", "--output", help="write the MTF curve as CSV")
    p.add_argument("--plot", help="write a figure (PNG/PDF/SVG)")

    p = add("esf", _cmd_esf, "ESF slope and 10-90%% width of an edge in a region")
    p.add_argument("image", help=_IMAGE_HELP)
    roi(p, required=True)
    edge_opts(p)
    p.add_argument("--half-span", type=float, default=0.5, help="half the finite-difference span, px")

    p = add("defocus", _cmd_defocus, "Zhuo & Sim defocus map (blur sigma in px)")
    p.add_argument("image", help=_IMAGE_HELP)
    p.add_argument("--method", choices=("matting", "guided", "fgs"), default="matting")
    p.add_argument("--sigma0", type=float, default=2.0, help="re-blur sigma, px (default 2)")
    p.add_argument("-o", "--output", help="write the map as .npy")
    p.add_argument("--plot", help="write a figure (image, edges, map)")

    p = add("disk", _cmd_disk, "limb ellipse, diameters, km/px, illuminated fraction and phase angle")
    p.add_argument("image", help=_IMAGE_HELP)
    p.add_argument("--threshold", type=float, default=0.02, help="lit threshold, fraction of the maximum")
    p.add_argument("--shape", choices=("ellipse", "circle"), default="ellipse")
    p.add_argument("--radius-km", type=float, help="equatorial radius of the body, km")

    p = add("spectrum", _cmd_spectrum, "disk-integrated spectrum of an image cube (L, H, W)")
    p.add_argument("cube", help="cube file (.npy, .fits) or ray file FILE.h5[:DETECTOR]")
    p.add_argument("--wavelengths", help="wavelengths in nm (.npy or .csv); a ray file supplies its own")
    p.add_argument("--mask", help="disk mask image (non-zero = disk)")
    p.add_argument("-o", "--output", help="write the spectrum as CSV")

    p = add("series", _cmd_series, "hourly disk-integrated spectra (SPECTRUM OF files) as one table with the "
            "apparent albedo of every line")
    p.add_argument("spectra_dir", help="folder of <YYYYmmddTHHMM>.csv files (wavelength_nm,flux_W,stderr_W)")
    p.add_argument("-o", "--output", required=True,
                   help="output CSV: time_utc,wavelength_nm,flux_W,stderr_W,apparent_albedo")
    p.add_argument("--plot", help="write the time x wavelength maps of the apparent albedo and of its difference "
                   "from the mean over time, side by side (PNG/PDF/SVG)")
    p.add_argument("--mean-plot", help="write the mean spectrum over time with its uncertainty band (PNG/PDF/SVG)")
    p.add_argument("--mean-output", help="write the mean spectrum as CSV: wavelength_nm,mean_apparent_albedo,"
                   "stderr,spread")
    p.add_argument("--features", choices=["earth", "none"], default="earth",
                   help="label the Earth's spectral features on the mean plot (default earth)")
    p.add_argument("--tsi", type=float, required=True, help="total solar irradiance at 1 AU, W/m2 (as SOLAR TSI)")
    p.add_argument("--sun-distance-au", type=float, required=True, help="distance of the body from the Sun, AU")
    p.add_argument("--distance-km", type=float, required=True, help="distance of the observer from the body, km")
    p.add_argument("--phase-deg", type=float, required=True, help="phase angle (Sun-body-observer), degrees")
    p.add_argument("--radius-km", type=float, required=True, help="radius of the body, km")
    p.add_argument("--area-m2", type=float, required=True, help="collecting area of the aperture, m2")

    p = add("despace", _cmd_despace, "the defocus study: the mirror spacing whose simulated frames match an "
            "observed one (chi2 with both frames' standard errors, a parabola; analysis/despace.py)")
    p.add_argument("observed", help="observed frame (.npy; its NAME.stderr.npy beside it, if any)")
    p.add_argument("--sweep", required=True, help="folder of simulated frames spacing_<um>um.npy (with .stderr.npy)")
    p.add_argument("-o", "--output", help="write the fit and the sweep's table as JSON (despace_fit.json)")
    p.add_argument("--plot", help="write the maps per spacing: frame and edges, defocus, difference (PNG)")
    p.add_argument("--curve-plot", help="write the mismatch curve chi2(spacing) with the fit (PNG)")
    p.add_argument("--design", nargs=3, type=float, metavar=("F1_MM", "M", "E_MM"),
                   help="the Cassegrain's primary focal length, secondary magnification and back focus behind the "
                        "primary vertex: the paraxial refocus (refocus_mm)")
    p.add_argument("--truth", type=float, help="the spacing an identical twin was traced at (recorded, not used)")
    p.add_argument("--fixed-scale", action="store_true", help="no free scale between observation and simulation")
    p.add_argument("--margin", type=int, default=12, help="px around the lit disk in the fit's region (default 12)")
    p.add_argument("--bin", type=int, default=4, help="chi2 over bin x bin pixel blocks (default 4)")
    p.add_argument("--variance-floor", type=float, default=0.5,
                   help="each block's variance at least this fraction of its frame's typical variance at its flux "
                        "(default 0.5; 0: the frames' own variances)")
    p.add_argument("--smooth", type=float, default=1.0,
                   help="Gaussian sigma (px) of the smoothing before the maps and ESF slopes (default 1)")

    p = add("animate", _cmd_animate, "every PNG of a folder, sorted by name, as an animated GIF or MP4")
    p.add_argument("frames_dir", help="folder of PNG frames")
    p.add_argument("-o", "--output", required=True, help="output animation: .gif or .mp4")
    p.add_argument("--fps", type=float, default=4.0, help="frames per second (default 4)")
    return subparsers


def run(args):
    """Run the subcommand chosen in ``args`` (from a parser built with :func:`build_parser`). Prints the result;
    returns 0, or 2 after printing ``error: ...`` to stderr for bad input (no traceback)."""
    try:
        result = args._analysis_handler(args)
    except (AnalysisError, OSError, ValueError, KeyError) as exc:
        message = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"error: {message}", file=sys.stderr)
        return 2
    _print(result, getattr(args, "json", False))
    return 0


def main(argv=None):
    """Entry point of ``python -m analysis``."""
    parser = argparse.ArgumentParser(prog="python -m analysis", description="irtlang analysis tools")
    build_parser(parser.add_subparsers(dest="analysis_command", required=True, metavar="SUBCOMMAND"))
    return run(parser.parse_args(argv))
