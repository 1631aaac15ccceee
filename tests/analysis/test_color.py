"""sRGB encoding, I/F composites, the CIE path and the image/animation writers."""

import cv2
import numpy as np
import pytest
from PIL import Image

from analysis import (AnalysisError, cie1931_cmf, rgb_composite, save_animation, save_png, spectrum_to_rgb,
                      srgb_decode, srgb_encode)
from analysis.color import XYZ_TO_LINEAR_SRGB


def test_srgb_encoding_values():
    assert srgb_encode(0.18) == pytest.approx(0.46136, abs=5e-6)
    assert srgb_encode(0.002) == pytest.approx(12.92 * 0.002, rel=1e-12)  # linear branch
    assert srgb_encode(0.0) == 0.0 and srgb_encode(1.0) == pytest.approx(1.0, abs=1e-12)
    # the two branches meet at the threshold (to the 1e-7 the standard's constants allow)
    assert 12.92 * 0.0031308 == pytest.approx(1.055 * 0.0031308 ** (1 / 2.4) - 0.055, abs=1e-6)
    x = np.linspace(0, 1, 101)
    np.testing.assert_allclose(srgb_decode(srgb_encode(x)), x, atol=1e-12)


def test_grey_scene_stays_grey():
    texture = np.random.default_rng(1).uniform(0.05, 0.6, (32, 40))
    rgb = rgb_composite(texture, texture, texture)
    assert rgb.dtype == np.uint8 and rgb.shape == (32, 40, 3)
    assert np.array_equal(rgb[..., 0], rgb[..., 1]) and np.array_equal(rgb[..., 1], rgb[..., 2])


def test_white_balance_against_the_sun():
    # A grey reflector under a coloured sun: radiance per band = rho E / pi. Balanced, it is grey; taken as
    # reflectance directly, it is not.
    rho = np.random.default_rng(2).uniform(0.05, 0.6, (16, 16))
    sun = np.array([1.5, 1.85, 2.0])
    bands = [rho * e / np.pi for e in sun]
    balanced = rgb_composite(*bands, solar_irradiance=sun)
    assert np.array_equal(balanced[..., 0], balanced[..., 2]) and np.array_equal(balanced[..., 1], balanced[..., 2])
    raw = rgb_composite(*bands)
    assert np.all(raw[..., 0].astype(int) <= raw[..., 2]) and np.any(raw[..., 0] < raw[..., 2])


def test_one_common_stretch():
    rng = np.random.default_rng(3)
    r, g, b = (rng.uniform(0.1, 0.5, (8, 8)) for _ in range(3))
    np.testing.assert_array_equal(rgb_composite(r, g, b), rgb_composite(10 * r, 10 * g, 10 * b))
    # explicit white level, linear encoding: value = round(255 * rho / white)
    out = rgb_composite(r, g, b, stretch=0.5, gamma="linear")
    np.testing.assert_array_equal(out[..., 1], np.round(255 * g / 0.5).astype(np.uint8))
    # sRGB encoding of the stretched reflectance
    out = rgb_composite(r, g, b, stretch="max")
    top = max(r.max(), g.max(), b.max())
    np.testing.assert_array_equal(out[..., 0], np.round(255 * srgb_encode(r / top)).astype(np.uint8))


def test_cie_fit_against_tabulated_cie1931():
    # CIE 1931 2-degree table values; the Wyman et al. (2013) multi-lobe fit is good to about 0.01-0.02.
    table = {450: (0.3362, 0.0380, 1.7721), 500: (0.0049, 0.3230, 0.2720), 550: (0.4334, 0.9950, 0.0087),
             600: (1.0622, 0.6310, 0.0008), 650: (0.2835, 0.1070, 0.0000)}
    for lam, xyz in table.items():
        np.testing.assert_allclose(cie1931_cmf(lam), xyz, atol=0.02)


def test_flat_spectrum_is_neutral():
    lam = np.arange(380.0, 781.0, 5.0)
    cube = np.ones((lam.size, 4, 5))
    rgb = spectrum_to_rgb(cube, lam)
    assert rgb.shape == (4, 5, 3)
    # the fit's three integrals differ by 0.15 %, i.e. well under one 8-bit step at white
    assert int(rgb.max()) - int(rgb.min()) <= 1
    # without adaptation the equal-energy white is pinkish in D65 sRGB: linear M @ (1, 1, 1)
    expected = XYZ_TO_LINEAR_SRGB.sum(axis=1)
    expected = np.round(255 * srgb_encode(expected / expected.max()))
    np.testing.assert_allclose(spectrum_to_rgb(np.ones(lam.size), lam, white="D65"), expected, atol=2)


def test_monochromatic_lines_have_the_right_hue():
    lam = np.arange(380.0, 781.0, 1.0)
    for centre, channel in ((450, 2), (530, 1), (630, 0)):
        spec = np.exp(-0.5 * ((lam - centre) / 5.0) ** 2)
        assert np.argmax(spectrum_to_rgb(spec, lam)) == channel


def test_save_png_round_trip(tmp_path):
    rgb = np.random.default_rng(4).integers(0, 256, (12, 17, 3), dtype=np.uint8)
    path = save_png(rgb, tmp_path / "c.png")
    back = cv2.cvtColor(cv2.imread(str(path), cv2.IMREAD_UNCHANGED), cv2.COLOR_BGR2RGB)
    np.testing.assert_array_equal(back, rgb)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.png"]  # no temporary file left


def test_save_animation_gif_and_mp4(tmp_path):
    frames = [np.full((16, 24, 3), 40 * k, np.uint8) for k in range(5)]
    gif = save_animation(frames, tmp_path / "a.gif", fps=5)
    with Image.open(gif) as im:
        assert im.n_frames == 5 and im.size == (24, 16)
    mp4 = save_animation(frames, tmp_path / "a.mp4", fps=5)
    cap = cv2.VideoCapture(str(mp4))
    count = 0
    while cap.read()[0]:
        count += 1
    cap.release()
    assert count == 5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif", "a.mp4"]
    with pytest.raises(AnalysisError, match="unsupported"):
        save_animation(frames, tmp_path / "a.avi")
    with pytest.raises(AnalysisError, match="different shapes"):
        save_animation([frames[0], frames[1][:8]], tmp_path / "b.gif")
