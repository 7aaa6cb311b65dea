"""The kernels against the float64 frame oracle, one light kind at a time.

Each test renders a small scene with the OpenCL shading pass and compares it with
clshade.verify.reference.radiance on the same G-buffer, at ≤ 1e-4 relative on the
covered pixels where every light's n·l and n·v are ≥ 1e-3 in magnitude (at grazing
light or view the kernels' documented floors act; the error there is
clshade.verify.bias's subject). Changing the point falloff, the spot cone or the
ambient term on either side fails these tests. The comparison is conftest.oracle_errors.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from clshade.models.registry import Registry
from clshade.render.scene import load_scene
from clshade.verify import reference as R

from conftest import (ORACLE_BOUND, ORACLE_DARK, ORACLE_HEIGHT, ORACLE_MIN_COS, ORACLE_WIDTH, SCENES,
                      oracle_errors)
from scene_toml import floor_ball_torus

resolve = Registry().resolve          # the built-in lobes

# Both workflows: metallic-roughness with Schlick Fresnel, and the k_d + k_s = 1 rule.
MODELS = ("ggx_correlated", "phong")


def scene_file(tmp_path, kind: str) -> Path:
    path = tmp_path / f"{kind}.toml"
    path.write_text(floor_ball_torus(kind), encoding="utf-8")
    return path


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("kind", ["directional", "point", "spot", "ambient", "shadowed"])
def test_light_kind_matches_oracle(tmp_path, kind, model, device_runtime):
    res = oracle_errors(scene_file(tmp_path, kind), model, device_runtime)
    assert res["pixels"] > 0.5 * res["covered"], res
    assert res["max"] <= ORACLE_BOUND, res
    assert res["background"] <= 1e-6, res
    if kind == "shadowed":
        assert res["shadowed"] > 0.05 * res["pixels"], res   # shadows are really in the comparison


@pytest.mark.parametrize("model", ["ggx_correlated", "lambert+walter_ggx@conductor", "oren_nayar+cook_torrance@dielectric",
                                   "burley+ggx_correlated/kdks", "blinn_phong_normalized"])
def test_textured_matches_oracle(model, device_runtime):
    """Base colour, metallic-roughness and normal maps sampled into the G-buffer; every Fresnel."""
    res = oracle_errors(SCENES / "textured.toml", model, device_runtime)
    assert res["pixels"] > 0.5 * res["covered"], res
    assert res["max"] <= ORACLE_BOUND, res


def test_float32_oracle_is_the_same_function():
    """dtype=float32 (the NumPy baseline) runs the same code in single precision."""
    from clshade.pipeline import prepare_frame
    frame = prepare_frame(SCENES / "robot.toml", 64, 48)
    model = resolve("ggx_correlated")
    hi = R.radiance(frame.gbuffer, frame.scene, model, camera=frame.camera)
    lo = R.radiance(frame.gbuffer, frame.scene, model, camera=frame.camera, dtype=np.float32)
    assert hi.dtype == np.float64 and lo.dtype == np.float32
    cov = frame.gbuffer.coverage
    rel = np.abs(lo[cov] - hi[cov]) / np.maximum(np.abs(hi[cov]), 1e-3 * np.abs(hi).max())
    assert 0 < rel.max() < 1e-3


def test_spot_cone_and_falloff_follow_the_scene_format():
    """scenes/README.md: I/r², full inside the inner angle, 0 outside the outer, t² between."""
    scene = load_scene(SCENES / "shadows.toml")
    spot = next(l for l in scene.lights if l.kind == "spot")
    co, ci = np.cos(np.radians(spot.outer_angle)), np.cos(np.radians(spot.inner_angle))
    c = np.array([ci + 0.1 * (1 - ci), ci, 0.75 * ci + 0.25 * co, 0.5 * (ci + co), co, co - 0.01])
    np.testing.assert_allclose(R.spot_cone(c, co, ci), [1, 1, 0.75 ** 2, 0.25, 0, 0], atol=1e-12)


def test_bench_error_column_is_the_oracle_with_shadows(tmp_path):
    """`clshade bench` on a shadowed scene: its error column compares with the frame oracle
    (shadow visibility included), and the general reference in float32 ran in the timed rounds (the NumPy
    baseline does not implement shadows: its column says why)."""
    import json

    from clshade.cli import main
    out = tmp_path / "bench.json"
    assert main(["bench", str(SCENES / "shadows.toml"), "-m", "lambert", "--frames", "3", "--warmup", "0",
                 "--width", "64", "--height", "40", "--numpy-frames", "2", "--no-progress", "--json", str(out)]) == 0
    row = json.loads(out.read_text(encoding="utf-8"))["models"][0]
    assert row["max_rel_error"] < ORACLE_BOUND and row["reference_ratio"] > 0
    assert row["numpy_ratio"] is None and "NumPy baseline" in row["numpy_note"]


@pytest.mark.parametrize("unit", [False, True])
@pytest.mark.parametrize("model", ["lambert", "ggx_correlated"])
def test_unusable_normals_shade_facing_the_viewer(tmp_path, device_runtime, model, unit):
    """Zero and NaN G-buffer normals (a zero one is bad input the G-buffer keeps; NaN only a
    hand-made G-buffer has) shade as if the normal were the view direction, as the oracle
    defines them: the kernels' fallback branch (shade.cl) against
    clshade.verify.reference.pixels. Every fourth covered pixel. With `unit` the G-buffer keeps
    build_gbuffer's promise of unit-or-zero normals for the rest (UNIT_NORMALS: the kernel only
    tests for zero), without it the kernel normalises every normal."""
    from clshade.device.shade import Shader, scene_features
    from clshade.pipeline import prepare_frame
    from clshade.render.gbuffer import GBuffer
    frame = prepare_frame(load_scene(scene_file(tmp_path, "directional")), ORACLE_WIDTH, ORACLE_HEIGHT)
    gb = frame.gbuffer
    normal = np.array(gb.channels["normal"], np.float32).reshape(-1, 3)
    bad = np.flatnonzero(gb.channels["depth"] > 0)[::4]
    normal[bad[::2]] = 0.0
    normal[bad[1::2]] = np.nan
    gb = GBuffer(gb.width, gb.height, {**gb.channels, "normal": normal.reshape(-1)}, gb.materials, gb.coverage,
                 unit_normals=unit)
    m = resolve(model)
    shader = Shader(device_runtime, gb, frame.scene, frame.camera)
    features = scene_features(frame.scene, geometry=frame.geometry)
    assert ("UNIT_NORMALS" in shader.variant(m, features).defines()) == unit
    image = shader.render(m, features)
    want = R.radiance(gb, frame.scene, m, camera=frame.camera).reshape(-1, 3)[bad]
    got = image[..., :3].reshape(-1, 3)[bad].astype(np.float64)
    assert np.isfinite(got).all()
    px = R.pixels(gb, frame.camera)
    l = next(R.light_rays(frame.scene, px))[1][np.isin(px.index, bad)]
    lit = np.abs(np.sum(px.v[np.isin(px.index, bad)] * l, axis=1)) >= ORACLE_MIN_COS
    assert lit.sum() > 10
    err = np.abs(got - want) / np.maximum(np.abs(want), ORACLE_DARK * float(np.abs(want).max()))
    assert float(err[lit].max()) <= ORACLE_BOUND
