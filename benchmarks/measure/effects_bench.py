"""What each scene effect costs, per lighting model, and what specialisation gains.

    python -m benchmarks.measure.effects_bench [--rounds N] [--width W --height H]

Writes benchmarks/results/effects.json (JSON only; `python -m benchmarks.publish` renders effects.md). One G-buffer per scene
configuration (lights 1 / 4 / 16 × shadows off / on × textures off / on); every
case (model × configuration × specialised or general kernel) is dispatched once
per round, cases interleaved within a round and the rounds repeated, so machine
noise hits every case alike; a case's time is the median of its rounds' device
times (OpenCL event profile, end − start). Ratios are paired: the median over
rounds of (time of case A ÷ time of case B in the same round), which cancels
slow drift in machine load (the 2-core development host is shared). All
ratios come from this one run.

Light sets: light 0 is a directional sun; the others alternate spot and point
lights on a ring. With shadows on, the sun and every spot cast shadows (point
lights cannot: no cube maps). Textures are sampled on the host into the
G-buffer, so their cost is the G-buffer stage's host time; the kernel is the
same program (its time is measured too, as a check).
"""
from __future__ import annotations

import argparse
import math
import statistics
import time
from dataclasses import replace
from pathlib import Path

from benchmarks.publish.results_io import RESULTS, ROOT, write_result
from clshade.device.runtime import get_runtime
from clshade.device.shade import Shader, scene_features
from clshade.models.registry import Registry
from clshade.pipeline import Timings, prepare_frame
from clshade.render.scene import parse_scene

MODELS = ("lambert", "phong", "ggx_correlated")
LIGHT_COUNTS = (1, 4, 16)
ROUNDS = 51                   # odd: the median is one measured frame
WARMUP = 1                    # untimed dispatches per case (first-touch of buffers)
SHADOW_MAP_SIZE = 512         # smaller than the scene default: 9 maps at 16 lights
TARGET_GAIN = 1.5             # the target: GGX, one light, specialised vs general


def scene_text(lights: int, shadows: bool, textures: bool, width: int, height: int) -> str:
    """A floor, a sphere and a box under `lights` lights (sun + alternating spot/point ring)."""
    ring = []
    for k in range(1, lights):
        a = 2 * math.pi * k / max(lights - 1, 1)
        x, z = 3.0 * math.cos(a), 3.0 * math.sin(a)
        if k % 2:
            ring.append(f'[[lights]]\ntype = "spot"\nposition = [{x:.4f}, 3.5, {z:.4f}]\n'
                        f'direction = [{-x:.4f}, -3.5, {-z:.4f}]\nintensity = {24.0 / lights:.4f}\n'
                        f'outer_angle = 40.0\ninner_angle = 30.0\n')
        else:
            ring.append(f'[[lights]]\ntype = "point"\nposition = [{x:.4f}, 2.0, {z:.4f}]\n'
                        f'intensity = {8.0 / lights:.4f}\nshadows = false\n')
    tex = ('base_color = [1.0, 1.0, 1.0]\nbase_color_texture = "textures/checker_base.png"\nuv_scale = 4.0\n'
           'normal_texture = "textures/bumps_normal.png"\nmetallic_roughness_texture = "textures/roughness_mr.png"\n'
           'roughness = 1.0\nmetallic = 1.0\n' if textures else 'base_color = [0.6, 0.6, 0.6]\nroughness = 0.6\n')
    return f"""
[camera]
position = [0.0, 2.4, 5.5]
target = [0.0, 0.5, 0.0]
fov = 45.0
width = {width}
height = {height}

[render]
ambient = 0.05
shadows = {str(shadows).lower()}
shadow_map_size = {SHADOW_MAP_SIZE}
shadow_pcf = 3

[[lights]]
type = "directional"
direction = [0.4, -1.0, -0.5]
irradiance = 2.5

{chr(10).join(ring)}

[materials.floor]
{tex}

[materials.ball]
base_color = [0.8, 0.2, 0.1]
roughness = 0.3
ks = 0.4

[[objects]]
primitive = "plane"
size = 12.0
material = "floor"

[[objects]]
primitive = "sphere"
radius = 0.7
subdivisions = 4
translate = [-0.9, 0.7, 0.0]
material = "ball"

[[objects]]
primitive = "box"
size = 0.9
rotate = [0.0, 30.0, 0.0]
translate = [1.0, 0.45, -0.2]
material = "{'floor' if textures else 'ball'}"
"""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=ROUNDS)
    ap.add_argument("--width", type=int, default=384)
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    started = time.perf_counter()
    rt = get_runtime()

    # ---- frames (host stages timed per configuration)
    configs = [(n, s, False) for n in LIGHT_COUNTS for s in (False, True)] + [(1, False, True)]
    frames, shaders, host = {}, {}, {}
    for n, shadows, textures in configs:
        timings = Timings()
        scene = parse_scene(scene_text(n, shadows, textures, args.width, args.height), ROOT / "scenes" / "bench.toml")
        frame = prepare_frame(scene, timings=timings)
        frames[(n, shadows, textures)] = frame
        shaders[(n, shadows, textures)] = Shader(rt, frame.gbuffer, frame.scene, frame.camera, frame.shadows)
        host[(n, shadows, textures)] = {k: round(v * 1e3, 2) for k, v in timings.items()}

    # ---- cases
    cases = []
    for name in MODELS:
        model = Registry().resolve(name)
        for key in configs:
            frame = frames[key]
            features = scene_features(frame.scene, geometry=frame.geometry)
            kinds = ("specialised", "general") if not key[2] else ("specialised",)
            for kind in kinds:
                f = replace(features, general=kind == "general")
                cases.append(dict(model=name, lights=key[0], shadows=key[1], textures=key[2], kernel=kind,
                                  dispatch=shaders[key].prepare(model, f), shader=shaders[key], times=[]))
    build_s = time.perf_counter() - started

    for case in cases:
        for _ in range(WARMUP):
            case["shader"].enqueue(case["dispatch"]).wait()
    for _ in range(args.rounds):
        for case in cases:
            event = case["shader"].enqueue(case["dispatch"])
            event.wait()
            case["times"].append((event.profile.end - event.profile.start) * 1e-6)

    rows = [{k: c[k] for k in ("model", "lights", "shadows", "textures", "kernel")}
            | {"median_ms": round(statistics.median(c["times"]), 4),
               "min_ms": round(min(c["times"]), 4), "max_ms": round(max(c["times"]), 4)} for c in cases]

    def key(model: str, n: int, shadows: bool = False, textures: bool = False, kernel: str = "specialised"):
        return (model, n, shadows, textures, kernel)

    times = {(c["model"], c["lights"], c["shadows"], c["textures"], c["kernel"]): c["times"] for c in cases}

    def t(*args, **kw) -> float:
        return round(statistics.median(times[key(*args, **kw)]), 4)

    def ratio(a: tuple, b: tuple) -> float:
        """Paired ratio: median over rounds of time(a) / time(b)."""
        return round(statistics.median(x / y for x, y in zip(times[a], times[b])), 3)

    effects = []
    for name in MODELS:
        base = key(name, 1)
        effects.append({
            "model": name, "base_ms": t(name, 1),
            "lights_4_ratio": ratio(key(name, 4), base), "lights_16_ratio": ratio(key(name, 16), base),
            "ms_per_extra_light": round((t(name, 16) - t(name, 1)) / 15, 4),
            "shadows_ratio": {str(n): ratio(key(name, n, True), key(name, n)) for n in LIGHT_COUNTS},
            "textures_kernel_ratio": ratio(key(name, 1, textures=True), base),
            "general_over_specialised": {f"{n}{'+shadows' if s else ''}": ratio(key(name, n, s, kernel="general"),
                                                                                key(name, n, s))
                                         for n in LIGHT_COUNTS for s in (False, True)},
        })
    gain = ratio(key("ggx_correlated", 1, kernel="general"), key("ggx_correlated", 1))
    result = {
        "schema": "clshade-effects/1",
        "device": rt.info.description,
        "pixels": args.width * args.height, "size": [args.width, args.height], "rounds": args.rounds,
        "shadow_map_size": SHADOW_MAP_SIZE, "shadow_pcf": 3,
        "target": {"case": "ggx_correlated, 1 light, no shadows", "specialised_gain": round(gain, 3),
                   "required": TARGET_GAIN, "met": gain >= TARGET_GAIN},
        "effects": effects,
        "host_stages_ms": {f"{n} lights{', shadows' if s else ''}{', textures' if x else ''}": host[(n, s, x)]
                           for (n, s, x) in configs},
        "cases": rows,
        "build_s": round(build_s, 1), "total_s": round(time.perf_counter() - started, 1),
    }
    write_result(args.out / "effects.json", result, get_runtime().info.description)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
