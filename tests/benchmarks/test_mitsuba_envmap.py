"""clshade's sky convention and truth against Mitsuba 3's envmap emitter (benchmarks/measure/mitsuba_envmap.py),
on small skies whose orientation tells u from −u and up from down. Skipped where Mitsuba is not installed."""
from __future__ import annotations

import numpy as np
import pytest

from sky_maps import sky_of, write_map

M = pytest.importorskip("benchmarks.measure.mitsuba_envmap")


@pytest.fixture(scope="module")
def mi():
    try:
        return M._mitsuba()
    except Exception as e:  # noqa: BLE001 — any reason Mitsuba cannot start is a reason to skip
        pytest.skip(f"Mitsuba 3 is not usable here: {e}")


def lopsided(d: np.ndarray) -> np.ndarray:
    """A sky brighter towards +x, +y and −z by different amounts, per channel."""
    return np.stack([1.0 + 0.8 * np.maximum(d[..., 0], 0), 1.0 + 0.5 * d[..., 1] + 0.4 * np.maximum(-d[..., 2], 0),
                     0.2 + np.maximum(d[..., 1], 0) ** 4 * 30.0], axis=-1)


@pytest.mark.parametrize("rotation", [0.0, 40.0])
def test_truth_agrees_with_mitsuba(tmp_path, mi, rotation):
    from clshade.render import environment as E
    write_map(tmp_path / "sky.exr", sky_of(lopsided, 32, 16))
    spec = E.EnvironmentSpec(map=tmp_path / "sky.exr", rotation=rotation)
    rng = np.random.default_rng(3)
    n = rng.normal(size=(12, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    row = M.compare_sky(mi, "lopsided", spec, tmp_path / "scene.toml", n, 1 << 15)
    assert max(row["orientation_max_rel"].values()) < 1e-5, row
    # E(n) differs from Mitsuba's estimate by its noise only: a few standard errors over 36 values
    assert row["max_z"] < 5.0, row
    assert row["rel_rmse"] < 4.0 * row["median_rel_se"] + 1e-3, row
