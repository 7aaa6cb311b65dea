"""Every OpenCL runtime present on one frame: health, what each build gets, kernel times and
the error against the float64 oracle.

Every device listed is probed (clshade/device/health.py); every healthy one shades the same
G-buffer with each model of MODELS and its copy kernel, interleaved in the same rounds with perf's
protocol (`measure`: noise hits every runtime alike), and its image is compared with the float64
frame oracle on the same pixels as `clshade bench`. The runtimes are ranked by the geometric mean
of their models' median kernel times; the document says which device the default selection picks
and whether it is the fastest (the order of clshade.device.runtime.RUNTIME_PREFERENCE;
tests/device/test_runtimes.py checks the committed result). benchmarks/measure/runtimes.py writes it,
clshade.report.runtimes renders it.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from clshade import __version__
from clshade.bench import perf
from clshade.bench.run import compared_pixels, relative_error
from clshade.device import health
from clshade.device.runtime import RUNTIME_PREFERENCE, Runtime, choose_device, device_health, list_devices
from clshade.device.shade import Shader, scene_features
from clshade.models.registry import Registry
from clshade.pipeline import prepare_frame
from clshade.render.scene import load_scene
from clshade.verify import reference

SCHEMA = "clshade-runtimes/1"
MODELS = ("lambert", "ggx_correlated", "phong", "oren_nayar+cook_torrance@dielectric")


def device_rows() -> list[dict]:
    """Every device listed, its health and (healthy ones) what its builds get."""
    rows = []
    for info, device in list_devices():
        state = device_health(info, device)
        row = dict(spec=info.spec, runtime=info.runtime, device=info.device, kind=info.kind,
                   platform=info.platform, platform_version=info.platform_version,
                   driver=str(device.driver_version), healthy=state.ok, reason=state.reason,
                   fp64="cl_khr_fp64" in device.extensions)
        if state.ok:
            rt = Runtime(info.spec)
            row.update(simd=rt.simd, inline_math=rt.inline_math, streaming_stores=rt.streaming_stores,
                       prefetch=rt.prefetches, local_size=rt.local_size, choice=rt.choice.label(),
                       choice_source=rt.choice_source)
        rows.append(row)
    return rows


def _device_ms(shader: Shader, dispatch) -> float:
    event = shader.enqueue(dispatch)
    event.wait()
    return (event.profile.end - event.profile.start) * 1e-6


def measure(scene_path: str, width: int, height: int, rounds: int, warmup: int, seed: int = 24) -> dict:
    """Time every healthy device × model (and its copy kernel) on one frame, and check each image
    against the float64 oracle. Protocol as perf's: each round runs every item in a new random order
    (seeded); each item starts with the process idle (perf.settle: one runtime's worker threads
    spinning after its dispatch must not slow the next runtime's) and is timed as the second of two
    back-to-back runs (perf.timed_after_itself); medians over the rounds."""
    devices = device_rows()
    healthy = [d for d in devices if d["healthy"]]
    scene = load_scene(scene_path)
    frame = prepare_frame(scene, width, height)
    feats = scene_features(frame.scene, geometry=frame.geometry)
    vis = (reference.visibility(frame.gbuffer, frame.scene, frame.shadows, frame.camera)
           if feats.shadows else None)
    models = [Registry().resolve(m) for m in MODELS]
    idx = compared_pixels(frame.gbuffer, frame.camera)
    truth = {m.id: reference.radiance(frame.gbuffer, frame.scene, m, visibility=vis,
                                      camera=frame.camera).reshape(-1, 3)[idx] for m in models}
    items: list[tuple[str, str, str, Shader, object]] = []
    for d in healthy:
        shader = Shader(Runtime(d["spec"]), frame.gbuffer, frame.scene, frame.camera, frame.shadows)
        d["models"] = {}
        for m in models:
            image = shader.render(m, feats)
            err_max, err_mean = relative_error(image, idx, truth[m.id])
            d["models"][m.id] = dict(max_rel_error=err_max, mean_rel_error=err_mean)
            for entry in ("shade", "copy"):
                items.append((d["spec"], m.id, entry, shader, shader.prepare(m, feats, entry=entry)))
    times: dict[tuple[str, str, str], list[float]] = {it[:3]: [] for it in items}
    rng = np.random.default_rng(seed)
    for r in range(warmup + rounds):
        for k in rng.permutation(len(items)):
            spec, mid, entry, shader, dispatch = items[k]
            perf.settle()
            ms = perf.timed_after_itself(lambda: _device_ms(shader, dispatch))
            if r >= warmup:
                times[(spec, mid, entry)].append(ms)
    for d in healthy:
        for mid, row in d["models"].items():
            shade, copy = np.array(times[(d["spec"], mid, "shade")]), np.array(times[(d["spec"], mid, "copy")])
            row.update(median_ms=float(np.median(shade)), mean_ms=float(shade.mean()),
                       avg_fps=1e3 / float(shade.mean()),
                       low1_fps=1e3 / float(np.sort(shade)[-max(1, len(shade) // 100):].mean()),
                       copy_ratio=float(np.median(shade) / np.median(copy)))
        d["geomean_median_ms"] = math.exp(float(np.mean([math.log(v["median_ms"]) for v in d["models"].values()])))
    ranked = sorted(healthy, key=lambda d: d["geomean_median_ms"])
    default = choose_device(None).info
    fastest_cpu = next((d for d in ranked if "cpu" in d["kind"]), None)
    return dict(
        schema=SCHEMA, clshade_version=__version__,
        created=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        environment=health.build_environment(),
        scene=str(Path(scene_path).name), width=width, height=height, pixels=frame.gbuffer.pixels,
        covered_pixels=int(frame.gbuffer.coverage.sum()), compared_pixels=int(len(idx)), rounds=rounds,
        warmup=warmup, seed=seed, timed_run=perf.TIMED_RUN,
        models=[m.id for m in models], devices=devices,
        ranking=[d["spec"] for d in ranked],
        runtime_preference=list(RUNTIME_PREFERENCE),
        default=dict(spec=default.spec, runtime=default.runtime),
        fastest_cpu=dict(spec=fastest_cpu["spec"], runtime=fastest_cpu["runtime"]) if fastest_cpu else None,
        gpu=("measured" if any("gpu" in d["kind"] for d in healthy)
             else "not run: no GPU OpenCL device on this machine"),
    )
