"""Regenerate benchmarks/REPORT.md and its images (benchmarks/report/) from one run.

The study reproduced: comparison sheets, the FPS table with lows, accuracy
against time, the plausibility table, and each of the study's claims checked
against our own measurements.

    python benchmarks/make_report.py [--frames 60] [--width 1920] [--height 1080]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from clshade.verify import plausibility as P  # noqa: E402
from clshade.verify import reference as R  # noqa: E402
from clshade.bench.run import Bench, ladder_cases, mark_pareto, report, run_cases, summarize  # noqa: E402
from clshade.report import bench_table as table, plot_fps, plot_ladder  # noqa: E402
from clshade.compare import compare_sheet, sweep_sheet, write_sheet  # noqa: E402
from clshade.device.evaluate import Samples, constant_materials, eval_brdf  # noqa: E402
from clshade.models import GROUPS, preset, resolve, resolve_many  # noqa: E402
from clshade.resources import kernels_dir  # noqa: E402

OUT = ROOT / "benchmarks"
IMAGES = OUT / "report"
FRESNEL_ITEMS = 1 << 20          # work-items of the Fresnel micro-benchmark
FRESNEL_REPEAT = 64              # term evaluations per work-item
FRESNEL_ROUNDS = 9               # interleaved timing rounds; medians reported
GOLD = ((0.18, 0.42, 1.37), (3.42, 2.35, 1.77))


# ------------------------------------------------------------------ claim (c)


def fresnel_cost(runtime) -> dict[str, float]:
    """ns per evaluation of each Fresnel term (compute-bound kernel, loop baseline subtracted)."""
    cl = runtime.cl
    source = "".join((kernels_dir() / name).read_text() for name in ("simd.h", "brdf.h")) + \
        (OUT / "kernels" / "fresnel_cost.cl").read_text()
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
    for name, exact, f0 in (("dielectric (IOR 1.5)", R.f_dielectric(c, 1.5), ((1.5 - 1) / 2.5) ** 2),
                            ("conductor (gold)", R.f_conductor(c, GOLD[0], GOLD[1]), None)):
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
                fn = lambda n, l, vv, lobe=lobe, r=r: R.brdf("none", lobe, n, l, vv, base_color=1.0,  # noqa: E731
                                                           roughness=r, f0=1.0)[..., 0]
                vals[lobe] = float(R.directional_albedo(fn, v=v))
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
            f = {m: float(eval_brdf(resolve(m), samples, runtime)[0, 0]) for m in ("walter_ggx", "ggx_correlated")}
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
    ap.add_argument("--frames", type=int, default=60, help="timed frames per model (default 60)")
    ap.add_argument("--ladder-frames", type=int, default=20)
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    args = ap.parse_args()
    start = time.perf_counter()
    IMAGES.mkdir(parents=True, exist_ok=True)

    # Sheets.
    models = resolve_many("all")
    sheet, tiles = compare_sheet(ROOT / "scenes" / "robot.toml", models, width=256, height=256)
    write_sheet(IMAGES / "robot_sheet.png", sheet)
    diff, _ = compare_sheet(ROOT / "scenes" / "robot.toml", resolve_many("microfacet,empirical"),
                            width=200, height=200, reference=resolve("ggx_correlated"))
    write_sheet(IMAGES / "robot_diff.png", diff)
    write_sheet(IMAGES / "sweep.png", sweep_sheet(ROOT / "scenes" / "red_ball.toml", resolve_many(
        "phong,phong_normalized,blinn_phong,blinn_phong_normalized,cook_torrance,walter_ggx,ggx_correlated"),
        size=120))

    # FPS table and ladders, one bench.
    bench = Bench.prepare(ROOT / "scenes" / "sphere_grid.toml", args.width, args.height, lights=1)
    rt = bench.runtime
    cases = [bench.case(m, label=m.label) for m in models]
    rows = summarize(cases, run_cases(cases, args.frames, args.warmup))
    ladder = ladder_cases(bench)
    ladder_rows = summarize(ladder, run_cases(ladder, args.ladder_frames, args.warmup))
    mark_pareto(ladder_rows)
    title = f"sphere_grid {args.width}x{args.height}, 1 light, {rt.info.device}"
    plot_fps(rows, IMAGES / "fps.png", title)
    plot_ladder(ladder_rows, IMAGES / "accuracy_vs_time.png", title)
    doc = report(bench, rows, args.frames, args.warmup, ladder_rows)

    # Plausibility and the claims.
    verdicts = P.evaluate_presets(P.Sweep(), None)
    cost = fresnel_cost(rt)
    schlick = schlick_error()
    albedo = smith_albedo()
    peaks = smith_peak(rt)
    on_diff = oren_nayar_vs_lambert(rt)
    groups = group_times(rows)
    mean = {g: float(np.mean(t)) for g, t in groups.items()}
    spread = {g: (max(t) - min(t)) / min(t) for g, t in groups.items()}
    ladder_by = {r["label"]: r for r in ladder_rows}

    doc["claims"] = dict(group_mean_ms=mean, group_spread=spread, fresnel_ns=cost, schlick_error=schlick,
                         smith_albedo=albedo, smith_peak=peaks, oren_nayar_sigma0_max_abs_diff=on_diff)
    doc["plausibility"] = [v.as_dict() for v in verdicts]
    (IMAGES / "report.json").write_text(json.dumps(doc, indent=2, ensure_ascii=False, default=float), encoding="utf-8")

    dev, mach = doc["device"], doc["machine"]
    pb_vs_emp = mean["microfacet"] / mean["empirical"] - 1
    d_ratio = ladder_by["exact dielectric"]["mean_ms"] / ladder_by["Schlick (dielectric F0 0.04)"]["mean_ms"]
    c_ratio = ladder_by["exact conductor"]["mean_ms"] / ladder_by["Schlick (conductor F0)"]["mean_ms"]
    sd, sc = schlick["dielectric (IOR 1.5)"], schlick["conductor (gold)"]
    gain = [r["correlated"] / r["separable"] - 1 for r in albedo]
    peak_gain = [r["correlated"] / r["separable"] - 1 for r in peaks]
    md = [
        "# clshade report: the study reproduced",
        "",
        f"Generated by `python benchmarks/make_report.py` in one run ({time.perf_counter() - start:.0f} s) on "
        f"{mach['processor']}, {mach['cpu_count']} shared CPUs, {mach['os']}; OpenCL device {dev['name']} "
        f"[{dev['platform_version']}]. Timings: scenes/sphere_grid.toml at {args.width}×{args.height}, one "
        f"directional light + ambient, precise math, {args.frames} frames per model after {args.warmup} warm-up, "
        "models and copy kernels interleaved in rounds. Only ratios from this one run are compared; the machine "
        "is shared and noisy. A CPU OpenCL device is not a GPU running Unity: where our numbers disagree with "
        "the study's, that difference is part of the answer.",
        "",
        "## What the models look like",
        "",
        "Every preset on one G-buffer of scenes/robot.toml (device time per frame under each tile):",
        "",
        "![robot sheet](report/robot_sheet.png)",
        "",
        "Where the empirical and microfacet models differ from GGX height-correlated (false colour, display values):",
        "",
        "![difference](report/robot_diff.png)",
        "",
        "The smoothness sweep (the study's Figure 4): the normalised lobes brighten as they narrow; unnormalised "
        "Phong and Blinn–Phong dim and the highlight energy is not conserved:",
        "",
        "![sweep](report/sweep.png)",
        "",
        "## Performance (FPS with 1 % and 0.1 % lows) and accuracy",
        "",
        table(rows),
        "",
        "![FPS](report/fps.png)",
        "",
        "## Accuracy against time: the approximation ladders",
        "",
        "Each rung's error against the float64 reference of its ladder's exact model; ● marks the Pareto front.",
        "",
        table(ladder_rows, ladder=True),
        "",
        "![accuracy vs time](report/accuracy_vs_time.png)",
        "",
        "## Physical plausibility (measured on the device)",
        "",
        *P.table(verdicts),
        "",
        *P.describe_method(),
        "",
        "## The study's claims, checked",
        "",
        f"**(a) Physically based models cost about 40 % more than the empirical ones.** Mean frame time of the "
        f"microfacet presets {mean['microfacet']:.2f} ms, of the empirical presets {mean['empirical']:.2f} ms, of the "
        f"diffuse presets {mean['diffuse']:.2f} ms: the microfacet models cost **{pb_vs_emp:+.0%}** relative to the "
        f"empirical ones. " + ("Holds." if 0.25 <= pb_vs_emp <= 0.55 else
                               "Does not hold here: on PoCL's CPU device the empirical lobes pay for a runtime "
                               "exponent (xⁿ = exp2(n·log2 x): a polynomial log2 and an exp2 per light), which a GPU "
                               "evaluates in a few cycles, and on the sphere grid read a material id per pixel "
                               "(shininess varies per sphere), while GGX needs only multiplies, one division "
                               "and square roots. The cost ordering follows the transcendental count, not the "
                               "model family."),
        "",
        "**(b) Within a category the difference is about 1 %.** Spread (slowest − fastest) / fastest: "
        + ", ".join(f"{g} **{spread[g]:.0%}**" for g in GROUPS) + ". "
        + ("Holds." if max(spread.values()) <= 0.05 else
           "Does not hold here: per-pixel arithmetic is not hidden behind memory traffic on this device (the "
           "kernels take 1.1–2× the copy kernel's time, see the table: the difference is arithmetic), so each "
           "extra term shows in the frame time; on a GPU at 1080p the study's frames were bound by other costs."),
        "",
        f"**(c) Schlick's Fresnel is about 32× cheaper than the exact one, with under 1 % error.** Arithmetic cost "
        f"per evaluation (compute-bound micro-benchmark, benchmarks/kernels/fresnel_cost.cl): Schlick "
        f"{cost['schlick']:.2f} ns, exact dielectric {cost['dielectric']:.2f} ns "
        f"(**{cost['dielectric'] / max(cost['schlick'], 1e-9):.1f}×**), exact conductor {cost['conductor']:.2f} ns "
        f"(**{cost['conductor'] / max(cost['schlick'], 1e-9):.1f}×**, three channels). In a whole GGX frame the "
        f"exact Fresnel costs {d_ratio:.2f}× (dielectric) and {c_ratio:.2f}× (conductor) the Schlick frame. Error "
        f"of Schlick against the exact term: dielectric IOR 1.5 — max relative {sd['max_rel']:.1%} (at cos θ = "
        f"{sd['argmax_cos']:.2f}), max absolute {sd['max_abs']:.4f}, cosine-weighted average {sd['avg_rel']:.2%}; "
        f"gold — max relative {sc['max_rel']:.1%}, average {sc['avg_rel']:.2%}. So: the cost ratio is "
        + ("of the study's order" if cost['dielectric'] / max(cost['schlick'], 1e-9) > 10 else
           "an order of magnitude below the study's 32× on this device")
        + "; 'under 1 % error' "
        + ", ".join(f"{'holds' if e['avg_rel'] < 0.01 else 'does not hold'} on average for {name}"
                    for name, e in schlick.items())
        + f" and holds pointwise for neither (max absolute error {sd['max_abs']:.3f} for the dielectric, "
        "largest near Brewster's angle where Schlick misses the dip of the p-polarised reflectance).",
        "",
        "**(d) Height-correlated Smith G gives brighter highlights and less energy loss than separable Smith.** "
        f"Directional albedo with F = 1 (float64 reference; energy lost = 1 − albedo), correlated vs separable: "
        f"the two agree at normal view (Λ(v) = 0 there, so G₂ = G₁(l) for both) and the correlated albedo is higher "
        f"everywhere else, by up to {max(gain):+.1%} (rough, grazing); at the mirror direction the correlated f is "
        f"higher by up to {max(peak_gain):+.1%} (device). "
        + ("Holds." if min(gain) > -1e-6 and min(peak_gain) > -1e-6 else "Does not hold everywhere (see the table)."),
        "",
        "| roughness | n·v | albedo separable | albedo correlated | energy lost separable | energy lost correlated |",
        "|---|---|---|---|---|---|",
        *[f"| {r['roughness']:g} | {r['nv']:g} | {r['separable']:.4f} | {r['correlated']:.4f} | "
          f"{1 - r['separable']:.4f} | {1 - r['correlated']:.4f} |" for r in albedo],
        "",
        f"**(e) Oren–Nayar with σ = 0 is Lambert.** Largest difference over 10⁵ random direction pairs and colours, "
        f"on the device: **{on_diff:.1e}** (A = 1, B = 0 at σ = 0). Holds exactly.",
        "",
        "## Targets of the benchmark issue",
        "",
        "See benchmarks/results/bench_1080p.md for the targets, which ones this device misses and the measured "
        "cause of each (its notes: what still limits each kernel).",
    ]
    (OUT / "REPORT.md").write_text("\n".join(md) + "\n", encoding="utf-8")
    print(f"wrote {OUT / 'REPORT.md'} and {IMAGES}/ in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
