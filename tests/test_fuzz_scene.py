"""Fuzz the scene parser with mutations of the bundled scenes: parse_scene either
returns a Scene or raises ClshadeError — never another exception."""
from __future__ import annotations

import tomllib

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from clshade.errors import ClshadeError
from clshade.resources import scenes_dir
from clshade.render.scene import Scene, parse_scene

SCENES = sorted(scenes_dir().glob("*.toml"))
TEXTS = [p.read_text() for p in SCENES]
VALUES = st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20),
                   st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8),
                   st.lists(st.floats(-1e3, 1e3), max_size=4), st.dictionaries(st.text(max_size=4), st.integers(), max_size=2))
SETTINGS = settings(max_examples=150, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _check(text: str, index: int) -> None:
    try:
        result = parse_scene(text, SCENES[index])
    except ClshadeError as exc:
        assert str(exc) and "\n" not in str(exc)
    else:
        assert isinstance(result, Scene)


def _dump(value) -> str:
    """A TOML fragment for a value (None → an empty inline table)."""
    if value is None:
        return "{}"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return {"nan": "nan", "inf": "inf", "-inf": "-inf"}.get(repr(value), repr(value))
    if isinstance(value, str):
        return '"' + value.encode("unicode_escape").decode().replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(_dump(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f'"{k}" = {_dump(v)}' for k, v in value.items()) + "}" if value else "{}"
    return repr(value)


@SETTINGS
@given(index=st.integers(0, len(SCENES) - 1), data=st.data())
def test_line_mutations(index: int, data) -> None:
    """Delete, duplicate, rename or re-value one line; or truncate the text anywhere."""
    lines = TEXTS[index].splitlines()
    kind = data.draw(st.sampled_from(["delete", "duplicate", "rename", "value", "truncate", "garbage"]))
    i = data.draw(st.integers(0, len(lines) - 1))
    line = lines[i]
    if kind == "delete":
        del lines[i]
    elif kind == "duplicate":
        lines.insert(i, line)
    elif kind == "rename" and "=" in line:
        key, _, rest = line.partition("=")
        lines[i] = data.draw(st.from_regex(r"[a-z_]{1,10}", fullmatch=True)) + " =" + rest
    elif kind == "value" and "=" in line:
        key = line.partition("=")[0]
        lines[i] = f"{key}= {_dump(data.draw(VALUES))}"
    elif kind == "truncate":
        text = "\n".join(lines)
        _check(text[:data.draw(st.integers(0, len(text)))], index)
        return
    elif kind == "garbage":
        lines.insert(i, data.draw(st.text(max_size=20)))
    _check("\n".join(lines), index)


@SETTINGS
@given(index=st.integers(0, len(SCENES) - 1), data=st.data())
def test_structural_mutations(index: int, data) -> None:
    """Replace any value of the parsed document (tables included) by a random value, re-emit."""
    doc = tomllib.loads(TEXTS[index])
    paths: list[tuple] = []

    def walk(node, path):
        paths.append(path)
        if isinstance(node, dict):
            for k, v in node.items():
                walk(v, path + (k,))
        elif isinstance(node, list):
            for j, v in enumerate(node):
                walk(v, path + (j,))
    walk(doc, ())
    path = data.draw(st.sampled_from(paths[1:]))
    parent = doc
    for p in path[:-1]:
        parent = parent[p]
    if data.draw(st.booleans()) and isinstance(parent, dict):
        del parent[path[-1]]
    else:
        parent[path[-1]] = data.draw(VALUES)
    _check(_emit(doc), index)


def _emit(doc: dict) -> str:
    """Emit a document as TOML using inline tables only (enough for the parser under test)."""
    out = []
    for k, v in doc.items():
        out.append(f'"{k}" = {_emit_value(v)}')
    return "\n".join(out) + "\n"


def _emit_value(v) -> str:
    if isinstance(v, dict):
        return "{" + ", ".join(f'"{k}" = {_emit_value(x)}' for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(_emit_value(x) for x in v) + "]"
    return _dump(v)


def test_unmutated_scenes_parse() -> None:
    for index, text in enumerate(TEXTS):
        assert isinstance(parse_scene(text, SCENES[index]), Scene)
