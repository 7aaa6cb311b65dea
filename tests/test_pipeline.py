"""End-to-end pipeline (clshade/pipeline.py): scene → rasterizer → G-buffer → OpenCL → image; an empty
scene renders its background, and NaN reaching the G-buffer is counted and shades as background."""
from __future__ import annotations

import math

import numpy as np
import pytest

from clshade.cli import main
from clshade.models.model import presets
from clshade.models.registry import Registry
from clshade.render.image import read_image
from clshade.pipeline import prepare_frame, render
from clshade.render.scene import parse_scene

from conftest import SCENES, run_cli, write_scene
from scene_toml import plane_facing_camera, point_and_spot, small_red_sphere

BUILT_IN = Registry()          # the built-in lobes


def test_lambert_plane_matches_closed_form(runtime):
    """A plane facing the camera and the light: L = (base/π)·E·cos0 exactly."""
    scene = parse_scene(plane_facing_camera())
    image = render(scene, BUILT_IN.resolve("lambert"), runtime=runtime).image
    expected = np.array([0.5, 0.25, 0.75]) / math.pi * np.array([2.0, 3.0, 4.0])
    assert image[..., 3].min() == 1.0                      # the plane covers every pixel
    np.testing.assert_allclose(image[..., :3].reshape(-1, 3), np.broadcast_to(expected, (48 * 32, 3)), rtol=1e-5)


def test_background_where_uncovered(runtime):
    scene = parse_scene(plane_facing_camera(size=0.5))
    image = render(scene, BUILT_IN.resolve("ggx_correlated"), runtime=runtime).image
    empty = image[..., 3] == 0
    assert empty.any() and (~empty).any()
    np.testing.assert_array_equal(image[empty][:, :3], np.broadcast_to([0.1, 0.2, 0.3], (empty.sum(), 3)).astype(np.float32))


@pytest.mark.parametrize("name", ["robot", "sphere_grid", "ground_plane"])
def test_bundled_scenes_render_finite_and_lit(runtime, name):
    result = render(SCENES / f"{name}.toml", BUILT_IN.resolve("ggx_correlated"), width=96, height=72, runtime=runtime)
    rgb, cov = result.image[..., :3], result.image[..., 3] > 0
    assert np.isfinite(rgb).all() and (rgb >= 0).all()
    assert cov.mean() > 0.05                               # something is in view
    assert rgb[cov].max() > 0.05                           # and it is lit


def test_every_preset_renders_sphere_grid(runtime):
    """Every preset through the whole pipeline equals the float64 frame oracle on the same G-buffer."""
    from clshade.verify.reference import radiance
    frame = prepare_frame(SCENES / "sphere_grid.toml", 80, 36)
    cov = frame.gbuffer.coverage
    assert cov.mean() > 0.05
    for model in presets():
        img = render(frame.scene, model, runtime=runtime, frame=frame).image
        assert np.isfinite(img).all() and (img[..., :3] >= 0).all(), model.id
        want = radiance(frame.gbuffer, frame.scene, model, camera=frame.camera)
        peak = np.abs(want[cov, :3]).max()
        assert peak > 0.05, model.id                                     # lit
        # Per pixel within 1e-3 relative (normalized Blinn–Phong's high exponent turns float32 rounding of n·h
        # into ~6e-4 at the highlight), floored at 1 % of the image's peak.
        rel = np.abs(img[cov, :3] - want[cov, :3]) / np.maximum(np.abs(want[cov, :3]), 1e-2 * peak)
        assert rel.max() <= 1e-3, (model.id, rel.max())
        assert img[cov][:, 0].mean() > img[cov][:, 2].mean(), model.id   # red plastic stays red


def test_oren_nayar_sigma0_is_lambert(runtime):
    """Oren–Nayar with σ = 0 is exactly Lambert (a claim of the study)."""
    scene = parse_scene(plane_facing_camera(roughness=0.0, rotate=(70.0, 10.0, 0.0)))
    a = render(scene, BUILT_IN.resolve("lambert"), runtime=runtime).image
    b = render(scene, BUILT_IN.resolve("oren_nayar"), runtime=runtime).image
    np.testing.assert_allclose(a, b, rtol=1e-6)


def test_variant_reads_only_what_the_model_uses(runtime):
    frame = prepare_frame(SCENES / "sphere_grid.toml", 32, 16)
    from clshade.device.shade import Shader, scene_features
    shader = Shader(runtime, frame.gbuffer, frame.scene)
    features = scene_features(frame.scene)
    assert shader.variant(BUILT_IN.resolve("lambert"), features).channels == ("depth", "normal", "base", "metallic")
    ggx = shader.variant(BUILT_IN.resolve("ggx_correlated"), features)
    assert "roughness" in ggx.channels and "material" not in ggx.channels
    # Phong's exponent differs per sphere: the material id channel appears.
    assert "material" in shader.variant(BUILT_IN.resolve("phong"), features).channels


def test_cli_render_png_and_exr(tmp_path, capsys):
    png, exr = tmp_path / "robot.png", tmp_path / "robot.exr"
    assert main(["render", str(SCENES / "robot.toml"), "-o", str(png), "--width", "64", "--height", "48"]) == 0
    out = capsys.readouterr().out
    assert f"wrote {png}" in out and ("rasterize" in out or "triangle setup" in out) and "shade" in out
    img = read_image(png)
    assert img.shape == (48, 64, 3) and img.max() > 0.2
    assert main(["render", str(SCENES / "robot.toml"), "-o", str(exr), "--width", "64", "--height", "48",
                 "-m", "oren_nayar+ggx_correlated", "--explain"]) == 0
    out = capsys.readouterr().out
    assert "G-buffer channels: depth, normal, base, roughness, metallic" in out
    assert "NUM_DIR=1 NUM_POINT=1 NUM_SPOT=1" in out
    linear = read_image(exr)
    assert linear.shape == (48, 64, 4) and np.isfinite(linear).all()
    assert linear[..., :3].max() > 0.2             # linear radiance, not tone mapped


def test_cli_models_and_devices(capsys):
    assert main(["models"]) == 0
    text = capsys.readouterr().out
    for lobe in BUILT_IN.lobes:
        assert lobe in text
    assert main(["devices"]) == 0
    assert "*" in capsys.readouterr().out


@pytest.mark.parametrize("half, width, height", [(False, 83, 37), (True, 83, 37), (False, 7, 9), (False, 3, 7)])
def test_odd_sized_frame_matches_the_oracle_pixel_by_pixel(runtime, half, width, height):
    """83×37 (rows wrap inside the SIMD work-items, the last work-item is padded), 7×9 (narrower than a
    work-item: its lanes span two rows at SIMD 8, three at 16) and 3×7 (four rows at SIMD 8), every pixel covered, lit unevenly by a point light and a
    spot: each pixel equals the float64 frame oracle at that pixel (with the half-float G-buffer: the
    oracle of the half-rounded G-buffer)."""
    from clshade.bench.numpy_baseline import half_gbuffer
    from clshade.verify.reference import radiance
    scene = parse_scene(plane_facing_camera(width, height, base_color=[0.51, 0.27, 0.73],  # not exact in half
                                            lights=point_and_spot()))
    frame = prepare_frame(scene)
    model = BUILT_IN.resolve("ggx_correlated")
    image = render(scene, model, runtime=runtime, frame=frame, half_gbuffer=half).image
    assert image.shape[:2] == (height, width) and image[..., 3].min() == 1.0
    gb = half_gbuffer(frame.gbuffer) if half else frame.gbuffer
    want = radiance(gb, frame.scene, model, camera=frame.camera)
    peak = np.abs(want).max()
    assert np.std(want[..., 0]) > 0.05 * peak                  # not a uniform image: lanes are distinguishable
    rel = np.abs(image[..., :3] - want) / np.maximum(np.abs(want), 1e-3 * peak)
    assert rel.max() <= 1e-4, rel.max()                       # measured 8e-7 (float32 rounding)


@pytest.mark.parametrize("spec", ["phong", "blinn_phong_normalized", "oren_nayar"])
def test_ambient_weight_ka_and_k_d_k_s_weights(runtime, spec):
    """The k_d + k_s workflow's own weights (k_a = 0.4, k_d = 0.5, k_s = 0.2: none of them 1 or 1 − the
    other) under ambient light and a point light, against the frame oracle."""
    from clshade.verify.reference import radiance
    scene = parse_scene(plane_facing_camera(ambient=[0.3, 0.2, 0.1], ka=0.4, kd=0.5, ks=0.2, lights=point_and_spot()))
    frame = prepare_frame(scene)
    model = BUILT_IN.resolve(spec)
    image = render(scene, model, runtime=runtime, frame=frame).image[..., :3]
    want = radiance(frame.gbuffer, frame.scene, model, camera=frame.camera)
    rel = np.abs(image - want) / np.maximum(np.abs(want), 1e-3 * np.abs(want).max())
    assert rel.max() <= 1e-4, rel.max()


def test_empty_scene_renders_background(tmp_path, capsys):
    scene = write_scene(tmp_path, small_red_sphere(objects=False))
    out = tmp_path / "empty.exr"
    code, stdout, err = run_cli(capsys, ["render", str(scene), "-o", str(out)])
    assert code == 0, err
    image = read_image(out)
    assert image.shape == (16, 24, 4)
    np.testing.assert_allclose(image[..., :3], np.broadcast_to([0.1, 0.2, 0.3], (16, 24, 3)), rtol=1e-6)


def test_nonfinite_gbuffer_inputs_are_counted_and_contained(tmp_path, capsys, monkeypatch):
    """NaN reaching the G-buffer (here: a NaN normal injected after build_geometry) is
    counted, its pixels shade as background, no other pixel changes, and the CLI warns."""
    from clshade import pipeline
    scene = write_scene(tmp_path)
    clean = tmp_path / "clean.exr"
    assert run_cli(capsys, ["render", str(scene), "-o", str(clean)])[0] == 0
    real = pipeline.build_geometry

    def poisoned(sc):
        g = real(sc)
        g.normals[::2] = np.nan
        return g
    monkeypatch.setattr(pipeline, "build_geometry", poisoned)
    out = tmp_path / "poisoned.exr"
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(out)])
    assert code == 0, err
    a, b = read_image(clean), read_image(out)
    assert np.isfinite(b).all()
    changed = np.any(a != b, axis=-1)
    count = int(err.split("warning: ")[1].split()[0])
    assert 0 < count == int(changed.sum())
    np.testing.assert_allclose(b[changed][:, :3], np.broadcast_to([0.1, 0.2, 0.3], (count, 3)), rtol=1e-6)
