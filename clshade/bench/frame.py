"""Whole frames: what a user waits for per frame, stage by stage, with the camera
moving between frames (nothing of the previous frame's raster or G-buffer is
reused; the stages keep their buffers between frames: the rasterizer its scratch
arrays, the G-buffer its planes (PlanePool), the Shader its device buffers and bound
kernels (Shader.rebind), as in any program that renders more than once).

Per frame, clshade.pipeline's stages, the same as `clshade render` and the viewer:
rasterize (the NumPy rasterizer on clshade.render.arrays.worker_count() threads, or only the
triangle setup where the device makes the visibility buffer) → g-buffer (build_gbuffer, or
the device's visibility + G-buffer kernels; GBufferStage picks the path and says why) →
upload (the Shader rebound to the new planes) → shade (one dispatch) → read back the image
(on a CPU device the shading kernel writes into host memory: the image is read in place, after a
map, with no copy; the benchmarks consume each frame's image before the next, Shader.read).
Geometry, shadow maps (they depend on the lights, not the camera), the path's check and
the kernel build are made once before the timed frames, as an interactive viewer would.
The camera orbits the target about the vertical axis by `step_degrees` a frame. The FPS
tables of `clshade bench` time the shading dispatch alone; this is the figure beside them.
"""
from __future__ import annotations

import dataclasses
import math
import os
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from clshade.bench.run import frame_stats
from clshade.device.runtime import Runtime
from clshade.device.shade import Shader, scene_features
from clshade.models.model import Model
from clshade.pipeline import Timings, gbuffer_stage, reads_tangents
from clshade.render.arrays import PlanePool, worker_count
from clshade.render.gbuffer import face_planes
from clshade.render.meshes import Geometry, build_geometry
from clshade.render.samples import supersampled
from clshade.render.scene import Camera, Scene
from clshade.render.shadows import ShadowMaps, build_shadow_maps

#: The stages of a whole frame, in order ("rasterize": the NumPy rasterizer, or the host's
#: triangle setup where the device makes the rest; "g-buffer": build_gbuffer, or the device's
#: visibility buffer and G-buffer).
STAGES = ("rasterize", "g-buffer", "upload", "shade", "read back")
#: Untimed whole frames before the timed ones: the first makes the path's check and the kernel build,
#: the second the PlanePool's second set of planes (the Shader still holds the first frame's while the
#: next G-buffer is built). A fresh set's page faults made a 1920x1080 frame several times its time.
WARMUP_FRAMES = 2


class FrameStream:
    """Whole frames of one scene on one runtime, the camera changing between them: the G-buffer
    stage of the frame pipeline (its path chosen once), the planes from one PlanePool and one
    Shader rebound to each new G-buffer."""

    def __init__(self, scene: Scene, geometry: Geometry, shadows: ShadowMaps | None, runtime: Runtime,
                 models: list[Model], gbuffer: str | None = None) -> None:
        self.scene, self.geometry, self.shadows, self.rt = scene, geometry, shadows, runtime
        self.stage = gbuffer_stage(geometry, runtime, mode=gbuffer, tangents=reads_tangents(models))
        self.faces = None if self.stage.tangents else face_planes(geometry, list(scene.materials.values()))
        self.features = scene_features(scene, geometry=geometry)
        self.pool = PlanePool()
        self.shader: Shader | None = None

    def frame(self, camera: Camera, model: Model, copy: bool = True) -> tuple[dict[str, float], np.ndarray]:
        """One whole frame of `model` from `camera`: (seconds per stage and 'frame', the image; N×N
        samples per pixel (the scene's) rasterized at N·W × N·H and resolved on the device).
        `copy=False`: on a CPU device the image is the Shader's output memory, read in place
        (Shader.read): valid until the next frame, for a caller that consumes it before then."""
        camera = supersampled(camera, self.scene.samples)
        t0 = time.perf_counter()
        raster, raster_s = self._raster(camera)
        t, image = self._finish(camera, raster, raster_s, model, copy)
        t["frame"] = time.perf_counter() - t0
        return t, image

    def frames(self, cameras: list[Camera], model: Model, overlap: bool = False, copy: bool = True):
        """Whole frames of `model` from each camera in turn, as (stage seconds, image). `overlap`, on the
        device path once a frame has chosen it: the host's triangle setup of the next frame runs on a
        second thread while this frame's G-buffer, shading and read-back run (the same images); 'frame'
        is then the time from one image to the next, and the stages overlap. `copy`: as frame's."""
        if not (overlap and self.stage.path is not None and self.stage.path.path == "device"):
            for camera in cameras:
                yield self.frame(camera, model, copy)
            return
        cams = [supersampled(c, self.scene.samples) for c in cameras]
        with ThreadPoolExecutor(max_workers=1) as worker:
            ahead = worker.submit(self._raster, cams[0]) if cams else None
            last = time.perf_counter()
            for k, camera in enumerate(cams):
                raster, raster_s = ahead.result()
                if k + 1 < len(cams):
                    ahead = worker.submit(self._raster, cams[k + 1])
                t, image = self._finish(camera, raster, raster_s, model, copy)
                now = time.perf_counter()
                t["frame"], last = now - last, now
                yield t, image

    def _raster(self, camera: Camera) -> tuple[object, float]:
        start = time.perf_counter()
        raster = self.stage.raster(camera)
        return raster, time.perf_counter() - start

    def _finish(self, camera: Camera, raster, raster_s: float, model: Model,
                copy: bool = True) -> tuple[dict[str, float], np.ndarray]:
        """The stages after the raster: G-buffer, upload (Shader rebound), shade, read back."""
        scratch = Timings()             # the path's one-off work (its check, face tables) lands here
        t1 = time.perf_counter()
        gbuffer, _, _ = self.stage.build(self.scene, camera, raster, scratch, self.faces, pool=self.pool)
        t2 = time.perf_counter()
        if self.shader is None:
            self.shader = Shader(self.rt, gbuffer, self.scene, camera, self.shadows)
        else:
            self.shader.rebind(gbuffer, self.scene, camera)
        dispatch = self.shader.prepare(model, self.features)     # built once: later frames hit the cache
        self.rt.queue.finish()
        t3 = time.perf_counter()
        self.shader.enqueue(dispatch).wait()
        t4 = time.perf_counter()
        image = self.shader.read(copy)
        t5 = time.perf_counter()
        return dict(zip(STAGES, (raster_s, t2 - t1, t3 - t2, t4 - t3, t5 - t4))), image


def orbit(camera: Camera, degrees: float) -> Camera:
    """`camera` turned about the vertical axis through its target by `degrees`."""
    a = math.radians(degrees)
    rot = np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])
    pos = camera.target + rot @ (np.asarray(camera.position, float) - camera.target)
    return dataclasses.replace(camera, position=pos)


def _shown(path: Path | None) -> str | None:
    """`path` relative to the working directory when it lies below it (results name no home folders)."""
    if path is None:
        return None
    try:
        return str(Path(path).resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def whole_frames(scene: Scene, model: Model, runtime: Runtime, width: int, height: int,
                 frames: int = 10, step_degrees: float = 2.0) -> dict[str, object]:
    """Per-stage seconds of `frames` whole frames (after WARMUP_FRAMES untimed ones);
    returns medians per stage, the median whole frame and every frame's stages."""
    return whole_frames_on(scene, model, [runtime], width, height, frames, step_degrees)[0]


def whole_frames_on(scene: Scene, model: Model, runtimes: list[Runtime], width: int, height: int,
                    frames: int = 10, step_degrees: float = 2.0, gbuffer: str | None = None) -> list[dict[str, object]]:
    """:func:`whole_frames` on each runtime, interleaved: every camera position is rendered on
    each runtime in turn, so that a slow spell of a shared machine falls on all of them alike.
    One result per runtime, in order, each naming its device and the G-buffer path it took."""
    geometry = build_geometry(scene)
    shadows = build_shadow_maps(scene, geometry) if scene.shadow_lights else None
    streams = [FrameStream(scene, geometry, shadows, runtime, [model], gbuffer) for runtime in runtimes]
    base = scene.camera.with_size(width, height)
    per_frame: list[list[dict[str, float]]] = [[] for _ in runtimes]
    for _ in range(WARMUP_FRAMES):
        for stream in streams:
            stream.frame(base, model, copy=False)
    for k in range(1, frames + 1):
        camera = orbit(base, step_degrees * k)
        for stream, timed in zip(streams, per_frame):
            timed.append(stream.frame(camera, model, copy=False)[0])
    load = _load_average()
    return [dict(scene=_shown(scene.path), model=model.id, width=width, height=height,
                 frames=frames, step_degrees=step_degrees, triangles=int(len(geometry.faces)),
                 host_threads=worker_count(), device=stream.rt.info.description, median_s=_medians(timed),
                 gbuffer=_path(stream), load_average=load, frames_s=timed)
            for stream, timed in zip(streams, per_frame)]


def _path(stream: FrameStream) -> dict[str, str]:
    path = stream.stage.path
    return dict(path=path.path, reason=path.reason)


def orbit_bench(scene: Scene, models: list[Model], runtime: Runtime, width: int | None, height: int | None,
                frames: int, step_degrees: float = 2.0, gbuffer: str | None = None,
                overlap: bool = False) -> dict[str, object]:
    """`clshade bench --whole-frames N`: N whole frames per model (after WARMUP_FRAMES untimed ones each),
    the camera orbiting and the models interleaved at each camera position (with `overlap`, see
    FrameStream.frames, each model's orbit in turn). Per model the frame statistics of whole frames
    (clshade.bench.run.frame_stats: average FPS, 1 % and 0.1 % lows), `whole_frame_ms_median`,
    `whole_frame_low1_fps` and the stage medians."""
    geometry = build_geometry(scene)
    shadows = build_shadow_maps(scene, geometry) if scene.shadow_lights else None
    stream = FrameStream(scene, geometry, shadows, runtime, models, gbuffer)
    base = scene.camera.with_size(width, height)
    cameras = [orbit(base, step_degrees * k) for k in range(frames + 1)]
    timed: dict[str, list[dict[str, float]]] = {m.id: [] for m in models}
    for _ in range(WARMUP_FRAMES):                      # untimed: the path's check, the kernel build, the planes
        for model in models:
            stream.frame(cameras[0], model, copy=False)
    if overlap:
        for model in models:
            timed[model.id] = [t for t, _ in stream.frames(cameras[1:], model, overlap=True, copy=False)]
    else:
        for camera in cameras[1:]:
            for model in models:
                timed[model.id].append(stream.frame(camera, model, copy=False)[0])
    rows = []
    for model in models:
        ms = np.array([f["frame"] for f in timed[model.id]]) * 1e3
        stats = frame_stats(ms, ms)
        stats.pop("host_overhead_ms")           # whole frames: host and device time are one
        medians = _medians(timed[model.id])
        rows.append(dict(model=model.id, name=model.label, frames=frames, **stats,
                         whole_frame_ms_median=medians["frame"] * 1e3, whole_frame_low1_fps=stats["low1_fps"],
                         stage_ms_median={s: medians[s] * 1e3 for s in STAGES}))
    return dict(scene=_shown(scene.path), width=base.width, height=base.height, frames=frames,
                step_degrees=step_degrees, triangles=int(len(geometry.faces)), host_threads=worker_count(),
                device=runtime.info.description, gbuffer=_path(stream), stages=list(STAGES),
                overlap=overlap and stream.stage.path.path == "device", load_average=_load_average(), models=rows)


def _load_average() -> float | None:
    """The 1-minute load average after the frames (how busy the shared machine was), None where unknown."""
    try:
        return round(os.getloadavg()[0], 2)
    except (OSError, AttributeError):
        return None


def _medians(timed: list[dict[str, float]]) -> dict[str, float]:
    return {s: float(np.median([f[s] for f in timed])) for s in (*STAGES, "frame")}


def merge_blocks(blocks: list[list[dict[str, object]]]) -> list[dict[str, object]]:
    """Results of several :func:`whole_frames_on` calls on the same runtimes (blocks run at
    different times of a benchmark, so that no one quiet or busy spell of a shared machine
    decides the figure) as one result per runtime: every block's frames, medians over all."""
    out = []
    for per_runtime in zip(*blocks):
        timed = [f for r in per_runtime for f in r["frames_s"]]
        out.append(dict(per_runtime[0], frames=len(timed), blocks=len(per_runtime), median_s=_medians(timed),
                        block_frame_s=[r["median_s"]["frame"] for r in per_runtime],
                        load_average=[r.get("load_average") for r in per_runtime], frames_s=timed))
    return out
