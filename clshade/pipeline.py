"""The deferred pipeline, stage by stage, with a wall-clock time per stage:
scene → geometry → rasterizer → G-buffer → kernel variant → image. `render` keeps the
whole frame (its G-buffer is shared by several models: compare, bench); `render_streamed`
(the CLI's render) works in bands of rows so that only the output image is full-frame.

The raster and G-buffer stages take one of two paths (GBufferStage), the same for render,
compare, bench, aa and the live viewer: the device's visibility buffer and G-buffer
(clshade.device.visibility: the host does only the triangle setup) where the device supports
it and has made the NumPy rasterizer's G-buffer bit for bit on a small frame of this geometry
(checked once per device and geometry in the process), else the NumPy rasterizer and
build_gbuffer, which stay the reference. `--gbuffer host|device|auto` (use_gbuffer) chooses."""
from __future__ import annotations

import dataclasses
import hashlib
import threading
import time
from collections import OrderedDict
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from clshade import budget
from clshade.budget import available_memory
from clshade.errors import ClshadeError
from clshade.render.gbuffer import GBuffer, build_gbuffer, face_planes, material_table
from clshade.render.meshes import Geometry, build_geometry
from clshade.models.model import Model
from clshade.render.raster import Fragments, RasterMesh, ViewSetup, rasterize_mesh, setup_view
from clshade.render.raster.batches import FACE_BATCH
from clshade.render.raster.resolve import view_max_triangles
from clshade.render.arrays import PlanePool
from clshade.device import visibility as device_visibility
from clshade.diagnostics import note
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
            self.add(name, time.perf_counter() - start)

    def add(self, name: str, seconds: float) -> None:
        self[name] = self.get(name, 0.0) + seconds

    def line(self) -> str:
        return ", ".join(f"{k} {v * 1e3:.1f} ms" for k, v in self.items())


#: --gbuffer: the device path where it is supported and verified, else the host (auto); the NumPy
#: rasterizer always (host); the device path required, refused where it cannot serve (device).
GBUFFER_MODES = ("auto", "host", "device")
#: The stage of the device's visibility buffer and G-buffer; the host's triangle setup before it is SETUP_STAGE.
DEVICE_GBUFFER_STAGE = "visibility + g-buffer (device)"
SETUP_STAGE = "triangle setup"
#: Geometries whose stages (raster mesh, device tables) are kept for the next frame of the process: a
#: few, as the sweep and aa alternate between a handful of geometries and each holds its device tables.
KEPT_STAGES = 4

_default_mode: dict[str, object] = {"mode": "auto", "device": None, "taken": None}
#: (device, mesh digest, face tables digest) → None where that device made the NumPy rasterizer's
#: G-buffer bit for bit, else what differed: each device and geometry is verified once per process.
#: Only verdicts are kept: a check that could not run (a buffer refused, the runtime out of
#: resources) leaves its stage on the host and lets the next stage of that geometry try again.
_VERIFIED: dict[tuple, str | None] = {}
_VERIFYING = threading.Lock()
_STAGES: OrderedDict[tuple, "GBufferStage"] = OrderedDict()


@contextmanager
def use_gbuffer(mode: str | None, device: str | None = None):
    """Run the block with `mode` (GBUFFER_MODES; None keeps the current) as the G-buffer path of
    every prepare_frame that names none, on `device` (the command's --device). Yields the list of
    the distinct GBufferPaths the block's frames took (what a command reports)."""
    if mode is not None and mode not in GBUFFER_MODES:
        raise ClshadeError(f"--gbuffer = {mode!r}: choose from {', '.join(GBUFFER_MODES)}")
    saved = dict(_default_mode)
    taken: list[GBufferPath] = []
    _default_mode.update(mode=mode or saved["mode"], device=device, taken=taken)
    try:
        yield taken
    finally:
        _default_mode.update(saved)


@dataclass(frozen=True)
class GBufferPath:
    """Which path a frame's raster and G-buffer took ('device' or 'host'), and why."""
    path: str
    reason: str

    def line(self) -> str:
        return f"g-buffer: {self.path} ({self.reason})"


def _digest(*arrays: np.ndarray) -> str:
    """A digest of arrays' dtypes, shapes and bytes (what the device's G-buffer depends on besides
    the camera: the mesh, once per stage, and each new set of face tables)."""
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype}{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _uncropped(camera: Camera) -> Camera:
    """The whole frame of a band camera (the verification frame is a resized whole frame)."""
    return dataclasses.replace(camera, crop=None, height=camera.crop[1]) if camera.crop else camera


class GBufferStage:
    """One geometry's raster and G-buffer stages on one runtime: the device's visibility buffer and
    G-buffer (host triangle setup, then clshade.device.visibility) where the device supports this
    geometry and has made the NumPy rasterizer's G-buffer bit for bit (device_visibility.verify, once
    per device and geometry in the process), else rasterize_mesh and build_gbuffer. `path` says which
    the last frame took and why."""

    def __init__(self, geometry: Geometry, runtime: Runtime | None = None, mode: str = "auto",
                 tangents: bool = False, device: str | None = None) -> None:
        if mode not in GBUFFER_MODES:
            raise ClshadeError(f"--gbuffer = {mode!r}: choose from {', '.join(GBUFFER_MODES)}")
        self.geometry, self.mode = geometry, mode
        self.tangents = tangents and geometry.tangents is not None
        self.mesh = RasterMesh(geometry.vertices, geometry.faces, geometry.cull)
        self._runtime, self._device = runtime, device
        self._gpu: device_visibility.DeviceGBuffer | None = None
        self._gpu_faces: tuple[object, str] | None = None       # (the face tables object, their digest)
        self._mesh_digest: str | None = None
        self._refusal: str | None = None                        # why this stage keeps to the host
        self.path: GBufferPath | None = None

    @property
    def runtime(self) -> Runtime:
        if self._runtime is None:
            self._runtime = get_runtime(self._device)
        return self._runtime

    def _static_refusal(self) -> str | None:
        """Why the device path cannot serve this geometry at all, else None."""
        if self.mode == "host":
            return "--gbuffer host"
        if self.tangents:
            return "a lobe reads the mesh tangents: the device path writes no tangent channel"
        return device_visibility.refusal(self.runtime, self.geometry)

    def _host(self, reason: str) -> None:
        if self.mode == "device":
            raise ClshadeError(f"--gbuffer device: {reason}; use --gbuffer auto or host")
        self._set(GBufferPath("host", reason))

    def _set(self, path: GBufferPath) -> None:
        if path != self.path:
            note("pipeline", path.line())       # `clshade --debug` prints it
        taken = _default_mode["taken"]
        if taken is not None and path not in taken:
            taken.append(path)
        self.path = path

    def raster(self, camera: Camera) -> Fragments | ViewSetup:
        """The triangle setup where the device may make the rest, else the NumPy rasterizer's fragments."""
        view, proj = camera.view_matrix(), camera.projection_matrix()
        if self._refusal is None:
            self._refusal = self._static_refusal() or ""
        if not self._refusal:
            setup = setup_view(self.mesh, view, proj, camera.width, camera.height)
            if setup is not None:
                return setup
            # Kept for the geometry's later frames: they skip the setup, and a stream keeps one path.
            self._refusal = (f"{len(self.geometry.faces)} faces: a view set up more triangles than the device path's "
                             f"keys number ({view_max_triangles(FACE_BATCH)})")
            self._host(self._refusal)
        else:
            self._host(self._refusal)
        return rasterize_mesh(self.mesh, view, proj, camera.width, camera.height)

    def build(self, scene: Scene, camera: Camera, raster: Fragments | ViewSetup, timings: Timings,
              faces: dict[str, np.ndarray] | None = None, table: np.ndarray | None = None,
              pool: PlanePool | None = None) -> tuple[GBuffer, Fragments | None, np.ndarray | None]:
        """The G-buffer of `raster` (from raster(camera)): (gbuffer, the host's fragments or None,
        the device's per-pixel coverage or None). A setup the device may not finish (its check
        failed) is rasterized on the host. `faces`: face_planes of the scene's materials."""
        if isinstance(raster, ViewSetup):
            if faces is None:
                with timings.stage("face tables"):
                    faces = face_planes(self.geometry, list(scene.materials.values()))
            device = self._proven(scene, camera, faces, timings)
            if device is not None:
                with timings.stage(DEVICE_GBUFFER_STAGE):
                    gbuffer, cover = device.build(raster, material_table(scene) if table is None else table, pool)
                return gbuffer, None, cover
            with timings.stage("rasterize"):
                raster = rasterize_mesh(self.mesh, camera.view_matrix(), camera.projection_matrix(),
                                        camera.width, camera.height)
        with timings.stage("g-buffer"):
            gbuffer = build_gbuffer(scene, self.geometry, raster, camera, self.tangents,
                                    faces=None if self.tangents else faces, pool=pool)
        return gbuffer, raster, None

    def _proven(self, scene: Scene, camera: Camera, faces: dict[str, np.ndarray],
                timings: Timings) -> device_visibility.DeviceGBuffer | None:
        """The device's G-buffer kernels for these face tables once verified on this device (the
        process keeps the verdict), else None with the host path and its reason set."""
        rt = self.runtime
        if self._gpu_faces is None or self._gpu_faces[0] is not faces:
            with timings.stage("g-buffer kernel"):
                if self._mesh_digest is None:
                    g = self.geometry
                    self._mesh_digest = _digest(g.vertices, g.faces, np.asarray(g.cull))
                digest = _digest(*(faces[k] for k in sorted(faces)))
                if self._gpu_faces is None or self._gpu_faces[1] != digest:
                    self._gpu = None
                self._gpu_faces = (faces, digest)
        key = (rt.info.spec, rt.info.description, self._mesh_digest, self._gpu_faces[1])
        with _VERIFYING:
            reason = _VERIFIED.get(key, "")
            if reason == "" or (reason is None and self._gpu is None):
                with timings.stage("g-buffer kernel"):
                    try:
                        self._gpu = device_visibility.DeviceGBuffer(rt, self.geometry, faces)
                        if reason == "":
                            reason = device_visibility.verify(self._gpu, scene, self.geometry, self.mesh,
                                                              _uncropped(camera), faces)
                            _VERIFIED[key] = reason
                    except (ClshadeError, rt.cl.Error) as exc:
                        # Not a verdict on the device: this stage stays on the host, the next may try.
                        self._gpu = None
                        self._refusal = (f"the device's G-buffer could not be made on {rt.info.runtime}: "
                                         f"{type(exc).__name__}: {exc}")
                        self._host(self._refusal)
                        return None
        if reason is None:
            self._set(GBufferPath("device", f"verified bit for bit on {rt.info.runtime}"))
            return self._gpu
        self._gpu = None                                        # its device buffers freed
        self._refusal = f"the device's G-buffer differed from the host's on {rt.info.runtime}: {reason}"
        self._host(self._refusal)
        return None

    def frame(self, scene: Scene, camera: Camera, timings: Timings, faces: dict[str, np.ndarray] | None = None,
              pool: PlanePool | None = None) -> tuple[GBuffer, Fragments | None]:
        """Raster and G-buffer of one frame by the chosen path: (gbuffer, the host's fragments or None)."""
        start = time.perf_counter()
        raster = self.raster(camera)
        # The host did only the triangle setup where the device makes the rest.
        timings.add(SETUP_STAGE if isinstance(raster, ViewSetup) else "rasterize", time.perf_counter() - start)
        gbuffer, fragments, _ = self.build(scene, camera, raster, timings, faces, pool=pool)
        return gbuffer, fragments


def gbuffer_stage(geometry: Geometry, runtime: Runtime | None = None, device: str | None = None,
                  mode: str | None = None, tangents: bool = False) -> GBufferStage:
    """The process's kept GBufferStage of (geometry, device, mode, tangents): its raster mesh and
    device tables serve the next frame of the same geometry (the last KEPT_STAGES are kept).
    `mode` and `device` default to use_gbuffer's."""
    mode = mode or _default_mode["mode"]
    device = device if device is not None else _default_mode["device"]
    key = (id(geometry), id(runtime) if runtime is not None else device, mode, tangents)
    stage = _STAGES.get(key)
    if stage is None or stage.geometry is not geometry:
        stage = GBufferStage(geometry, runtime, mode, tangents, device)
        _STAGES[key] = stage
        while len(_STAGES) > KEPT_STAGES:
            _STAGES.popitem(last=False)
    _STAGES.move_to_end(key)
    return stage


@dataclass
class Frame:
    """Everything up to the shading pass, computed once and shared by every model."""
    scene: Scene
    camera: Camera
    geometry: Geometry
    raster: Fragments | None                 # the host's fragments; None where the device made the G-buffer
    gbuffer: GBuffer
    shadows: ShadowMaps | None = None
    timings: Timings = field(default_factory=Timings)
    gbuffer_path: GBufferPath | None = None

    @property
    def fragments(self) -> Fragments:
        """The NumPy rasterizer's fragments (made on first use where the device made the G-buffer)."""
        if self.raster is None:
            c = self.camera
            self.raster = rasterize_mesh(RasterMesh(self.geometry.vertices, self.geometry.faces, self.geometry.cull),
                                         c.view_matrix(), c.projection_matrix(), c.width, c.height)
        return self.raster


def reads_tangents(models: list[Model]) -> bool:
    """Whether some model's lobe reads the tangent frame: the G-buffer then carries the mesh tangents."""
    return any("tangents" in m.uses for m in models)


def prepare_frame(scene: Scene | str | Path, width: int | None = None, height: int | None = None,
                  timings: Timings | None = None, samples: int | None = None,
                  geometry: Geometry | None = None, tangents: bool = False, *, runtime: Runtime | None = None,
                  device: str | None = None, gbuffer: str | None = None) -> Frame:
    """Load (if needed), build geometry, rasterise and write the G-buffer. With N×N
    `samples` per pixel (default: the scene's `[render] samples`) the raster is
    N·W × N·H (clshade/render/samples.py) and the frame's scene carries N, so that
    every Shader of the frame resolves to W × H on the device. `geometry` reuses the
    meshes of an earlier frame of the same scene (jittered or moving cameras). The raster and
    G-buffer take GBufferStage's path (`gbuffer`: GBUFFER_MODES, default use_gbuffer's) on
    `runtime` (default: get_runtime(`device`)); the Frame's gbuffer_path says which and why."""
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
    stage = gbuffer_stage(geometry, runtime, device, gbuffer, tangents)
    built, fragments = stage.frame(scene, camera, timings)
    shadows = None
    if scene.shadow_lights:
        with timings.stage("shadow maps"):
            shadows = build_shadow_maps(scene, geometry)
    return Frame(scene, camera, geometry, fragments, built, shadows, timings, stage.path)


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
    with timings.stage("opencl setup"):
        rt = runtime or get_runtime(device)
    frame = frame or prepare_frame(scene, width, height, timings, tangents=reads_tangents([model]), runtime=rt)
    with timings.stage("opencl setup"):
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
    gbuffer_path: GBufferPath | None = None


def render_streamed(scene: Scene, model: Model, on_band, *, width: int | None = None, height: int | None = None,
                    device: str | None = None, runtime: Runtime | None = None, half_gbuffer: bool = False,
                    fast_math: bool = False, general: bool = False, band_pixels: int = BAND_PIXELS,
                    timings: Timings | None = None, progress=None, gbuffer: str | None = None) -> StreamResult:
    """Render a frame band by band (rows [r0, r0 + rows)): geometry and shadow maps once,
    then per band rasterize → G-buffer (GBufferStage's path, `gbuffer`: GBUFFER_MODES) → shade →
    `on_band(r0, image)` with the band's (rows, W, 4) float32 radiance + coverage. Each band's
    camera is Camera.band, so the pixels are those of the whole frame. `progress(done, total)`
    after each band."""
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
    stage = gbuffer_stage(geometry, rt, None, gbuffer, reads_tangents([model]))
    faces = None if stage.tangents else face_planes(geometry, list(scene.materials.values()))
    n = scene.samples                     # N×N samples: each band's raster is N² times larger
    check_samples(n, camera.width, camera.height)
    rows = band_rows(camera.width, camera.height, max(1, band_pixels // (n * n)))
    starts = list(range(0, camera.height, rows))
    covered = nonfinite = 0
    shader = None
    for done, r0 in enumerate(starts, 1):
        cam = camera.band(r0, min(rows, camera.height - r0)) if len(starts) > 1 else camera
        cam = supersampled(cam, n)
        gbuffer, _ = stage.frame(scene, cam, timings, faces)
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
    return StreamResult(camera, geometry, features, shader, shadows, covered, nonfinite, len(starts), timings,
                        stage.path)


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
