"""Contact sheets and the smoothness sweep (clshade/compare.py): labels, timings, the difference view,
one row per model and its labels; a sweep or sheet over the budget refused in one line."""
from __future__ import annotations

import numpy as np
import pytest

from clshade import budget
from clshade.cli import main
from clshade.models.registry import Registry
from clshade.compare import LABEL_HEIGHT, MAX_COLUMNS, SHEET_BACKGROUND, compare_sheet, difference, false_colour
from clshade.render.image import read_image

from conftest import SCENES, refused, write_scene

BUILT_IN = Registry()          # the built-in lobes
RED_BALL = str(SCENES / "red_ball.toml")


def test_sheet_groups_labels_and_timings(runtime):
    chosen = BUILT_IN.resolve_many("lambert,phong,ggx_correlated")
    sheet, tiles = compare_sheet(SCENES / "robot.toml", chosen, width=64, height=64, runtime=runtime)
    assert [t.model.id for t in tiles] == [m.id for m in chosen]
    assert all(t.ms > 0 for t in tiles)
    # Three groups → three rows of one tile each, each with a title and a label band.
    assert sheet.shape[1] == 6 + (64 + 6)
    assert sheet.shape[0] > 3 * (64 + LABEL_HEIGHT)
    # The label band under the first tile has text (pixels brighter than the sheet background).
    band = sheet[30 + 6 + 64: 30 + 6 + 64 + LABEL_HEIGHT, 6:70]
    assert (band.max(axis=-1) > np.max(SHEET_BACKGROUND) + 0.3).sum() > 20
    # Tiles differ between models (the metal parts are black under a diffuse-only model).
    assert not np.allclose(tiles[0].image, tiles[2].image)


def test_difference_view_and_wrapping(runtime):
    chosen = BUILT_IN.resolve_many("all")
    sheet, tiles = compare_sheet(SCENES / "sphere_grid.toml", chosen, width=40, height=18,
                                 reference=BUILT_IN.resolve("ggx_correlated"), runtime=runtime)
    assert sheet.shape[1] == 6 + MAX_COLUMNS * (40 + 6)       # rows wrap at MAX_COLUMNS tiles


def test_difference_maps_the_largest_difference_to_the_top_of_the_ramp():
    """|a − b| (max over RGB) divided by the scale, through the false-colour ramp: 0 → its first stop, the
    largest difference → its last, a given scale is honoured, and the sign of a − b does not matter."""
    a = np.zeros((1, 4, 3))
    b = np.zeros((1, 4, 3))
    b[0, 1, 2] = 0.2           # differs in blue only
    b[0, 2] = -0.4             # the largest difference, negative
    b[0, 3, 0] = 0.1
    img, scale = difference(a, b)
    assert scale == pytest.approx(0.4)
    ramp = false_colour(np.array([0.0, 0.5, 1.0, 0.25]))
    np.testing.assert_allclose(img[0], ramp, atol=1e-6)
    img2, scale2 = difference(a, b, scale=0.8)
    assert scale2 == 0.8
    np.testing.assert_allclose(img2[0], false_colour(np.array([0.0, 0.25, 0.5, 0.125])), atol=1e-6)


def test_cli_compare_and_sweep(tmp_path, capsys):
    out = tmp_path / "sheet.png"
    assert main(["compare", str(SCENES / "robot.toml"), "-m", "diffuse", "-o", str(out), "--tile", "48"]) == 0
    assert "Oren–Nayar" in capsys.readouterr().out
    assert read_image(out).shape[1] == 6 + 3 * (48 + 6)
    sweep = tmp_path / "sweep.png"
    assert main(["sweep", "-m", "phong,phong_normalized", "--roughness", "0.2,0.8", "--size", "40",
                 "-o", str(sweep)]) == 0
    assert read_image(sweep).shape[1] == 6 + 2 * (40 + 6)


def test_normalized_highlight_brightens_as_it_narrows(runtime):
    """The study's Figure 4: a normalised lobe's peak grows as roughness falls; the unnormalised one's does not."""
    from clshade.compare import shade_all
    from clshade.pipeline import prepare_frame
    from clshade.render.scene import load_scene
    import dataclasses
    scene = load_scene(SCENES / "red_ball.toml")
    peaks = {}
    for r in (0.3, 0.6):
        mats = {k: dataclasses.replace(m, roughness=r) for k, m in scene.materials.items()}
        frame = prepare_frame(dataclasses.replace(scene, materials=mats), 96, 96)
        for t in shade_all(frame, BUILT_IN.resolve_many("phong,phong_normalized"), runtime, repeats=1):
            peaks[(t.model.id, r)] = t.image[..., 2].max()       # blue: specular only (red base)
    assert peaks[("lambert+phong_normalized", 0.3)] > 2 * peaks[("lambert+phong_normalized", 0.6)]
    assert peaks[("lambert+phong", 0.3)] < 1.5 * peaks[("lambert+phong", 0.6)]


def test_sweep_one_row_per_model_and_labels(runtime):
    from clshade.compare import GAP, LABEL_HEIGHT, TITLE_HEIGHT, sweep_labels, sweep_sheet, model_title
    roughness = (0.05, 0.15, 0.3, 0.5, 0.7, 0.9)
    pair = [BUILT_IN.resolve("phong"), BUILT_IN.resolve("ggx_correlated@dielectric")]
    sheet = sweep_sheet(RED_BALL, pair, roughness, size=8, runtime=runtime)
    assert sheet.shape[1] == GAP + len(roughness) * (8 + GAP)                       # 6 columns, no wrap
    assert sheet.shape[0] == GAP + len(pair) * (TITLE_HEIGHT + 8 + LABEL_HEIGHT + GAP)   # one row each
    assert sweep_labels(BUILT_IN.resolve("phong"), 0.5, 30.0) == ("r = 0.5", "n = 30")
    assert sweep_labels(BUILT_IN.resolve("lambert"), 0.5, 30.0) == ("r = 0.5", "")
    assert sweep_labels(BUILT_IN.resolve("ggx_correlated"), 0.5, 30.0) == ("r = 0.5", "")
    assert model_title(BUILT_IN.resolve("ggx_correlated@conductor")) == "GGX height-correlated, Conductor Fresnel"
    assert model_title(BUILT_IN.resolve("lambert")) == "Lambert"


def test_sweep_columns_are_bounded(tmp_path, capsys):
    values = ",".join(f"{i / 4999:.4f}" for i in range(5000))
    refused(capsys, ["sweep", str(write_scene(tmp_path)), "-o", str(tmp_path / "s.png"), "--roughness", values],
            "--roughness", "5000 values", f"limit of {budget.MAX_SWEEP_COLUMNS}")
    refused(capsys, ["sweep", str(write_scene(tmp_path)), "-o", str(tmp_path / "s.png"), "--roughness", "0.5",
                     "--size", "4096", "-m", "all"], "sheet", f"limit of {budget.MAX_SHEET_PIXELS}")
    assert not (tmp_path / "s.png").exists()
