"""Whole frames: what a user waits for per frame, stage by stage, with the camera
moving between frames (nothing of the previous frame's raster or G-buffer is
reused; the rasterizer keeps its empty scratch arrays between calls, as in any
program that renders more than once).

Per frame, the host stages on clshade.render.arrays.worker_count() threads:
rasterize (clshade.render.raster) → G-buffer (clshade.render.gbuffer) → upload the channels the variant reads → shade (one dispatch) → read back the
image. Geometry, shadow maps (they depend on the lights, not the camera) and
the kernel build are made once before the timed frames, as an interactive
viewer would. The camera orbits the target about the vertical axis by
`step_degrees` a frame. The FPS tables of `clshade bench` time the shading
dispatch alone; this is the figure beside them.
"""
from __future__ import annotations

import dataclasses
import math
import os
import time
from pathlib import Path

import numpy as np

from clshade.device.runtime import Runtime
from clshade.device.shade import Shader, scene_features
from clshade.models.model import Model
from clshade.render.arrays import worker_count
from clshade.render.gbuffer import build_gbuffer
from clshade.render.meshes import build_geometry
from clshade.render.raster import rasterize
from clshade.render.scene import Camera, Scene
from clshade.render.shadows import build_shadow_maps

STAGES = ("rasterize", "g-buffer", "upload", "shade", "read back")


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
    """Per-stage seconds of `frames` whole frames (after one untimed frame);
    returns medians per stage, the median whole frame and every frame's stages."""
    return whole_frames_on(scene, model, [runtime], width, height, frames, step_degrees)[0]


def whole_frames_on(scene: Scene, model: Model, runtimes: list[Runtime], width: int, height: int,
                    frames: int = 10, step_degrees: float = 2.0) -> list[dict[str, object]]:
    """:func:`whole_frames` on each runtime, interleaved: every camera position is rendered on
    each runtime in turn, so that a slow spell of a shared machine falls on all of them alike.
    One result per runtime, in order, each naming its device."""
    geometry = build_geometry(scene)
    shadows = build_shadow_maps(scene, geometry) if scene.shadow_lights else None
    features = scene_features(scene, geometry=geometry)
    base = scene.camera.with_size(width, height)
    per_frame: list[list[dict[str, float]]] = [[] for _ in runtimes]
    for k in range(frames + 1):
        camera = orbit(base, step_degrees * k)
        for runtime, timed in zip(runtimes, per_frame):
            t0 = time.perf_counter()
            fragments = rasterize(geometry.vertices, geometry.faces, camera.view_matrix(),
                                  camera.projection_matrix(), camera.width, camera.height,
                                  cull_backfaces=geometry.cull)
            t1 = time.perf_counter()
            gbuffer = build_gbuffer(scene, geometry, fragments, camera)
            t2 = time.perf_counter()
            shader = Shader(runtime, gbuffer, scene, camera, shadows)
            dispatch = shader.prepare(model, features)        # built once: later frames hit the cache
            runtime.queue.finish()
            t3 = time.perf_counter()
            shader.enqueue(dispatch).wait()
            t4 = time.perf_counter()
            shader.read()
            t5 = time.perf_counter()
            t = dict(zip(STAGES, (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4)))
            t["frame"] = t5 - t0
            if k > 0:
                timed.append(t)
    load = _load_average()
    return [dict(scene=_shown(scene.path), model=model.id, width=width, height=height,
                 frames=frames, step_degrees=step_degrees, triangles=int(len(geometry.faces)),
                 host_threads=worker_count(), device=runtime.info.description, median_s=_medians(timed),
                 load_average=load, frames_s=timed) for runtime, timed in zip(runtimes, per_frame)]


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
