"""The NumPy baseline the benchmark times: the frame oracle
(clshade.verify.reference.radiance) instantiated in float32.

Not a second light loop: the same function as the float64 reference, with
``dtype=np.float32``, so it does exactly the work the model needs (its lobes,
the lit pixels of each light, the covered pixels only) and is what a Python
user would otherwise write. NumPy's element-wise operations run on one
thread (NUMPY_THREADS); the benchmark states it beside the device's.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from clshade.models import Model
from clshade.render.gbuffer import GBuffer
from clshade.render.scene import Camera, Scene
from clshade.render.shadows import ShadowMaps
from clshade.verify.reference import radiance

NUMPY_THREADS = 1     # NumPy ufuncs are single-threaded; the oracle's per-pixel path calls no BLAS routine


def half_gbuffer(gb: GBuffer) -> GBuffer:
    """The G-buffer with normal and base colour rounded to half floats, as the device reads them."""
    channels = {**gb.channels, **{k: gb.channel(k, half=True).astype(np.float32) for k in ("normal", "base")}}
    return dataclasses.replace(gb, channels=channels, unit_normals=False)   # half normals are not unit


def shade_numpy(model: Model, gb: GBuffer, scene: Scene, camera: Camera, half: bool = False,
                shadows: ShadowMaps | None = None) -> np.ndarray:
    """The shaded image, (H, W, 4) float32: float32 radiance, coverage in alpha (the
    scene's background and its alpha 0 where empty, as the kernel writes them). With
    `shadows`, the shadow-map lookups are part of the work, as in the kernel."""
    rgb = radiance(half_gbuffer(gb) if half else gb, scene, model, dtype=np.float32, camera=camera, shadows=shadows)
    alpha = gb.coverage.astype(np.float32)[..., None]
    return np.concatenate([rgb, alpha], axis=-1)
