"""`clshade bench`: frame-time statistics per lighting model, with accuracy next
to time and the distance to the memory-bandwidth floor.

One rasterisation and one upload per G-buffer; then every case (model ×
features) is dispatched `frames` times after `warmup`, interleaved in rounds
(case 1, case 2, …, then the copy kernels, then the next round) so that machine
noise hits every case alike. Per frame: device time from the event profile
(end − start) and host time (enqueue → wait complete). The copy kernel of a
case (kernels/copy.cl: the same channels read, the same float4 written) is the
bandwidth floor; the NumPy float32 baseline (numpy_shading.py) is what a
Python user would otherwise write; the error is against the float64 reference
(reference.py) on the same G-buffer. The JSON schema is docs/bench-schema.md.
"""
from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import os
import platform
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from clshade import __version__

from clshade.verify import reference
from clshade.errors import ClshadeError
from clshade.render.gbuffer import GBuffer
from clshade.models import NONE, Model, resolve, resolve_many
from clshade.bench.numpy_baseline import shade_numpy
from clshade.pipeline import Frame, prepare_frame
from clshade.device.runtime import Runtime, get_runtime
from clshade.render.scene import Light, Scene, load_scene
from clshade.device.shade import Shader, camera_args, pack_lights, scene_features
from clshade.device.variants import Features

SCHEMA = "clshade-bench/1"
OUTPUT_BYTES = 16            # one float4 written per pixel
# Relative error = |L − L_ref| / max(|L_ref|, REL_ERROR_FLOOR · peak(L_ref)): the floor keeps
# near-black pixels (where a 1e-9 absolute difference is "100 %") from dominating.
REL_ERROR_FLOOR = 1e-3
MIN_ALPHA = 1e-4             # kernels/brdf.h: the α floor the reference is given
MIN_N_DOT_V = 1e-4           # kernels/brdf.h: pixels at or below are left out of the error
NUMPY_FRAMES = 3             # NumPy frames per model (median)
MODEL_KEYS = ("model", "name", "mean_ms", "avg_fps", "low1_fps", "low01_fps", "median_ms", "p99_ms",
              "host_overhead_ms", "mpixel_per_s", "bytes_per_pixel", "mean_bytes_per_pixel", "lambert_ratio", "copy_ratio",
              "copy_mean_ms", "numpy_ms", "numpy_ratio", "max_rel_error", "mean_rel_error", "frames")


@dataclass
class Case:
    """One timed configuration: a model on a G-buffer with a feature set."""
    label: str
    model: Model
    features: Features
    shader: Shader
    scene: Scene
    gbuffer: GBuffer
    truth: GBuffer | None = None       # G-buffer the reference reads (default: gbuffer)
    target: Model | None = None        # model the reference evaluates (default: model)
    group: str = ""                    # ladder name
    numpy: bool = True
    device_ms: list[float] = field(default_factory=list)
    host_ms: list[float] = field(default_factory=list)


def frame_stats(device_ms: np.ndarray, host_ms: np.ndarray) -> dict[str, float]:
    """Mean, FPS, 1 % / 0.1 % lows (mean of the slowest 1 % / 0.1 % of frame times, at
    least one frame, as FPS), median, p99 and mean host overhead (host − device)."""
    d = np.sort(np.asarray(device_ms, float))
    if len(d) == 0:
        raise ClshadeError("bench: no frames recorded (use --frames ≥ 1)")
    slow = lambda frac: float(d[-max(1, math.ceil(len(d) * frac)):].mean())  # noqa: E731
    mean = float(d.mean())
    return dict(mean_ms=mean, avg_fps=1e3 / mean, low1_fps=1e3 / slow(0.01), low01_fps=1e3 / slow(0.001),
                median_ms=float(np.median(d)), p99_ms=float(np.percentile(d, 99)),
                host_overhead_ms=float(np.mean(np.asarray(host_ms) - np.asarray(device_ms))))


def with_lights(scene: Scene, count: int) -> Scene:
    """A copy of `scene` with exactly `count` lights: the scene's first lights, then
    directional lights turned about the vertical axis in equal steps from the first
    directional light (or straight down the view axis), each of that light's irradiance."""
    if count < 0:
        raise ClshadeError(f"--lights = {count}: must be ≥ 0")
    lights = list(scene.lights[:count])
    first = next((l for l in scene.lights if l.kind == "directional"), None)
    d0 = first.direction if first is not None else np.array([0.0, 0.0, -1.0])
    color = first.color if first is not None else np.ones(3)
    for k in range(len(lights), count):
        a = 2 * math.pi * k / count
        rot = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
        d = rot @ d0
        lights.append(Light("directional", np.array(color), direction=d / np.linalg.norm(d)))
    return dataclasses.replace(scene, lights=tuple(lights))


# ---------------------------------------------------------------- reference and error


def reference_image(model: Model, gb: GBuffer, scene: Scene, camera) -> tuple[np.ndarray, np.ndarray]:
    """(pixel indices, float64 radiance (K, 3)): n, l, v rebuilt from the G-buffer and
    camera as shade.cl does, reference.brdf · (n·l) · E summed over lights + ambient.
    Covered pixels whose shading normal faces away from the viewer (n·v ≤ MIN_N_DOT_V, at
    silhouettes) are left out: there the reference defines f = 0 while the kernels floor
    n·v, a convention difference rather than an error (their count: `grazing_pixels`)."""
    idx = np.flatnonzero(gb.channels["depth"] > 0)
    idx = idx[_facing(gb, camera, idx)]
    pos, fwd, right, up = (a[:3].astype(float) for a in camera_args(camera))
    px, py = idx % gb.width + 0.5, idx // gb.width + 0.5
    sx, sy = px * (2.0 / gb.width) - 1.0, 1.0 - py * (2.0 / gb.height)
    ray = fwd + sx[:, None] * right + sy[:, None] * up
    v = -ray / np.linalg.norm(ray, axis=1, keepdims=True)
    n = gb.channels["normal"].reshape(-1, 3)[idx].astype(float)
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(ln * ln > 1e-20, n / np.maximum(ln, 1e-300), v)
    base = np.maximum(gb.channels["base"].reshape(-1, 3)[idx].astype(float), 0.0)
    r = np.clip(gb.channels["roughness"][idx].astype(float), 0, 1)
    m = np.clip(gb.channels["metallic"][idx].astype(float), 0, 1)
    rows = (gb.materials.astype(float)[gb.channels["material"][idx].astype(np.intp)] if len(gb.materials)
            else np.zeros((len(idx), 4, 4)))
    kd, ks, ka, shin = rows[:, 0, 0], rows[:, 0, 1], rows[:, 0, 2], rows[:, 0, 3]
    ior, eta, k = rows[:, 1, 0], rows[:, 2, :3], rows[:, 3, :3]
    kdks = model.workflow == "kdks"
    f0 = ((ior - 1) / (ior + 1)) ** 2 if kdks else None
    args = dict(base_color=base, roughness=r, metallic=m, workflow=model.workflow, fresnel=model.fresnel,
                ior=ior, eta=eta, k=k, kd=kd if kdks else 1.0, ks=ks if kdks else 1.0, shininess=shin,
                alpha_floor=MIN_ALPHA)
    if kdks:
        args["f0"] = f0[:, None]
    P = pos + gb.channels["depth"][idx].astype(float)[:, None] * ray
    table = pack_lights(scene.lights).astype(float)
    feats = scene_features(scene)
    L = np.zeros((len(idx), 3))
    o = 0
    for kind, count in (("directional", feats.num_dir), ("point", feats.num_point), ("spot", feats.num_spot)):
        for _ in range(count):
            if kind == "directional":
                l = np.broadcast_to(-table[o, :3], P.shape)
                E = np.broadcast_to(table[o + 1, :3], P.shape)
                o += 2
            else:
                d = table[o, :3] - P
                d2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-8)
                l = d / np.sqrt(d2)[:, None]
                E = table[o + 1, :3] / d2[:, None]
                if kind == "spot":
                    cos_o, cos_i = table[o, 3], table[o + 1, 3]
                    t = np.clip((-l @ table[o + 2, :3] - cos_o) / max(cos_i - cos_o, 1e-6), 0, 1)
                    E = E * (t * t)[:, None]
                o += 2 if kind == "point" else 3
            f = reference.brdf(model.diffuse, model.specular, n, l, v, **args)
            nl = np.einsum("ij,ij->i", n, l)
            L += np.where((nl > 0)[:, None], f * (E * np.maximum(nl, 0)[:, None]), 0.0)
    if any(a > 0 for a in scene.ambient):
        if kdks:
            dc, spec0, wd, ws, wa = base, np.repeat(f0[:, None], 3, 1), kd, ks, ka
        else:
            dc, spec0 = base * (1 - m)[:, None], 0.04 * (1 - m)[:, None] + base * m[:, None]
            wd = ws = wa = np.ones(len(idx))
        amb = np.zeros_like(L)
        if model.diffuse != NONE:
            coupled = not kdks and model.specular != NONE and model.uses_fresnel
            amb += (1 - spec0 if coupled else wd[:, None]) * dc     # compose.h ambient_term
        if model.specular != NONE:
            amb += ws[:, None] * spec0
        occlusion = np.clip(gb.channels["occlusion"][idx], 0, 1)[:, None] if "occlusion" in gb.channels else 1.0
        L += wa[:, None] * np.asarray(scene.ambient, float) * amb * occlusion
    if "emissive" in gb.channels:   # shade.cl: emitted radiance added unlit
        L += np.maximum(gb.channels["emissive"].reshape(-1, 3)[idx].astype(float), 0.0)
    return idx, L


def _view_rays(gb: GBuffer, camera, idx: np.ndarray) -> np.ndarray:
    _, fwd, right, up = (a[:3].astype(float) for a in camera_args(camera))
    sx = (idx % gb.width + 0.5) * (2.0 / gb.width) - 1.0
    sy = 1.0 - (idx // gb.width + 0.5) * (2.0 / gb.height)
    return fwd + sx[:, None] * right + sy[:, None] * up


def _facing(gb: GBuffer, camera, idx: np.ndarray) -> np.ndarray:
    """Mask of pixels whose normal faces the viewer: n·v > MIN_N_DOT_V (kernels/brdf.h)."""
    ray = _view_rays(gb, camera, idx)
    n = gb.channels["normal"].reshape(-1, 3)[idx].astype(float)
    nv = -np.einsum("ij,ij->i", n, ray) / np.linalg.norm(ray, axis=1) / np.maximum(np.linalg.norm(n, axis=1), 1e-300)
    return nv > MIN_N_DOT_V


def grazing_pixels(gb: GBuffer, camera) -> int:
    """Covered pixels left out of the error (normal facing away from the viewer)."""
    idx = np.flatnonzero(gb.channels["depth"] > 0)
    return int(np.count_nonzero(~_facing(gb, camera, idx)))


def relative_error(image: np.ndarray, idx: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    """(max, mean) over covered pixels of the per-pixel largest channel relative error."""
    if len(idx) == 0:
        return 0.0, 0.0
    got = image.reshape(-1, 4)[idx, :3].astype(float)
    floor = REL_ERROR_FLOOR * max(float(np.abs(ref).max()), 1e-30)
    err = (np.abs(got - ref) / np.maximum(np.abs(ref), floor)).max(axis=1)
    return float(err.max()), float(err.mean())


# ---------------------------------------------------------------- running


def _progress(done: int, total: int, start: float, enabled: bool) -> None:
    if not enabled:
        return
    width = 30
    filled = int(width * done / max(total, 1))
    eta = (time.perf_counter() - start) / max(done, 1) * (total - done)
    sys.stderr.write(f"\rbench [{'#' * filled}{'.' * (width - filled)}] {done}/{total} rounds, {eta:5.0f} s left")
    if done == total:
        sys.stderr.write("\n")
    sys.stderr.flush()


def _timed(shader: Shader, dispatch) -> tuple[float, float]:
    t0 = time.perf_counter()
    event = shader.enqueue(dispatch)
    event.wait()
    host = (time.perf_counter() - t0) * 1e3
    return (event.profile.end - event.profile.start) * 1e-6, host


def run_cases(cases: list[Case], frames: int, warmup: int, progress: bool = True) -> dict[tuple, list[float]]:
    """Time every case and its copy kernel, interleaved in rounds; fills case.device_ms /
    host_ms and returns copy device times per copy key (shader, channels, half)."""
    shade = [c.shader.prepare(c.model, c.features) for c in cases]
    copies: dict[tuple, tuple[Shader, object]] = {}
    for c, d in zip(cases, shade):
        key = (id(c.shader), d.variant.channels, c.features.half_gbuffer)
        copies.setdefault(key, (c.shader, c.shader.prepare(c.model, c.features, entry="copy")))
    copy_ms: dict[tuple, list[float]] = {k: [] for k in copies}
    for _ in range(warmup):
        for c, d in zip(cases, shade):
            _timed(c.shader, d)
        for shader, d in copies.values():
            _timed(shader, d)
    start = time.perf_counter()
    for r in range(frames):
        for c, d in zip(cases, shade):
            dev, host = _timed(c.shader, d)
            c.device_ms.append(dev)
            c.host_ms.append(host)
        for key, (shader, d) in copies.items():
            copy_ms[key].append(_timed(shader, d)[0])
        if progress and (r % max(1, frames // 100) == 0 or r == frames - 1):
            _progress(r + 1, frames, start, progress)
    return copy_ms


def summarize(cases: list[Case], copy_ms: dict[tuple, list[float]], numpy_frames: int = NUMPY_FRAMES,
              error: bool = True) -> list[dict]:
    """Per-case rows with every key of MODEL_KEYS (plus label, group, features)."""
    rows, lambert_ms = [], None
    refs: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
    for c in cases:
        variant = c.shader.variant(c.model, c.features)
        stats = frame_stats(np.array(c.device_ms), np.array(c.host_ms))
        copy_key = (id(c.shader), variant.channels, c.features.half_gbuffer)
        copy_mean = float(np.mean(copy_ms[copy_key]))
        row: dict[str, object] = dict(model=c.model.id, name=c.model.label, label=c.label, group=c.group,
                                      frames=len(c.device_ms), **stats)
        row["mpixel_per_s"] = c.gbuffer.pixels / (stats["mean_ms"] * 1e3)
        row["channels"] = list(variant.channels)
        row["bytes_per_pixel"] = c.gbuffer.bytes_per_pixel(variant.channels, c.features.half_gbuffer) + OUTPUT_BYTES
        row["mean_bytes_per_pixel"] = c.gbuffer.mean_bytes_per_pixel(
            variant.channels, c.features.half_gbuffer, c.shader.rt.simd, OUTPUT_BYTES)
        row["copy_mean_ms"] = copy_mean
        row["copy_ratio"] = stats["mean_ms"] / copy_mean
        row["fast_math"], row["half_gbuffer"] = c.features.fast_math, c.features.half_gbuffer
        row["lights"] = c.features.num_lights
        if c.model.id == "lambert" and not (c.features.fast_math or c.features.half_gbuffer) and lambert_ms is None:
            lambert_ms = stats["mean_ms"]
        image = c.shader.render(c.model, c.features) if error or c.numpy else None
        if c.numpy:
            times = []
            for _ in range(max(1, numpy_frames)):
                t0 = time.perf_counter()
                shade_numpy(c.model, c.gbuffer, c.scene, c.shader.camera, c.features.half_gbuffer)
                times.append((time.perf_counter() - t0) * 1e3)
            row["numpy_ms"] = float(np.median(times))
            row["numpy_ratio"] = row["numpy_ms"] / stats["mean_ms"]
        else:
            row["numpy_ms"] = row["numpy_ratio"] = None
        if error:
            target = c.target or c.model
            truth = c.truth or c.gbuffer
            key = (target.id, id(truth), id(c.scene))
            if key not in refs:
                refs[key] = reference_image(target, truth, c.scene, c.shader.camera)
            row["max_rel_error"], row["mean_rel_error"] = relative_error(image, *refs[key])
            row["error_target"] = target.id
        else:
            row["max_rel_error"] = row["mean_rel_error"] = None
        rows.append(row)
    for row in rows:
        row["lambert_ratio"] = row["mean_ms"] / lambert_ms if lambert_ms else None
    return rows


def pareto(points: list[tuple[float, float]]) -> list[bool]:
    """True where no other point is at most as slow and at most as wrong (and better in one)."""
    out = []
    for i, (t, e) in enumerate(points):
        dominated = any((t2 <= t and e2 <= e) and (t2 < t or e2 < e) for j, (t2, e2) in enumerate(points) if j != i)
        out.append(not dominated)
    return out


# ---------------------------------------------------------------- setup


@dataclass
class Bench:
    """A prepared frame and runtime; builds cases on it."""
    frame: Frame
    runtime: Runtime
    features: Features
    device: str | None = None
    shaders: dict[int, Shader] = field(default_factory=dict)

    @classmethod
    def prepare(cls, scene: Scene | str | Path, width: int | None = None, height: int | None = None,
                lights: int | None = None, device: str | None = None) -> "Bench":
        scene = scene if isinstance(scene, Scene) else load_scene(scene)
        if lights is not None:
            scene = with_lights(scene, lights)
        frame = prepare_frame(scene, width, height)
        return cls(frame, get_runtime(device), scene_features(frame.scene), device)

    def shader(self, gbuffer: GBuffer | None = None, scene: Scene | None = None) -> Shader:
        """The Shader for (gbuffer, scene), uploaded once. Shaders share the runtime:
        Shader.prepare binds each dispatch's arguments on its own cl.Kernel object."""
        gb, sc = gbuffer or self.frame.gbuffer, scene or self.frame.scene
        key = hash((id(gb), id(sc)))
        if key not in self.shaders:
            self.shaders[key] = Shader(self.runtime, gb, sc, self.frame.camera)
        return self.shaders[key]

    def case(self, model: Model, *, label: str = "", half: bool = False, fast_math: bool = False,
             gbuffer: GBuffer | None = None, scene: Scene | None = None, target: Model | None = None,
             group: str = "", numpy: bool = True) -> Case:
        sc = scene or self.frame.scene
        gb = gbuffer or self.frame.gbuffer
        features = dataclasses.replace(scene_features(sc), half_gbuffer=half, fast_math=fast_math)
        return Case(label or model.id, model, features, self.shader(gb, sc), sc, gb,
                    target=target, group=group, numpy=numpy)

    def metal_gbuffer(self) -> GBuffer:
        """The G-buffer with every covered pixel a conductor: metallic 1, base colour the
        normal-incidence reflectance of the first material's η + ik (Schlick's F0)."""
        gb = self.frame.gbuffer
        row = gb.materials[0] if len(gb.materials) else np.zeros((4, 4), np.float32)
        eta, k = row[2, :3].astype(float), row[3, :3].astype(float)
        f0 = ((eta - 1) ** 2 + k ** 2) / ((eta + 1) ** 2 + k ** 2)
        cov = gb.channels["depth"] > 0
        channels = dict(gb.channels)
        base = gb.channels["base"].reshape(-1, 3).copy()
        base[cov] = f0.astype(np.float32)
        metal = gb.channels["metallic"].copy()
        metal[cov] = 1.0
        channels["base"], channels["metallic"] = base.reshape(-1), metal
        return dataclasses.replace(gb, channels=channels)


def ladder_cases(bench: Bench) -> list[Case]:
    """The approximation ladders, each rung's error against the ladder's exact model."""
    ggx = resolve("ggx_correlated")
    ggx_diel = resolve("ggx_correlated@dielectric")
    ggx_cond = resolve("ggx_correlated@conductor")
    metal = bench.metal_gbuffer()
    out = [
        bench.case(ggx, label="Schlick (dielectric F0 0.04)", target=ggx_diel, group="fresnel-dielectric"),
        bench.case(ggx_diel, label="exact dielectric", group="fresnel-dielectric"),
        bench.case(ggx, label="Schlick (conductor F0)", gbuffer=metal, target=ggx_cond, group="fresnel-conductor"),
        bench.case(ggx_cond, label="exact conductor", gbuffer=metal, group="fresnel-conductor"),
        bench.case(resolve("lambert+ggx_smith_schlick"), label="Smith–Schlick k=α/2", target=ggx, group="smith"),
        bench.case(resolve("walter_ggx"), label="separable Smith (Walter)", target=ggx, group="smith"),
        bench.case(ggx, label="height-correlated Smith", group="smith"),
        bench.case(ggx, label="precise math", group="math"),
        bench.case(ggx, label="-cl-fast-relaxed-math", fast_math=True, group="math"),
        bench.case(ggx, label="float32 G-buffer", group="storage"),
        bench.case(ggx, label="half normal/base", half=True, group="storage"),
    ]
    for c in out:
        c.numpy = False
    return out


def machine_info(runtime: Runtime) -> dict[str, object]:
    """Machine and OpenCL device description for the JSON."""
    return dict(
        machine=dict(processor=platform.processor() or platform.machine(), machine=platform.machine(),
                     cpu_count=os.cpu_count(), os=platform.platform(), python=platform.python_version(),
                     numpy=np.__version__),
        device=dict(name=runtime.info.device, platform=runtime.info.platform,
                    platform_version=runtime.info.platform_version, kind=runtime.info.kind,
                    local_size=runtime.local_size),
    )


def report(bench: Bench, rows: list[dict], frames: int, warmup: int, ladder: list[dict] | None = None) -> dict:
    """The JSON document (docs/bench-schema.md)."""
    fr = bench.frame
    return dict(schema=SCHEMA, clshade_version=__version__, created=time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                **machine_info(bench.runtime),
                scene=str(fr.scene.path) if fr.scene.path else None, width=fr.camera.width, height=fr.camera.height,
                pixels=fr.gbuffer.pixels, covered_pixels=int(fr.gbuffer.coverage.sum()),
                grazing_pixels=grazing_pixels(fr.gbuffer, fr.camera),
                frames=frames, warmup=warmup, features=dataclasses.asdict(bench.features),
                error_definition=f"|L - L_ref| / max(|L_ref|, {REL_ERROR_FLOOR:g} * peak(L_ref)), "
                                 "largest channel per covered pixel with n.v > 1e-4, L_ref float64 (clshade.verify.reference)",
                models=rows, ladder=ladder or [])


# ---------------------------------------------------------------- output


def _fmt(x: object, spec: str) -> str:
    return "—" if x is None else format(x, spec)


def table(rows: list[dict], ladder: bool = False) -> str:
    """A Markdown table of the rows."""
    if ladder:
        head = "| ladder | rung | model | mean ms | copy × | max rel err | mean rel err | error vs | Pareto |"
        out = [head, "|" + "---|" * 9]
        for r in rows:
            out.append(f"| {r['group']} | {r['label']} | {r['model']} | {r['mean_ms']:.2f} | {r['copy_ratio']:.2f} | "
                       f"{_fmt(r['max_rel_error'], '.2e')} | {_fmt(r['mean_rel_error'], '.2e')} | "
                       f"{r.get('error_target', '')} | {'●' if r.get('pareto') else ''} |")
        return "\n".join(out)
    head = ("| model | mean ms | avg FPS | 1 % low | 0.1 % low | median ms | p99 ms | host ms | Mpix/s | B/px | "
            "mean B/px | × Lambert | × copy | NumPy ms | × NumPy | max rel err | mean rel err |")
    out = [head, "|" + "---|" * 17]
    for r in rows:
        out.append(f"| {r['label']} | {r['mean_ms']:.2f} | {r['avg_fps']:.1f} | {r['low1_fps']:.1f} | "
                   f"{r['low01_fps']:.1f} | {r['median_ms']:.2f} | {r['p99_ms']:.2f} | "
                   f"{r['host_overhead_ms']:.3f} | {r['mpixel_per_s']:.1f} | {r['bytes_per_pixel']} | "
                   f"{r['mean_bytes_per_pixel']:.1f} | {_fmt(r['lambert_ratio'], '.2f')} | {r['copy_ratio']:.2f} | {_fmt(r['numpy_ms'], '.1f')} | "
                   f"{_fmt(r['numpy_ratio'], '.1f')} | {_fmt(r['max_rel_error'], '.2e')} | "
                   f"{_fmt(r['mean_rel_error'], '.2e')} |")
    return "\n".join(out)


def write_csv(rows: list[dict], path: Path) -> None:
    keys = list(MODEL_KEYS) + [k for k in rows[0] if k not in MODEL_KEYS] if rows else list(MODEL_KEYS)
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        writer.writeheader()
        for r in rows:
            writer.writerow({k: (";".join(v) if isinstance(v, list) else v) for k, v in r.items()})


def _pyplot():
    try:
        import matplotlib
    except ImportError as exc:
        raise ClshadeError("--plot needs matplotlib: pip install 'clshade[bench]'") from exc
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _finish(plt, fig, ax, path: Path, title: str, legend_size: int) -> None:
    """Title, legend, tight layout; write the PNG and close the figure."""
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=legend_size)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_fps(rows: list[dict], path: Path, title: str) -> None:
    """Bar chart: average FPS with 1 % and 0.1 % lows per model."""
    plt = _pyplot()
    x = np.arange(len(rows))
    fig, ax = plt.subplots(figsize=(max(6, 0.9 * len(rows) + 2), 4.5))
    w = 0.27
    for off, key, name in ((-w, "avg_fps", "average"), (0, "low1_fps", "1 % low"), (w, "low01_fps", "0.1 % low")):
        bars = ax.bar(x + off, [r[key] for r in rows], w, label=name)
        ax.bar_label(bars, fmt="%.1f", fontsize=6, rotation=90, padding=2)
    ax.set_xticks(x, [r["label"] for r in rows], rotation=35, ha="right", fontsize=8)
    ax.set_ylabel("frames per second")
    _finish(plt, fig, ax, path, title, legend_size=8)


def plot_ladder(rows: list[dict], path: Path, title: str) -> None:
    """Time vs error (log error axis), Pareto front of each ladder marked with a ring."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for group in dict.fromkeys(r["group"] for r in rows):
        pts = [r for r in rows if r["group"] == group]
        errs = [max(r["mean_rel_error"], 1e-9) for r in pts]
        sc = ax.scatter([r["mean_ms"] for r in pts], errs, label=group)
        for r, e in zip(pts, errs):
            ax.annotate(r["label"], (r["mean_ms"], e), fontsize=6, xytext=(3, 3), textcoords="offset points")
            if r.get("pareto"):
                ax.scatter([r["mean_ms"]], [e], s=160, facecolors="none", edgecolors=sc.get_facecolor()[0])
    ax.set_yscale("log")
    ax.set_xlabel("mean frame time (ms)")
    ax.set_ylabel("mean relative error vs the ladder's exact model (float64)")
    _finish(plt, fig, ax, path, title, legend_size=7)


def mark_pareto(rows: list[dict]) -> None:
    """Set row['pareto'] within each ladder group (time vs mean error)."""
    for group in dict.fromkeys(r["group"] for r in rows):
        pts = [r for r in rows if r["group"] == group]
        for r, front in zip(pts, pareto([(r["mean_ms"], r["mean_rel_error"]) for r in pts])):
            r["pareto"] = front


# ---------------------------------------------------------------- CLI


def add_parser(sub, checks) -> None:
    p = sub.add_parser("bench", help="frame-time statistics, accuracy and bandwidth floor per model",
                       description="Rasterise SCENE once, dispatch each model's kernel N times and report FPS "
                                   "with 1 % and 0.1 % lows, the copy-kernel floor, the NumPy float32 "
                                   "baseline and the error against the float64 reference.")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("-m", "--models", default="all", help="comma-separated models, a group or 'all' (default)")
    p.add_argument("--frames", type=int, default=1000, help="timed frames per model (default 1000)")
    p.add_argument("--warmup", type=int, default=10, help="untimed frames per kernel first (default 10)")
    p.add_argument("--width", type=int, help="override camera.width")
    p.add_argument("--height", type=int, help="override camera.height")
    p.add_argument("--lights", type=int, help="use exactly N lights (extra directional lights are added)")
    p.add_argument("--ladder", action="store_true", help="also run the approximation ladders")
    p.add_argument("--numpy-frames", type=int, default=NUMPY_FRAMES, help="NumPy frames per model (median)")
    p.add_argument("--json", metavar="OUT", help="write the results as JSON (docs/bench-schema.md)")
    p.add_argument("--csv", metavar="OUT", help="write the per-model table as CSV")
    p.add_argument("--plot", metavar="OUT.png", help="bar chart of FPS and lows (ladder plot beside it)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--device", metavar="D", help="OpenCL device (see `clshade devices`)")
    p.set_defaults(func=cmd_bench)


PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg")


def check_outputs(args: argparse.Namespace) -> None:
    """Every output path, and matplotlib for --plot, before the benchmark runs."""
    from clshade.outputs import check_output_file
    if args.json:
        check_output_file(args.json, "--json")
    if args.csv:
        check_output_file(args.csv, "--csv")
    if args.plot:
        check_output_file(args.plot, "--plot", PLOT_SUFFIXES)
        _pyplot()


def cmd_bench(args: argparse.Namespace) -> int:
    if args.frames < 1 or args.warmup < 0:
        raise ClshadeError(f"--frames = {args.frames}, --warmup = {args.warmup}: need frames ≥ 1, warmup ≥ 0")
    check_outputs(args)
    models = resolve_many(args.models)
    bench = Bench.prepare(args.scene, args.width, args.height, args.lights, args.device)
    cases = [bench.case(m, label=m.label) for m in models]
    ladder = ladder_cases(bench) if args.ladder else []
    copy_ms = run_cases(cases + ladder, args.frames, args.warmup, progress=not args.no_progress)
    rows = summarize(cases, copy_ms, args.numpy_frames)
    ladder_rows = summarize(ladder, copy_ms) if ladder else []
    mark_pareto(ladder_rows)
    doc = report(bench, rows, args.frames, args.warmup, ladder_rows)
    cam = bench.frame.camera
    print(f"{Path(args.scene).name} {cam.width}x{cam.height}, {args.frames} frames after {args.warmup} warm-up, "
          f"{bench.features.num_lights} lights, device {bench.runtime.info.description}")
    print(table(rows))
    if ladder_rows:
        print()
        print(table(ladder_rows, ladder=True))
    if args.json:
        Path(args.json).write_text(json.dumps(doc, indent=2, ensure_ascii=False), encoding="utf-8")
    if args.csv:
        write_csv(rows, Path(args.csv))
    if args.plot:
        title = f"{Path(args.scene).stem} {cam.width}x{cam.height}, {bench.runtime.info.device}"
        plot_fps(rows, Path(args.plot), title)
        if ladder_rows:
            out = Path(args.plot)
            plot_ladder(ladder_rows, out.with_name(out.stem + "_ladder" + out.suffix), title)
    return 0
