"""How a result generator writes its results JSON: stamped with the provenance and the machine record
(clshade.provenance.stamp), as JSON at the path the registry (benchmarks/publish/registry.py) names.
The Markdown of a result is publish's (`python -m benchmarks.publish`)."""
from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Callable

from clshade.provenance import stamp

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "benchmarks" / "results"


def load_average() -> list[float]:
    """The load average (1, 5, 15 min) now: on a shared machine, how busy it was."""
    return [round(x, 2) for x in os.getloadavg()]


def write_result(out: Path | str, doc: dict, device: str | None = None, commit: str | None = None) -> dict:
    """`doc` stamped (provenance on `device`, default the host CPU, and the machine record) and written
    as JSON at `out`; returns the stamped document."""
    doc = stamp(doc, device, commit)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(doc, indent=2, ensure_ascii=False, default=float) + "\n", encoding="utf-8")
    print(f"wrote {out}; render its tables with: python -m benchmarks.publish")
    return doc


def measure_and_write(out: Path | str, measure: Callable[[], dict]) -> dict:
    """Run `measure` and write its document with the date and the load average at the start and the end,
    on the default device."""
    from clshade.device.runtime import get_runtime
    date, start = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), load_average()
    doc = {"date": date, **measure()}
    doc["load_average"] = {"start": start, "end": load_average()}
    return write_result(out, doc, get_runtime().info.description)
