"""Time and check the sample user lobes (scenes/lobes/: BRDF Explorer files and a clshade-format
lobe) beside built-in models, with the columns a built-in gets, and write
benchmarks/results/user_lobes.json. JSON only: `python -m benchmarks.publish` renders
benchmarks/results/user_lobes.md and the worked example of docs/user-lobes.md from it.

Per model: device time per frame (mean over interleaved rounds), × copy kernel, × Lambert,
the frame's max and mean relative error against its float64 frame (`clshade bench`'s
columns); the float32 lobe against its float64 reference on the sampled hemisphere
(clshade.verify.accuracy.model_accuracy: the Python oracle for built-ins, the lobe's own
double-precision build for the user's) and, for built-ins, the double build against the oracle;
plausibility (`clshade check plausibility --quick`); stability counts over the torture grid,
both builds (`clshade check stability`).

    python -m benchmarks.measure.user_lobes [--frames N] && python -m benchmarks.publish
"""
from __future__ import annotations

import argparse
import datetime as _dt
import time

from benchmarks.publish.results_io import RESULTS, ROOT, write_result
from clshade.models.registry import Registry
from clshade.bench.run import run_bench
from clshade.device.runtime import get_runtime
from clshade.verify import accuracy as A
from clshade.verify import plausibility as P
from clshade.verify import stability as S

OUT = RESULTS / "user_lobes.json"
LOBES = ROOT / "scenes" / "lobes"
SCENE = ROOT / "scenes" / "red_ball.toml"
BUILT_INS = ("lambert", "blinn_phong", "ggx_correlated")
USERS = ("lambert_brdf.brdf", "blinn_phong_brdf.brdf", "ggx_brdf.brdf", "ward.brdf", "lommel_seeliger.cl")
ACCURACY_SAMPLES = 20000


def measure(frames: int, width: int, height: int) -> dict:
    rt = get_runtime()
    registry = Registry()
    chosen = [registry.resolve(m) for m in BUILT_INS] + [registry.resolve(str(LOBES / f)) for f in USERS]
    bench = run_bench(SCENE, chosen, frames, 10, width=width, height=height, numpy_frames=0)
    timed = {row["model"]: row for row in bench["models"]}
    verdicts = {v.preset: v for v in P.evaluate_presets(P.QUICK, models=chosen)}
    grid = S.geometry_grid()
    rows = []
    for model in chosen:
        lobe = model.lobes[-1]
        acc = A.model_accuracy(model, ACCURACY_SAMPLES, runtime=rt)
        agree = None if model.is_users else A.oracle_agreement(model, ACCURACY_SAMPLES, runtime=rt)
        grid_runs = [S.run_model(model, grid, rt, fm, {}) for fm in (False, True)]
        t, v = timed[model.id], verdicts[model.id]
        rows.append(dict(
            model=model.id, origin=lobe.origin, file=str(lobe.path.relative_to(ROOT)) if lobe.is_users else None,
            mean_ms=t["mean_ms"], copy_ratio=t["copy_ratio"], lambert_ratio=t["lambert_ratio"],
            frame_max_rel_error=t["max_rel_error"], frame_mean_rel_error=t["mean_rel_error"],
            reference=A.FP64 if model.is_users else A.ORACLE,
            f32_max_rel_err=acc.max_rel_err, f32_median_rel_err=acc.median_rel_err, f32_samples=acc.samples,
            fp64_vs_oracle=None if agree is None else agree.max_rel_err,
            min_f=v.min_f, reciprocity=v.max_reciprocity_error, max_albedo=max(v.max_albedo, v.composed_albedo),
            physically_based=v.physically_based,
            grid_cases=sum(r.cases for r in grid_runs), grid_nonfinite=sum(r.nonfinite for r in grid_runs),
            grid_negative=sum(r.negative for r in grid_runs)))
    return dict(schema=1, created=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                device=rt.info.description,
                command=f"python -m benchmarks.measure.user_lobes --frames {frames} --width {width} --height {height}",
                scene=str(SCENE.relative_to(ROOT)), width=width, height=height, frames=frames,
                accuracy_samples=ACCURACY_SAMPLES, rows=rows)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--width", type=int, default=512)
    parser.add_argument("--height", type=int, default=512)
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args()
    start = time.perf_counter()
    doc = measure(args.frames, args.width, args.height)
    doc["seconds"] = round(time.perf_counter() - start, 1)
    write_result(args.out, doc, get_runtime().info.description)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
