"""The figure functions write a PNG each (smoke tests: the numbers are tested elsewhere)."""

import numpy as np

from analysis import plots

PNG = b"\x89PNG\r\n\x1a\n"


def test_every_plot_writes_a_png(tmp_path):
    rng = np.random.default_rng(0)
    img = rng.uniform(size=(20, 24))
    written = [
        plots.plot_rgb(rng.integers(0, 256, (20, 24, 3), dtype=np.uint8), tmp_path / "rgb.png", title="t"),
        plots.plot_defocus(img, 2 * img, tmp_path / "def.png", edges=img > 0.9, difference=img - 0.5),
        plots.plot_mtf(np.linspace(0, 1, 20), np.linspace(1, 0, 20), tmp_path / "mtf.png",
                       reference=(np.linspace(0, 1, 5), np.linspace(1, 0, 5))),
        plots.plot_esf(np.linspace(-5, 5, 40), np.linspace(0, 1, 40), tmp_path / "esf.png"),
        plots.plot_psf(np.arange(10.0), np.exp(-np.arange(10.0)), tmp_path / "psf.png", ee_radius=np.arange(10.0),
                       ee=1 - np.exp(-np.arange(10.0))),
        plots.plot_spectra([450, 550, 650], [[1, 2, 3], [2, 3, 4]], tmp_path / "spec.png", labels=["a", "b"]),
        plots.plot_time_wavelength(rng.normal(size=(5, 3)), np.arange(5.0), [450, 550, 650], tmp_path / "tw.png"),
    ]
    for path in written:
        assert path.read_bytes()[:8] == PNG
    assert len(list(tmp_path.iterdir())) == len(written)  # no temporary files left
