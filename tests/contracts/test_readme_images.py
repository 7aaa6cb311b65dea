"""The README's images are what the code makes: each caption quotes the command
benchmarks/docgen/make_images.py runs for it, and the README's robot image shows what the float64 frame
oracle says the scene looks like."""
from __future__ import annotations

import os

import numpy as np
import pytest

from clshade.cli import main
from clshade.render.image import read_image

from conftest import ROOT


@pytest.mark.text
def test_readme_images_come_from_make_images():
    """Each README image's caption quotes the command benchmarks/docgen/make_images.py runs for it."""
    make_images = pytest.importorskip("benchmarks.docgen.make_images", reason="needs the source checkout")
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    for name in ("robot.png", "robot_sheet.png"):
        assert f"docs/images/{name}" in readme
        assert "clshade " + " ".join(make_images.COMMANDS[name]) + " -o" in readme, name


def test_readme_robot_image_shows_the_float64_truth(tmp_path):
    """`clshade render scenes/robot.toml` (the README's command) and the committed
    docs/images/robot.png both show what the float64 frame oracle says the scene looks like
    (every light kind, shadows, ambient; the scene's exposure and tone map, 8-bit sRGB): at
    most 1/255 apart on every pixel that faces the viewer, the worst named. Not a comparison
    with an image the same code wrote: a wrong spot cone, falloff or tone map fails it."""
    from clshade.bench.run import compared_pixels
    from clshade.models.registry import Registry
    from clshade.pipeline import prepare_frame
    from clshade.render.image import to_display
    from clshade.render.scene import load_scene
    from clshade.verify import reference
    resolve = Registry().resolve          # the built-in lobes

    out = tmp_path / "robot.png"
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        assert main(["render", "scenes/robot.toml", "-o", str(out)]) == 0
    finally:
        os.chdir(cwd)
    scene = load_scene(ROOT / "scenes" / "robot.toml")
    frame = prepare_frame(scene)
    truth = reference.radiance(frame.gbuffer, frame.scene, resolve(scene.model), camera=frame.camera,
                               shadows=frame.shadows)
    want = to_display(truth, scene.tonemap, scene.exposure).reshape(-1, 3).astype(np.int16)
    idx = compared_pixels(frame.gbuffer, frame.camera)
    width = frame.camera.width
    for name, path in (("clshade render", out), ("docs/images/robot.png", ROOT / "docs" / "images" / "robot.png")):
        got = np.round(read_image(path)[..., :3] * 255.0).reshape(-1, 3).astype(np.int16)
        assert got.shape == want.shape, name
        err = np.abs(got[idx] - want[idx]).max(axis=1)
        worst = int(np.argmax(err))
        assert err[worst] <= 1, (f"{name}: pixel (row {idx[worst] // width}, column {idx[worst] % width}) is "
                                 f"{got[idx[worst]]}, the oracle says {want[idx[worst]]}; "
                                 f"{int((err > 1).sum())} pixels over 1/255 (python -m benchmarks.docgen.make_images)")
