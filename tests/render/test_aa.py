"""Anti-aliasing: supersampling (clshade/render/samples.py) and its device resolve, MSAA, specular AA, their
scene keys and commands, and the truth of `clshade aa`'s ladder (clshade/bench/aa.py)."""
from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest

from clshade.bench.aa import errors, sphere_cells, spheres as project_spheres, temporal, truth_frame
from clshade.bench.run import compared_pixels
from clshade.cli import main
from clshade.device.shade import Shader, camera_args, scene_features
from clshade.errors import ClshadeError
from clshade.models.registry import Registry
from clshade.pipeline import prepare_frame, render, render_streamed
from clshade.render.gbuffer import build_gbuffer
from clshade.render.image import read_image
from clshade.render.meshes import build_geometry
from clshade.render.raster import rasterize
from clshade.device.resolve import CoverageBlend
from clshade.render.samples import coverage_gbuffer, jittered, sample_offsets
from clshade.render.scene import load_scene, parse_scene
from clshade.render.transforms import perspective
from clshade.verify import reference

from conftest import ORACLE_BOUND, SCENES
from scene_toml import camera, plane_facing_camera, scene, table

resolve = Registry().resolve          # the built-in lobes

GGX = resolve("ggx_correlated")
W, H = 96, 44
# Two renderings of the same samples: equal to float32 rounding of a few operations.
SAME_PIXEL = 1e-5


def assert_every_pixel(err: np.ndarray, bound: float, what: str, index: np.ndarray | None = None) -> None:
    """Every pixel's error is within `bound`; the message names the worst pixel (row, column)."""
    flat = np.asarray(err, np.float64).reshape(-1)
    worst = int(np.argmax(flat))
    pixel = int(index[worst]) if index is not None else worst
    width = W if index is not None or np.ndim(err) < 2 else np.shape(err)[1]
    assert flat[worst] <= bound, (f"{what}: worst pixel (row {pixel // width}, column {pixel % width}) "
                                  f"error {flat[worst]:.3g} > {bound:g}; {int((flat > bound).sum())} pixels over")


@pytest.fixture(scope="module")
def spheres():
    scene = load_scene(SCENES / "aa_spheres.toml")
    scene = dataclasses.replace(scene, camera=scene.camera.with_size(W, H))
    return scene, build_geometry(scene)


def _render(scene, geometry, runtime, model=GGX, **kw):
    frame = prepare_frame(dataclasses.replace(scene, **kw), geometry=geometry)
    return render(None, model, runtime=runtime, frame=frame)


# ---------------------------------------------------------------- N = 1 is today's image


def test_one_sample_equals_the_plain_pipeline_bit_for_bit(runtime):
    """samples = 1 (the default, or asked for) renders exactly what the rasterizer →
    G-buffer → Shader path renders without any of the supersampling code: no resolve
    kernel, an unshifted camera, the same bits."""
    scene = load_scene(SCENES / "sphere_grid.toml")
    cam = scene.camera.with_size(160, 72)
    geometry = build_geometry(scene)
    fr = rasterize(geometry.vertices, geometry.faces, cam.view_matrix(), cam.projection_matrix(), cam.width,
                   cam.height, cull_backfaces=geometry.cull)
    gb = build_gbuffer(scene, geometry, fr, cam)
    plain = Shader(runtime, gb, scene, cam).render(GGX, scene_features(scene))
    for sc in (scene, dataclasses.replace(scene, samples=1)):
        result = render(sc, GGX, width=160, height=72, runtime=runtime)
        assert result.shader.resolver is None
        assert result.image.tobytes() == plain.tobytes()
    assert np.array_equal(cam.projection_matrix(), perspective(cam.fov, cam.aspect, cam.near, cam.far))


def test_zero_shift_leaves_camera_rays_unchanged():
    cam = load_scene(SCENES / "sphere_grid.toml").camera
    for a, b in zip(camera_args(cam), camera_args(jittered(cam, 0.0, 0.0))):
        assert a.tobytes() == b.tobytes()


# ---------------------------------------------------------------- sample positions and resolve


def test_sample_offsets_are_the_ordered_grid():
    off = sample_offsets(4)
    assert off.shape == (16, 2)
    assert np.allclose(sorted(set(off[:, 0])), [-0.375, -0.125, 0.125, 0.375])
    assert np.allclose(off.mean(axis=0), 0.0)
    assert np.allclose(sample_offsets(1), 0.0)


def test_device_resolve_is_the_box_mean_of_the_samples(spheres, device_runtime):
    scene, geometry = spheres
    result = _render(scene, geometry, device_runtime, samples=3)
    samples = result.shader.read_samples()
    assert samples.shape == (3 * H, 3 * W, 4)
    box = samples.reshape(H, 3, W, 3, 4).mean(axis=(1, 3))
    assert result.image.shape == (H, W, 4)
    np.testing.assert_allclose(result.image, box, rtol=1e-6, atol=1e-7)
    # Alpha is the covered fraction: some silhouette pixels are partly covered.
    alpha = result.image[..., 3]
    assert ((alpha > 0) & (alpha < 1)).any()


@pytest.mark.parametrize("n", [2, 3])
def test_device_resolve_keeps_saturated_samples_finite(runtime, n):
    """Samples at the shading's ±MAX_RADIANCE clamp (a user lobe at its hard inputs) resolve to the finite
    mean, not to a sum overflowed to ±Inf; an ordinary block beside them to its mean."""
    from clshade.device.resolve import Resolver
    from clshade.verify.stability import MAX_RADIANCE

    top = np.float32(MAX_RADIANCE)
    samples = np.zeros((n, 3 * n, 4), np.float32)
    samples[:, :n] = (top, -top, top, 1.0)
    samples[:, n:2 * n] = np.arange(n * n * 4, dtype=np.float32).reshape(n, n, 4)
    samples[:, 2 * n:, 0] = -top
    samples[0, 2 * n, 0] = top
    source = runtime.to_device(samples.ravel())          # held: the kernel's arguments do not keep it
    resolver = Resolver(runtime, 3, 1, n, source)
    resolver.enqueue(runtime.cl.enqueue_marker(runtime.queue)).wait()
    image = resolver.read()[0]
    assert np.isfinite(image).all()
    np.testing.assert_allclose(image[0], (top, -top, top, 1.0), rtol=1e-6)
    np.testing.assert_allclose(image[1], samples[:, n:2 * n].reshape(-1, 4).mean(axis=0), rtol=1e-6)
    assert -top < image[2, 0] < 0


@pytest.mark.parametrize("shift", [(0.0, 0.0), (0.3, -0.45)])
def test_supersampling_equals_the_mean_of_jittered_frames(spheres, runtime, shift):
    """The N·W × N·H raster samples the same points as N² frames with the camera
    shifted by sample_offsets(N): the sample positions are what samples.py says; a
    camera shift (the temporal study's pan) moves every sample by the same fraction
    of an output pixel."""
    scene, geometry = spheres
    moved = dataclasses.replace(scene, camera=jittered(scene.camera, *shift))
    ss = _render(moved, geometry, runtime, samples=2).image
    mean = np.zeros_like(ss)
    for dx, dy in sample_offsets(2):
        cam = jittered(scene.camera, shift[0] + dx, shift[1] + dy)
        mean += _render(dataclasses.replace(scene, camera=cam), geometry, runtime).image
    mean /= 4
    assert_every_pixel(np.abs(ss - mean).max(axis=-1), SAME_PIXEL, "supersampled vs mean of jittered frames")


def test_supersampling_in_bands_equals_the_whole_frame(spheres, runtime):
    """The CLI renders in bands of rows (pipeline.render_streamed): a supersampled band is
    the band of the supersampled frame (Camera.band with the N·W × N·H raster)."""
    scene, geometry = spheres
    ss = dataclasses.replace(scene, samples=2)
    whole = _render(ss, geometry, runtime).image
    out = np.zeros_like(whole)

    def keep(r0, band):
        out[r0:r0 + len(band)] = band

    result = render_streamed(ss, GGX, keep, runtime=runtime, band_pixels=4 * W * 10)
    assert result.bands == 5
    assert_every_pixel(np.abs(out - whole).max(axis=-1), SAME_PIXEL, "banded vs whole supersampled frame")


def test_samples_convergence_against_the_float64_pixel_integral(spheres, device_runtime):
    """Error against the supersampled float64 truth falls with N, on the whole frame,
    on silhouettes and on highlights."""
    scene, geometry = spheres
    truth = truth_frame(scene, geometry, GGX, 8)
    errs = [errors(_render(scene, geometry, device_runtime, samples=n).image, truth) for n in (1, 2, 4)]
    for key in ("frame_rel_error", "silhouette_rel_error", "highlight_rel_error"):
        e = [x[key] for x in errs]
        assert e[0] > e[1] > e[2], (key, e)
    assert errs[2]["frame_rel_error"] < 0.5 * errs[0]["frame_rel_error"]
    assert errs[2]["silhouette_rel_error"] < 0.3 * errs[0]["silhouette_rel_error"]


def test_truth_at_one_sample_is_the_oracle_frame(spheres, runtime):
    scene, geometry = spheres
    truth = truth_frame(scene, geometry, GGX, 1)
    frame = prepare_frame(scene, geometry=geometry)
    assert np.array_equal(truth.radiance, reference.radiance(frame.gbuffer, frame.scene, GGX))
    assert np.array_equal(truth.coverage, frame.gbuffer.coverage.astype(float))


def test_sphere_cells_move_with_the_content(spheres):
    """A camera shifted by +2 px moves the content, and each sphere's cell, 2 px left/up."""
    scene, _ = spheres
    balls = project_spheres(scene)
    assert len(balls) == 10
    still = sphere_cells(balls, (H, W), (0.0, 0.0))
    moved = sphere_cells(balls, (H, W), (2.0, 2.0))
    assert np.array_equal(moved[:-2, :-2], still[2:, 2:])
    assert (still >= 0).sum() > 0.5 * H * W


def test_temporal_measure_is_zero_without_motion_and_falls_with_samples(spheres, runtime):
    """A still camera changes no energy (the measure's zero); under the sub-pixel pan the
    highlights flicker less with 4×4 samples or specular AA than with one (mean over spheres)."""
    scene, geometry = spheres
    still = temporal(scene, geometry, [GGX], runtime, frames=3, step=(0.0, 0.0))
    assert all(r["max_energy_change"] == 0.0 for r in still)
    rows = {r["label"]: r for r in temporal(scene, geometry, [GGX], runtime, frames=6)}
    one = rows["1 sample"]["mean_energy_change"]
    assert one > 0.1
    assert rows["4×4"]["mean_energy_change"] < 0.5 * one
    assert rows["specular AA"]["mean_energy_change"] < 0.2 * one


# ---------------------------------------------------------------- MSAA-style rung


def _msaa(scene, geometry, runtime, n, model=GGX):
    frame = prepare_frame(dataclasses.replace(scene, samples=n), geometry=geometry)
    gb, fraction = coverage_gbuffer(frame.gbuffer, n)
    one = dataclasses.replace(frame.scene, samples=1)
    shader = Shader(runtime, gb, one, scene.camera)
    blend = CoverageBlend(runtime, fraction, shader.background, shader.out)
    blend.enqueue(shader.enqueue(shader.prepare(model, scene_features(one)))).wait()
    return shader.read(), gb, fraction


def test_msaa_shades_the_centre_sample_and_blends_by_coverage(spheres, device_runtime):
    """Odd N: the pixel's shading sample is its centre, so fully covered pixels equal the
    1-sample image; partly covered ones are L·c + background·(1 − c), c the covered fraction."""
    scene, geometry = spheres
    image, gb, fraction = _msaa(scene, geometry, device_runtime, 3)
    ss = prepare_frame(dataclasses.replace(scene, samples=3), geometry=geometry).gbuffer
    cov = (ss.channels["depth"].reshape(H, 3, W, 3) > 0).mean(axis=(1, 3))
    np.testing.assert_array_equal(fraction, cov)
    one = _render(scene, geometry, device_runtime).image
    full = fraction == 1.0
    assert_every_pixel(np.where(full, np.abs(image - one).max(-1), 0.0), SAME_PIXEL, "MSAA vs 1 sample, full pixels")
    np.testing.assert_allclose(image[..., 3], fraction, atol=1e-7)
    part = (fraction > 0) & (fraction < 1)
    shaded = Shader(device_runtime, gb, dataclasses.replace(scene, samples=1), scene.camera).render(GGX, scene_features(scene))
    bg = np.asarray(scene.background, np.float32)
    expect = shaded[part, :3] * fraction[part, None] + bg * (1 - fraction[part, None])
    np.testing.assert_allclose(image[part, :3], expect, rtol=1e-5, atol=1e-6)


def test_msaa_silhouettes_beat_one_sample(spheres, device_runtime):
    scene, geometry = spheres
    truth = truth_frame(scene, geometry, GGX, 6)
    msaa = errors(_msaa(scene, geometry, device_runtime, 4)[0], truth)
    one = errors(_render(scene, geometry, device_runtime).image, truth)
    assert msaa["silhouette_rel_error"] < 0.5 * one["silhouette_rel_error"]


# ---------------------------------------------------------------- specular AA


def _widened_roughness(gb, variance=0.15, threshold=0.2):
    """NumPy model of kernels/specular_aa.h: neighbour differences → α'² → perceptual r'."""
    h, w = gb.height, gb.width
    n = gb.channels["normal"].reshape(h, w, 3).astype(np.float64)
    cov = gb.channels["depth"].reshape(h, w) > 0

    def diff(axis: int) -> np.ndarray:
        size = n.shape[axis]
        idx = np.arange(size)
        shape = [1, 1]
        shape[axis] = size
        idx = idx.reshape(shape)
        nxt = np.minimum(idx + 1, size - 1)
        prv = np.maximum(idx - 1, 0)
        take = lambda a, i: np.take_along_axis(a, np.broadcast_to(i, a.shape[:2]), axis)  # noqa: E731
        c_next = take(cov, nxt) & (idx + 1 < size)
        c_prev = take(cov, prv) & (idx > 0)
        pick = np.where(c_next, np.broadcast_to(nxt, cov.shape), np.where(c_prev, np.broadcast_to(prv, cov.shape),
                                                                         np.broadcast_to(idx, cov.shape)))
        q = np.stack([take(n[..., c], pick) for c in range(3)], axis=-1)
        d = q - n
        return (d * d).sum(-1)

    kernel = np.minimum(2 * variance * (diff(1) + diff(0)), threshold)
    alpha = np.maximum(gb.channels["roughness"].reshape(h, w).astype(np.float64) ** 2, 1e-4)
    a2 = np.clip(alpha ** 2 + kernel, 0, 1)
    return np.sqrt(np.sqrt(a2))


def test_specular_aa_matches_its_formula(spheres, device_runtime):
    """The kernel's widened GGX equals the float64 reference evaluated with the roughness
    of Tokuyoshi–Kaplanyan / Filament (σ² = 0.15, κ = 0.2) from the G-buffer normals."""
    scene, geometry = spheres
    result = _render(scene, geometry, device_runtime, specular_aa=True)
    gb = result.frame.gbuffer
    widened = dataclasses.replace(gb, channels={**gb.channels,
                                                "roughness": _widened_roughness(gb).astype(np.float32).ravel()})
    idx = compared_pixels(widened, result.frame.camera)
    L = reference.radiance(widened, result.frame.scene, GGX, camera=result.frame.camera).reshape(-1, 3)[idx]
    got = result.image.reshape(-1, 4)[idx, :3]
    rel = np.abs(got - L) / np.maximum(np.abs(L), 1e-3 * np.abs(L).max())
    assert_every_pixel(rel.max(axis=1), ORACLE_BOUND, "specular AA vs the float64 reference", idx)
    plain = _render(scene, geometry, device_runtime)
    assert not np.array_equal(plain.image, result.image)


def test_specular_aa_widens_the_sharpest_highlights(spheres, runtime):
    """On the smooth spheres the specular lobe (alone, no ambient) lights more pixels
    with specular AA than without: the lobe widened, for GGX α and a Blinn–Phong exponent."""
    scene, geometry = spheres
    dark = dataclasses.replace(scene, ambient=(0.0, 0.0, 0.0))
    lower = slice(H // 2, H)            # the bottom row: the five smoothest spheres
    for model in (GGX, resolve("blinn_phong_normalized")):
        spec = dataclasses.replace(model, diffuse="none")
        plain, aa = (_render(dark, geometry, runtime, spec, specular_aa=on).image[lower] for on in (False, True))
        plain, aa = (np.where(x[..., 3] > 0, x[..., 1], 0.0) for x in (plain, aa))
        level = 0.01 * max(plain.max(), aa.max())
        assert (aa > level).sum() > 1.5 * (plain > level).sum(), model.id


def test_specular_aa_is_a_no_op_on_a_plane(runtime, tmp_path):
    """Constant normal (up to 1e-23 interpolation rounding): no widening, the same image bit for bit."""
    scene = parse_scene(plane_facing_camera(), tmp_path / "plane.toml")
    plain = render(scene, GGX, runtime=runtime)
    aa = render(dataclasses.replace(scene, specular_aa=True), GGX, runtime=runtime)
    normals = plain.frame.gbuffer.channels["normal"].reshape(-1, 3)
    assert plain.frame.gbuffer.coverage.all() and np.ptp(normals, axis=0).max() < 1e-12
    assert np.array_equal(aa.image, plain.image)


@pytest.mark.parametrize("model", ["ggx_correlated", "blinn_phong"])
def test_specular_aa_general_kernel_equals_specialised(spheres, runtime, model):
    """The general kernel compiles the same widening in (a compile-time feature of both)."""
    scene, geometry = spheres
    frame = prepare_frame(dataclasses.replace(scene, specular_aa=True), geometry=geometry)
    shader = Shader(runtime, frame.gbuffer, frame.scene, frame.camera)
    features = scene_features(frame.scene)
    m = resolve(model)
    special, general = shader.render(m, features), shader.render(m, dataclasses.replace(features, general=True))
    np.testing.assert_allclose(special, general, rtol=1e-5, atol=1e-6 * float(np.abs(general).max()))
    plain = Shader(runtime, frame.gbuffer, scene, frame.camera).render(m, scene_features(scene, general=True))
    assert not np.allclose(plain, general)


def test_specular_aa_is_absent_from_kernels_of_scenes_that_do_not_ask(spheres, runtime):
    """Without [render] specular_aa the define is not set and specular_aa.h (the code) is
    not assembled: shade.cl's one call sits under #ifdef SPECULAR_AA and drops out."""
    scene, geometry = spheres
    shader = Shader(runtime, prepare_frame(scene, geometry=geometry).gbuffer, scene)
    header, define = '#line 1 "specular_aa.h"', "#define SPECULAR_AA "
    for model in (GGX, resolve("blinn_phong"), resolve("lambert")):
        off = shader.variant(model, scene_features(scene))
        src = off.source("shade.cl", runtime.simd)
        assert "SPECULAR_AA" not in off.defines()
        assert header not in src and define not in src and "INLINE Surface specular_aa" not in src
        on = shader.variant(model, scene_features(dataclasses.replace(scene, specular_aa=True)))
        src_on = on.source("shade.cl", runtime.simd)
        if model.specular == "none":
            assert header not in src_on                      # no specular lobe: nothing to widen
        else:
            assert on.defines()["SPECULAR_AA"] == "1" and header in src_on and define in src_on
    general = shader.variant(GGX, scene_features(scene, general=True))
    assert header not in general.source("shade.cl", runtime.simd)


# ---------------------------------------------------------------- scene key and CLI


def _render_keys(lines: str) -> str:
    """A 32×24 camera and a [render] table of these `key = value` lines."""
    return scene(camera(position=[0.0, 0.0, 3.0], width=32, height=24), table("render", **tomllib.loads(lines)))


@pytest.mark.parametrize("line, key, value", [("samples = 0", "render.samples", "0"),
                                              ("samples = 9", "render.samples", "9"),
                                              ('samples = "2"', "render.samples", "'2'"),
                                              ("samples = 2.0", "render.samples", "2.0"),
                                              ("specular_aa = 1", "render.specular_aa", "1")])
def test_scene_keys_are_validated(tmp_path, line, key, value):
    path = tmp_path / "s.toml"
    with pytest.raises(ClshadeError) as exc:
        parse_scene(_render_keys(line), path)
    msg = str(exc.value)
    assert str(path) in msg and key in msg and value in msg


def test_scene_keys_are_read():
    s = parse_scene(_render_keys("samples = 3\nspecular_aa = true"), Path("s.toml"))
    assert s.samples == 3 and s.specular_aa


def test_render_command_samples(tmp_path, capsys):
    out = tmp_path / "x.exr"
    assert main(["render", str(SCENES / "aa_spheres.toml"), "--width", "48", "--height", "22",
                 "--samples", "2", "--specular-aa", "-o", str(out)]) == 0
    assert read_image(out).shape[:2] == (22, 48)
    assert main(["render", str(SCENES / "aa_spheres.toml"), "--samples", "99", "-o", str(out)]) == 2
    assert "samples" in capsys.readouterr().err


@pytest.mark.extra
def test_aa_command_writes_its_results(tmp_path, capsys):
    prefix = tmp_path / "aa"
    assert main(["aa", "-m", "ggx_correlated", "--width", "48", "--height", "22", "--frames", "1",
                 "--truth-samples", "2", "--check-samples", "3", "--temporal-frames", "2", "-o", str(prefix)]) == 0
    for suffix in (".json", ".md", "_ladder.png", "_crops.png"):
        assert (tmp_path / f"aa{suffix}").stat().st_size > 0
    text = capsys.readouterr().out
    assert "specular AA + 2×2" in text and "Temporal stability" in text and "converged" in text
