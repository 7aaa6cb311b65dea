"""`clshade bench`: frame-time statistics per lighting model, with accuracy next
to time and the distance to the memory-bandwidth floor.

One rasterisation and one upload per G-buffer; then every case (model ×
features) is dispatched `frames` times after `warmup`, interleaved in rounds
(case 1, case 2, …, then the copy kernels, then the next round) so that machine
noise hits every case alike. Per frame: device time from the event profile
(end − start) and host time (enqueue → wait complete). The copy kernel of a
case (kernels/copy.cl: the same channels read, the same float4 written) is the
bandwidth floor. The NumPy baseline (numpy_baseline.py: what a NumPy user
would write, specialised to the scene; checked against the kernel's image
first) and the general reference in float32 (the frame oracle in float32) are
timed in the same rounds, on the same wall clock as the kernel's host time
(enqueue → completion), and beside them a minimal NumPy Lambert, the guard
that marks the NumPy column suspect when the baseline's Lambert is more than
SUSPECT_RATIO times slower. The error is against the float64 frame oracle
(clshade.verify.reference.radiance) on the same G-buffer. The JSON schema is
docs/bench-schema.md; Markdown, CSV and plots are clshade.report's.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from clshade import __version__
from clshade.provenance import stamp
from clshade.bench.numpy_baseline import (GUARD_FRAMES, NUMPY_THREADS, SUSPECT_RATIO, NumpyShader, Unsupported, minimal_lambert,
                                          numpy_shader, shade_reference_f32, suspect)
from clshade.bench.peers import VERIFY_RTOL, verify, well_conditioned
from clshade.device.runtime import Runtime, get_runtime
from clshade.device.shade import Shader, scene_features
from clshade.device.timing import timed_dispatch
from clshade.device.variants import Features
from clshade.errors import ClshadeError
from clshade.models.model import Model, preset
from clshade.models.registry import Registry
from clshade.pipeline import Frame, prepare_frame, reads_tangents
from clshade.render.gbuffer import GBuffer
from clshade.render.scene import Light, Scene, load_scene
from clshade.resources import constant
from clshade.verify import reference
from clshade.bench import NUMPY_FRAMES       # the default of --numpy-frames (defined light, for the CLI parser)

SCHEMA = "clshade-bench/1"
OUTPUT_BYTES = 16            # one float4 written per pixel
# Relative error = |L − L_ref| / max(|L_ref|, REL_ERROR_FLOOR · peak(L_ref)): the floor keeps
# near-black pixels (where a 1e-9 absolute difference is "100 %") from dominating.
REL_ERROR_FLOOR = 1e-3
MODEL_KEYS = ("model", "name", "mean_ms", "avg_fps", "low1_fps", "low01_fps", "median_ms", "p99_ms",
              "host_overhead_ms", "mpixel_per_s", "bytes_per_pixel", "mean_bytes_per_pixel", "lambert_ratio", "copy_ratio",
              "copy_mean_ms", "wall_median_ms", "numpy_ms", "numpy_ratio", "numpy_frames", "numpy_layout",
              "numpy_check", "numpy_note", "reference_ms", "reference_ratio", "max_rel_error", "mean_rel_error", "frames")


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
    visibility: np.ndarray | None = None   # shadow factors of the scene's lights (None = no shadows)
    device_ms: list[float] = field(default_factory=list)
    host_ms: list[float] = field(default_factory=list)
    numpy_ms: list[float] = field(default_factory=list)
    reference_ms: list[float] = field(default_factory=list)
    baseline: NumpyShader | None = None    # the NumPy baseline, once checked against the kernel's image
    numpy_check: float | None = None       # its largest relative difference from the kernel's image
    numpy_note: str = ""                   # why there is no NumPy time


@dataclass
class Guard:
    """The straw-man guard: the baseline's Lambert and a minimal NumPy Lambert on the same
    G-buffer, timed in pairs (GUARD_FRAMES of them) spread over the same rounds as the NumPy
    baselines."""
    lambert: NumpyShader
    minimal: Callable[[], object]
    lambert_ms: list[float] = field(default_factory=list)
    minimal_ms: list[float] = field(default_factory=list)

    def summary(self) -> dict[str, object]:
        """Medians, their ratio and whether it marks the NumPy column suspect (> SUSPECT_RATIO)."""
        median = lambda t: float(np.median(t)) if t else None  # noqa: E731
        ratio, bad = suspect(self.lambert_ms, self.minimal_ms)
        return dict(baseline_lambert_ms=median(self.lambert_ms), minimal_lambert_ms=median(self.minimal_ms),
                    ratio=ratio, limit=SUSPECT_RATIO, suspect=bad, frames=len(self.minimal_ms),
                    baseline_lambert_layout=self.lambert.layout)


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


# ---------------------------------------------------------------- error against the oracle


def compared_pixels(gb: GBuffer, camera) -> np.ndarray:
    """Covered pixels in the error: those whose shading normal faces the viewer,
    n·v > MIN_N_DOT_V (kernels/brdf.h). Below it the oracle defines f = 0 while the
    kernels floor n·v, a convention difference rather than an error."""
    px = reference.pixels(gb, camera)
    return px.index[np.sum(px.n * px.v, axis=1) > constant("MIN_N_DOT_V")]


def grazing_pixels(gb: GBuffer, camera) -> int:
    """Covered pixels left out of the error (normal facing away from the viewer)."""
    return int(gb.coverage.sum()) - len(compared_pixels(gb, camera))


def relative_error(image: np.ndarray, idx: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    """(max, mean) over pixels `idx` of the per-pixel largest channel relative error;
    `ref` is the (K, 3) float64 radiance of those pixels."""
    if len(idx) == 0:
        return 0.0, 0.0
    got = image.reshape(-1, 4)[idx, :3].astype(float)
    floor = REL_ERROR_FLOOR * max(float(np.abs(ref).max()), 1e-30)
    err = (np.abs(got - ref) / np.maximum(np.abs(ref), floor)).max(axis=1)
    return float(err.max()), float(err.mean())


# ---------------------------------------------------------------- running


def _wall(fn: Callable[[], object]) -> float:
    """Wall ms of one call."""
    t0 = time.perf_counter()
    fn()
    return (time.perf_counter() - t0) * 1e3


def _reference_frame(c: Case) -> None:
    """One frame of the general reference in float32 (shadow lookups included when the case has them)."""
    shade_reference_f32(c.model, c.gbuffer, c.scene, c.shader.camera, c.features.half_gbuffer,
                        c.shader.shadows if c.features.shadows else None)


def prepare_baseline(c: Case) -> None:
    """Build the case's NumPy baseline and check it against the kernel's image (covered pixels,
    VERIFY_RTOL relative, the pixels float32 implementations can agree on): a baseline that
    differs is not timed, and the note says by how much."""
    try:
        shader = numpy_shader(c.model, c.gbuffer, c.scene, c.shader.camera, c.features)
    except Unsupported as exc:
        c.numpy_note = str(exc)
        return
    c.shader.render(c.model, c.features)
    image = c.shader.read_samples()
    covered = np.flatnonzero(c.gbuffer.coverage.ravel())
    mine = np.concatenate([shader.run(), np.ones((c.gbuffer.pixels, 1), np.float32)], axis=1)
    c.numpy_check = verify(mine, image, covered[well_conditioned(c.model, c.gbuffer, covered)])
    if c.numpy_check <= VERIFY_RTOL:
        c.baseline = shader
    else:
        c.numpy_note = f"differs from the kernel's image by {c.numpy_check:.1e} > {VERIFY_RTOL:g}: not timed"


def numpy_schedule(frames: int, numpy_frames: int) -> list[int]:
    """NumPy frames to run in each of the `frames` timed rounds: `numpy_frames` in all,
    spread evenly (several per round when there are fewer rounds than NumPy frames)."""
    per_round = [0] * frames
    for j in range(max(0, numpy_frames)):
        per_round[j * frames // max(numpy_frames, 1)] += 1
    return per_round


def run_cases(cases: list[Case], frames: int, warmup: int, progress: Callable[[int, int], None] | None = None,
              numpy_frames: int = NUMPY_FRAMES, guard: Guard | None = None) -> dict[tuple, list[float]]:
    """Time every case, its copy kernel and (cases with `numpy`) its NumPy baseline and the
    general reference in float32, interleaved in the same rounds, with the `guard`'s two
    Lambert frames in every round that runs NumPy; fills case.device_ms / host_ms / numpy_ms /
    reference_ms and the guard's lists, and returns copy device times per copy key (shader,
    channels, half). `progress(done, total)` is called after each round."""
    shade = [c.shader.prepare(c.model, c.features) for c in cases]
    for c in cases:
        if c.numpy:
            prepare_baseline(c)
    copies: dict[tuple, tuple[Shader, object]] = {}
    for c, d in zip(cases, shade):
        key = (id(c.shader), d.variant.channels, c.features.half_gbuffer)
        copies.setdefault(key, (c.shader, c.shader.prepare(c.model, c.features, entry="copy")))
    copy_ms: dict[tuple, list[float]] = {k: [] for k in copies}
    numpy_runs = any(c.numpy for c in cases)
    for w in range(warmup):
        for c, d in zip(cases, shade):
            timed_dispatch(c.shader, d)
            if c.numpy and w == 0:
                _reference_frame(c)
                if c.baseline is not None:
                    c.baseline.run()
        if guard is not None and numpy_runs and w == 0:
            guard.lambert.run(), guard.minimal()
        for shader, d in copies.values():
            timed_dispatch(shader, d)
    schedule, guard_schedule = numpy_schedule(frames, numpy_frames), numpy_schedule(frames, GUARD_FRAMES)
    for r in range(frames):
        for c, d in zip(cases, shade):
            dev, host = timed_dispatch(c.shader, d)
            c.device_ms.append(dev)
            c.host_ms.append(host)
            if c.numpy:
                for _ in range(schedule[r]):
                    if c.baseline is not None:
                        c.numpy_ms.append(_wall(c.baseline.run))
                    c.reference_ms.append(_wall(lambda: _reference_frame(c)))
        if guard is not None and numpy_runs:
            for _ in range(guard_schedule[r]):
                guard.lambert_ms.append(_wall(guard.lambert.run))
                guard.minimal_ms.append(_wall(guard.minimal))
        for key, (shader, d) in copies.items():
            copy_ms[key].append(timed_dispatch(shader, d)[0])
        if progress is not None:
            progress(r + 1, frames)
    return copy_ms


def summarize(cases: list[Case], copy_ms: dict[tuple, list[float]], error: bool = True) -> list[dict]:
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
            variant.channels, c.features.half_gbuffer, c.shader.rt.for_model(c.model).simd, OUTPUT_BYTES)
        row["copy_mean_ms"] = copy_mean
        row["copy_ratio"] = stats["mean_ms"] / copy_mean
        row["fast_math"], row["half_gbuffer"] = c.features.fast_math, c.features.half_gbuffer
        row["lights"] = c.features.num_lights
        row["wall_median_ms"] = float(np.median(c.host_ms))
        if c.model.id == "lambert" and not (c.features.fast_math or c.features.half_gbuffer) and lambert_ms is None:
            lambert_ms = stats["mean_ms"]
        numpy_ms = float(np.median(c.numpy_ms)) if c.numpy_ms else None
        reference_ms = float(np.median(c.reference_ms)) if c.reference_ms else None
        row.update(numpy_ms=numpy_ms, numpy_ratio=numpy_ms / row["wall_median_ms"] if numpy_ms else None,
                   numpy_frames=len(c.numpy_ms) if c.numpy_ms else None,
                   numpy_layout=c.baseline.layout if c.baseline else None, numpy_check=c.numpy_check,
                   numpy_note=c.numpy_note or None, reference_ms=reference_ms,
                   reference_ratio=reference_ms / row["wall_median_ms"] if reference_ms else None)
        if error:
            c.shader.render(c.model, c.features)
            target = c.target or c.model
            truth = c.truth or c.gbuffer
            key = (target.id, id(truth), id(c.scene))
            if key not in refs:
                idx = compared_pixels(truth, c.shader.camera)
                L = reference.radiance(truth, c.scene, target, visibility=c.visibility, camera=c.shader.camera)
                refs[key] = idx, L.reshape(-1, 3)[idx]
            # Per shaded sample: the supersampled G-buffer when the scene asks for N×N samples.
            row["max_rel_error"], row["mean_rel_error"] = relative_error(c.shader.read_samples(), *refs[key])
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
    _visibility: dict[tuple[int, int], np.ndarray | None] = field(default_factory=dict)

    @classmethod
    def prepare(cls, scene: Scene | str | Path, width: int | None = None, height: int | None = None,
                lights: int | None = None, device: str | None = None, tangents: bool = False) -> "Bench":
        scene = scene if isinstance(scene, Scene) else load_scene(scene)
        if lights is not None:
            scene = with_lights(scene, lights)
        runtime = get_runtime(device)
        frame = prepare_frame(scene, width, height, tangents=tangents, runtime=runtime)
        return cls(frame, runtime, scene_features(frame.scene, geometry=frame.geometry), device)

    def shader(self, gbuffer: GBuffer | None = None, scene: Scene | None = None) -> Shader:
        """The Shader for (gbuffer, scene), uploaded once. Shaders share the runtime:
        Shader.prepare binds each dispatch's arguments on its own cl.Kernel object."""
        gb, sc = gbuffer or self.frame.gbuffer, scene or self.frame.scene
        key = hash((id(gb), id(sc)))
        if key not in self.shaders:
            self.shaders[key] = Shader(self.runtime, gb, sc, self.frame.camera, self.frame.shadows)
        return self.shaders[key]

    def visibility(self, gbuffer: GBuffer, scene: Scene) -> np.ndarray | None:
        """The shadow factors of (gbuffer, scene) from the frame's shadow maps, computed once."""
        key = (id(gbuffer), id(scene))
        if key not in self._visibility:
            self._visibility[key] = reference.visibility(gbuffer, scene, self.frame.shadows, self.frame.camera)
        return self._visibility[key]

    def case(self, model: Model, *, label: str = "", half: bool = False, fast_math: bool = False,
             gbuffer: GBuffer | None = None, scene: Scene | None = None, target: Model | None = None,
             group: str = "", numpy: bool = True) -> Case:
        sc = scene or self.frame.scene
        gb = gbuffer or self.frame.gbuffer
        # The frame's geometry decides textures, emission and uniform channels; another scene's
        # or G-buffer's is unknown here, so none of them is assumed.
        geometry = self.frame.geometry if scene is None and gbuffer is None else None
        features = dataclasses.replace(scene_features(sc, geometry=geometry), half_gbuffer=half,
                                       fast_math=fast_math)
        vis = self.visibility(gb, sc) if features.shadows else None
        # A user's lobe has no NumPy formula (its float64 reference is its own double build).
        return Case(label or model.id, model, features, self.shader(gb, sc), sc, gb,
                    target=target, group=group, numpy=numpy and not model.is_users, visibility=vis)

    def guard(self) -> Guard | None:
        """The straw-man guard on the frame (None where the baseline has no Lambert for the scene)."""
        fr = self.frame
        try:
            lambert = numpy_shader(preset("lambert"), fr.gbuffer, fr.scene, fr.camera, self.features)
        except Unsupported:
            return None
        return Guard(lambert, minimal_lambert(fr.gbuffer, fr.scene))

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
    resolve = Registry().resolve
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


def device_record(runtime: Runtime) -> dict[str, object]:
    """The OpenCL device of a results JSON (docs/bench-schema.md, *Device*); the machine record is
    clshade.provenance.stamp's."""
    return dict(name=runtime.info.device, platform=runtime.info.platform,
                platform_version=runtime.info.platform_version, kind=runtime.info.kind,
                local_size=runtime.local_size, compute_units=int(runtime.device.max_compute_units),
                build=runtime.build_record())


def report(bench: Bench, rows: list[dict], frames: int, warmup: int, ladder: list[dict] | None = None,
           numpy_frames: int = NUMPY_FRAMES, guard: Guard | None = None) -> dict:
    """The JSON document (docs/bench-schema.md)."""
    fr = bench.frame
    return stamp(dict(schema=SCHEMA, clshade_version=__version__, created=time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                device=device_record(bench.runtime), numpy_threads=NUMPY_THREADS,
                scene=str(fr.scene.path) if fr.scene.path else None, width=fr.camera.width // fr.scene.samples,
                height=fr.camera.height // fr.scene.samples, samples=fr.scene.samples,
                specular_aa=fr.scene.specular_aa,
                pixels=fr.gbuffer.pixels, covered_pixels=int(fr.gbuffer.coverage.sum()),
                grazing_pixels=grazing_pixels(fr.gbuffer, fr.camera),
                frames=frames, warmup=warmup, numpy_frames=numpy_frames, features=dataclasses.asdict(bench.features),
                error_definition=f"|L - L_ref| / max(|L_ref|, {REL_ERROR_FLOOR:g} * peak(L_ref)), "
                                 "largest channel per covered pixel with n.v > MIN_N_DOT_V, L_ref float64 (clshade.verify.reference.radiance)",
                numpy_guard=guard.summary() if guard is not None else None,
                models=rows, ladder=ladder or []), bench.runtime.info.description)



def mark_pareto(rows: list[dict], error: str = "mean_rel_error", key: str = "pareto", floor: float = 0.0) -> None:
    """Set row[key] within each ladder group: on the front of time vs max(row[error], floor)
    (None where that error is None)."""
    for group in dict.fromkeys(r["group"] for r in rows):
        pts = [r for r in rows if r["group"] == group and r[error] is not None]
        for r, front in zip(pts, pareto([(r["mean_ms"], max(r[error], floor)) for r in pts])):
            r[key] = front
        for r in rows:
            if r["group"] == group and r[error] is None:
                r[key] = None


def run_bench(scene: Scene | str | Path, models: list[Model], frames: int, warmup: int, *, width: int | None = None,
              height: int | None = None, lights: int | None = None, ladder: bool = False,
              numpy_frames: int = NUMPY_FRAMES, device: str | None = None,
              progress: Callable[[int, int], None] | None = None) -> dict:
    """`clshade bench`: prepare the frame, time every model (and the ladders) in interleaved
    rounds, and return the JSON document (docs/bench-schema.md)."""
    if frames < 1 or warmup < 0:
        raise ClshadeError(f"--frames = {frames}, --warmup = {warmup}: need frames ≥ 1, warmup ≥ 0")
    for m in models:
        reference.check_model(m)
    bench = Bench.prepare(scene, width, height, lights, device, tangents=reads_tangents(models))
    cases = [bench.case(m, label=m.label) for m in models]
    rungs = ladder_cases(bench) if ladder else []
    guard = bench.guard() if numpy_frames > 0 else None
    copy_ms = run_cases(cases + rungs, frames, warmup, progress, numpy_frames, guard)
    rows = summarize(cases, copy_ms)
    ladder_rows = summarize(rungs, copy_ms) if rungs else []
    mark_pareto(ladder_rows)
    return report(bench, rows, frames, warmup, ladder_rows, numpy_frames, guard)
