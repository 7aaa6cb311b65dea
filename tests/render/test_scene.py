"""The scene file (clshade.render.scene, scenes/README.md is the format): the documented defaults are what
the parser fills in; a bad scene is refused through `clshade render` in one line naming the file, the key
and the value (exit status 2, no traceback, nothing written); vectors of any finite length render as their
direction; and the parser, fuzzed with mutations of the bundled scenes, returns a Scene or raises
ClshadeError, never another exception."""
from __future__ import annotations

import re
import tomllib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from clshade import budget
from clshade.errors import ClshadeError
from clshade.render.scene import Scene, parse_scene
from clshade.resources import scenes_dir

from conftest import assert_one_line_error, cli_image, refused, render_refused, run_cli, write_scene
from scene_toml import camera, light, material, obj, scene, small_red_sphere


# ---------------------------------------------------------------- the documented defaults

def documented_material_defaults() -> dict[str, object]:
    text = (scenes_dir() / "README.md").read_text(encoding="utf-8")
    table = text.split("## `[materials.NAME]`", 1)[1].split("\n## ", 1)[0]
    out: dict[str, object] = {}
    for key, default in re.findall(r"^\| `([a-z_0-9]+)` \| [^|]+ \| ([^|]+) \|", table, re.M):
        default = default.strip()
        if re.fullmatch(r"-?[0-9.]+", default):
            out[key] = float(default)
        elif re.fullmatch(r"\[[0-9., ]+\]", default):
            out[key] = tuple(float(x) for x in default.strip("[]").split(","))
        elif default in ("false", "true"):
            out[key] = default == "true"
    return out


@pytest.mark.text
def test_material_defaults_match_the_documentation():
    """Every numeric default of the material table of the installed scenes/README.md equals what the parser
    fills in for a material that names none of them."""
    documented = documented_material_defaults()
    assert {"base_color", "roughness", "metallic", "ks", "ka", "ior", "f90"} <= set(documented)
    minimal = scene(camera(position=[0.0, 0.0, 3.0]),
                    light("directional", direction=[0.0, 0.0, -1.0], irradiance=[1.0, 1.0, 1.0]),
                    material("plain"),
                    obj(name="ball", primitive="sphere", material="plain"))
    material_ = parse_scene(minimal).materials["plain"]
    for key, value in documented.items():
        got = getattr(material_, key)
        if isinstance(value, tuple):
            assert tuple(got) == pytest.approx(value), key
        elif isinstance(got, tuple):            # "RGB or number": a number means every channel
            assert got == pytest.approx((value,) * len(got)), key
        else:
            assert got == pytest.approx(value), key
    assert material_.constants()["kd"] == pytest.approx(1.0 - documented["ks"])      # "1 − ks"


# ---------------------------------------------------------------- bad scenes, refused in one line

def test_malformed_toml_names_line_and_column(tmp_path, capsys):
    err = render_refused(tmp_path, capsys, small_red_sphere() + "\nbroken = [1,\n")
    assert "malformed TOML" in err and "line" in err and "column" in err


def test_unknown_key_suggests_nearest(tmp_path, capsys):
    err = render_refused(tmp_path, capsys, small_red_sphere(red=dict(roughness=None, rougness=0.4)), "rougness")
    assert "did you mean 'roughness'" in err


@pytest.mark.parametrize("table, keys, key, value", [
    ("red", dict(roughness="rough"), "materials.red.roughness", "'rough'"),
    ("camera_keys", dict(width=24.5), "camera.width", "24.5"),
    ("shape", dict(primitive="sphere", subdivisions=True), "objects[0].subdivisions", "True"),
])
def test_wrong_types(tmp_path, capsys, table, keys, key, value):
    err = render_refused(tmp_path, capsys, small_red_sphere(**{table: keys}), key, value)
    assert "must be" in err


@pytest.mark.parametrize("table, keys, key, value", [
    ("red", dict(roughness=2), "materials.red.roughness", "2"),
    ("red", dict(base_color=[0.8, -0.1, 0.1]), "materials.red.base_color", "-0.1"),
    ("camera_keys", dict(width=0), "camera.width", "0"),
])
def test_out_of_range(tmp_path, capsys, table, keys, key, value):
    err = render_refused(tmp_path, capsys, small_red_sphere(**{table: keys}), key, value)
    assert "within" in err


def test_missing_scene_points_to_the_bundled_one(tmp_path, capsys, monkeypatch):
    """Outside the checkout `clshade render scenes/robot.toml` names where the installed scenes are."""
    monkeypatch.chdir(tmp_path)
    code, _, err = run_cli(capsys, ["render", "scenes/robot.toml"])
    assert_one_line_error(code, err, "scenes/robot.toml: scene file not found", str(scenes_dir() / "robot.toml"))
    code, _, err = run_cli(capsys, ["render", "nowhere.toml"])
    assert_one_line_error(code, err, "nowhere.toml: scene file not found")
    assert "bundled" not in err


def test_error_values_are_plain_numbers():
    text = scene(camera(position=[0.0, 0.0, 3.0], target=[0.0, 0.0, 3.0]))
    with pytest.raises(ClshadeError) as info:
        parse_scene(text)
    assert "camera.target = [0.0, 0.0, 3.0]" in str(info.value)
    assert "np." not in str(info.value)


def test_the_reported_target_is_refused_in_one_line(tmp_path, capsys):
    text = small_red_sphere(camera_keys=dict(target=[0, 1e308, 0]))
    refused(capsys, ["render", str(write_scene(tmp_path, text)), "-o", str(tmp_path / "o.png")],
            "camera.target = [0, 1e+308, 0]", f"[-{budget.MAX_COORDINATE:g}, {budget.MAX_COORDINATE:g}]")


@pytest.mark.parametrize("key, value", [("position", "[1e308, 0, 4]"), ("position", "[0, 0, 1e300]"),
                                        ("target", "[0, 0, -1e200]")])
def test_camera_coordinates_that_overflow_are_refused(tmp_path, capsys, key, value):
    text = small_red_sphere(camera_keys={key: tomllib.loads(f"v = {value}")["v"]})
    refused(capsys, ["render", str(write_scene(tmp_path, text)), "-o", str(tmp_path / "o.png")],
            f"camera.{key}", "scene.toml", "components must be within")


# ---------------------------------------------------------------- vectors of any finite length

@pytest.mark.parametrize("up", ["[0, 1e200, 0]", "[0, 1e-300, 0]", "[0, 5e-324, 0]", "[0, 1.7e308, 0]"])
def test_camera_up_of_any_finite_length(tmp_path, capsys, up):
    plain = cli_image(capsys, write_scene(tmp_path), tmp_path / "plain.exr")
    text = small_red_sphere(camera_keys=dict(up=tomllib.loads(f"v = {up}")["v"]))
    image = cli_image(capsys, write_scene(tmp_path, text, "up.toml"), tmp_path / "up.exr")
    assert image[..., 3].sum() > 0
    np.testing.assert_array_equal(image, plain)


@pytest.mark.parametrize("tiny, unit", [("[1e-320, 0, 0]", "[1, 0, 0]"), ("[1e308, 1e308, 1e308]", "[1, 1, 1]"),
                                        ("[-1e-310, -2e-310, 0]", "[-1, -2, 0]")])
def test_light_direction_of_any_finite_length(tmp_path, capsys, tiny, unit):
    def image(direction: str, name: str) -> np.ndarray:
        text = small_red_sphere(lights=[light("directional", direction=tomllib.loads(f"v = {direction}")["v"])])
        return cli_image(capsys, write_scene(tmp_path, text, f"{name}.toml"), tmp_path / f"{name}.exr")
    np.testing.assert_allclose(image(tiny, "scaled"), image(unit, "unit"), rtol=1e-6, atol=0)


def test_light_direction_contributes(tmp_path, capsys):
    """The subnormal direction lights the sphere: brighter than the same scene unlit."""
    text = small_red_sphere(lights=[light("directional", direction=[-1e-320, 0, -1e-320])])
    lit = cli_image(capsys, write_scene(tmp_path, text, "lit.toml"), tmp_path / "lit.exr")
    dark_text = small_red_sphere(lights=[light("directional", direction=[-1, 0, -1], irradiance=0.0)])
    dark = cli_image(capsys, write_scene(tmp_path, dark_text, "dark.toml"), tmp_path / "dark.exr")
    covered = lit[..., 3] > 0
    assert covered.any() and lit[covered, :3].sum() > 2 * dark[covered, :3].sum()


# ---------------------------------------------------------------- the parser fuzzed: a Scene or ClshadeError

SCENE_FILES = sorted(scenes_dir().glob("*.toml"))
TEXTS = [p.read_text() for p in SCENE_FILES]
VALUES = st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20),
                   st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8),
                   st.lists(st.floats(-1e3, 1e3), max_size=4), st.dictionaries(st.text(max_size=4), st.integers(), max_size=2))
SETTINGS = settings(max_examples=150, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _check(text: str, index: int) -> None:
    try:
        result = parse_scene(text, SCENE_FILES[index])
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
@given(index=st.integers(0, len(SCENE_FILES) - 1), data=st.data())
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
@given(index=st.integers(0, len(SCENE_FILES) - 1), data=st.data())
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
        assert isinstance(parse_scene(text, SCENE_FILES[index]), Scene)
