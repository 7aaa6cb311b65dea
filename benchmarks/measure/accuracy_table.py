"""Measure every term of brdf.h and every model of the accuracy tests against the float64 reference (metric and
limits: clshade/verify/accuracy.py) and write benchmarks/results/accuracy.json. JSON only:
`python -m benchmarks.publish` renders docs/accuracy.md from it.

    python -m benchmarks.measure.accuracy_table [--samples N] && python -m benchmarks.publish
"""
from __future__ import annotations

import argparse
import datetime as _dt
import time

from benchmarks.publish.results_io import RESULTS, write_result
from clshade.device.runtime import get_runtime
from clshade.verify import accuracy as A

OUT = RESULTS / "accuracy.json"


def measure(samples: int = A.SAMPLES) -> dict:
    """Terms, then models: samples, max and median relative error (and outside the limits)."""
    rt = get_runtime()
    terms = []
    for name in A.TERMS:
        r = A.term_accuracy(name, samples, runtime=rt)
        terms.append(dict(name=name, samples=r.samples, max_rel_err=r.max_rel_err, median_rel_err=r.median_rel_err))
    models = []
    for model in A.accuracy_models():
        r = A.model_accuracy(model, samples, runtime=rt)
        models.append(dict(model=model.id, samples=r.samples, max_rel_err=r.max_rel_err,
                           median_rel_err=r.median_rel_err, hard_samples=r.hard_samples,
                           hard_max_rel_err=r.hard_max_rel_err))
    return dict(schema=1, created=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                command="python -m benchmarks.measure.accuracy_table", device=rt.info.description, target=A.TARGET,
                floor_rel=A.FLOOR_REL, min_cosine=A.MIN_COSINE, min_roughness=A.MIN_ROUGHNESS,
                min_alpha_cosine=A.MIN_ALPHA_COSINE, max_shininess=A.MAX_SHININESS, terms=terms, models=models)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=A.SAMPLES)
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args()
    start = time.perf_counter()
    doc = measure(args.samples)
    doc["seconds"] = round(time.perf_counter() - start, 1)
    write_result(args.out, doc, doc["device"])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
