"""Measure the bias of every named floor of the kernels through the shade path (clshade.verify.bias.floor_bias)
and write benchmarks/results/floor_bias.json. JSON only: the floor tables of docs/stability.md and
docs/models.md are rendered from it by `python -m benchmarks.publish`.

    python -m benchmarks.measure.floor_bias && python -m benchmarks.publish
"""
from __future__ import annotations

import datetime as _dt
import time

from benchmarks.publish.results_io import RESULTS, write_result
from clshade.device.runtime import get_runtime
from clshade.verify.bias import floor_bias

OUT = RESULTS / "floor_bias.json"


def main() -> int:
    start = time.perf_counter()
    rt = get_runtime()
    rows = floor_bias(rt)
    doc = dict(schema=1, created=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
               command="python -m benchmarks.measure.floor_bias", device=rt.info.device,
               seconds=round(time.perf_counter() - start, 1), floors=rows)
    write_result(OUT, doc, rt.info.description)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
