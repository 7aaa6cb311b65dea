"""BRDF Explorer's `.brdf` files as clshade lobes.

The format (Disney's BRDF Explorer, wdas/brdf): a first line `analytic`; a
parameter block

    ::begin parameters
    float NAME MIN MAX DEFAULT
    color NAME R G B
    bool NAME DEFAULT
    ::end parameters

and a shader block `::begin shader … ::end shader` of GLSL defining
`vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)`: f for unit directions
towards the light L and the viewer V, the normal N and the tangent frame X, Y,
without the cosine. Lines starting with `#` outside the blocks are comments.

The shader is translated by clshade.models.glsl into a specular lobe of family
`brdf` (compose.h then adds nothing: f = the file's BRDF). A parameter named
like a material key (MATERIAL_KEYS: base_color, roughness, shininess, ior,
f90) is that key, read per pixel; the others are compiled in: the file's
defaults, replaced by `--param NAME=VALUE` (which also fixes a material-key
parameter to one value). The lobe
reads the Geometry's vectors (n, l, v) and, only when the shader reads X or Y,
its tangent frame.
"""
from __future__ import annotations

import math
import os
import re
import stat
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

from clshade.errors import ClshadeError
from clshade.models.glsl.emitter import translate
from clshade import budget
from clshade.models.glsl.limits import MAX_FLOAT
from clshade.models.lobe import BRDF_FILE, Lobe, Param

FAMILY = "brdf"

# Parameters named like a material key (scenes/README.md) read that key per pixel from the
# Surface (kernels/surface.h) — the scene's materials and textures set them and `clshade sweep`
# varies roughness — unless `--param` fixes them: name → (type, Surface member, `uses:` entry).
MATERIAL_KEYS = {"base_color": ("color", "s.base", None), "roughness": ("float", "s.roughness", "roughness"),
                 "shininess": ("float", "s.shininess", "shininess"), "ior": ("float", "s.ior", "ior"),
                 "f90": ("float", "s.f90", "f90")}


def lobe_id(path: Path) -> str:
    """The model id of a .brdf file: its name, lower-case, other characters as `_`."""
    text = re.sub(r"[^a-z0-9_]", "_", path.stem.lower())
    return text if text[:1].isalpha() else "brdf_" + text


def _number(path: Path, line: int, name: str, text: str) -> float:
    """A number of a parameter line: finite and within float range (the kernel's float build
    compiles it in: NaN or an infinity would reach the OpenCL compiler as `nan`, `inf`)."""
    try:
        value = float(text)
    except ValueError:
        raise ClshadeError(f"{path}:{line}: parameter {name!r}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise ClshadeError(f"{path}:{line}: parameter {name!r}: {text!r} is not a finite number")
    if abs(value) > MAX_FLOAT:
        raise ClshadeError(f"{path}:{line}: parameter {name!r}: {text} is past the largest float ({MAX_FLOAT:.8g})")
    return value


def parse_value(kind: str, text: str, where: str):
    """A parameter value given as text (`--param NAME=VALUE`): float, bool (0/1/true/false) or
    color (R,G,B or one grey level)."""
    try:
        if kind == "bool":
            low = text.strip().lower()
            if low in ("1", "true", "on", "yes"):
                return 1.0
            if low in ("0", "false", "off", "no"):
                return 0.0
            raise ValueError
        if kind == "color":
            parts = [float(x) for x in text.split(",")]
            if len(parts) == 1:
                parts *= 3
            if len(parts) != 3:
                raise ValueError
            return tuple(parts)
        return float(text)
    except ValueError:
        want = {"bool": "0, 1, true or false", "color": "R,G,B or one number"}.get(kind, "a number")
        raise ClshadeError(f"{where}: {text!r} is not {want}") from None


@dataclass(frozen=True)
class BrdfSource:
    """A .brdf file as written: its declared parameters (kind, name, default values, line) and its
    shader's text with the file line the shader starts at."""
    params: tuple[tuple[str, str, tuple[float, ...], int], ...]
    ranges: Mapping[str, tuple[float, float]]
    shader: str
    shader_line: int


def read_source(path: Path) -> BrdfSource:
    """The blocks of a .brdf file; errors name the file and the line."""
    lines = budget.read_text(path, "lobe file", budget.MAX_LOBE_FILE_BYTES).splitlines()
    first = next(((i, l.strip()) for i, l in enumerate(lines, 1) if l.strip() and not l.strip().startswith("#")),
                 (1, ""))
    if first[1] != "analytic":
        raise ClshadeError(f"{path}:{first[0]}: the first line must be 'analytic' "
                           f"(BRDF Explorer's measured and image BRDFs are not supported)")
    blocks: dict[str, tuple[int, list[str]]] = {}
    current, start = None, 0
    for i, raw in enumerate(lines, 1):
        line = raw.strip()
        m = re.fullmatch(r"::(begin|end)\s+(\w+)", line)
        if m:
            verb, name = m.groups()
            if verb == "begin":
                if current is not None:
                    raise ClshadeError(f"{path}:{i}: '::begin {name}' inside '::begin {current}'")
                if name not in ("parameters", "shader"):
                    raise ClshadeError(f"{path}:{i}: unknown block '::begin {name}' (parameters or shader)")
                if name in blocks:
                    raise ClshadeError(f"{path}:{i}: a second '::begin {name}' block (the first begins at line "
                                       f"{blocks[name][0] - 1})")
                current, start = name, i
                blocks[name] = (i + 1, [])
            else:
                if current != name:
                    raise ClshadeError(f"{path}:{i}: '::end {name}' without '::begin {name}'")
                current = None
            continue
        if current is not None:
            blocks[current][1].append(raw)
    if current is not None:
        raise ClshadeError(f"{path}:{start}: '::begin {current}' has no '::end {current}'")
    if "shader" not in blocks:
        raise ClshadeError(f"{path}:{len(lines)}: no '::begin shader' block")

    params: list[tuple[str, str, tuple[float, ...], int]] = []
    ranges: dict[str, tuple[float, float]] = {}
    p_first, p_lines = blocks.get("parameters", (1, []))
    for k, raw in enumerate(p_lines):
        at = p_first + k
        words = raw.split("#", 1)[0].split()
        if not words:
            continue
        kind, name = words[0], (words[1] if len(words) > 1 else "")
        if not re.fullmatch(r"[A-Za-z_]\w*", name):
            raise ClshadeError(f"{path}:{at}: parameter line {raw.strip()!r} is not 'TYPE NAME ...'")
        if kind == "float" and len(words) == 5:
            low, high, default = (_number(path, at, name, w) for w in words[2:5])
            if not low <= default <= high:
                raise ClshadeError(f"{path}:{at}: parameter {name!r}: default {default:g} outside its range "
                                   f"[{low:g}, {high:g}]")
            ranges[name] = (low, high)
            params.append((kind, name, (default,), at))
        elif kind == "color" and len(words) == 5:
            rgb = tuple(_number(path, at, name, w) for w in words[2:5])
            if not all(0.0 <= c <= 1.0 for c in rgb):
                raise ClshadeError(f"{path}:{at}: colour parameter {name!r}: default {' '.join(words[2:5])} has a "
                                   f"component outside [0, 1]")
            params.append((kind, name, rgb, at))
        elif kind == "bool" and len(words) == 3:
            params.append((kind, name, (1.0 if _number(path, at, name, words[2]) else 0.0,), at))
        else:
            raise ClshadeError(f"{path}:{at}: parameter line {raw.strip()!r} is not 'float NAME MIN MAX DEFAULT', "
                               f"'color NAME R G B' or 'bool NAME DEFAULT'")
        if sum(p[1] == name for p in params) > 1:
            raise ClshadeError(f"{path}:{at}: parameter {name!r} is declared twice")
    s_first, s_lines = blocks["shader"]
    return BrdfSource(tuple(params), MappingProxyType(ranges), "\n".join(s_lines), s_first)


def load_brdf(path: Path, values: Mapping[str, str]) -> Lobe:
    """The Lobe of a .brdf file with its parameters set (defaults, then `values`)."""
    source = read_source(path)
    params: list[Param] = []
    compiled: dict[str, tuple[str, str]] = {}
    for kind, name, default, at in source.params:
        if kind == "float":
            low, high = source.ranges[name]
            value = float(parse_value("float", values[name], f"--param {name}")) if name in values else default[0]
            if not low <= value <= high:
                raise ClshadeError(f"--param {name}={value:g}: outside [{low:g}, {high:g}] of {path}:{at}")
            params.append(Param(name, low, high, default[0], f"float parameter of {path.name}", "float", (value,)))
            compiled[name] = ("float", f"G_LIT({_c(value)})")
        elif kind == "color":
            rgb = parse_value("color", values[name], f"--param {name}") if name in values else default
            params.append(Param(name, 0.0, 1.0, sum(default) / 3, f"colour parameter of {path.name} "
                                f"(default {', '.join(f'{c:g}' for c in default)})", "color", tuple(rgb)))
            compiled[name] = ("vec3", "v3(" + ", ".join(f"G_LIT({_c(c)})" for c in rgb) + ")")
        else:
            value = parse_value("bool", values[name], f"--param {name}") if name in values else default[0]
            params.append(Param(name, 0.0, 1.0, default[0], f"bool parameter of {path.name}", "bool", (value,)))
            compiled[name] = ("bool", "G_TRUE" if value else "G_FALSE")

    uses = {"vectors"}
    for i, p in enumerate(params):
        key = MATERIAL_KEYS.get(p.name)
        if key is not None and key[0] == p.kind and p.name not in values:
            compiled[p.name] = ("vec3" if p.kind == "color" else "float", f"({key[1]})")
            uses |= {key[2]} - {None}
            params[i] = replace(p, value=(), description=f"the material key {p.name}, per pixel ({path.name})")
    s_first = source.shader_line
    tr = translate(source.shader, path, compiled, first_line=s_first)
    tangents = bool(tr.reads & {"X", "Y"})
    frame = "g.x, g.y" if tangents else "v3s((real)(0.0f)), v3s((real)(0.0f))"
    code = (f'#line 1 "{path}"\n{tr.code}'
            f'#line {s_first} "{path}"\n'
            f"INLINE vec3 specular_lobe(const Geometry g, const Surface s) {{\n"
            f"    return {tr.entry}(g.l, g.v, g.n, {frame}, s);\n}}\n")
    ident = lobe_id(path)
    return Lobe(id=ident, name=path.stem, kind="specular", family=FAMILY,
                formula=f"f = BRDF(L, V, N, X, Y) of {path.name} (BRDF Explorer shader, translated)",
                source=str(path), params=tuple(params),
                uses=frozenset(uses | ({"tangents"} if tangents else set())),
                notes=(), deviations=(), path=path, origin=BRDF_FILE, code=code)


def _c(x: float) -> str:
    """A value as a literal for G_LIT (repr: round-trips in double)."""
    text = repr(float(x))
    return text if ("." in text or "e" in text) else text + ".0"
