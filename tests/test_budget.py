"""The resource budget (clshade/budget.py): no size read from input is allocated before the budget allows
it. A path that is not a regular file is refused before it is read; a texture, a set of shadow maps or a
count of lights over its ceiling, or more than the memory available, is refused in one line; the README's
Resource limits section states each ceiling as budget.py holds it."""
from __future__ import annotations

import os
import re

import pytest

from clshade import budget
from clshade.errors import ClshadeError

from conftest import assert_one_line_error, refused, run_cli, run_cli_process, write_scene
from scene_toml import light, small_red_sphere

SIZE = ["--width", "24", "--height", "16"]


@pytest.mark.parametrize("path", ["/dev/zero", "/dev/urandom", "fifo", "folder"])
def test_special_scene_paths_are_refused_at_once(tmp_path, path):
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "fifo")
    proc = run_cli_process(["render", path, "-o", "out.png"], tmp_path, timeout=30)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert "not a regular file" in proc.stderr and path in proc.stderr


@pytest.mark.parametrize("key", ["mesh", "base_color_texture"])
@pytest.mark.parametrize("path", ["/dev/zero", "fifo", "folder"])
def test_special_mesh_and_texture_paths_are_refused(tmp_path, capsys, key, path):
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "fifo")
    text = small_red_sphere(shape=dict(mesh=path)) if key == "mesh" else small_red_sphere(red={key: path})
    args = ["render", str(write_scene(tmp_path, text)), "-o", str(tmp_path / "o.png")]
    if path == "fifo":      # an accepted FIFO blocks its reader: in a child, so that the test fails instead of hanging
        proc = run_cli_process(args, tmp_path, timeout=30)
        code, err = proc.returncode, proc.stderr
    else:
        code, _, err = run_cli(capsys, args)
    assert_one_line_error(code, err, "not a regular file", key, "scene.toml")


def test_texture_within_the_ceiling_is_refused_when_memory_is_short(monkeypatch):
    monkeypatch.setattr(budget, "available_memory", lambda: 64 << 20)
    with pytest.raises(budget.ClshadeError, match=r"2048x2048 texture needs about .* GiB of memory, 0.06 GiB"):
        budget.texture_pixels(2048, 2048, 4)
    assert budget.texture_pixels(1024, 1024, 4) <= 64 << 20


def test_shadow_budget_boundary(monkeypatch):
    """Exactly the ceiling fits, one map more does not, whatever the memory (decided before allocation)."""
    monkeypatch.setattr(budget, "available_memory", lambda: 1 << 40)
    assert budget.shadow_texels(1, 8192) == 8192 * 8192 * budget.SHADOW_BYTES_PER_TEXEL
    assert budget.shadow_texels(64, 1024) == budget.shadow_texels(1, 8192)
    for count, size in ((2, 8192), (65, 1024), (1025, 256)):
        with pytest.raises(ClshadeError, match=f"{count} shadow maps of {size}x{size}"):
            budget.shadow_texels(count, size)
    monkeypatch.setattr(budget, "available_memory", lambda: 64 << 20)
    with pytest.raises(ClshadeError, match=r"32 shadow maps of 1024x1024 needs about 0.1\d GiB"):
        budget.shadow_texels(32, 1024)


def test_bench_lights_are_bounded(tmp_path, capsys):
    """The lights `bench --lights` adds and the lights of a scene: each over MAX_LIGHTS refused in one line."""
    refused(capsys, ["bench", str(write_scene(tmp_path)), "--lights", "1000000000", *SIZE], "--lights = 1000000000",
            f"[0, {budget.MAX_LIGHTS}]")
    many = small_red_sphere(lights=[light("directional", direction=[0.0, -1.0, -1.0])] * (budget.MAX_LIGHTS + 1))
    refused(capsys, ["render", str(write_scene(tmp_path, many)), "-o", str(tmp_path / "o.png")],
            "scene.toml: lights", f"limit of {budget.MAX_LIGHTS}")


def test_readme_states_the_budget_as_it_is(checkout):
    """README's Resource limits section names each ceiling with the value budget.py holds."""
    text = (checkout / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## Resource limits"):text.index("## What it measures")]
    for name, shown in (("MAX_SCENE_FILE_BYTES", f"{budget.MAX_SCENE_FILE_BYTES >> 20} MiB"),
                        ("MAX_TEXTURE_PIXELS", "4096 × 4096"), ("MAX_SHADOW_TEXELS", "8192²"),
                        ("MAX_LIGHTS", str(budget.MAX_LIGHTS)), ("MAX_FRAMES", f"{budget.MAX_FRAMES:,}".replace(",", " ")),
                        ("MAX_SWEEP_COLUMNS", str(budget.MAX_SWEEP_COLUMNS)), ("MAX_SHEET_PIXELS", "8192²"),
                        ("MAX_COORDINATE", f"±{budget.MAX_COORDINATE:.0e}".replace("e+", "e")),
                        ("MAX_LOBE_FILE_BYTES", f"{budget.MAX_LOBE_FILE_BYTES >> 10} KiB"),
                        ("MAX_LOBE_FOLDER_FILES", str(budget.MAX_LOBE_FOLDER_FILES))):
        assert re.search(rf"{re.escape(shown)}[^|\n]*`{name}`", section), (name, shown)
    assert budget.MAX_TEXTURE_PIXELS == 4096 * 4096 and budget.MAX_SHADOW_TEXELS == 8192 ** 2
    assert budget.MAX_SHEET_PIXELS == 8192 ** 2
