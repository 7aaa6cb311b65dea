"""The deferred pipeline, stage by stage, with a wall-clock time per stage:
scene → geometry → rasterizer → G-buffer → kernel variant → image. `render` keeps the
whole frame (its G-buffer is shared by several models: compare, bench); `render_streamed`
(the CLI's render) works in bands of rows so that only the output image is full-frame."""
from __future__ import annotations

import dataclasses
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from clshade import budget
from clshade.budget import available_memory
from clshade.errors import ClshadeError
from clshade.render.gbuffer import GBuffer, build_gbuffer
from clshade.render.meshes import Geometry, build_geometry
from clshade.models.model import Model
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


def reads_tangents(models: list[Model]) -> bool:
    """Whether some model's lobe reads the tangent frame: the G-buffer then carries the mesh tangents."""
    return any("tangents" in m.uses for m in models)


def prepare_frame(scene: Scene | str | Path, width: int | None = None, height: int | None = None,
                  timings: Timings | None = None, samples: int | None = None,
                  geometry: Geometry | None = None, tangents: bool = False) -> Frame:
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
    budget.frame_samples(camera.width, camera.height, samples)
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
        gbuffer = build_gbuffer(scene, geometry, fragments, camera, tangents)
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
    frame = frame or prepare_frame(scene, width, height, timings, tangents=reads_tangents([model]))
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


# ---------------------------------------------------------------- large frames: bands of rows

#: Pixels per band of a streamed render: the working set of one band (fragments,
#: G-buffer, device buffers and their temporaries) is bounded by this whatever the
#: frame size; only the output image is full-frame (3 B/px 8-bit RGB for PNG/JPEG,
#: 16 B/px float RGBA for EXR).
BAND_PIXELS = 1 << 19
#: The allowance for everything that does not scale with the frame — interpreter, NumPy,
#: PoCL, geometry, one band's working set — when deciding whether a frame fits.
#: benchmarks/measure/memory_bench.py measures the real peaks (benchmarks/results/memory.md).
STREAM_BASE_BYTES = 320 << 20


def band_rows(width: int, height: int, band_pixels: int = BAND_PIXELS) -> int:
    """Rows per band: about `band_pixels` pixels, at least one row."""
    return max(1, min(height, band_pixels // max(width, 1)))


@dataclass
class StreamResult:
    """What a streamed render leaves besides the bands it handed over."""
    camera: Camera
    geometry: Geometry
    features: Features
    shader: Shader              # the last band's (its variant and runtime describe every band)
    shadows: ShadowMaps | None
    covered: int
    nonfinite: int
    bands: int
    timings: Timings


def render_streamed(scene: Scene, model: Model, on_band, *, width: int | None = None, height: int | None = None,
                    device: str | None = None, runtime: Runtime | None = None, half_gbuffer: bool = False,
                    fast_math: bool = False, general: bool = False, band_pixels: int = BAND_PIXELS,
                    timings: Timings | None = None, progress=None) -> StreamResult:
    """Render a frame band by band (rows [r0, r0 + rows)): geometry and shadow maps once,
    then per band rasterize → G-buffer → shade → `on_band(r0, image)` with the band's
    (rows, W, 4) float32 radiance + coverage. Each band's camera is Camera.band, so the
    pixels are those of the whole frame. `progress(done, total)` after each band."""
    timings = timings if timings is not None else Timings()
    camera = scene.camera.with_size(width, height)
    with timings.stage("geometry"):
        geometry = build_geometry(scene)
    shadows = None
    if scene.shadow_lights:
        with timings.stage("shadow maps"):
            shadows = build_shadow_maps(scene, geometry)
    with timings.stage("opencl setup"):
        rt = runtime or get_runtime(device)
        features = scene_features(scene, half_gbuffer and not general, fast_math, geometry, general)
    n = scene.samples                     # N×N samples: each band's raster is N² times larger
    check_samples(n, camera.width, camera.height)
    rows = band_rows(camera.width, camera.height, max(1, band_pixels // (n * n)))
    starts = list(range(0, camera.height, rows))
    covered = nonfinite = 0
    shader = None
    for done, r0 in enumerate(starts, 1):
        cam = camera.band(r0, min(rows, camera.height - r0)) if len(starts) > 1 else camera
        cam = supersampled(cam, n)
        with timings.stage("rasterize"):
            fragments = rasterize(geometry.vertices, geometry.faces, cam.view_matrix(), cam.projection_matrix(),
                                  cam.width, cam.height, cull_backfaces=geometry.cull)
        with timings.stage("g-buffer"):
            gbuffer = build_gbuffer(scene, geometry, fragments, cam, reads_tangents([model]))
        del fragments
        covered += int(gbuffer.coverage.sum())
        nonfinite += gbuffer.nonfinite_pixels
        with timings.stage("kernel build"):
            shader = Shader(rt, gbuffer, scene, cam, shadows)
            dispatch = shader.prepare(model, features)
        with timings.stage("shade"):
            shader.enqueue(dispatch).wait()
        with timings.stage("read back"):
            image = shader.read()
        del gbuffer
        with timings.stage("output"):
            on_band(r0, image)
        if progress is not None:
            progress(done, len(starts))
    return StreamResult(camera, geometry, features, shader, shadows, covered, nonfinite, len(starts), timings)


def check_frame_memory(width: int, height: int, output_bytes_per_pixel: int, available: int | None = None) -> int:
    """Refuse, before anything is allocated, a streamed frame whose output image plus the
    fixed working set cannot fit in the memory available now. Returns the estimate."""
    need = width * height * output_bytes_per_pixel + STREAM_BASE_BYTES
    available = available_memory() if available is None else available
    if available is not None and need > available:
        raise ClshadeError(f"a {width}x{height} frame needs about {need / 2**30:.1f} GiB of memory "
                           f"({output_bytes_per_pixel} B/pixel of output + {STREAM_BASE_BYTES >> 20} MiB), "
                           f"{available / 2**30:.1f} GiB available; render it smaller")
    return need
