"""The scenes the tests write, as TOML text (scenes/README.md is the format): small builders for each
table, and the scenes more than one test uses, each written once with keyword overrides for what a
test varies (a size, a material key, the lights) instead of text replaced in a copy.

    from scene_toml import plane_facing_camera
    scene = parse_scene(plane_facing_camera(size=0.5))
"""
from __future__ import annotations

import math
from typing import Any, Iterable


# ---------------------------------------------------------------- builders

def value(v: Any) -> str:
    """`v` as a TOML value: bool, int, float (nan and ±inf included), str, a list/tuple of those, a dict of
    those (an inline table)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, int):
        return str(v) if -2 ** 63 <= v < 2 ** 63 else repr(float(v))
    if isinstance(v, str):
        return '"' + v.encode("unicode_escape").decode("ascii").replace('"', '\\"') + '"'
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + "}" if v else "{}"
    return "[" + ", ".join(value(x) for x in v) + "]"


def _keys(keys: dict[str, Any]) -> str:
    """One `key = value` line per key whose value is not None, in the order given."""
    return "".join(f"{k} = {value(v)}\n" for k, v in keys.items() if v is not None)


def table(name: str, **keys: Any) -> str:
    """`[name]` and its keys."""
    return f"[{name}]\n" + _keys(keys)


def camera(**keys: Any) -> str:
    return table("camera", **keys)


def render(**keys: Any) -> str:
    """`[render]`; no table at all when every key is None."""
    return table("render", **keys) if any(v is not None for v in keys.values()) else ""


def light(kind: str, **keys: Any) -> str:
    """One `[[lights]]` entry of `type` `kind`."""
    return "[[lights]]\n" + _keys({"type": kind, **keys})


def material(name: str, **keys: Any) -> str:
    return table(f"materials.{name}", **keys)


def obj(**keys: Any) -> str:
    """One `[[objects]]` entry."""
    return "[[objects]]\n" + _keys(keys)


def scene(*parts: str | Iterable[str]) -> str:
    """The tables in order, a blank line between them (a part may be a list of tables)."""
    flat = [p for part in parts for p in ([part] if isinstance(part, str) else part)]
    return "\n".join(p for p in flat if p)


# ---------------------------------------------------------------- the shared scenes

def plane_facing_camera(width: int = 48, height: int = 32, size: float = 20.0,
                        rotate: tuple[float, float, float] = (90.0, 0.0, 0.0), ambient: list | None = None,
                        lights: Iterable[str] = (), **surface: Any) -> str:
    """A plane filling a 48×32 frame, facing the camera and a directional light of irradiance (2, 3, 4):
    Lambert there is (base/π)·E exactly (tests/test_pipeline.py). `surface` overrides or adds material
    keys (base_color (0.5, 0.25, 0.75), roughness 0.5); `lights` come after the directional one."""
    return scene(camera(position=[0.0, 0.0, 3.0], fov=40.0, width=width, height=height),
                 render(ambient=ambient, background=[0.1, 0.2, 0.3]),
                 light("directional", direction=[0.0, 0.0, -1.0], irradiance=[2.0, 3.0, 4.0]),
                 material("m", **{"base_color": [0.5, 0.25, 0.75], "roughness": 0.5, **surface}),
                 obj(primitive="plane", size=size, rotate=list(rotate), material="m"),
                 lights)


def point_and_spot() -> list[str]:
    """A point light and a spot lighting plane_facing_camera unevenly (every pixel differs)."""
    return [light("point", position=[0.7, -0.4, 1.0], intensity=[3.0, 2.0, 1.0]),
            light("spot", position=[-0.5, 0.6, 1.5], direction=[0.3, -0.4, -1.0], intensity=[4.0, 4.0, 4.0],
                  inner_angle=10.0, outer_angle=30.0)]


#: The oracle's light kinds one at a time (tests/verify/test_oracle.py), each a list of tables.
ORACLE_LIGHTS: dict[str, list[str]] = {
    "directional": [light("directional", direction=[0.4, -1.0, -0.5], irradiance=[2.0, 1.8, 1.5])],
    # 2.5 units above the floor: 1/r² and 1/r differ by > 2× over the floor
    "point": [light("point", position=[0.3, 2.5, 1.2], intensity=[9.0, 7.0, 5.0])],
    # the cone's edge and its t² band cross the floor in view
    "spot": [light("spot", position=[-0.5, 3.0, 1.5], direction=[0.2, -1.0, -0.4], intensity=[30.0, 26.0, 20.0],
                   inner_angle=12.0, outer_angle=32.0)],
    "ambient": [render(ambient=[0.6, 0.5, 0.4], background=[0.1, 0.2, 0.3])],
    "shadowed": [render(shadows=True, shadow_map_size=256, shadow_pcf=3),
                 light("directional", direction=[0.5, -1.0, -0.3], irradiance=[2.0, 1.9, 1.7]),
                 light("spot", position=[-2.0, 3.0, 1.0], direction=[0.55, -0.8, -0.25], intensity=[25.0, 20.0, 15.0],
                       inner_angle=20.0, outer_angle=35.0)],
}


def floor_ball_torus(lights: str) -> str:
    """A floor, a dielectric ball (IOR 1.7, f90 0.8) and a metal torus at 96×72, lit by
    ORACLE_LIGHTS[`lights`]: both workflows' keys on every material (tests/verify/test_oracle.py)."""
    return scene(camera(position=[0.0, 2.2, 5.0], target=[0.0, 0.4, 0.0], fov=45.0, width=96, height=72),
                 ORACLE_LIGHTS[lights],
                 material("floor", base_color=[0.6, 0.55, 0.5], roughness=0.6, ks=0.3, shininess=24.0),
                 material("ball", base_color=[0.8, 0.2, 0.1], roughness=0.35, ks=0.4, shininess=60.0, ior=1.7,
                          f90=0.8),
                 material("metal", base_color=[0.9, 0.8, 0.5], roughness=0.25, metallic=1.0),
                 obj(primitive="plane", size=8.0, material="floor"),
                 obj(primitive="sphere", radius=0.7, translate=[-0.8, 0.7, 0.0], material="ball"),
                 obj(primitive="torus", major_radius=0.5, minor_radius=0.2, rotate=[70.0, 0.0, 0.0],
                     translate=[0.9, 0.7, 0.3], material="metal"))


def two_spheres(width: int = 96, height: int = 96, lobes: str | None = None, model: str | None = None) -> str:
    """Two spheres of two materials (every key of both workflows) under a directional and a point light,
    black background: a lobe's parameters named like material keys must follow each pixel's material
    (tests/models/). `lobes` and `model` are the [render] keys of a user's lobe folder."""
    both = dict(metallic=0.0, kd=0.6, ks=0.4)
    return scene(camera(position=[0.0, 0.0, 4.2], fov=30.0, width=width, height=height),
                 render(lobes=lobes, model=model, background=[0.0, 0.0, 0.0]),
                 light("directional", direction=[-0.45, -0.5, -1.0], irradiance=[3.0, 3.0, 3.0]),
                 light("point", position=[2.0, 1.0, 2.5], intensity=[4.0, 3.0, 2.0]),
                 material("m", base_color=[0.8, 0.3, 0.05], roughness=0.5, **both, shininess=40.0),
                 material("n", base_color=[0.2, 0.5, 0.9], roughness=0.7, **both, shininess=12.0),
                 obj(primitive="sphere", radius=1.0, subdivisions=4, material="m"),
                 obj(primitive="sphere", radius=0.4, translate=[1.1, -0.6, 0.8], material="n"))


def small_red_sphere(camera_keys: dict | None = None, render_keys: dict | None = None,
                     lights: Iterable[str] | None = None, red: dict | None = None, shape: dict | None = None,
                     objects: bool = True) -> str:
    """A red sphere at 24×16 under one directional light, with a background and a little ambient: the
    scene the command-line tests change one key of, to see it refused or rendered. Each dict overrides
    or adds keys of its table (camera, render, the material `red`; a None value drops the key);
    `lights` replace the directional light; `shape` replaces the object's primitive keys (a `mesh`);
    objects=False leaves the object out."""
    def keys(default: dict, changes: dict | None) -> dict:
        return {**default, **(changes or {})}
    if lights is None:
        lights = [light("directional", direction=[-0.4, -0.5, -1.0])]
    return scene(camera(**keys(dict(position=[0.0, 0.0, 4.0], width=24, height=16, fov=40.0), camera_keys)),
                 render(**keys(dict(background=[0.1, 0.2, 0.3], ambient=[0.02, 0.02, 0.02]), render_keys)),
                 lights,
                 material("red", **keys(dict(base_color=[0.8, 0.1, 0.1], roughness=0.4), red)),
                 obj(**(shape or dict(primitive="sphere", subdivisions=2)), material="red") if objects else "")


def red_sphere(mesh: str | None = None, **red: Any) -> str:
    """The scene the hostile-input properties mutate (tests/contracts/test_hostile_properties.py): a red
    sphere (or `mesh` in its place) under a directional light and a spot, every table the format
    has, most of their keys written out. `red` adds keys to the material."""
    shape = dict(mesh=mesh) if mesh else dict(primitive="sphere", subdivisions=1)
    return scene(camera(position=[0.0, 0.0, 4.0], target=[0.0, 0.0, 0.0], up=[0.0, 1.0, 0.0], fov=40.0,
                        width=32, height=32),
                 render(background=[0.1, 0.2, 0.3], ambient=[0.02, 0.02, 0.02], exposure=0.0,
                        model="ggx_correlated"),
                 light("directional", direction=[-0.4, -0.5, -1.0], irradiance=[3.0, 3.0, 3.0]),
                 light("spot", position=[0.0, 3.0, 3.0], direction=[0.0, -1.0, -1.0], intensity=10.0,
                       outer_angle=30.0),
                 material("red", base_color=[0.8, 0.1, 0.1], roughness=0.4, metallic=0.0, ior=1.5, **red),
                 obj(**shape, material="red", translate=[0.0, 0.0, 0.0], scale=1.0))


def shadowed_floor_and_ball(width: int = 64, height: int = 48, shadows: bool = True,
                            lights: Iterable[str] | None = None, floor: dict | None = None,
                            ball: dict | None = None) -> str:
    """A floor and a ball with shadows, ambient and three light kinds (the point light casting
    none), the two materials differing in roughness and metallic (tests/device/test_specialisation.py).
    `lights` replace the three; `floor` and `ball` override or add material keys."""
    if lights is None:
        lights = [light("directional", direction=[0.4, -1.0, -0.3], irradiance=[2.0, 2.0, 1.8]),
                  light("point", position=[-2.0, 1.5, 1.5], intensity=[3.0, 2.0, 1.0], shadows=False),
                  light("spot", position=[1.5, 3.0, 1.5], direction=[-0.4, -1.0, -0.4], intensity=[20.0, 20.0, 24.0],
                        inner_angle=20.0, outer_angle=35.0)]
    return scene(camera(position=[0.0, 2.5, 5.0], target=[0.0, 0.4, 0.0], fov=45.0, width=width, height=height),
                 render(background=[0.1, 0.1, 0.12], ambient=[0.05, 0.06, 0.07], shadows=shadows,
                        shadow_map_size=128, shadow_pcf=3),
                 lights,
                 material("floor", **{"base_color": [0.6, 0.6, 0.6], "roughness": 0.7, "ks": 0.2, **(floor or {})}),
                 material("ball", **{"base_color": [0.8, 0.2, 0.1], "roughness": 0.3, "metallic": 0.5, "ks": 0.5,
                                     **(ball or {})}),
                 obj(primitive="plane", size=8.0, material="floor"),
                 obj(primitive="sphere", radius=0.6, subdivisions=3, translate=[0.0, 0.6, 0.0], material="ball"))
