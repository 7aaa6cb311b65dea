"""Large frames: the CLI renders in bands of rows (pipeline.render_streamed), so only the
output image is full-frame; a frame that cannot fit is refused before any allocation."""
from __future__ import annotations

import numpy as np
import pytest

from clshade.cli import main
from clshade.models.registry import Registry
from clshade.errors import ClshadeError
from clshade.pipeline import check_frame_memory, render, render_streamed
from clshade.render.scene import load_scene

from conftest import SCENES

BUILT_IN = Registry()          # the built-in lobes


@pytest.mark.parametrize("name", ["robot", "textured", "shadows"])
def test_bands_equal_the_whole_frame(runtime, name):
    """Bands of 37 rows (the last one short) give the full-frame image: same coverage, radiance
    equal to float32 rounding (texture LOD, shadows and view rays are band-independent)."""
    scene = load_scene(SCENES / f"{name}.toml")
    model = BUILT_IN.resolve("ggx_correlated")
    full = render(scene, model, width=160, height=120, runtime=runtime).image
    out = np.full_like(full, np.nan)

    def keep(first_row, band):
        out[first_row:first_row + len(band)] = band

    result = render_streamed(scene, model, keep, width=160, height=120, runtime=runtime, band_pixels=160 * 37)
    assert result.bands == 4
    assert np.array_equal(full[..., 3] > 0, out[..., 3] > 0)
    assert result.covered == int((full[..., 3] > 0).sum())
    rel = np.abs(full[..., :3] - out[..., :3]) / np.maximum(np.abs(full[..., :3]), 1e-3)
    assert rel.max() <= 1e-4


def test_frame_memory_estimate_and_refusal():
    need = check_frame_memory(4096, 4096, 3, available=64 << 30)
    assert 4096 * 4096 * 3 < need < 4096 * 4096 * 64
    with pytest.raises(ClshadeError, match=r"16384x16384 frame needs about .* GiB available"):
        check_frame_memory(16384, 16384, 16, available=2 << 30)


def test_cli_refuses_before_any_work(monkeypatch, capsys, tmp_path):
    """Not enough memory: one line, exit 2, and no geometry was built."""
    import clshade.pipeline as pipeline

    def never(*a, **k):
        raise AssertionError("work started before the memory check")

    monkeypatch.setattr(pipeline, "available_memory", lambda: 1 << 30)
    monkeypatch.setattr(pipeline, "build_geometry", never)
    status = main(["render", str(SCENES / "robot.toml"), "--width", "16384", "--height", "16384",
                   "-o", str(tmp_path / "big.png")])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "16384x16384 frame needs about" in err
    assert not (tmp_path / "big.png").exists()
