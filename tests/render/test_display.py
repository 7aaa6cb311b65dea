"""The display transform (clshade/render/image.py): exposure, tone maps and the sRGB codec against
independent reference values (IEC 61966-2-1 and the documented tone-map formulas)."""
from __future__ import annotations

import numpy as np
import pytest

from clshade.render.image import srgb_decode, srgb_encode, to_display, tonemap

# IEC 61966-2-1: linear → encoded, computed in float64 from the standard's piecewise definition.
SRGB = [(0.0, 0.0), (0.0031308, 0.0404499), (0.01, 0.0998528), (0.18, 0.4613561), (0.5, 0.7353570), (1.0, 1.0)]


@pytest.mark.parametrize("linear, encoded", SRGB)
def test_srgb_encode_and_decode_match_the_standard(linear, encoded):
    assert float(srgb_encode(np.array(linear))) == pytest.approx(encoded, abs=2e-7)
    assert float(srgb_decode(np.array(encoded))) == pytest.approx(linear, abs=2e-7)


def test_reinhard_and_none():
    x = np.array([[0.0, 0.25, 1.0, 3.0]])
    np.testing.assert_allclose(tonemap(x, "reinhard"), [[0.0, 0.2, 0.5, 0.75]], atol=1e-12)
    np.testing.assert_allclose(tonemap(x, "none"), [[0.0, 0.25, 1.0, 1.0]], atol=1e-12)


def test_aces_fit_values():
    """Narkowicz's ACES fit y = x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14) after a 0.6 pre-exposure."""
    x = np.array([0.18, 1.0])
    y = tonemap(x, "aces")
    np.testing.assert_allclose(y, [0.1401196, 0.6732905], atol=1e-6)
    assert tonemap(np.array([1e30]), "aces")[0] == 1.0


@pytest.mark.parametrize("method", ["none", "reinhard", "aces"])
def test_exposure_is_a_power_of_two_scale(method):
    x = np.linspace(0.0, 2.0, 9)
    np.testing.assert_allclose(tonemap(x, method, exposure=1.0), tonemap(2.0 * x, method), atol=1e-12)
    np.testing.assert_allclose(tonemap(x, method, exposure=-2.0), tonemap(0.25 * x, method), atol=1e-12)


def test_8bit_display_value_of_middle_grey():
    """Linear 0.18, no tone map → sRGB 0.4614 → 118 of 255."""
    img = np.full((1, 1, 3), 0.18, np.float32)
    assert to_display(img, "none").tolist() == [[[118, 118, 118]]]
