"""Measure the bias of every named floor of the kernels through the shade path (clshade.verify.bias.floor_bias)
and write benchmarks/results/floor_bias.json. JSON only: docs/stability.md's floor table is rendered from it by
benchmarks/publish.py, and docs/models.md (benchmarks/models_doc.py) quotes the same file.

    python benchmarks/floor_bias.py && python benchmarks/publish.py
"""
from __future__ import annotations

import datetime as _dt
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from clshade.device.runtime import get_runtime  # noqa: E402
from clshade.provenance import stamp  # noqa: E402
from clshade.verify.bias import floor_bias  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "floor_bias.json"


def main() -> int:
    start = time.perf_counter()
    rt = get_runtime()
    rows = floor_bias(rt)
    doc = dict(schema=1, created=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
               command="python benchmarks/floor_bias.py", device=rt.info.device,
               seconds=round(time.perf_counter() - start, 1), floors=rows)
    doc = stamp(doc, rt.info.description)
    OUT.write_text(json.dumps(doc, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    print(f"wrote {OUT} in {doc['seconds']} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
