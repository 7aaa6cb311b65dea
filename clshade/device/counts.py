"""The counting build's term counters (kernels/count.h, -D COUNT_TERMS): a buffer of
TERMS × CHECKS uint the kernel increments where a term's raw value is NaN, ±Inf,
negative or above its bound, before any clamp could hide it."""
from __future__ import annotations

import re
from functools import lru_cache

import numpy as np

from clshade.resources import kernels_dir


@lru_cache(maxsize=None)
def _names(prefix: str) -> tuple[str, ...]:
    """The NAME of each `#define {prefix}NAME index` of count.h, in index order."""
    text = (kernels_dir() / "count.h").read_text(encoding="utf-8")
    found = {int(m.group(2)): m.group(1)
             for m in re.finditer(rf"^#define {prefix}([A-Z_]+?)\s+(\d+)\b", text, re.M)}
    return tuple(found[i] for i in range(len(found)))


def term_names() -> tuple[str, ...]:
    """D, V, F, FD, FS, SPECULAR, BRDF, LIGHT, AMBIENT, RADIANCE (count.h's TERM_*)."""
    return _names("TERM_")


def check_names() -> tuple[str, ...]:
    """evaluated, nan, inf, negative, above (count.h's CHECK_*)."""
    return tuple(n.lower() for n in _names("CHECK_"))


def zeros(runtime):
    """A fresh counter buffer on the device."""
    return runtime.to_device(np.zeros(len(term_names()) * len(check_names()), np.uint32))


def read(runtime, buffer) -> dict[str, dict[str, int]]:
    """The counters by term and check."""
    terms, checks = term_names(), check_names()
    host = np.empty(len(terms) * len(checks), np.uint32)
    runtime.cl.enqueue_copy(runtime.queue, host, buffer)
    table = host.reshape(len(terms), len(checks))
    return {t: {c: int(table[i, j]) for j, c in enumerate(checks)} for i, t in enumerate(terms)}


def add(total: dict[str, dict[str, int]], more: dict[str, dict[str, int]]) -> dict[str, dict[str, int]]:
    """Counter tables summed (a new dict)."""
    out = {t: dict(c) for t, c in total.items()}
    for t, checks in more.items():
        row = out.setdefault(t, {})
        for c, n in checks.items():
            row[c] = row.get(c, 0) + n
    return out


def failures(table: dict[str, dict[str, int]]) -> dict[str, dict[str, int]]:
    """The non-zero NaN / Inf / negative / above-bound counts, by term."""
    out = {}
    for t, checks in table.items():
        bad = {c: n for c, n in checks.items() if c != "evaluated" and n}
        if bad:
            out[t] = bad
    return out
