"""irtlang analysis: pure functions of arrays and saved files, to judge a simulated instrument as Ryu et al.
(Optics Express 2017) did: true-colour composites, defocus maps (Zhuo & Sim 2011), edge-spread and MTF measures,
PSF figures, whole-disk metrics and spectra, time series of disk spectra with their apparent albedo, and
animations of frame folders. Figures live in :mod:`analysis.plots`; the command line in
:mod:`analysis.cli` (``python -m analysis``). Every function raises :class:`AnalysisError` (a ValueError) on bad
input. See docs/analysis.md."""

from ._common import AnalysisError
from .animate import animate_folder, frame_files, read_frames
from .color import cie1931_cmf, rgb_composite, save_animation, save_png, spectrum_to_rgb, srgb_decode, srgb_encode
from .defocus import defocus_map, difference_map, edge_map, matting_laplacian, sparse_defocus_map
from .disk import (apparent_albedo, disk_averaged_spectrum, disk_metrics, lambert_phase, lambert_sphere_flux,
                   limb_points, time_wavelength_map)
from .files import load_array, load_cube, load_image
from .fit import SpacingFit, fit_mirror_spacing, image_metric
from .mtf import EdgeProfile, edge_spread_function, esf_slope, esf_width_10_90, mtf50, slanted_edge_mtf
from .psf import (centroid, encircled_energy, encircled_energy_rays, ensquared_energy, peak_value, psf_metrics,
                  psf_metrics_rays, radial_profile)
from .rayfile import Detector, RayFile, read_rays, write_rays_v1
from .series import (SpectraSeries, format_time_utc, lambert_series_flux, parse_time_tag, read_spectra_series,
                     series_apparent_albedo, solar_band_irradiance, write_series_csv)

__all__ = [
    "AnalysisError",
    "srgb_encode", "srgb_decode", "cie1931_cmf", "rgb_composite", "spectrum_to_rgb", "save_png", "save_animation",
    "edge_map", "sparse_defocus_map", "defocus_map", "matting_laplacian", "difference_map",
    "EdgeProfile", "edge_spread_function", "slanted_edge_mtf", "mtf50", "esf_slope", "esf_width_10_90",
    "centroid", "peak_value", "radial_profile", "encircled_energy", "ensquared_energy", "psf_metrics",
    "encircled_energy_rays", "psf_metrics_rays",
    "lambert_phase", "lambert_sphere_flux", "apparent_albedo", "disk_metrics", "limb_points",
    "disk_averaged_spectrum", "time_wavelength_map",
    "SpectraSeries", "parse_time_tag", "format_time_utc", "read_spectra_series", "solar_band_irradiance",
    "series_apparent_albedo", "lambert_series_flux", "write_series_csv",
    "frame_files", "read_frames", "animate_folder",
    "SpacingFit", "image_metric", "fit_mirror_spacing",
    "Detector", "RayFile", "read_rays", "write_rays_v1",
    "load_array", "load_image", "load_cube",
]
