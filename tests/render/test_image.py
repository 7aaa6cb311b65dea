"""The output stage: the chunked display transform and the PNG settings change no pixel."""
from __future__ import annotations

import numpy as np
import pytest

from clshade.cli import main
from clshade.render import image
from clshade.render.image import display, read_image, to_display

from conftest import SCENES


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")  # -inf × 2^exposure
@pytest.mark.parametrize("method,exposure", [("aces", 0.0), ("reinhard", 1.5), ("none", -2.0)])
def test_to_display_in_chunks_is_one_pass(method, exposure, monkeypatch):
    """Several chunks, a partial last one, NaN/±Inf and values past white: the same bytes as
    the display transform over the whole image at once."""
    monkeypatch.setattr(image, "DISPLAY_CHUNK_PIXELS", 1000)
    rng = np.random.default_rng(7)
    img = (rng.random((53, 37, 4)) * 4.0).astype(np.float32)
    img[::5, ::3, 0] = np.nan
    img[::7, ::2, 1] = np.inf
    img[::3, ::4, 2] = -np.inf
    whole = np.round(display(img, method, exposure) * 255.0).astype(np.uint8)
    np.testing.assert_array_equal(to_display(img, method, exposure), whole)


def test_png_holds_the_display_transform_of_the_radiance(tmp_path):
    """The PNG the CLI writes (fast zlib settings) decodes to exactly to_display of the
    EXR it writes for the same frame: compression changes the file size, never a pixel."""
    png, exr = tmp_path / "r.png", tmp_path / "r.exr"
    args = [str(SCENES / "robot.toml"), "--width", "96", "--height", "80"]
    assert main(["render", *args, "-o", str(png)]) == 0
    assert main(["render", *args, "-o", str(exr)]) == 0
    radiance = read_image(exr)
    expected = to_display(radiance)
    decoded = np.round(read_image(png) * 255.0).astype(np.uint8)
    np.testing.assert_array_equal(decoded, expected)


def test_png_declares_srgb(tmp_path):
    """The PNG says it is sRGB (sRGB chunk before the image data) without the oiio:ColorSpace
    attribute that write_encoded no longer sets for PNG."""
    out = image.write_encoded(tmp_path / "tag.png", np.zeros((4, 5, 3), np.uint8))
    data = out.read_bytes()
    assert b"sRGB" in data and data.index(b"sRGB") < data.index(b"IDAT")
    assert read_image(out).shape == (4, 5, 3)


def _textbook_tonemap(rgb, method, exposure):
    """The tone maps as plain expressions (what image.tonemap computes in place)."""
    x = np.nan_to_num(np.asarray(rgb, np.float64), nan=0.0, posinf=np.finfo(np.float32).max) * (2.0 ** exposure)
    x = np.maximum(x, 0.0)
    if method == "reinhard":
        x = x / (1.0 + x)
    elif method == "aces":
        x = 0.6 * x
        with np.errstate(over="ignore", invalid="ignore"):
            x = (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)
        x = np.where(np.isfinite(x), x, 2.51 / 2.43)
    return np.clip(x, 0.0, 1.0)


def _textbook_srgb(c):
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("method", ["none", "reinhard", "aces"])
@pytest.mark.parametrize("exposure", [0.0, 1.5, -3.0, 64.0, -64.0])
def test_in_place_display_transform_is_the_textbook_one(method, exposure):
    """Bit for bit on every kind of float32 radiance: random bit patterns (NaN, ±∞, subnormals,
    huge, negative), values around the sRGB knee and around 1."""
    rng = np.random.default_rng(11)
    values = np.concatenate([
        rng.integers(0, 2**32, 30000, dtype=np.uint64).astype(np.uint32).view(np.float32),
        (rng.random(30000) * 4).astype(np.float32), np.float32(0.0031308) * (1 + rng.normal(0, 1e-3, 3000)),
        np.array([np.nan, np.inf, -np.inf, 0.0, -0.0, np.finfo(np.float32).max, 1e-45], np.float32)]).astype(np.float32)
    rgb = values[: len(values) // 3 * 3].reshape(-1, 1, 3)
    expected = _textbook_tonemap(rgb, method, exposure)
    np.testing.assert_array_equal(image.tonemap(rgb, method, exposure), expected)
    np.testing.assert_array_equal(image.srgb_encode(expected), _textbook_srgb(expected))
    quantised = np.round(_textbook_srgb(expected).astype(np.float32) * 255.0).astype(np.uint8)
    np.testing.assert_array_equal(to_display(rgb, method, exposure), quantised)
    assert np.array_equal(rgb, values[: len(values) // 3 * 3].reshape(-1, 1, 3), equal_nan=True)   # input untouched


def test_srgb_knee_and_float64_input_untouched():
    """The linear segment up to and including 0.0031308 (IEC 61966-2-1), the power curve
    right above it; tonemap leaves a float64 input as it was."""
    knee = 0.0031308
    c = np.array([np.nextafter(knee, 0.0), knee, np.nextafter(knee, 1.0), 0.5])
    np.testing.assert_array_equal(image.srgb_encode(c), _textbook_srgb(c))
    assert image.srgb_encode(c)[1] == 12.92 * knee
    radiance = np.array([[0.5, np.nan, np.inf], [-1.0, 2.0, 1e-3]])
    before = radiance.copy()
    for method in ("none", "reinhard", "aces"):
        image.tonemap(radiance, method, 1.0)
    np.testing.assert_array_equal(radiance, before)
