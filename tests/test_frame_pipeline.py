"""The frame pipeline's G-buffer path (clshade.pipeline.GBufferStage): the device's visibility buffer and
G-buffer where supported and verified, else the NumPy rasterizer, which stays the reference. Both paths give
the same images bit for bit on every healthy device; the path taken is reported with its reason; a device
refused by its check (or a scene the device path cannot serve) falls back to the host."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from clshade import pipeline
from clshade.bench import frame as whole
from clshade.device import visibility as device_visibility
from clshade.errors import ClshadeError
from clshade.models.registry import Registry
from clshade.pipeline import GBufferStage, Timings, prepare_frame, render, render_streamed, use_gbuffer
from clshade.render.meshes import build_geometry
from clshade.render.scene import load_scene

from conftest import SCENES, run_cli

BUILT_IN = Registry()
#: Scenes the device path serves (no textures): one mesh, many spheres, shadows and spot lights, a ground plane.
UNTEXTURED = ["robot", "sphere_grid", "shadows", "many_lights", "ground_plane"]
#: The orbit: azimuths of the scene camera about its target (degrees), near and across the silhouettes.
ORBIT = (0.0, 33.0, 145.0, 260.0)


def _bits(a: np.ndarray) -> np.ndarray:
    return a.view(f"u{a.itemsize}")         # NaN and -0 compared as bit patterns


def _assert_same_gbuffer(a, b) -> None:
    assert sorted(a.channels) == sorted(b.channels)
    for name in a.channels:
        np.testing.assert_array_equal(_bits(a.plane(name)), _bits(b.plane(name)), err_msg=name)
    np.testing.assert_array_equal(a.coverage, b.coverage)
    assert a.nonfinite_pixels == b.nonfinite_pixels and a.unit_normals == b.unit_normals


def _device_or_skip(runtime, geometry) -> None:
    if not device_visibility.supports(runtime, geometry):
        pytest.skip(f"{runtime.info.description}: no doubles or 64-bit atomics (the device path does not apply)")


@pytest.mark.parametrize("name", UNTEXTURED)
def test_both_paths_render_the_same_orbit_bit_for_bit(device_runtime, name):
    """For each camera of an orbit, the device path's G-buffer and image equal the NumPy rasterizer's bit
    for bit, and the device path is the one taken (verified on this device)."""
    scene = load_scene(SCENES / f"{name}.toml")
    geometry = build_geometry(scene)
    _device_or_skip(device_runtime, geometry)
    model = BUILT_IN.resolve("ggx_correlated")
    for azimuth in ORBIT:
        camera = whole.orbit(scene.camera.with_size(97, 61), azimuth)     # odd sizes: padded planes
        moved = dataclasses.replace(scene, camera=camera)
        frames = {mode: prepare_frame(moved, geometry=geometry, runtime=device_runtime, gbuffer=mode)
                  for mode in ("auto", "host")}
        # sphere_grid: several face batches, resolved in one device pass
        assert frames["auto"].gbuffer_path.path == "device", frames["auto"].gbuffer_path
        assert frames["auto"].gbuffer_path.reason.startswith("verified bit for bit on ")
        assert frames["host"].gbuffer_path == pipeline.GBufferPath("host", "--gbuffer host")
        _assert_same_gbuffer(frames["auto"].gbuffer, frames["host"].gbuffer)
        images = [render(moved, model, runtime=device_runtime, frame=f).image for f in frames.values()]
        np.testing.assert_array_equal(_bits(images[0]), _bits(images[1]))


def test_streamed_bands_are_the_same_both_ways(runtime):
    """render_streamed in several bands of rows (band cameras, supersampled): the same pixels by either path."""
    scene = dataclasses.replace(load_scene(SCENES / "robot.toml"), samples=2)
    _device_or_skip(runtime, build_geometry(scene))
    model = BUILT_IN.resolve("ggx_correlated")
    out = {}
    for mode in ("device", "host"):
        image = np.zeros((45, 80, 4), np.float32)

        def keep(r0, band, image=image):
            image[r0:r0 + len(band)] = band
        result = render_streamed(scene, model, keep, width=80, height=45, runtime=runtime, band_pixels=80 * 10 * 4,
                                 gbuffer=mode)
        assert result.bands > 1 and result.gbuffer_path.path == mode
        out[mode] = image
    np.testing.assert_array_equal(_bits(out["device"]), _bits(out["host"]))


def test_textures_the_device_cannot_sample_take_the_host_path_and_say_why(runtime):
    """A one-channel texture (kernel `texture` samples RGB pyramids): the frame takes the host path, the
    reason names the textures, and --gbuffer device is refused saying so."""
    import dataclasses
    from clshade.render.textures import Texture
    scene = load_scene(SCENES / "textured.toml")
    geometry = build_geometry(scene)
    _device_or_skip(runtime, geometry)
    grey = Texture.from_pixels(np.full((4, 4), 0.5, np.float32), "grey")
    grey_geometry = dataclasses.replace(geometry, texture_sets=tuple(
        dataclasses.replace(t, base_color=grey) for t in geometry.texture_sets))
    frame = prepare_frame(scene, 64, 48, runtime=runtime, geometry=grey_geometry)
    assert frame.gbuffer_path.path == "host"
    assert "textures that are not RGB" in frame.gbuffer_path.reason, frame.gbuffer_path.reason
    with pytest.raises(ClshadeError, match=r"--gbuffer device: textures that are not RGB"):
        prepare_frame(scene, 64, 48, runtime=runtime, geometry=grey_geometry, gbuffer="device")


def test_a_device_that_fails_its_check_falls_back_to_the_host(runtime, monkeypatch):
    """A device whose small frame differs from the host's is not used: the frame is the host's, the reason
    says what differed, and --gbuffer device is refused."""
    scene = load_scene(SCENES / "robot.toml")
    geometry = build_geometry(scene)
    _device_or_skip(runtime, geometry)
    monkeypatch.setattr(pipeline, "_VERIFIED", {})
    monkeypatch.setattr(device_visibility, "verify", lambda *args: "7 of 5184 pixels differ from the host's in depth")
    frame = prepare_frame(scene, 96, 54, runtime=runtime, geometry=geometry)
    assert frame.gbuffer_path.path == "host"
    assert "differed from the host's on" in frame.gbuffer_path.reason and "7 of 5184" in frame.gbuffer_path.reason
    assert "g-buffer" in frame.timings and pipeline.DEVICE_GBUFFER_STAGE not in frame.timings
    _assert_same_gbuffer(frame.gbuffer, prepare_frame(scene, 96, 54, runtime=runtime, gbuffer="host").gbuffer)
    monkeypatch.setattr(pipeline, "_VERIFIED", {})
    with pytest.raises(ClshadeError, match="--gbuffer device: the device's G-buffer differed"):
        prepare_frame(scene, 96, 54, runtime=runtime, geometry=build_geometry(scene), gbuffer="device")


def test_each_device_and_geometry_is_verified_once(runtime, monkeypatch):
    """The check runs once per device and geometry in the process, whichever stage asks, and again for
    other face tables (another material)."""
    scene = load_scene(SCENES / "robot.toml")
    _device_or_skip(runtime, build_geometry(scene))
    calls = []
    real = device_visibility.verify
    monkeypatch.setattr(pipeline, "_VERIFIED", {})
    monkeypatch.setattr(device_visibility, "verify", lambda *a: calls.append(1) or real(*a))
    for azimuth in (0.0, 20.0, 40.0):
        moved = dataclasses.replace(scene, camera=whole.orbit(scene.camera.with_size(64, 36), azimuth))
        assert prepare_frame(moved, runtime=runtime).gbuffer_path.path == "device"
    assert len(calls) == 1
    mats = {k: dataclasses.replace(m, roughness=min(1.0, m.roughness + 0.1)) for k, m in scene.materials.items()}
    prepare_frame(dataclasses.replace(scene, materials=mats), 64, 36, runtime=runtime)
    assert len(calls) == 2


def test_only_verdicts_are_kept(runtime, monkeypatch):
    """A device G-buffer that could not be made (a buffer refused, the runtime out of resources) is no
    verdict: its stage stays on the host, saying why, and the next stage of the geometry is verified and
    takes the device path. A verdict that the device differed is kept: later stages build no device
    G-buffer for it."""
    scene = load_scene(SCENES / "robot.toml")
    geometry = build_geometry(scene)
    _device_or_skip(runtime, geometry)
    camera = scene.camera.with_size(64, 36)
    real, built = device_visibility.DeviceGBuffer, []

    def refused(*args, **kwargs):
        raise ClshadeError("the staging buffer for 'setup' needs more memory than is available")
    monkeypatch.setattr(pipeline, "_VERIFIED", {})
    monkeypatch.setattr(device_visibility, "DeviceGBuffer", refused)
    stage = GBufferStage(geometry, runtime)
    stage.frame(scene, camera, Timings())
    assert stage.path.path == "host" and "could not be made" in stage.path.reason
    assert "staging buffer for 'setup'" in stage.path.reason and pipeline._VERIFIED == {}
    monkeypatch.setattr(device_visibility, "DeviceGBuffer", lambda *a, **k: built.append(1) or real(*a, **k))
    stage.frame(scene, camera, Timings())
    assert stage.path.path == "host" and not built        # a stream keeps its path
    again = GBufferStage(geometry, runtime)
    again.frame(scene, camera, Timings())
    assert again.path.path == "device" and len(built) == 1

    monkeypatch.setattr(pipeline, "_VERIFIED", {})
    monkeypatch.setattr(device_visibility, "verify", lambda *args: "7 of 5184 pixels differ from the host's in depth")
    for _ in range(3):
        stage = GBufferStage(geometry, runtime)
        stage.frame(scene, camera, Timings())
        assert stage.path.path == "host" and "7 of 5184" in stage.path.reason
    assert len(built) == 2


def test_a_stage_hashes_its_mesh_once(runtime, monkeypatch):
    """Frames given no face tables make new ones each frame: their digest is taken again, the mesh's not."""
    scene = load_scene(SCENES / "robot.toml")
    geometry = build_geometry(scene)
    _device_or_skip(runtime, geometry)
    real, hashed = pipeline._digest, []
    monkeypatch.setattr(pipeline, "_digest", lambda *a: hashed.append(a[0] is geometry.vertices) or real(*a))
    stage = GBufferStage(geometry, runtime)
    for azimuth in (0.0, 20.0, 40.0):
        stage.frame(scene, whole.orbit(scene.camera.with_size(64, 36), azimuth), Timings())
        assert stage.path.path == "device"
    assert hashed.count(True) == 1 and hashed.count(False) == 3


def test_the_stage_refuses_an_unknown_mode(runtime):
    with pytest.raises(ClshadeError, match=r"--gbuffer = 'gpu'"):
        GBufferStage(build_geometry(load_scene(SCENES / "red_ball.toml")), runtime, "gpu")
    with pytest.raises(ClshadeError, match=r"--gbuffer = 'gpu'"):
        with use_gbuffer("gpu"):
            pass


def test_use_gbuffer_sets_the_default_and_collects_the_paths(runtime):
    scene = load_scene(SCENES / "red_ball.toml")
    with use_gbuffer("host") as paths:
        frame = prepare_frame(scene, 32, 24, runtime=runtime)
    assert frame.gbuffer_path.path == "host" and paths == [frame.gbuffer_path]
    assert prepare_frame(scene, 32, 24, runtime=runtime, gbuffer="host").timings.keys() >= {"rasterize", "g-buffer"}


# ---------------------------------------------------------------- the commands say which path


def test_render_explain_names_the_path(tmp_path, runtime, capsys):
    scene = SCENES / "robot.toml"
    _device_or_skip(runtime, build_geometry(load_scene(scene)))
    out = {}
    for mode in ("auto", "host"):
        code, text, _ = run_cli(capsys, ["render", str(scene), "--width", "64", "--height", "36", "--explain",
                                 "--gbuffer", mode, "-o", str(tmp_path / f"{mode}.exr")])
        assert code == 0
        out[mode] = text
    assert "g-buffer: device (verified bit for bit on " in out["auto"]
    assert "g-buffer: host (--gbuffer host)" in out["host"]
    # The pixels bit for bit (not the files: OpenImageIO stamps each EXR with the second it was written).
    from clshade.render.image import read_image
    auto, host = read_image(tmp_path / "auto.exr"), read_image(tmp_path / "host.exr")
    np.testing.assert_array_equal(_bits(auto), _bits(host))


def test_debug_names_the_path_of_compare(tmp_path, capsys):
    code, _, err = run_cli(capsys, ["--debug", "compare", str(SCENES / "textured.toml"), "-m", "lambert", "--tile", "32",
                            "-o", str(tmp_path / "sheet.png"), "--gbuffer", "host"])
    assert code == 0 and "clshade: debug: pipeline: g-buffer: host (--gbuffer host)" in err


# ---------------------------------------------------------------- whole frames


def test_bench_whole_frames_json(tmp_path, runtime, capsys):
    """`clshade bench --whole-frames N`: per model the whole-frame median and 1 % low, the stage medians and
    the G-buffer path, beside the dispatch tables."""
    out = tmp_path / "bench.json"
    code, text, _ = run_cli(capsys, ["bench", str(SCENES / "robot.toml"), "-m", "lambert,phong", "--frames", "3",
                             "--warmup", "0", "--numpy-frames", "0", "--width", "64", "--height", "36",
                             "--whole-frames", "3", "--json", str(out), "--no-progress"])
    assert code == 0, text
    doc = json.loads(out.read_text())
    wf = doc["whole_frames"]
    assert wf["gbuffer"]["path"] in ("device", "host") and wf["gbuffer"]["reason"]
    assert doc["gbuffer"] == [wf["gbuffer"]]            # the dispatch tables' frame took the same path
    assert [r["model"] for r in wf["models"]] == [r["model"] for r in doc["models"]]
    for r in wf["models"]:
        assert r["frames"] == 3 and r["whole_frame_ms_median"] > 0 and r["whole_frame_low1_fps"] > 0
        assert set(r["stage_ms_median"]) == set(whole.STAGES)
        assert r["whole_frame_low1_fps"] <= r["avg_fps"] + 1e-9
    assert "Whole frames: robot.toml 64x36" in text and f"g-buffer: {wf['gbuffer']['path']}" in text


def _fake_frames(monkeypatch, frame_ms: list[float]) -> None:
    """FrameStream.frame returning these whole-frame times in turn (the stages a fixed split of each)."""
    times = iter(frame_ms)

    def frame(self, camera, model, copy=True):
        self.stage.path = pipeline.GBufferPath("host", "frames made up by the test")
        ms = next(times)
        t = dict(zip(whole.STAGES, (0.4 * ms, 0.3 * ms, 0.1 * ms, 0.1 * ms, 0.1 * ms)))
        return {k: v / 1e3 for k, v in (t | {"frame": ms}).items()}, None
    monkeypatch.setattr(whole.FrameStream, "frame", frame)


def test_whole_frame_lows_are_the_slow_tail(runtime, monkeypatch):
    """The 1 % low is the slowest frames' rate: frames of 10, 10, 10 and 50 ms (after the untimed) → 20 FPS,
    the median 10 ms, the average 1000 / 20 ms."""
    _fake_frames(monkeypatch, [99.0] * whole.WARMUP_FRAMES + [10.0, 10.0, 50.0, 10.0])
    scene = load_scene(SCENES / "red_ball.toml")
    row = whole.orbit_bench(scene, [BUILT_IN.resolve("lambert")], runtime, 32, 24, 4)["models"][0]
    assert row["whole_frame_low1_fps"] == pytest.approx(20.0) and row["low01_fps"] == pytest.approx(20.0)
    assert row["whole_frame_ms_median"] == pytest.approx(10.0) and row["avg_fps"] == pytest.approx(50.0)
    assert row["stage_ms_median"]["rasterize"] == pytest.approx(4.0)


@pytest.mark.parametrize("gbuffer", ["auto", "host"])
def test_timed_whole_frames_make_no_planes(runtime, monkeypatch, gbuffer):
    """The untimed frames leave a stream its working set: every timed frame takes its planes from the pool's
    blocks (a fresh block's page faults made a 1920x1080 frame several times its time), on both paths."""
    from clshade.render.arrays import PlanePool
    frames, fresh = [0], []
    real_frame, real_empty = whole.FrameStream.frame, PlanePool.empty

    def frame(self, *args, **kwargs):
        frames[0] += 1
        return real_frame(self, *args, **kwargs)

    def empty(self, *args, **kwargs):
        blocks = len(self._blocks)
        out = real_empty(self, *args, **kwargs)
        if len(self._blocks) > blocks:
            fresh.append(frames[0])
        return out
    monkeypatch.setattr(whole.FrameStream, "frame", frame)
    monkeypatch.setattr(PlanePool, "empty", empty)
    scene = load_scene(SCENES / "robot.toml")
    doc = whole.orbit_bench(scene, [BUILT_IN.resolve("ggx_correlated")], runtime, 64, 36, 4, gbuffer=gbuffer)
    assert frames[0] == whole.WARMUP_FRAMES + 4 and fresh
    assert max(fresh) <= whole.WARMUP_FRAMES, f"new planes in frames {fresh} ({doc['gbuffer']['path']} path)"


def test_each_stage_is_timed_as_its_own(runtime, monkeypatch):
    """A raster stage made slow shows in the rasterize column only."""
    import time
    slow_s = 0.3                        # far above what a 48x32 frame's other stages take, even on a loaded machine
    real = pipeline.GBufferStage.raster

    def raster(self, camera):
        time.sleep(slow_s)
        return real(self, camera)
    monkeypatch.setattr(pipeline.GBufferStage, "raster", raster)
    scene = load_scene(SCENES / "red_ball.toml")
    row = whole.orbit_bench(scene, [BUILT_IN.resolve("lambert")], runtime, 48, 32, 2)["models"][0]
    stages = row["stage_ms_median"]
    assert stages["rasterize"] >= slow_s * 1e3
    assert all(stages[s] < slow_s * 1e3 for s in whole.STAGES if s != "rasterize")
    assert row["whole_frame_ms_median"] >= sum(stages.values()) * 0.99


@pytest.mark.parametrize("samples", [1, 2])
def test_whole_frames_reuse_buffers_and_show_the_reference_image(runtime, samples):
    """The whole-frame stream (one PlanePool, one Shader rebound frame after frame) gives, camera after camera,
    the image of a fresh render from the NumPy rasterizer's G-buffer, bit for bit (N×N samples resolved)."""
    scene = dataclasses.replace(load_scene(SCENES / "robot.toml"), samples=samples)
    geometry = build_geometry(scene)
    model = BUILT_IN.resolve("ggx_correlated")
    stream = whole.FrameStream(scene, geometry, None, runtime, [model])
    for azimuth in (0.0, 2.0, 90.0):
        camera = whole.orbit(scene.camera.with_size(72, 40), azimuth)
        _, image = stream.frame(camera, model)
        moved = dataclasses.replace(scene, camera=camera)
        frame = prepare_frame(moved, geometry=geometry, runtime=runtime, gbuffer="host")
        expected = render(moved, model, runtime=runtime, frame=frame).image
        np.testing.assert_array_equal(_bits(image), _bits(expected))
    assert stream.stage.path.path == ("device" if device_visibility.supports(runtime, geometry) else "host")


def test_an_image_read_in_place_is_the_copy(runtime):
    """FrameStream.frame(copy=False) reads the image where the shading kernel wrote it (on a CPU device the
    Shader's output is host memory: no copy; the next frame writes over it): the same bits as the copy, frame
    after frame, while a copy stays the caller's own."""
    scene = load_scene(SCENES / "robot.toml")
    geometry = build_geometry(scene)
    model = BUILT_IN.resolve("ggx_correlated")
    stream = whole.FrameStream(scene, geometry, None, runtime, [model])
    first, second = (whole.orbit(scene.camera.with_size(72, 40), a) for a in (0.0, 40.0))
    _, kept = stream.frame(first, model)
    _, here = stream.frame(first, model, copy=False)
    np.testing.assert_array_equal(_bits(here), _bits(kept))
    _, later = stream.frame(second, model)
    _, there = stream.frame(second, model, copy=False)
    np.testing.assert_array_equal(_bits(there), _bits(later))
    assert (_bits(kept) != _bits(later)).any() and there.shape == kept.shape == (40, 72, 4)
    if "cpu" in runtime.info.kind:              # one memory, overwritten by the next frame
        assert np.shares_memory(here, there) and not np.shares_memory(kept, here)
        np.testing.assert_array_equal(_bits(here), _bits(later))


def test_the_perf_tables_name_each_runtimes_path(runtime):
    """benchmarks/measure/perf.py's whole frames (whole_frames_on) record and print each runtime's path."""
    from clshade.report.perf import perf_whole_frame_markdown
    scene = load_scene(SCENES / "robot.toml")
    out = whole.whole_frames_on(scene, BUILT_IN.resolve("lambert"), [runtime], 64, 36, frames=1, gbuffer="host")
    assert out[0]["gbuffer"] == dict(path="host", reason="--gbuffer host")
    text = "\n".join(perf_whole_frame_markdown(out))
    assert "Raster and G-buffer: " in text and ": host (--gbuffer host)" in text


def test_overlapped_frames_are_the_sequential_frames(runtime):
    """With the next frame's triangle setup on a second thread, an orbit gives the same images, bit for bit,
    as frame after frame; and the bench says it overlapped only where the device path ran."""
    scene = load_scene(SCENES / "robot.toml")
    geometry = build_geometry(scene)
    _device_or_skip(runtime, geometry)
    model = BUILT_IN.resolve("ggx_correlated")
    cameras = [whole.orbit(scene.camera.with_size(80, 45), 7.0 * k) for k in range(5)]
    sequential = whole.FrameStream(scene, geometry, None, runtime, [model])
    expected = [image for _, image in sequential.frames(cameras, model)]
    overlapped = whole.FrameStream(scene, geometry, None, runtime, [model])
    overlapped.frame(cameras[0], model)          # the path is chosen (and checked) on a first frame
    got = list(overlapped.frames(cameras, model, overlap=True))
    assert len(got) == len(cameras)
    for (t, image), want in zip(got, expected):
        np.testing.assert_array_equal(_bits(image), _bits(want))
        assert set(t) == {*whole.STAGES, "frame"}
    assert whole.orbit_bench(scene, [model], runtime, 48, 27, 2, overlap=True)["overlap"]
    assert not whole.orbit_bench(scene, [model], runtime, 48, 27, 2, gbuffer="host", overlap=True)["overlap"]
