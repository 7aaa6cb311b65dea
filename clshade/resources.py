"""Find the project's data folders (kernels/, scenes/) in a checkout or an install.

In a checkout they sit beside the package; a regular install maps them into
the package as clshade/kernels and clshade/scenes (see pyproject.toml).
"""
from __future__ import annotations

import re
from dataclasses import dataclass
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


@dataclass(frozen=True)
class KernelConstant:
    """A `#define NAME value` of a kernel header with the comment above it."""
    name: str
    value: float
    comment: str
    file: str


_DEFINE = re.compile(r"/\*(?P<comment>(?:(?!\*/).)*)\*/\s*#define\s+(?P<name>[A-Z0-9_]+)\s+(?P<value>[-+0-9.eE]+)f?\s*$",
                     re.S | re.M)
_PLAIN_DEFINE = re.compile(r"^#define\s+(?P<name>[A-Z0-9_]+)\s+(?P<value>[-+0-9.eE]+)f?\s*$", re.M)

# The clamps of the BRDF terms (the documented, commented constants of the lobes).
CLAMP_FILES = ("brdf.h", "surface.h")
# Every kernel file holding a numeric constant Python needs (the one copy of each
# lives in the kernel source; Python reads it from there).
CONSTANT_FILES = ("brdf.h", "surface.h", "shade.cl", "shadow.h")


@lru_cache(maxsize=None)
def kernel_constants(files: tuple[str, ...] = CLAMP_FILES) -> dict[str, KernelConstant]:
    """The commented numeric `#define`s of these kernel files (comment = the block above)."""
    out: dict[str, KernelConstant] = {}
    for name in files:
        text = (kernels_dir() / name).read_text(encoding="utf-8")
        for m in _DEFINE.finditer(text):
            comment = " ".join(line.strip().lstrip("*").strip() for line in m.group("comment").splitlines()).strip()
            out[m.group("name")] = KernelConstant(m.group("name"), float(m.group("value")), comment, name)
    return out


@lru_cache(maxsize=None)
def _all_defines() -> dict[str, float]:
    """The first numeric `#define NAME value` of each name in CONSTANT_FILES."""
    out: dict[str, float] = {}
    for name in CONSTANT_FILES:
        for m in _PLAIN_DEFINE.finditer((kernels_dir() / name).read_text(encoding="utf-8")):
            out.setdefault(m.group("name"), float(m.group("value")))
    return out


def constant(name: str) -> float:
    """The value of a kernel constant, e.g. constant('MIN_ALPHA'), read from the kernel source."""
    try:
        return _all_defines()[name]
    except KeyError:
        raise ClshadeError(f"kernels/{{{','.join(CONSTANT_FILES)}}}: no '#define {name} <number>'") from None
