"""Every kind of bad input raises AnalysisError (a ValueError) with a clear message."""

import numpy as np
import pytest

import analysis as A

GOOD = np.outer(np.ones(32), np.r_[np.zeros(16), np.ones(16)]) + 0.1
ZERO = np.zeros((32, 32))
NAN = GOOD.copy()
NAN[3, 4] = np.nan
INF = GOOD.copy()
INF[5, 5] = np.inf


def test_analysis_error_is_a_value_error():
    assert issubclass(A.AnalysisError, ValueError)


CASES = {
    # different shapes
    "rgb shapes": (lambda: A.rgb_composite(GOOD, GOOD, GOOD[:, :10]), "different shapes"),
    "difference shapes": (lambda: A.difference_map(GOOD, GOOD.T[:10]), "different shapes"),
    "fit shapes": (lambda: A.fit_mirror_spacing(GOOD, lambda s: GOOD[:20], [0, 1, 2]), "different shapes"),
    "spectrum mask shape": (lambda: A.disk_averaged_spectrum(np.ones((2, 4, 4)), mask=np.ones((3, 3))),
                            "different shapes"),
    # ROI outside the image
    "esf roi outside": (lambda: A.esf_slope(GOOD, (20, 0, 20, 10)), "outside the image"),
    "mtf roi negative": (lambda: A.slanted_edge_mtf(GOOD, (-1, 0, 10, 10)), "outside the image"),
    "roi not integers": (lambda: A.esf_slope(GOOD, (0.5, 0, 10, 10)), "four integers"),
    "roi too small": (lambda: A.esf_width_10_90(GOOD, (0, 0, 1, 10)), "smaller than"),
    # all zero
    "psf zero": (lambda: A.psf_metrics(ZERO, 1.0), "all zero"),
    "mtf zero": (lambda: A.slanted_edge_mtf(ZERO), "all zero"),
    "disk zero": (lambda: A.disk_metrics(ZERO), "all zero"),
    "defocus zero": (lambda: A.defocus_map(ZERO), "all zero"),
    "rgb zero": (lambda: A.rgb_composite(ZERO, ZERO, ZERO), "all zero"),
    "spectrum zero": (lambda: A.spectrum_to_rgb(np.zeros((5, 2, 2)), np.arange(5.0) + 400), "all zero"),
    "edge zero": (lambda: A.edge_map(ZERO), "all zero"),
    # not finite
    "psf nan": (lambda: A.psf_metrics(NAN, 1.0), "non-finite"),
    "mtf inf": (lambda: A.slanted_edge_mtf(INF), "non-finite"),
    "disk nan": (lambda: A.disk_metrics(NAN), "non-finite"),
    "defocus inf": (lambda: A.defocus_map(INF), "non-finite"),
    "difference nan": (lambda: A.difference_map(NAN, GOOD), "non-finite"),
    "rays nan": (lambda: A.psf_metrics_rays([0.0, np.nan], [0.0, 1.0]), "non-finite"),
    "albedo nan": (lambda: A.apparent_albedo([np.nan], solar_irradiance=1.0, radius=1, distance=2,
                                             phase_angle_deg=30), "non-finite"),
    # other nonsense
    "no edge": (lambda: A.slanted_edge_mtf(np.ones((20, 20))), "no edge"),
    "1-D image": (lambda: A.psf_metrics(np.ones(10), 1.0), "must be 2-D"),
    "bad pitch": (lambda: A.psf_metrics(GOOD, -2.0), "positive"),
    "bad method": (lambda: A.defocus_map(GOOD, method="magic"), "method must be"),
    "bad phase": (lambda: A.lambert_phase(200.0), r"\[0, 180\]"),
    "wavelength count": (lambda: A.spectrum_to_rgb(np.ones((4, 2, 2)), [400.0, 500.0]), "wavelengths"),
    "solar shape": (lambda: A.rgb_composite(GOOD, GOOD, GOOD, solar_irradiance=[1, 2]), "3 positive"),
    "rays lengths": (lambda: A.encircled_energy_rays([0, 1], [0, 1, 2]), "one length"),
    "mtf50 never": (lambda: A.mtf50([0.0, 0.1, 0.2], [1.0, 0.9, 0.8]), "does not fall"),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_input_raises(name):
    func, message = CASES[name]
    with pytest.raises(A.AnalysisError, match=message):
        func()


def test_ray_file_of_another_version_is_refused(tmp_path):
    import h5py

    path = tmp_path / "v2.h5"
    A.write_rays_v1(path, wavelengths_nm=[550.0])
    with h5py.File(path, "a") as fh:
        fh.attrs["schema_version"] = 2
    with pytest.raises(A.AnalysisError, match="version 2"):
        A.read_rays(path)


def test_writers_refuse_missing_folder(tmp_path):
    with pytest.raises(A.AnalysisError, match="does not exist"):
        A.save_png(np.zeros((4, 4, 3), np.uint8), tmp_path / "nope" / "x.png")
