"""The project error: library code raises it, only the CLI prints it."""
from __future__ import annotations

from pathlib import Path
from typing import Any


class ClshadeError(Exception):
    """An error a user can act on; its message is one line naming what is wrong."""


def located(message: str, file: str | Path | None = None, key: str | None = None,
            value: Any = None, *, has_value: bool = False) -> ClshadeError:
    """Build an error whose message names the file, the key and the value."""
    parts = []
    if file is not None:
        parts.append(str(file))
    if key is not None:
        parts.append(key if not has_value else f"{key} = {plain(value)!r}")
    where = ": ".join(parts)
    return ClshadeError(f"{where}: {message}" if where else message)


def plain(value: Any) -> Any:
    """NumPy scalars and arrays (also inside lists and tuples) as Python numbers and lists,
    so messages read `[0.0, 1.0]`, not `[np.float64(0.0), ...]`."""
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        return value.tolist()
    return value
