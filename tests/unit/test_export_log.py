"""EXPORT ... LOG: a .png on a logarithmic colour scale, so that a faint ghost or halo shows beside its image.

The oracle is the definition of the scale (irtlang.io.images.log_scale): LogNorm from a decade below the faintest
lit pixel (at most LOG_DECADES below the brightest) to the brightest, unlit pixels NaN (black).  A halo 1e-5 of the
peak then sits at a known fraction of the colour range (1/6), where the linear picture puts it at 1e-5 (invisible);
and the PNG actually drawn shows the halo's pixels brighter than the unlit background, which the linear one does
not.
"""
import math

import numpy as np
from matplotlib.image import imread

from irtlang.io.images import LOG_DECADES, log_scale, write_image


def _spot_and_halo(n=64):
    y, x = np.mgrid[:n, :n] + 0.5
    r = np.hypot(x - n / 2, y - n / 2)
    img = np.where(r < 20, 1e-5, 0.0)
    img[n // 2, n // 2] = 1.0
    return img, r


def test_log_scale_definition():
    img, r = _spot_and_halo()
    pic, norm = log_scale(img)
    assert math.isclose(norm.vmin, 1e-6, rel_tol=1e-15) and norm.vmax == 1.0
    assert np.all(np.isnan(pic[img == 0])) and np.array_equal(pic[img > 0], img[img > 0])
    # the halo a decade above the scale's bottom, the peak at its top; halfway in log: 10^-3
    assert math.isclose(float(norm(1e-5)), 1 / 6, rel_tol=1e-12) and float(norm(1.0)) == 1.0
    assert math.isclose(float(norm(1e-3)), 0.5, rel_tol=1e-12)
    # a dynamic range beyond LOG_DECADES is cut there
    img[0, 0] = 1e-12
    assert log_scale(img)[1].vmin == 10.0 ** -LOG_DECADES
    # nothing lit: no scale
    assert log_scale(np.zeros((4, 4)))[1] is None


def _luminance(path):
    a = imread(path)[..., :3]
    return a.mean(axis=2)


def test_log_png_shows_the_halo(tmp_path):
    """The same image drawn linear and LOG: in the log picture the halo's colour differs from the unlit
    background's (black), in the linear one it does not (both are the colour map's bottom, 1e-5 of the range)."""
    img, _ = _spot_and_halo()
    lin, log = tmp_path / "lin.png", tmp_path / "log.png"
    write_image(lin, img[None], extent=(-1, 1, -1, 1))
    write_image(log, img[None], extent=(-1, 1, -1, 1), log=True)
    L_lin, L_log = _luminance(lin), _luminance(log)
    assert L_lin.shape == L_log.shape
    # where the linear picture is black (the unlit background and the halo, both at the colour map's bottom),
    # the log picture draws the halo in colour: the 64 x 64 image spans about 370 screen pixels, so the halo's
    # disk of radius 20 covers about pi (115)^2 = 4e4 of them
    black = L_lin < 0.02
    lit_in_log = int(np.sum(L_log[black] > 0.05))
    assert lit_in_log > 20000, lit_in_log
    assert np.sum(L_lin[black] > 0.05) == 0
