"""Every OpenCL runtime present on one frame: health, what each build gets, kernel times and
the error against the float64 oracle (issue 24).

    python -m clshade.bench.runtimes [--out benchmarks/results/runtimes] [--rounds 100]

Every device listed is probed (clshade/device/health.py); every healthy one shades the same
G-buffer (scenes/sphere_grid.toml, 1920×1080) with each model of MODELS and its copy kernel,
interleaved in the same rounds with perf's protocol (`measure`: noise hits every runtime alike),
and its image is compared with the float64 frame oracle on the same pixels as `clshade bench`.
The runtimes are ranked by the geometric mean of their models' median kernel times; the JSON
says which device the default selection picks and whether it is the fastest (the order of
clshade.device.runtime.RUNTIME_PREFERENCE; tests/test_runtimes.py checks the committed file).
Writes OUT.json and OUT.md (the Markdown rendered from the JSON).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
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
from clshade.provenance import stamp
from clshade.render.scene import load_scene
from clshade.resources import scenes_dir
from clshade.verify import reference

SCHEMA = "clshade-runtimes/1"
MODELS = ("lambert", "ggx_correlated", "phong", "oren_nayar+cook_torrance@dielectric")


def commit() -> str | None:
    """The checkout's HEAD (with '+dirty' when the working tree differs), or None outside git."""
    root = Path(__file__).resolve().parents[2]
    head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True)
    if head.returncode:
        return None
    dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True).stdout.strip()
    return head.stdout.strip() + ("+dirty" if dirty else "")


def _cpu() -> str:
    try:
        return next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo", encoding="utf-8")
                    if l.startswith("model name"))
    except (OSError, StopIteration):
        return platform.processor() or platform.machine()


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
                       prefetch=rt.prefetches, local_size=rt.local_size)
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
        schema=SCHEMA, clshade_version=__version__, commit=commit(),
        created=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        machine=dict(cpu=_cpu(), cores=os.cpu_count(), os=platform.platform(), python=platform.python_version(),
                     load_average_at_start=list(os.getloadavg())),
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
        command=f"python -m clshade.bench.runtimes --rounds {rounds}",
    )


def markdown(doc: dict) -> str:
    """The Markdown table of a runtimes JSON."""
    lines = [f"# Every OpenCL runtime on one frame",
             "",
             f"{doc['scene']} at {doc['width']}×{doc['height']} ({doc['covered_pixels']} covered pixels), "
             f"{doc['rounds']} interleaved rounds after {doc['warmup']} warm-up ({doc['timed_run']}, process idle before each); medians; measured {doc['created']} on "
             f"{doc['machine']['cpu']} ({doc['machine']['cores']} cores), commit `{doc['commit']}`, "
             f"with `{doc['command']}`.",
             f"Error: against the float64 frame oracle on the same G-buffer, as in `clshade bench`. "
             f"GPU: {doc['gpu']}.",
             "",
             "| device | runtime | state | SIMD | inline math | streaming stores | prefetch | fp64 |",
             "|---|---|---|---|---|---|---|---|"]
    yn = lambda v: "—" if v is None else ("yes" if v else "no")  # noqa: E731
    for d in doc["devices"]:
        state = "healthy" if d["healthy"] else f"broken: {d['reason']}"
        lines.append(f"| {d['spec']} {d['device']} | {d['runtime']} | {state} | {d.get('simd', '—')} | "
                     f"{yn(d.get('inline_math'))} | {yn(d.get('streaming_stores'))} | {yn(d.get('prefetch'))} | "
                     f"{yn(d['fp64'])} |")
    healthy = [d for d in doc["devices"] if d["healthy"]]
    lines += ["", "| model | " + " | ".join(f"{d['runtime']} ms (× copy) | max / mean rel. error" for d in healthy) + " |",
              "|---|" + "---|---|" * len(healthy)]
    for m in doc["models"]:
        cells = []
        for d in healthy:
            r = d["models"][m]
            cells += [f"{r['median_ms']:.2f} ({r['copy_ratio']:.2f})",
                      f"{r['max_rel_error']:.1e} / {r['mean_rel_error']:.1e}"]
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    lines.append("| geometric mean of the medians | " + " | ".join(
        f"{d['geomean_median_ms']:.2f} | " for d in healthy) + " |")
    fastest = doc["fastest_cpu"]
    agree = fastest is not None and fastest["spec"] == doc["default"]["spec"]
    lines += ["", f"Ranking (fastest first): {', '.join(next(d['runtime'] for d in healthy if d['spec'] == s) for s in doc['ranking'])}. "
              f"The default selection picks {doc['default']['runtime']} ({doc['default']['spec']}); "
              + ("it is the fastest healthy CPU runtime measured here."
                 if agree else f"the fastest healthy CPU runtime measured here is {fastest and fastest['runtime']}.")
              + f" Preference order in the code: {', '.join(doc['runtime_preference'])}.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(scenes_dir() / "sphere_grid.toml"))
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--rounds", type=int, default=100)
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--out", default="benchmarks/results/runtimes", help="path stem: writes .json and .md")
    ap.add_argument("--render-only", action="store_true", help="re-render OUT.md from OUT.json")
    args = ap.parse_args(argv)
    out = Path(args.out)
    if args.render_only:
        doc = json.loads(out.with_suffix(".json").read_text(encoding="utf-8"))
    else:
        doc = stamp(measure(args.scene, args.width, args.height, args.rounds, args.warmup))   # every runtime: the host
        out.with_suffix(".json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    out.with_suffix(".md").write_text(markdown(doc), encoding="utf-8")
    print(f"wrote {out.with_suffix('.json')} and {out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
