"""Measure the report: benchmarks/report/report.json and its images (benchmarks/report/), one run.

The study reproduced: comparison sheets, the FPS table with lows, accuracy against time, the plausibility
table, the data of each of the study's claims, and a noise band: the GGX height-correlated kernel timed
NOISE_REPEATS times in the same rounds as the models. JSON only: benchmarks/REPORT.md is rendered from it by
`python -m benchmarks.publish`.

    python -m benchmarks.measure.make_report [--frames 1000] [--width 1920] [--height 1080]
    python -m benchmarks.publish
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.publish.results_io import ROOT, load_average, write_result
from clshade.bench.run import Bench, ladder_cases, mark_pareto, report, run_cases, summarize
from clshade.compare import compare_sheet, sweep_sheet, write_sheet
from clshade.device.evaluate import Samples, constant_materials, eval_brdf
from clshade.device.runtime import get_runtime
from clshade.models.model import GROUPS, preset
from clshade.models.registry import Registry
from clshade.report.bench import plot_fps, plot_ladder
from clshade.resources import kernels_dir
from clshade.verify import plausibility
from clshade.verify import reference

IMAGES = ROOT / "benchmarks" / "report"
FRESNEL_SOURCE = ROOT / "benchmarks" / "experiments" / "kernels" / "fresnel_cost.cl"
BUILT_IN = Registry()            # the built-in lobes
FRESNEL_ITEMS = 1 << 20          # work-items of the Fresnel micro-benchmark
FRESNEL_REPEAT = 64              # term evaluations per work-item
FRESNEL_ROUNDS = 9               # interleaved timing rounds; medians reported
GOLD = ((0.18, 0.42, 1.37), (3.42, 2.35, 1.77))
NOISE_MODEL = "ggx_correlated"   # the kernel timed several times in the same rounds: the noise band
NOISE_REPEATS = 3


# ------------------------------------------------------------------ claim (c)


def fresnel_cost(runtime) -> dict[str, float]:
    """ns per evaluation of each Fresnel term (compute-bound kernel, loop baseline subtracted)."""
    cl = runtime.cl
    source = "".join((kernels_dir() / name).read_text() for name in ("simd.h", "brdf.h")) + \
        FRESNEL_SOURCE.read_text()
    out = runtime.empty(FRESNEL_ITEMS * 4)
    kernels = {}
    for term, name in enumerate(("schlick", "dielectric", "conductor", "loop")):
        built = runtime.kernel(f"#define TERM {term}\n#define REPEAT {FRESNEL_REPEAT}\n" + source,
                               "fresnel_cost", label=f"fresnel_cost {name}")
        k = cl.Kernel(built.get_info(cl.kernel_info.PROGRAM), "fresnel_cost")
        k.set_args(np.uint32(FRESNEL_ITEMS), np.float32(1.5), np.array([*GOLD[0], 0], np.float32),
                   np.array([*GOLD[1], 0], np.float32), np.array([0.04, 0.04, 0.04, 0], np.float32), out)
        kernels[name] = k
    times: dict[str, list[float]] = {n: [] for n in kernels}
    size = runtime.global_size(FRESNEL_ITEMS)
    for _ in range(FRESNEL_ROUNDS + 1):                      # first round = warm-up
        for name, k in kernels.items():
            e = cl.enqueue_nd_range_kernel(runtime.queue, k, (size,), (runtime.local_size,))
            e.wait()
            times[name].append((e.profile.end - e.profile.start) * 1e-9)
    med = {n: float(np.median(t[1:])) for n, t in times.items()}
    evals = FRESNEL_ITEMS * FRESNEL_REPEAT
    return {n: max(med[n] - med["loop"], 0.0) / evals * 1e9 for n in ("schlick", "dielectric", "conductor")}


def schlick_error() -> dict[str, float]:
    """Schlick against the exact Fresnel over the incidence cosine (float64 reference)."""
    c = np.linspace(1e-4, 1.0, 100_001)
    w = 2 * c                                                 # cosine-weighted hemispherical average
    out = {}
    for name, exact, f0 in (("dielectric (IOR 1.5)", reference.f_dielectric(c, 1.5), ((1.5 - 1) / 2.5) ** 2),
                            ("conductor (gold)", reference.f_conductor(c, GOLD[0], GOLD[1]), None)):
        exact = np.asarray(exact, float).reshape(len(c), -1)
        f0 = exact[-1] if f0 is None else np.array([f0])
        approx = f0 + (1 - f0) * (1 - c[:, None]) ** 5
        rel = np.abs(approx - exact) / exact
        out[name] = dict(max_rel=float(rel.max()), argmax_cos=float(c[rel.max(axis=1).argmax()]),
                         max_abs=float(np.abs(approx - exact).max()),
                         avg_rel=float(np.trapezoid(np.abs(approx - exact).mean(1) * w, c)
                                       / np.trapezoid(exact.mean(1) * w, c)))
    return out


# ------------------------------------------------------------------ claim (d)


def smith_albedo() -> list[dict]:
    """Directional albedo (F = 1) of GGX with separable vs height-correlated Smith G."""
    rows = []
    for r in (0.3, 0.5, 0.7, 1.0):
        for mu in (1.0, 0.5, 0.2):
            v = (np.sqrt(1 - mu * mu), 0.0, mu)
            vals = {}
            for lobe in ("walter_ggx", "ggx_correlated"):
                fn = lambda n, l, vv, lobe=lobe, r=r: reference.brdf("none", lobe, n, l, vv, base_color=1.0,  # noqa: E731
                                                           roughness=r, f0=1.0)[..., 0]
                vals[lobe] = float(reference.directional_albedo(fn, v=v))
            rows.append(dict(roughness=r, nv=mu, separable=vals["walter_ggx"], correlated=vals["ggx_correlated"]))
    return rows


def smith_peak(runtime) -> list[dict]:
    """f at the mirror direction (the highlight peak), device evaluation, F = 1."""
    rows = []
    for r in (0.2, 0.5, 0.8):
        for mu in (0.9, 0.5, 0.2):
            s = np.sqrt(1 - mu * mu)
            n, v, l = np.array([[0, 0, 1.0]]), np.array([[s, 0, mu]]), np.array([[-s, 0, mu]])
            one = np.ones((1, 3))
            samples = Samples(n, l, v, one, np.array([r]), np.array([1.0]), constant_materials(1))
            f = {m: float(eval_brdf(BUILT_IN.resolve(m), samples, runtime)[0, 0]) for m in ("walter_ggx", "ggx_correlated")}
            rows.append(dict(roughness=r, nv=mu, separable=f["walter_ggx"], correlated=f["ggx_correlated"]))
    return rows


# ------------------------------------------------------------------ claim (e)


def oren_nayar_vs_lambert(runtime, count: int = 100_000) -> float:
    """max |f_ON(σ = 0) − f_Lambert| over random directions and colours, on the device."""
    rng = np.random.default_rng(7)

    def dirs() -> np.ndarray:
        d = rng.normal(size=(count, 3))
        d[:, 2] = np.abs(d[:, 2])
        return d / np.linalg.norm(d, axis=1, keepdims=True)
    n = np.tile([0.0, 0.0, 1.0], (count, 1))
    samples = Samples(n, dirs(), dirs(), rng.uniform(0, 1, (count, 3)), np.zeros(count), np.zeros(count),
                      constant_materials(count))
    return float(np.abs(eval_brdf(preset("oren_nayar"), samples, runtime)
                        - eval_brdf(preset("lambert"), samples, runtime)).max())


# ------------------------------------------------------------------ report


def group_times(rows: list[dict]) -> dict[str, list[float]]:
    by_id = {r["model"]: r["mean_ms"] for r in rows}
    return {g: [by_id[preset(p).id] for p in members] for g, members in GROUPS.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=1000, help="timed frames per model (default 1000)")
    ap.add_argument("--ladder-frames", type=int, default=200)
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    args = ap.parse_args()
    start, at_start = time.perf_counter(), load_average()
    IMAGES.mkdir(parents=True, exist_ok=True)

    # Sheets.
    models = BUILT_IN.resolve_many("all")
    sheet, tiles = compare_sheet(ROOT / "scenes" / "robot.toml", models, width=256, height=256)
    write_sheet(IMAGES / "robot_sheet.png", sheet)
    diff, _ = compare_sheet(ROOT / "scenes" / "robot.toml", BUILT_IN.resolve_many("microfacet,empirical"),
                            width=200, height=200, reference=BUILT_IN.resolve("ggx_correlated"))
    write_sheet(IMAGES / "robot_diff.png", diff)
    write_sheet(IMAGES / "sweep.png", sweep_sheet(ROOT / "scenes" / "red_ball.toml", BUILT_IN.resolve_many(
        "phong,phong_normalized,blinn_phong,blinn_phong_normalized,cook_torrance,walter_ggx,ggx_correlated"),
        size=120))

    # FPS table and ladders, one bench.
    bench = Bench.prepare(ROOT / "scenes" / "sphere_grid.toml", args.width, args.height, lights=1)
    rt = bench.runtime
    cases = [bench.case(m, label=m.label) for m in models]
    noise = [bench.case(BUILT_IN.resolve(NOISE_MODEL), label=f"{NOISE_MODEL} #{k + 2}", numpy=False)
             for k in range(NOISE_REPEATS - 1)]
    guard = bench.guard()
    copy_ms = run_cases(cases + noise, args.frames, args.warmup, guard=guard)
    rows = summarize(cases, copy_ms)
    noise_rows = summarize(noise, copy_ms, error=False)
    ladder = ladder_cases(bench)
    ladder_rows = summarize(ladder, run_cases(ladder, args.ladder_frames, args.warmup))
    mark_pareto(ladder_rows)
    title = f"sphere_grid {args.width}x{args.height}, 1 light, {rt.info.device}"
    plot_fps(rows, IMAGES / "fps.png", title)
    plot_ladder(ladder_rows, IMAGES / "accuracy_vs_time.png", title)
    doc = report(bench, rows, args.frames, args.warmup, ladder_rows, guard=guard)

    # Plausibility and the claims.
    verdicts = plausibility.evaluate_presets(plausibility.Sweep(), None)
    cost = fresnel_cost(rt)
    schlick = schlick_error()
    albedo = smith_albedo()
    peaks = smith_peak(rt)
    on_diff = oren_nayar_vs_lambert(rt)
    groups = group_times(rows)
    mean = {g: float(np.mean(t)) for g, t in groups.items()}
    spread = {g: (max(t) - min(t)) / min(t) for g, t in groups.items()}

    doc["claims"] = dict(group_mean_ms=mean, group_spread=spread, fresnel_ns=cost, schlick_error=schlick,
                         smith_albedo=albedo, smith_peak=peaks, oren_nayar_sigma0_max_abs_diff=on_diff)
    doc["plausibility"] = [v.as_dict() for v in verdicts]
    doc["noise"] = dict(model=NOISE_MODEL, mean_ms=[next(r["mean_ms"] for r in rows if r["model"] == BUILT_IN.resolve(NOISE_MODEL).id)]
                        + [r["mean_ms"] for r in noise_rows])
    doc["seconds"] = round(time.perf_counter() - start, 1)
    doc["load_average"] = dict(start=at_start, end=load_average())
    write_result(IMAGES / "report.json", doc, get_runtime().info.description)
    print(f"wrote the images of {IMAGES} in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
