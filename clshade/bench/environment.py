"""The environment ladder: every model × rung × sample count of a scene's [environment], its error against
the float64 truth next to its device time per frame and the sky's precompute cost — `clshade bench` on a
scene with a sky (docs/environment-ladder.md).

The rungs are enumerated from clshade.render.environment's DIFFUSE_RUNGS × SPECULAR_RUNGS (a rung added
there is measured here with no change); a combination that samples (diffuse or specular `sampled`) is run
once per N of the sample ladder, the others once. The frame is rasterised once; every case is dispatched
`frames` times after `warmup`, interleaved in rounds (case 1, case 2, …, then the next round) so that machine
noise hits every case alike; the statistics are clshade.bench.run.frame_stats's (mean, FPS, 1 % / 0.1 %
lows). The error is clshade.verify.environment_oracle's (relative RMSE and max over its pixel subset, split
by n·v), one truth per model (it does not depend on the rung). The precompute is the sky's prepare() from
the radiance map, timed cold, and the bytes of every array it keeps (SH, CDFs, pdf, and whatever else a rung
adds to the Environment: a mip chain, a LUT).
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from clshade import __version__
from clshade.bench.run import Bench, device_record, frame_stats
from clshade.device.shade import Shader
from clshade.device.timing import timed_dispatch
from clshade.device.variants import EnvironmentFeatures, Features
from clshade.errors import ClshadeError
from clshade.models.model import Model
from clshade.pipeline import reads_tangents
from clshade.provenance import stamp
from clshade.render import environment as E
from clshade.render.scene import Scene, load_scene
from clshade.verify import environment_oracle as O
from clshade.verify import reference
from clshade.verify.environment_rungs import SAMPLE_LADDER, Rung, ladder_rungs, model_rungs  # noqa: F401 (re-exported)

SCHEMA = "clshade-environment-bench/1"
#: Precompute repetitions: the cold prepare() is timed this many times and the median kept (the first
#: call also pays NumPy's import-time warm-up).
PRECOMPUTE_REPEATS = 3


def parse_samples(text: str) -> tuple[int, ...]:
    """A comma-separated N list (--environment-ladder); refused in one line naming the flag and value."""
    try:
        values = tuple(int(t) for t in text.split(",") if t.strip())
    except ValueError:
        raise ClshadeError(f"--environment-ladder = {text!r}: not a comma-separated list of integers") from None
    if not values:
        raise ClshadeError(f"--environment-ladder = {text!r}: no N given")
    for n in values:
        why = E.check_rungs(E.DEFAULT_DIFFUSE, "none", n)
        if why:
            raise ClshadeError(f"--environment-ladder = {text!r}: N = {n}: {why}")
    return values


def array_bytes(env: E.Environment) -> dict[str, int]:
    """The bytes of every array an Environment keeps, by field (the radiance itself included)."""
    out = {}
    for f in dataclasses.fields(env):
        value = getattr(env, f.name)
        if isinstance(value, np.ndarray):
            out[f.name] = int(value.nbytes)
        elif isinstance(value, (tuple, list)) and value and all(isinstance(v, np.ndarray) for v in value):
            out[f.name] = int(sum(v.nbytes for v in value))
    return out


def precompute(spec: E.EnvironmentSpec, scene_file: Path | str | None = None,
               repeats: int = PRECOMPUTE_REPEATS) -> dict[str, object]:
    """The sky's precompute from its radiance map (read once, not timed): the median wall ms of
    E.prepare over `repeats` cold calls, the host bytes it keeps by field and in all, and the bytes the
    kernels receive (params, texels and CDFs)."""
    radiance = E.sky_radiance(spec, scene_file)
    times, env = [], None
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        env = E.prepare(radiance, spec.rotation)
        times.append((time.perf_counter() - t0) * 1e3)
    by_field = array_bytes(env)
    device = int(env.params().nbytes + env.texels().nbytes + env.cdf().nbytes)
    return dict(ms=float(np.median(times)), bytes=by_field, total_bytes=int(sum(by_field.values())),
                device_bytes=device, size=list(env.size), constant=env.constant)


@dataclass
class EnvCase:
    """One timed rung of one model."""
    model: Model
    rung: Rung
    features: Features
    shader: Shader
    device_ms: list[float] = field(default_factory=list)
    host_ms: list[float] = field(default_factory=list)


def _with_samples(scene: Scene, n: int | None) -> Scene:
    """The scene with its sky's sample count N (the kernels' argument; the rung is a feature)."""
    if n is None or n == scene.environment.samples:
        return scene
    return dataclasses.replace(scene, environment=dataclasses.replace(scene.environment, samples=n))


def build_cases(bench: Bench, models: list[Model], rungs: list[Rung]) -> list[EnvCase]:
    """The cases on a prepared frame: one Shader per N (the sample count is bound with the arguments),
    the frame's features with each rung's EnvironmentFeatures."""
    scene = bench.frame.scene
    sky = bench.features.environment
    scenes: dict[int | None, Scene] = {}
    cases = []
    for m in models:
        for r in model_rungs(m, rungs):
            sc = scenes.setdefault(r.samples, _with_samples(scene, r.samples))
            features = dataclasses.replace(bench.features, environment=EnvironmentFeatures(
                r.diffuse, r.specular, sky.map_sampling, sky.background))
            cases.append(EnvCase(m, r, features, bench.shader(bench.frame.gbuffer, sc)))
    return cases


def run_rounds(cases: list[EnvCase], frames: int, warmup: int,
               progress: Callable[[int, int], None] | None = None) -> None:
    """Time every case `frames` times after `warmup`, interleaved in rounds."""
    dispatches = [c.shader.prepare(c.model, c.features) for c in cases]
    for _ in range(warmup):
        for c, d in zip(cases, dispatches):
            timed_dispatch(c.shader, d)
    for r in range(frames):
        for c, d in zip(cases, dispatches):
            dev, host = timed_dispatch(c.shader, d)
            c.device_ms.append(dev)
            c.host_ms.append(host)
        if progress is not None:
            progress(r + 1, frames)


def summarize(bench: Bench, cases: list[EnvCase], oracle_pixels: int,
              subdivisions: int = O.DEFAULT_SUBDIVISIONS) -> list[dict]:
    """A row per case: model, rung, N, the frame statistics and the error against the truth."""
    fr = bench.frame
    env = E.prepare_spec(fr.scene.environment, fr.scene.path)
    truths: dict[str, O.Truth] = {}
    rows = []
    for c in cases:
        if c.model.id not in truths:
            truths[c.model.id] = O.truth(fr.gbuffer, fr.scene, c.model, env, camera=fr.camera, shadows=fr.shadows,
                                         count=oracle_pixels, subdivisions=subdivisions)
        c.shader.render(c.model, c.features)
        err = O.errors(c.shader.read_samples(), truths[c.model.id])
        stats = frame_stats(np.array(c.device_ms), np.array(c.host_ms))
        rows.append(dict(model=c.model.id, name=c.model.label, diffuse=c.rung.diffuse, specular=c.rung.specular,
                         samples=c.rung.samples, rung=c.rung.label, frames=len(c.device_ms), **stats,
                         rel_rmse=err["rel_rmse"], max_rel=err["max_rel"], by_nv=err["by_nv"],
                         oracle_pixels=len(truths[c.model.id].index)))
    return rows


def run_environment_bench(scene: Scene | str | Path, models: list[Model], frames: int, warmup: int, *,
                          width: int | None = None, height: int | None = None,
                          samples: tuple[int, ...] = SAMPLE_LADDER, oracle_pixels: int = O.DEFAULT_PIXELS,
                          oracle_subdivisions: int = O.DEFAULT_SUBDIVISIONS,
                          device: str | None = None, progress: Callable[[int, int], None] | None = None) -> dict:
    """The environment ladder of a scene with an [environment]: the JSON document (module docstring).
    `oracle_subdivisions` cells per texel side in the truth (1 keeps a 1024×512 map's truth within seconds
    per model; its own gap is measured by environment_oracle.truth(check=True))."""
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    if scene.environment is None:
        raise ClshadeError(f"{scene.path or 'the scene'}: no [environment] table: the environment ladder needs a sky")
    if frames < 1 or warmup < 0:
        raise ClshadeError(f"--frames = {frames}, --warmup = {warmup}: need frames ≥ 1, warmup ≥ 0")
    if oracle_pixels < 1:
        raise ClshadeError(f"--oracle-pixels = {oracle_pixels}: must be ≥ 1")
    for m in models:
        reference.check_model(m)
    rungs = ladder_rungs(samples)
    pre = precompute(scene.environment, scene.path)
    bench = Bench.prepare(scene, width, height, None, device, tangents=reads_tangents(models))
    cases = build_cases(bench, models, rungs)
    run_rounds(cases, frames, warmup, progress)
    rows = summarize(bench, cases, oracle_pixels, oracle_subdivisions)
    fr = bench.frame
    spec = fr.scene.environment
    return stamp(dict(
        schema=SCHEMA, clshade_version=__version__, created=time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        device=device_record(bench.runtime), scene=str(fr.scene.path) if fr.scene.path else None,
        environment=dict(map=str(spec.map) if spec.map is not None else None,
                         uniform=list(spec.uniform) if spec.uniform is not None else None,
                         intensity=spec.intensity, rotation=spec.rotation),
        width=fr.camera.width // fr.scene.samples, height=fr.camera.height // fr.scene.samples,
        pixels=fr.gbuffer.pixels, covered_pixels=int(fr.gbuffer.coverage.sum()), frames=frames, warmup=warmup,
        sample_ladder=list(dict.fromkeys(samples)), diffuse_rungs=list(E.DIFFUSE_RUNGS),
        specular_rungs=list(E.SPECULAR_RUNGS), oracle_pixels=oracle_pixels,
        oracle_subdivisions=oracle_subdivisions, nv_bins=list(O.NV_BINS),
        error_definition="relative RMSE sqrt(sum|L - T|^2 / sum|T|^2) and max over RGB of |L - T| / "
                         f"max(|T|, {O.REL_ERROR_FLOOR:g} * peak(T)) over the oracle's pixels "
                         "(clshade.verify.environment_oracle), T float64",
        precompute=pre, rows=rows), bench.runtime.info.description)
