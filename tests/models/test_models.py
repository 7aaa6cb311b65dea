"""Models and the lobe registry (clshade/models/model.py, registry.py): model specs resolve to their
lobes, workflow and Fresnel term, and a malformed or unknown spec is refused in one line naming what is
wrong, from the command line and from the scene. The registry is an object, not process state: two
scenes with different lobe folders, read and rendered in one process, each see their own lobes only,
even where both folders hold a lobe of the same id with different code."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from clshade.errors import ClshadeError
from clshade.models.model import PRESETS
from clshade.models.registry import Registry
from clshade.render.scene import load_scene

from conftest import refused, render_refused, write_scene
from scene_toml import small_red_sphere, two_spheres

BUILT_IN = Registry()          # the built-in lobes


# ---------------------------------------------------------------- model specs

def test_model_specs_resolve():
    m = BUILT_IN.resolve("oren_nayar+ggx_correlated")
    assert (m.diffuse, m.specular, m.workflow) == ("oren_nayar", "ggx_correlated", "metallic")
    assert BUILT_IN.resolve("phong").workflow == "kdks"
    assert BUILT_IN.resolve("cook_torrance@conductor").fresnel == "conductor"
    assert len(BUILT_IN.resolve_many("all")) == len(PRESETS)
    with pytest.raises(Exception, match="did you mean 'ggx_correlated'"):
        BUILT_IN.resolve("ggx_corelated")


@pytest.mark.parametrize("model, fault", [
    ("+", "empty lobe name"), ("lambert+", "empty lobe name"), ("+lambert", "empty lobe name"),
    ("lambert++phong", "empty lobe name"), ("lambert@conductor", "lambert has no Fresnel term"),
    ("oren_nayar@dielectric", "oren_nayar has no Fresnel term")])
def test_malformed_model_specs_are_refused(tmp_path, capsys, model, fault):
    """Refused with the spec and what is wrong with it, from the command line and from the scene."""
    scene = write_scene(tmp_path)
    refused(capsys, ["render", str(scene), "-m", model, "-o", str(tmp_path / "o.png")], repr(model), fault)
    text = small_red_sphere(render_keys=dict(model=model))
    refused(capsys, ["render", str(write_scene(tmp_path, text)), "-o", str(tmp_path / "o.png")],
            f"render.model = {model!r}", "scene.toml", fault)
    assert not (tmp_path / "o.png").exists()


def test_unknown_model_in_the_scene_names_file_and_key(tmp_path, capsys):
    render_refused(tmp_path, capsys, small_red_sphere(render_keys=dict(model="ggx_corelated")),
                   "render.model = 'ggx_corelated'", "unknown model")


# ---------------------------------------------------------------- one registry per command, not per process


def _diffuse_lobe(folder: Path, ident: str, value: float) -> None:
    """A diffuse lobe of constant f = `value` (clshade's .cl format)."""
    (folder / f"{ident}.cl").write_text(
        f"/*! clshade-model\n * id: {ident}\n * name: {ident}\n * kind: diffuse\n * family: diffuse\n"
        f" * formula: f = {value}\n * source: test\n */\n"
        f"INLINE real diffuse_lobe(const Geometry g, const Surface s) {{ return (real)({value}f); }}\n",
        encoding="utf-8")


def _brdf_lobe(folder: Path, ident: str) -> None:
    """A specular lobe of constant f = k (BRDF Explorer's .brdf format)."""
    (folder / f"{ident}.brdf").write_text(
        "analytic\n::begin parameters\nfloat k 0 1 0.5\n::end parameters\n::begin shader\n"
        "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(k); }\n::end shader\n", encoding="utf-8")


@pytest.fixture
def two_scenes(tmp_path: Path) -> tuple[Path, Path]:
    """Scene A (folder A: glow.cl, tint.cl with f = 0.25) and scene B (folder B: sheen.brdf,
    tint.cl with f = 1), each naming its folder in render.lobes and using `tint`."""
    scenes = []
    for name, own, tint in (("a", "glow", 0.25), ("b", "sheen", 1.0)):
        folder = tmp_path / f"lobes_{name}"
        folder.mkdir()
        _diffuse_lobe(folder, "tint", tint)
        if own == "glow":
            _diffuse_lobe(folder, own, 0.5)
        else:
            _brdf_lobe(folder, own)
        scene = tmp_path / f"{name}.toml"
        scene.write_text(two_spheres(16, 16, lobes=str(folder), model="tint"), encoding="utf-8")
        scenes.append(scene)
    return scenes[0], scenes[1]


def test_scenes_do_not_see_each_others_lobes(two_scenes):
    path_a, path_b = two_scenes
    scene_a, scene_b = load_scene(path_a), load_scene(path_b)
    assert scene_a.lobes == (path_a.parent / "lobes_a",) and scene_b.lobes == (path_b.parent / "lobes_b",)
    registry_a, registry_b = Registry().with_lobes(*scene_a.lobes), Registry().with_lobes(*scene_b.lobes)
    assert registry_a.resolve("glow").is_users and registry_b.resolve("sheen").is_users
    with pytest.raises(ClshadeError, match="unknown model or lobe 'sheen'"):
        registry_a.resolve("sheen")
    with pytest.raises(ClshadeError, match="unknown model or lobe 'glow'"):
        registry_b.resolve("glow")
    for registry in (Registry(), Registry.from_env({})):      # reading both scenes changed nothing else
        assert "glow" not in registry.lobes and "sheen" not in registry.lobes and "tint" not in registry.lobes


def test_a_scene_naming_the_other_scenes_lobe_is_refused(two_scenes, tmp_path):
    path_a, path_b = two_scenes
    load_scene(path_a)
    other = tmp_path / "b_glow.toml"
    other.write_text(two_spheres(16, 16, lobes=str(tmp_path / "lobes_b"), model="glow"), encoding="utf-8")
    with pytest.raises(ClshadeError, match=r"render\.model = 'glow': unknown model or lobe 'glow'"):
        load_scene(other)


def test_one_id_two_folders_two_frames(two_scenes, runtime):
    """`tint` is 0.25 in A and 1 in B: shaded one after the other on one G-buffer by one Shader (its
    kernel cache shared), B's frame is 4 × A's on every covered pixel."""
    from clshade.device.shade import Shader, scene_features
    from clshade.pipeline import prepare_frame
    tints = []
    for path in two_scenes:
        scene = load_scene(path)
        tints.append(Registry().with_lobes(*scene.lobes).resolve(scene.model))
    assert tints[0].id == tints[1].id == "tint" and tints[0] != tints[1]
    frame = prepare_frame(load_scene(two_scenes[0]))
    shader = Shader(runtime, frame.gbuffer, frame.scene, frame.camera, frame.shadows)
    features = scene_features(frame.scene, geometry=frame.geometry)
    a, b = (shader.render(model, features).copy() for model in tints)
    covered = a[..., 3] > 0
    assert covered.sum() > 20
    np.testing.assert_allclose(b[covered][:, :3], 4.0 * a[covered][:, :3], rtol=1e-5, atol=1e-7)


def test_the_cli_builds_a_registry_per_command(two_scenes, tmp_path, capsys):
    """`clshade render` of scene A then of scene B with A's lobe: the second command refuses it."""
    from clshade.cli import main
    path_a, path_b = two_scenes
    assert main(["render", str(path_a), "-m", "glow", "-o", str(tmp_path / "a.png")]) == 0
    capsys.readouterr()
    refused(capsys, ["render", str(path_b), "-m", "glow", "-o", str(tmp_path / "b.png")],
            "unknown model or lobe 'glow'")
