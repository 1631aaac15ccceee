"""Point-spread-function figures from images and from ray records: FWHM, encircled and ensquared energy, RMS
radius, centroid, Strehl ratio, first dark ring.  They live in :mod:`irtlang.optics.psf_measures` (irtlang's PSF
command reports them too); this module re-exports them for the analysis package and its users."""

from irtlang.optics.psf_measures import (centroid, encircled_energy, encircled_energy_rays, ensquared_energy,
                                         peak_value, psf_metrics, psf_metrics_rays, radial_profile)

__all__ = [
    "centroid", "peak_value", "radial_profile", "encircled_energy", "ensquared_energy", "psf_metrics",
    "encircled_energy_rays", "psf_metrics_rays",
]
