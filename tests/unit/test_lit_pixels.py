"""irtlang.core.stats.lit_pixels: the lit disk of a frame, which the printed per-pixel errors and the benchmarks'
error figures are taken over.  The oracle is the geometry the test draws: a disk with a bright and a dark half
(cloud and ocean, 10:1) and one Monte Carlo outlier 100 times the bright level; every disk pixel is lit, none
outside.  A threshold at 2 % of the image's maximum (what the code used before) keeps only the outlier."""
from __future__ import annotations

import numpy as np

from irtlang.core.stats import lit_pixels


def _frame():
    y, x = np.mgrid[:64, :64]
    disk = (x - 32) ** 2 + (y - 32) ** 2 < 25 ** 2
    img = np.where(disk, np.where(x < 32, 1.0, 0.1), 0.0)
    img[30, 40] = 100.0         # the outlier, inside the dark half
    return img, disk


def test_an_outlier_does_not_shrink_the_lit_disk():
    img, disk = _frame()
    assert np.array_equal(lit_pixels(img), disk)
    assert (img > 0.02 * img.max()).sum() == 1      # the maximum's threshold keeps only the outlier


def test_per_image_on_a_stack():
    img, disk = _frame()
    stack = np.stack([img, 3.0 * img, np.zeros_like(img)])
    lit = lit_pixels(stack)
    assert lit.shape == stack.shape
    assert np.array_equal(lit[0], disk) and np.array_equal(lit[1], disk)
    assert not lit[2].any()
