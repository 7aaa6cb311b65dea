"""What light from the sky costs at 1920×1080, against one directional light: benchmarks/results/environment_cost.json.
JSON only: `python -m benchmarks.publish` renders benchmarks/results/environment_cost.md.

The robot of scenes/environment.toml, rasterised once at --width × --height on the default device (or
--device). Per model, the cases share the G-buffer: one directional light and no sky (the study's lighting),
then the sky alone (no punctual light, no background) in the precomputed rungs — constant, sh9 — and sh9 beside
each precomputed specular rung (split_sum, split_sum_ms), and the sampled rungs at SAMPLES. Every case is
dispatched once per round after WARMUP rounds, ROUNDS rounds interleaved (case order shuffled per round);
the median device time per case is kept, with each rung's time over the directional light's. The sampled
rung's cost against N is fitted with a line (least squares) and its largest relative departure reported.

The precompute (on the host): for the scene's own map and each 1024×512 map of ../shared/assets/hdri, the sky's
prepare (SH9 and the luminance CDFs), a prefiltered mip chain per lobe family and a DFG table per lobe, each
timed cold (their in-memory caches cleared) and again warm (cached), with their bytes.

    python -m benchmarks.measure.environment_cost [--width 1920 --height 1080] [--rounds 15] [--device SPEC]
"""
from __future__ import annotations

import argparse
import dataclasses
import random
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.publish.results_io import RESULTS, ROOT, load_average, write_result

SCENE = ROOT / "scenes" / "environment.toml"
HDRI = ROOT.parent / "shared" / "assets" / "hdri"
MODELS = ("lambert", "blinn_phong", "ggx_correlated", "cook_torrance")
#: The sampled rung's N: enough points for a line through them to say whether the cost is linear in N.
SAMPLES = (1, 2, 4, 8)
ROUNDS = 9
WARMUP = 2
#: The one directional light of the baseline: white, from above and in front (the robot lit, not grazing).
LIGHT_DIRECTION = (-0.3, -1.0, -0.45)


def _cases(scene, models, samples, geometry):
    """(model, label, N, scene variant, features) per case, the directional light first for each model; the
    sampled rung samples both lobes (the diffuse alone for a model without a specular lobe)."""
    from clshade.device.shade import scene_features
    from clshade.device.variants import EnvironmentFeatures
    from clshade.render import environment as E
    from clshade.render.scene import Light
    from clshade.verify.environment_rungs import Rung, model_rungs
    d = np.asarray(LIGHT_DIRECTION, np.float64)
    lit = dataclasses.replace(scene, environment=None,
                              lights=(Light("directional", np.ones(3), direction=d / np.linalg.norm(d)),))
    rungs = [Rung(x, "none") for x in E.DIFFUSE_RUNGS if x != "sampled"]
    rungs += [Rung(E.DEFAULT_DIFFUSE, s) for s in E.SPECULAR_RUNGS if s not in ("none", "sampled")]
    sky = dataclasses.replace(scene, lights=())
    out = []
    for m in models:
        out.append((m, "directional light", None, lit, scene_features(lit, geometry=geometry)))
        sampled = [Rung("sampled", "sampled" if m.specular != "none" else "none", n) for n in samples]
        for r in model_rungs(m, rungs) + sampled:
            sc = sky if r.samples is None else dataclasses.replace(
                sky, environment=dataclasses.replace(sky.environment, samples=r.samples))
            base = scene_features(sc, geometry=geometry)
            features = dataclasses.replace(base, environment=EnvironmentFeatures(
                r.diffuse, r.specular, base.environment.map_sampling, False))
            out.append((m, r.label, r.samples, sc, features))
    return out


def shading(width: int, height: int, rounds: int, device: str | None, samples=SAMPLES) -> dict:
    from clshade.bench.run import Bench, device_record
    from clshade.device.timing import timed_dispatch
    from clshade.models.registry import Registry
    from clshade.render.scene import load_scene
    scene = load_scene(SCENE)
    models = Registry().resolve_many(",".join(MODELS))
    bench = Bench.prepare(scene, width, height, None, device)
    cases = []
    for m, label, n, sc, features in _cases(bench.frame.scene, models, samples, bench.frame.geometry):
        shader = bench.shader(bench.frame.gbuffer, sc)
        cases.append(dict(model=m, label=label, samples=n, shader=shader, dispatch=shader.prepare(m, features),
                          ms=[]))
    rng = random.Random(1)
    for r in range(WARMUP + rounds):
        order = list(range(len(cases)))
        rng.shuffle(order)
        for i in order:
            c = cases[i]
            dev, _ = timed_dispatch(c["shader"], c["dispatch"])
            if r >= WARMUP:
                c["ms"].append(dev)
        print(f"round {r + 1}/{WARMUP + rounds}", file=sys.stderr, flush=True)
    by_model: dict[str, dict] = {}
    for c in cases:
        entry = by_model.setdefault(c["model"].id, dict(model=c["model"].id, name=c["model"].label, rows=[]))
        med = float(np.median(c["ms"]))
        if c["label"] == "directional light":
            entry["directional_ms"] = med
        entry["rows"].append(dict(rung=c["label"], samples=c["samples"], median_ms=med,
                                  spread_ms=[float(np.min(c["ms"])), float(np.max(c["ms"]))]))
    for entry in by_model.values():
        for row in entry["rows"]:
            row["over_directional"] = row["median_ms"] / entry["directional_ms"]
        pts = [(r["samples"], r["median_ms"]) for r in entry["rows"] if r["samples"] is not None]
        if len(pts) >= 2:
            n, ms = np.array(pts, np.float64).T
            slope, intercept = np.polyfit(n, ms, 1)
            fit = slope * n + intercept
            entry["sampled_fit"] = dict(ms_per_sample=float(slope), intercept_ms=float(intercept),
                                        max_rel_departure=float(np.max(np.abs(ms - fit) / ms)))
    return dict(device=device_record(bench.runtime), width=width, height=height, rounds=rounds, warmup=WARMUP,
                covered_pixels=int(bench.frame.gbuffer.coverage.sum()), light_direction=list(LIGHT_DIRECTION),
                models=list(by_model.values())), bench.runtime.info.description


def _timed(fn) -> tuple[float, object]:
    t0 = time.perf_counter()
    value = fn()
    return (time.perf_counter() - t0) * 1e3, value


def precompute(maps: list[Path], scene_file: Path) -> list[dict]:
    """Cold and warm times and bytes of each map's prepare, mip chains and DFG tables (module docstring)."""
    from clshade.render import environment as E
    from clshade.render import prefilter as P
    lobes = sorted(P.FRESNEL_LOBES) + sorted(P.NORMALISED.values())
    out = []
    for path in maps:
        radiance = E.read_map(path, scene_file)
        h, w = radiance.shape[:2]
        prep_ms, env = _timed(lambda: E.prepare(radiance, 0.0))
        P._mip_chain.cache_clear()
        P._dfg_table.cache_clear()
        chains = {}
        for fam in P.FAMILIES:
            cold, chain = _timed(lambda: P.mip_chain(radiance, fam))
            warm, _ = _timed(lambda: P.mip_chain(radiance, fam))
            chains[fam] = dict(cold_ms=cold, warm_ms=warm, bytes=chain.nbytes, levels=len(chain.levels))
        tables = {}
        for lobe in lobes:
            cold, table = _timed(lambda: P.dfg_table(lobe))
            warm, _ = _timed(lambda: P.dfg_table(lobe))
            tables[lobe] = dict(cold_ms=cold, warm_ms=warm, bytes=int(table.nbytes))
        ggx = prep_ms + chains["ggx"]["cold_ms"] + tables["ggx_correlated"]["cold_ms"]
        out.append(dict(map=path.name, size=[w, h], prepare_ms=prep_ms, chains=chains, dfg=tables,
                        ggx_split_sum_ms=ggx,
                        all_families_ms=prep_ms + sum(c["cold_ms"] for c in chains.values())
                        + sum(t["cold_ms"] for t in tables.values())))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--rounds", type=int, default=ROUNDS)
    ap.add_argument("--device", default=None)
    ap.add_argument("--hdri", type=Path, default=HDRI)
    ap.add_argument("--out", default=str(RESULTS / "environment_cost.json"))
    args = ap.parse_args()
    from clshade.render.scene import load_scene
    start = load_average()
    scene = load_scene(SCENE)
    maps = [Path(scene.environment.map)] + (sorted(args.hdri.glob("*.exr")) if args.hdri.is_dir() else [])
    pre = precompute(maps, scene.path)
    shade, device = shading(args.width, args.height, args.rounds, args.device)
    out = Path(args.out).resolve()
    doc = dict(command="python -m benchmarks.measure.environment_cost " + " ".join(sys.argv[1:]),
               created=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), scene=str(SCENE.relative_to(ROOT)),
               results_file=str(out.relative_to(ROOT)) if out.is_relative_to(ROOT) else str(out),
               shading=shade, precompute=pre, skipped=None if args.hdri.is_dir() else f"{args.hdri} is absent",
               load_average={"start": start, "end": load_average()})
    write_result(out, doc, device)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
