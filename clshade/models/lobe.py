"""One lobe: its parameters, where it comes from, and the `/*! clshade-model` header it is read from.

Each lobe is one file whose header block declares its id, name, kind, family, formula,
source, parameters, the inputs it uses and its deviations from the study. This module
parses those headers; nothing here repeats them. The built-in lobes (kernels/models/*.cl)
are read once per process and never change.
"""
from __future__ import annotations

import math
import re
import unicodedata
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

from clshade import budget
from clshade.errors import ClshadeError
from clshade.resources import kernels_dir


@dataclass(frozen=True)
class Param:
    """One lobe parameter as declared in its kernel file: `name | min | max | default | text`.
    A BRDF Explorer file's parameters are Params too (`kind` float, color or bool; a colour's
    default is its grey level, its `value` the RGB triple compiled in)."""
    name: str
    low: float
    high: float
    default: float
    description: str
    kind: str = "float"
    value: tuple[float, ...] = ()


# Where a lobe comes from: shipped in kernels/models/, a user's .cl file, a BRDF Explorer .brdf file.
BUILT_IN, USER, BRDF_FILE = "built-in", "user", "brdf"

# The inputs a lobe may declare in `uses:` (Surface fields, the Fresnel term, and the
# Geometry's vectors: `vectors` = n, l, v; `tangents` = the tangent frame x, y too).
USES = frozenset({"roughness", "metallic", "fresnel", "shininess", "kd", "ks", "ka", "ior", "f90", "eta", "k",
                  "vectors", "tangents"})
# The surface inputs every model reads besides its lobes' parameters (kernels/surface.h
# make_surface, per pixel in the G-buffer), declared as a lobe declares its parameters. The
# defaults are the scene format's (clshade.render.scene.Material; tests/view/test_view.py checks them).
SURFACE_PARAMS = (
    Param("base_color", 0.0, 1.0, 0.8, "linear base colour, each of R, G, B (albedo; a metal's F0)", kind="color"),
    Param("metallic", 0.0, 1.0, 0.0, "metalness (metallic workflow): 0 dielectric, 1 metal"),
)


@dataclass(frozen=True)
class Lobe:
    """A diffuse or specular lobe, read from kernels/models/<id>.cl or a user's lobe file."""
    id: str
    name: str
    kind: str          # "diffuse" or "specular"
    family: str        # "diffuse", "empirical" or "microfacet" (built-in); any word for a user's lobe
    formula: str
    source: str
    params: tuple[Param, ...]
    uses: frozenset[str]
    notes: tuple[str, ...]
    deviations: tuple[str, ...]
    path: Path
    origin: str = BUILT_IN
    code: str = ""     # the OpenCL C that clshade.device.variants assembles (with its #line marker)

    @property
    def is_users(self) -> bool:
        return self.origin != BUILT_IN


_HEADER = re.compile(r"/\*!\s*clshade-model(.*?)\*/", re.S)
# The function a lobe file defines, by kind (compose.h calls it).
LOBE_FUNCTIONS = {"diffuse": ("real", "diffuse_lobe"), "specular": ("vec3", "specular_lobe")}
ID_PATTERN = re.compile(r"[a-z][a-z0-9_]*")


# Characters a lobe file's path may not hold: the kernel source names the file in `#line N "path"`
# markers, which a line break, a quote or a backslash would end or change (C has no escape there
# that every compiler reads back), and a compiler's log is read line by line.
_PATH_BREAKING = frozenset('"\\')
_LINE_BREAKING_CATEGORIES = frozenset({"Cc", "Zl", "Zp"})    # control characters, line and paragraph separators


def check_lobe_path(path: Path) -> Path:
    """`path` when it can be named in a `#line` marker; else a one-line error naming it (escaped)."""
    text = str(path)
    bad = next((c for c in text if c in _PATH_BREAKING or unicodedata.category(c) in _LINE_BREAKING_CATEGORIES), None)
    if bad is not None:
        raise ClshadeError(f"{ascii(text)[1:-1]}: a lobe file's path may not hold {ascii(bad)} (control characters, "
                           f"quotes and backslashes would break the kernel's #line markers); rename it")
    return path


def parse_lobe(path: Path, origin: str = BUILT_IN) -> Lobe:
    """A lobe file's header and code; errors name the file and the header line (`path:line: ...`).
    The file must be a regular file of at most budget.MAX_LOBE_FILE_BYTES of UTF-8."""
    text = budget.read_text(path, "lobe file", budget.MAX_LOBE_FILE_BYTES)
    where = str(path)
    match = _HEADER.search(text)
    if not match:
        raise ClshadeError(f"{where}:1: no '/*! clshade-model' header block")
    first = text.count("\n", 0, match.start(1)) + 1
    single: dict[str, str] = {}
    lines: dict[str, int] = {}
    multi: dict[str, list[tuple[str, int]]] = {"param": [], "note": [], "deviation": []}
    for offset, raw in enumerate(match.group(1).splitlines()):
        line = raw.strip().lstrip("*").strip()
        at = first + offset
        if not line:
            continue
        key, sep, value = line.partition(":")
        if not sep:
            raise ClshadeError(f"{where}:{at}: header line {line!r} is not 'key: value'")
        key, value = key.strip(), value.strip()
        lines[key] = at
        if key in multi:
            multi[key].append((value, at))
        else:
            single[key] = value
    end = text.count("\n", 0, match.end()) + 1
    required = ("id", "name", "kind", "family", "formula", "source")
    missing = [k for k in required if k not in single]
    if missing:
        raise ClshadeError(f"{where}:{end}: header lacks {', '.join(missing)}")
    if single["id"] != path.stem:
        raise ClshadeError(f"{where}:{lines['id']}: id = {single['id']!r} differs from the file name")
    if not ID_PATTERN.fullmatch(single["id"]):
        raise ClshadeError(f"{where}:{lines['id']}: id = {single['id']!r} must be lower-case letters, digits and _")
    if single["kind"] not in LOBE_FUNCTIONS:
        raise ClshadeError(f"{where}:{lines['kind']}: kind = {single['kind']!r} must be diffuse or specular")
    params = []
    for value, at in multi["param"]:
        cells = [c.strip() for c in value.split("|")]
        try:
            if len(cells) != 5:
                raise ValueError
            low, high, default = float(cells[1]), float(cells[2]), float(cells[3])
        except ValueError:
            raise ClshadeError(f"{where}:{at}: param {value!r} is not 'name | min | max | default | text'") from None
        # NaN, inf and 1e309 would reach the compiler and JSON (`clshade models --json`, the viewer).
        for key, number, written in zip(("min", "max", "default"), (low, high, default), cells[1:4]):
            if not math.isfinite(number):
                raise ClshadeError(f"{where}:{at}: param {cells[0]}: {key} = {written} is not a finite number")
        if not low <= default <= high:
            raise ClshadeError(f"{where}:{at}: param {cells[0]}: default {default:g} is outside [{low:g}, {high:g}]")
        params.append(Param(cells[0], low, high, default, cells[4]))
    uses = frozenset(u.strip() for u in single.get("uses", "-").split(",") if u.strip() not in ("", "-"))
    unknown = sorted(uses - USES)
    if unknown:
        raise ClshadeError(f"{where}:{lines['uses']}: uses {', '.join(unknown)}: not an input of a lobe "
                           f"(known: {', '.join(sorted(USES))})")
    ctype, function = LOBE_FUNCTIONS[single["kind"]]
    body = text[match.end():]
    if not re.search(rf"\b{ctype}\s+{function}\s*\(", body):
        raise ClshadeError(f"{where}:{end}: kind: {single['kind']} needs a function "
                           f"'INLINE {ctype} {function}(const Geometry g, const Surface s)' after the header")
    name = f"models/{path.name}" if origin == BUILT_IN else str(path)
    return Lobe(id=single["id"], name=single["name"], kind=single["kind"], family=single["family"],
                formula=single["formula"], source=single["source"], params=tuple(params), uses=uses,
                notes=tuple(v for v, _ in multi["note"]), deviations=tuple(v for v, _ in multi["deviation"]),
                path=path, origin=origin, code=f'#line 1 "{name}"\n{text}\n')


@lru_cache(maxsize=None)
def builtin_lobes() -> Mapping[str, Lobe]:
    """The lobes clshade ships (kernels/models/*.cl), by id (read-only)."""
    found = {}
    for path in sorted((kernels_dir() / "models").glob("*.cl")):
        lobe = parse_lobe(path)
        found[lobe.id] = lobe
    return MappingProxyType(found)
