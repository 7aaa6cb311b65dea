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
