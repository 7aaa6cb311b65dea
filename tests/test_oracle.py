"""The kernels against the float64 frame oracle, one light kind at a time.

Each test renders a small scene with the OpenCL shading pass and compares it with
clshade.verify.reference.radiance on the same G-buffer, at ≤ 1e-4 relative on the
covered pixels where every light's n·l and n·v are ≥ 1e-3 in magnitude (at grazing
light or view the kernels' documented floors act; the error there is
clshade.verify.bias's subject). Changing the point falloff, the spot cone or the
ambient term on either side fails these tests (see the report of issue 12).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from clshade.models.registry import Registry
from clshade.pipeline import render
from clshade.render.scene import load_scene
from clshade.resources import scenes_dir
from clshade.verify import reference as R
from scene_toml import floor_ball_torus

resolve = Registry().resolve          # the built-in lobes

SCENES = scenes_dir()      # the scenes the imported clshade ships (textures included)
TOLERANCE = 1e-4        # relative, the bound
DARK = 1e-3             # relative error below DARK · peak radiance counts as absolute
MIN_COS = 1e-3          # n·l and n·v at least this far from 0
WIDTH, HEIGHT = 96, 72

# Both workflows: metallic-roughness with Schlick Fresnel, and the k_d + k_s = 1 rule.
MODELS = ("ggx_correlated", "phong")


def compare(scene_path, model_spec: str, runtime=None) -> dict[str, float]:
    """Render with the kernel (on `runtime`, default the default device), evaluate the oracle;
    errors on the comparable pixels."""
    model = resolve(model_spec)
    r = render(scene_path, model, width=WIDTH, height=HEIGHT, runtime=runtime)
    frame = r.frame
    vis = R.visibility(frame.gbuffer, frame.scene, frame.shadows, frame.camera)
    want = R.radiance(frame.gbuffer, frame.scene, model, visibility=vis, camera=frame.camera)
    px = R.pixels(frame.gbuffer, frame.camera)
    keep = np.sum(px.n * px.v, axis=1) >= MIN_COS
    for _, l, _ in R.light_rays(frame.scene, px):
        keep &= np.abs(np.sum(px.n * l, axis=1)) >= MIN_COS
    if vis is not None:   # pixels whose PCF taps sit on a texel edge may round either way
        for dx, dy in ((1e-3, 1e-3), (-1e-3, -1e-3)):
            other = R.visibility(frame.gbuffer, frame.scene, frame.shadows, frame.camera, offset=(dx, dy))
            keep &= (other == vis).reshape(len(vis), -1)[:, px.index].all(axis=0)
    idx = px.index[keep]
    got = r.image[..., :3].reshape(-1, 3)[idx].astype(np.float64)
    ref = want.reshape(-1, 3)[idx]
    peak = float(np.abs(ref).max())
    err = np.abs(got - ref) / np.maximum(np.abs(ref), DARK * peak)
    empty = ~frame.gbuffer.coverage.reshape(-1)
    bg = np.abs(r.image[..., :3].reshape(-1, 3)[empty] - want.reshape(-1, 3)[empty])
    return dict(pixels=len(idx), covered=len(px.index), max=float(err.max()), background=float(bg.max(initial=0)),
                shadowed=int((vis < 1).reshape(len(vis), -1)[:, idx].any(axis=0).sum()) if vis is not None else 0)


def scene_file(tmp_path, kind: str) -> Path:
    path = tmp_path / f"{kind}.toml"
    path.write_text(floor_ball_torus(kind), encoding="utf-8")
    return path


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("kind", ["directional", "point", "spot", "ambient", "shadowed"])
def test_light_kind_matches_oracle(tmp_path, kind, model, device_runtime):
    res = compare(scene_file(tmp_path, kind), model, device_runtime)
    assert res["pixels"] > 0.5 * res["covered"], res
    assert res["max"] <= TOLERANCE, res
    assert res["background"] <= 1e-6, res
    if kind == "shadowed":
        assert res["shadowed"] > 0.05 * res["pixels"], res   # shadows are really in the comparison


@pytest.mark.parametrize("model", ["ggx_correlated", "lambert+walter_ggx@conductor", "oren_nayar+cook_torrance@dielectric",
                                   "burley+ggx_correlated/kdks", "blinn_phong_normalized"])
def test_textured_matches_oracle(model, device_runtime):
    """Base colour, metallic-roughness and normal maps sampled into the G-buffer; every Fresnel."""
    res = compare(SCENES / "textured.toml", model, device_runtime)
    assert res["pixels"] > 0.5 * res["covered"], res
    assert res["max"] <= TOLERANCE, res


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
    assert row["max_rel_error"] < TOLERANCE and row["reference_ratio"] > 0
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
    frame = prepare_frame(load_scene(scene_file(tmp_path, "directional")), WIDTH, HEIGHT)
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
    lit = np.abs(np.sum(px.v[np.isin(px.index, bad)] * l, axis=1)) >= MIN_COS
    assert lit.sum() > 10
    err = np.abs(got - want) / np.maximum(np.abs(want), DARK * float(np.abs(want).max()))
    assert float(err[lit].max()) <= TOLERANCE
