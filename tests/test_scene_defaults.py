"""Scene defaults are what scenes/README.md promises: every numeric default of the material table of the
installed scenes/README.md equals what the parser fills in for a material that names none of them."""
from __future__ import annotations

import re

import pytest

from clshade.render.scene import parse_scene
from clshade.resources import scenes_dir

MINIMAL = """
[camera]
position = [0.0, 0.0, 3.0]
[[lights]]
type = "directional"
direction = [0.0, 0.0, -1.0]
irradiance = [1.0, 1.0, 1.0]
[materials.plain]
[[objects]]
name = "ball"
primitive = "sphere"
material = "plain"
"""


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
    documented = documented_material_defaults()
    assert {"base_color", "roughness", "metallic", "ks", "ka", "ior", "f90"} <= set(documented)
    material = parse_scene(MINIMAL).materials["plain"]
    for key, value in documented.items():
        got = getattr(material, key)
        if isinstance(value, tuple):
            assert tuple(got) == pytest.approx(value), key
        elif isinstance(got, tuple):            # "RGB or number": a number means every channel
            assert got == pytest.approx((value,) * len(got)), key
        else:
            assert got == pytest.approx(value), key
    assert material.constants()["kd"] == pytest.approx(1.0 - documented["ks"])      # "1 − ks"
