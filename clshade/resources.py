"""Find the project's data folders (kernels/, scenes/) in a checkout or an install.

In a checkout they sit beside the package; a regular install maps them into
the package as clshade/kernels and clshade/scenes (see pyproject.toml).
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from clshade.errors import ClshadeError

_PACKAGE = Path(__file__).resolve().parent


def _find(name: str, marker: str) -> Path:
    for candidate in (_PACKAGE / name, _PACKAGE.parent / name):
        if (candidate / marker).exists():
            return candidate
    raise ClshadeError(f"cannot find the {name}/ folder next to {_PACKAGE} "
                       f"(looked for {name}/{marker}); reinstall clshade")


@lru_cache(maxsize=None)
def kernels_dir() -> Path:
    """The folder holding brdf.h, the entry kernels and models/*.cl."""
    return _find("kernels", "brdf.h")


@lru_cache(maxsize=None)
def scenes_dir() -> Path:
    """The folder holding the bundled scene files."""
    return _find("scenes", "README.md")
