"""Markdown tables and CSV for every command: the one formatter of tabular data.

Measuring code returns rows (dicts or lists); this module turns them into text.
Markdown goes through `tabulate` (GitHub pipe tables), CSV through the standard
library. Cells are formatted by the caller with :func:`cell`.
"""
from __future__ import annotations

import csv
from pathlib import Path
from typing import Iterable, Sequence

from tabulate import tabulate

from clshade.outputs import write_atomic

MISSING = "—"     # a value that was not measured


def cell(x: object, spec: str = "") -> str:
    """`x` formatted with `spec`, or MISSING for None."""
    return MISSING if x is None else format(x, spec)


def escape(text: object) -> str:
    """Text safe in a Markdown table cell or list item: a `|` would end the cell."""
    return str(text).replace("|", "\\|")


def markdown(header: Sequence[object], rows: Iterable[Sequence[object]]) -> str:
    """A GitHub Markdown pipe table; cells are used as given (no number parsing), `|` escaped."""
    return tabulate([[escape(c) for c in r] for r in rows], headers=[escape(h) for h in header], tablefmt="github",
                    disable_numparse=True)


def write_csv(rows: list[dict], path: Path | str, first: Sequence[str] = ()) -> None:
    """Rows as CSV: the `first` keys, then every other key in the order met; lists joined by ';'."""
    keys = list(first) + [k for r in rows for k in r if k not in first]
    keys = list(dict.fromkeys(keys))

    def write(tmp: Path) -> None:
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            writer = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
            writer.writeheader()
            for r in rows:
                writer.writerow({k: (";".join(map(str, v)) if isinstance(v, list) else v) for k, v in r.items()})
    write_atomic(path, write)
