"""The deferred pipeline, stage by stage, with a wall-clock time per stage:
scene → geometry → rasterizer → G-buffer → kernel variant → image."""
from __future__ import annotations

import dataclasses
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from clshade.render.gbuffer import GBuffer, build_gbuffer
from clshade.render.meshes import Geometry, build_geometry
from clshade.models import Model
from clshade.render.raster import Fragments, rasterize
from clshade.render.samples import check_samples, supersampled
from clshade.device.runtime import Runtime, get_runtime
from clshade.render.scene import Camera, Scene, load_scene
from clshade.device.shade import Shader, scene_features
from clshade.render.shadows import ShadowMaps, build_shadow_maps
from clshade.device.variants import Features


class Timings(dict):
    """Stage name → seconds, in the order the stages ran."""

    @contextmanager
    def stage(self, name: str):
        start = time.perf_counter()
        try:
            yield
        finally:
            self[name] = self.get(name, 0.0) + time.perf_counter() - start

    def line(self) -> str:
        return ", ".join(f"{k} {v * 1e3:.1f} ms" for k, v in self.items())


@dataclass
class Frame:
    """Everything up to the shading pass, computed once and shared by every model."""
    scene: Scene
    camera: Camera
    geometry: Geometry
    fragments: Fragments
    gbuffer: GBuffer
    shadows: ShadowMaps | None = None
    timings: Timings = field(default_factory=Timings)


def prepare_frame(scene: Scene | str | Path, width: int | None = None, height: int | None = None,
                  timings: Timings | None = None, samples: int | None = None,
                  geometry: Geometry | None = None) -> Frame:
    """Load (if needed), build geometry, rasterise and write the G-buffer. With N×N
    `samples` per pixel (default: the scene's `[render] samples`) the raster is
    N·W × N·H (clshade/render/samples.py) and the frame's scene carries N, so that
    every Shader of the frame resolves to W × H on the device. `geometry` reuses the
    meshes of an earlier frame of the same scene (jittered or moving cameras)."""
    timings = timings if timings is not None else Timings()
    if not isinstance(scene, Scene):
        with timings.stage("load scene"):
            scene = load_scene(scene)
    camera = scene.camera.with_size(width, height)
    samples = scene.samples if samples is None else samples
    check_samples(samples, camera.width, camera.height)
    if samples != scene.samples:
        scene = dataclasses.replace(scene, samples=samples)
    camera = supersampled(camera, samples)
    if geometry is None:
        with timings.stage("geometry"):
            geometry = build_geometry(scene)
    with timings.stage("rasterize"):
        fragments = rasterize(geometry.vertices, geometry.faces, camera.view_matrix(), camera.projection_matrix(),
                              camera.width, camera.height, cull_backfaces=geometry.cull)
    with timings.stage("g-buffer"):
        gbuffer = build_gbuffer(scene, geometry, fragments, camera)
    shadows = None
    if scene.shadow_lights:
        with timings.stage("shadow maps"):
            shadows = build_shadow_maps(scene, geometry)
    return Frame(scene, camera, geometry, fragments, gbuffer, shadows, timings)


@dataclass
class Render:
    image: np.ndarray          # (H, W, 4) float32 linear radiance + coverage
    frame: Frame
    model: Model
    features: Features
    shader: Shader
    timings: Timings


def render(scene: Scene | str | Path, model: Model, *, width: int | None = None, height: int | None = None,
           device: str | None = None, runtime: Runtime | None = None, half_gbuffer: bool = False,
           fast_math: bool = False, frame: Frame | None = None, general: bool = False) -> Render:
    """Render one model; the returned Render keeps the frame and shader for reuse.
    `general` renders with the general kernel (same result, slower)."""
    timings = Timings()
    frame = frame or prepare_frame(scene, width, height, timings)
    with timings.stage("opencl setup"):
        rt = runtime or get_runtime(device)
        shader = Shader(rt, frame.gbuffer, frame.scene, frame.camera, frame.shadows)
        features = scene_features(frame.scene, half_gbuffer and not general, fast_math, frame.geometry, general)
    with timings.stage("kernel build"):
        dispatch = shader.prepare(model, features)
    with timings.stage("shade"):
        shader.enqueue(dispatch).wait()
    with timings.stage("read back"):
        image = shader.read()
    return Render(image, frame, model, features, shader, timings)
