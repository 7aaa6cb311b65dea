"""Measure every term of brdf.h and every model of the accuracy tests against the float64 reference (metric and
limits: clshade/verify/accuracy.py) and write benchmarks/results/accuracy.json. JSON only:
`python benchmarks/publish.py` renders docs/accuracy.md from it.

    python benchmarks/accuracy_table.py [--samples N] && python benchmarks/publish.py
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from clshade.verify import accuracy as A  # noqa: E402
from clshade.device.runtime import get_runtime  # noqa: E402
from clshade.provenance import stamp  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "accuracy.json"


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
                command="python benchmarks/accuracy_table.py", device=rt.info.description, target=A.TARGET,
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
    doc = stamp(doc, doc["device"])
    Path(args.out).write_text(json.dumps(doc, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    print(f"wrote {args.out} in {doc['seconds']} s; render docs/accuracy.md with: python benchmarks/publish.py")
    return 0


if __name__ == "__main__":
    sys.exit(main())
