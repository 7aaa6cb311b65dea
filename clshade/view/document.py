"""The viewer's scene as a TOML document: the scene file's own tables with the page's
controls written into them (camera position, model, exposure, materials, lights), so
that the frame on screen, the scene the viewer renders and the file "save" writes are
one text, parsed by the one scene parser (clshade.render.scene.parse_scene)."""
from __future__ import annotations

import copy
import json
import math
import os
import re
from pathlib import Path
from typing import Any

from clshade.errors import ClshadeError
from clshade.models.registry import LOBE_SUFFIXES
from clshade.render.scene import TEXTURE_KEYS
from clshade.view.controls import SKY_NONE, SKY_WHITE

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


# ---------------------------------------------------------------- TOML out


def _key(key: str) -> str:
    return key if _BARE_KEY.match(key) else json.dumps(key, ensure_ascii=False)


def _value(value: Any) -> str:
    """One TOML value; floats as repr (shortest text that parses back to the same double)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ClshadeError(f"cannot write {value!r} to a scene file")
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)     # JSON's escapes are TOML basic-string escapes
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(v)}" for k, v in value.items()) + " }"
    raise ClshadeError(f"cannot write a {type(value).__name__} to a scene file")


def _is_table_array(value: Any) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def _table(lines: list[str], path: list[str], table: dict[str, Any], header: str | None,
           in_array: bool = False) -> None:
    """Write `table` under `header`: its plain values first (they belong to the header),
    then its sub-tables; inside an array of tables, sub-tables are written inline."""
    if header is not None:
        lines += ["", header]

    def subtable(v: Any) -> bool:
        return isinstance(v, dict) and not in_array

    for k, v in table.items():
        if not subtable(v) and not _is_table_array(v):
            lines.append(f"{_key(k)} = {_value(v)}")
    for k, v in table.items():
        sub = path + [_key(k)]
        if subtable(v):
            _table(lines, sub, v, f"[{'.'.join(sub)}]")
        elif _is_table_array(v):
            for item in v:
                _table(lines, sub, item, f"[[{'.'.join(sub)}]]", in_array=True)


def dumps(doc: dict[str, Any]) -> str:
    """A TOML text that tomllib reads back as `doc` (tables, arrays of tables, inline
    tables inside them, strings, booleans, integers, finite floats, arrays)."""
    lines: list[str] = []
    _table(lines, [], doc, None)
    return "\n".join(lines).lstrip("\n") + "\n"


# ---------------------------------------------------------------- controls → document


def applied(base: dict[str, Any], controls, position, width: int, height: int) -> dict[str, Any]:
    """`base` (the scene file's tables) with `controls` (clshade.view.controls.Controls) and
    the orbit camera `position` written in; `base` itself is not changed. Only the tables
    written here are copied ([environment] replaced, never changed in place); the rest (objects,
    meshes) is shared with `base`, which the
    scene parser only reads (tests/view/test_view.py checks that `base` stays as it was)."""
    doc = dict(base)
    doc["camera"] = dict(doc.get("camera", {}))
    doc["render"] = dict(doc.get("render", {}))
    if controls.materials:
        doc["materials"] = dict(doc["materials"])
        for name, _ in controls.materials:
            doc["materials"][name] = dict(doc["materials"][name])
    if controls.lights:
        doc["lights"] = list(doc["lights"])
        for index, _, _ in controls.lights:
            doc["lights"][index] = dict(doc["lights"][index])
    camera = doc["camera"]
    camera["position"] = [float(x) for x in position]
    camera["width"], camera["height"] = int(width), int(height)
    render = doc["render"]
    render.update(model=controls.model_a, exposure=float(controls.exposure), tonemap=controls.tonemap,
                  samples=int(controls.samples), specular_aa=bool(controls.specular_aa))
    for name, params in controls.materials:
        doc["materials"][name].update({k: [float(c) for c in v] if isinstance(v, tuple) else float(v)
                                       for k, v in params})
    if controls.environment is not None:
        _sky_applied(doc, controls.environment)
    for index, direction, scale in controls.lights:
        light = doc["lights"][index]
        if direction is not None:
            light["direction"] = [float(x) for x in direction]
        if scale is not None:
            key = "irradiance" if light.get("type") == "directional" else "intensity"
            color = light.get(key, 1.0)
            color = [color] * 3 if isinstance(color, (int, float)) else color
            light[key] = [float(c) * float(scale) for c in color]
    return doc


def _sky_applied(doc: dict[str, Any], sky) -> None:
    """Write the environment controls (clshade.view.controls.SkyControls) into `doc`'s [environment]
    (and its render.background, which cannot show a sky that is gone)."""
    if sky.sky == SKY_NONE or (sky.sky is None and "environment" not in doc):
        doc.pop("environment", None)
        if doc["render"].get("background") == "environment":
            doc["render"]["background"] = [0.0, 0.0, 0.0]
        return
    table = dict(doc.get("environment", {}))
    if sky.sky is not None:
        table.pop("map", None)
        table.pop("uniform", None)
        if sky.sky == SKY_WHITE:
            table["uniform"] = [1.0, 1.0, 1.0]
        else:
            table["map"] = sky.sky
    table.update(diffuse=sky.diffuse, specular=sky.specular, samples=int(sky.samples),
                 rotation=float(sky.rotation), intensity=float(sky.intensity))
    doc["environment"] = table


def relocated(doc: dict[str, Any], scene_dir: Path, out_dir: Path) -> dict[str, Any]:
    """`doc` with its relative mesh, texture and lobe paths (render.lobes, a lobe file as
    render.model) rewritten for a file in `out_dir` (they name the same files as from `scene_dir`)."""
    doc = copy.deepcopy(doc)
    if Path(scene_dir).resolve() == Path(out_dir).resolve():
        return doc

    def move(table: dict[str, Any], key: str) -> None:
        value = table.get(key)
        if isinstance(value, str) and not Path(value).is_absolute():
            table[key] = os.path.relpath(Path(scene_dir).resolve() / value, Path(out_dir).resolve())

    render = doc.get("render")
    if isinstance(doc.get("environment"), dict):
        move(doc["environment"], "map")
    if isinstance(render, dict):
        move(render, "lobes")
        if Path(str(render.get("model", ""))).suffix in LOBE_SUFFIXES:
            move(render, "model")
    for material in doc.get("materials", {}).values():
        for key in TEXTURE_KEYS:
            move(material, key)
    for obj in doc.get("objects", []):
        move(obj, "mesh")
        if isinstance(obj.get("material"), dict):
            for key in TEXTURE_KEYS:
                move(obj["material"], key)
    return doc
