"""Shared by the benchmark scripts that publish a results JSON and a Markdown file rendered
from it: the machine description, and the measure-or-re-render flow."""
from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path
from typing import Callable

from clshade.provenance import stamp


def machine() -> dict:
    """CPU model, core count, memory, Python, device and the load average now."""
    from clshade.device.runtime import get_runtime
    info = Path("/proc/cpuinfo").read_text().splitlines() if Path("/proc/cpuinfo").exists() else []
    cpu = next((l.split(":", 1)[1].strip() for l in info if l.startswith("model name")), platform.processor())
    meminfo = Path("/proc/meminfo").read_text().splitlines() if Path("/proc/meminfo").exists() else []
    mem = next((int(l.split()[1]) * 1024 for l in meminfo if l.startswith("MemTotal")), None)
    return {"cpu": cpu, "cores": os.cpu_count(), "memory_bytes": mem, "python": platform.python_version(),
            "device": get_runtime().info.description, "load_average_at_start": list(os.getloadavg())}


def load_average() -> list[float]:
    """The load average (1, 5, 15 min) now: on the shared machine, how busy it was."""
    return [round(x, 2) for x in os.getloadavg()]


def publish(out: Path, measure: Callable[[], dict], markdown: Callable[[dict], str], markdown_only: bool) -> dict:
    """Measure (unless `markdown_only`: re-read `out`), write `out` (JSON, with date, machine and provenance)
    and the Markdown rendered from it beside it (.md)."""
    if markdown_only:
        doc = json.loads(out.read_text(encoding="utf-8"))
    else:
        host = machine()
        doc = stamp({"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "machine": host, **measure()},
                    host["device"])
        out.write_text(json.dumps(doc, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    out.with_suffix(".md").write_text(markdown(doc), encoding="utf-8")
    print(f"wrote {out} and {out.with_suffix('.md')}")
    return doc
