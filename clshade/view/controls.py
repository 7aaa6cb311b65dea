"""What the page may ask for, checked on the server before anything is rendered.

The page sends its whole control state as JSON with every change. `parse_message`
turns the text into a dict (no NaN or Infinity: JSON has neither, Python's reader
would take them), `parse_controls` checks every value against the limits of the
scene at hand (`Limits`: its materials, its lights, the lobes' declared parameter
ranges) and returns a frozen `Controls`, or raises ControlError naming the key,
the value and the reason, which the page shows. Nothing unchecked reaches the
renderer.

The models a state names are resolved once, when it is checked, and travel with its
Controls: a lobe file or folder a message names is read for that message only (the
session's registry never changes), from the folders the session's registry is confined
to (ViewSession: the scene's folder and the lobe folders given to the command).
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from typing import Any

from clshade.errors import ClshadeError
from clshade.models.lobe import SURFACE_PARAMS, Param
from clshade.models.model import Model
from clshade.models.registry import Registry
from clshade.render import environment as env
from clshade.render.scene import EXPOSURE_RANGE, MAX_RESOLUTION, MAX_SAMPLES, TONEMAPS, Material, Scene

#: Longest message the server reads (a control state is well under 4 KiB).
MAX_MESSAGE_BYTES = 64 * 1024
#: Longest model spec accepted (`diffuse+specular@fresnel/workflow` is under 60 characters).
MAX_MODEL_SPEC = 128
#: Elevation of the orbit camera, degrees: short of the poles, where the view direction
#: would be parallel to the camera's up vector (scene.py refuses that camera).
MAX_ELEVATION = 89.0
#: Zoom range as a factor of the scene camera's own distance to its target.
ZOOM_RANGE = (0.02, 50.0)
#: Light intensity: a factor on the scene's irradiance / intensity of that light.
LIGHT_SCALE_RANGE = (0.0, 100.0)
#: Largest |azimuth| in degrees (the page keeps it small; this bounds the float math).
MAX_AZIMUTH = 1e6
#: A light's key in `lights`: its index in ASCII digits (str.isdigit would take '²', which int() refuses);
#: four digits are plenty under budget.MAX_LIGHTS.
LIGHT_INDEX = re.compile(r"[0-9]{1,4}")
#: The largest canvas the server renders by default (a bigger window is rendered at this size, its
#: aspect kept, and scaled up by the browser): 1080p is the size the frame-rate target is set for.
MAX_CANVAS = (1920, 1080)
#: The sky picker's two skies that are no file: no environment at all, and a uniform white sky
#: (the furnace: a white Lambert surface is exactly 1 under it).
SKY_NONE, SKY_WHITE = "none", "white"
#: Sky rotation, degrees (the scene parser's range) and intensity (a scale on the map; up to 10⁶,
#: well inside float32 for maps of HDR range).
SKY_ROTATION_RANGE = (-360.0, 360.0)
SKY_INTENSITY_RANGE = (0.0, 1e6)
SKY_KEYS = ("sky", "diffuse", "specular", "samples", "rotation", "intensity")


class ControlError(ClshadeError):
    """A control value the server refuses: `key = value: why`."""


@dataclass(frozen=True)
class Controls:
    azimuth: float                    # degrees about the scene camera's up axis, 0 = the scene's camera
    elevation: float                  # degrees above the plane through the target
    distance: float                   # camera to target, scene units
    model_a: str
    model_b: str
    split: bool
    diff: bool
    exposure: float
    tonemap: str
    samples: int
    specular_aa: bool
    # (material, ((param, value), …)); a colour's value is (R, G, B)
    materials: tuple[tuple[str, tuple[tuple[str, float | tuple[float, float, float]], ...]], ...] = ()
    lights: tuple[tuple[int, tuple[float, float, float] | None, float | None], ...] = ()  # (index, direction, scale)
    environment: "SkyControls | None" = None     # None: the scene's [environment] as written
    width: int | None = None                      # the canvas in device pixels, capped (fit_canvas); None:
    height: int | None = None                     # the session's size
    # (spec, Model) of model A and B as parse_controls resolved them; empty for Controls made by hand
    resolved: tuple[tuple[str, Model], ...] = field(default=(), compare=False, repr=False)

    def models(self, registry: Registry) -> tuple[Model, Model]:
        """Models A and B: as resolved when the state was checked, else resolved in `registry`."""
        known = dict(self.resolved)
        a, b = (known[spec] if spec in known else registry.resolve(spec) for spec in (self.model_a, self.model_b))
        return a, b


@dataclass(frozen=True)
class SkyControls:
    """The environment picker and the rung controls. `sky`: None keeps the scene's map or uniform
    colour; SKY_NONE drops the [environment] table; SKY_WHITE is a uniform white sky; any other value
    is a map file of Limits.skies, relative to the scene's folder."""
    sky: str | None
    diffuse: str
    specular: str
    samples: int
    rotation: float
    intensity: float


def canvas_cap(text: str, name: str) -> tuple[int, int]:
    """A cap written WxH (each within [1, MAX_RESOLUTION]); refused in one line naming `name`."""
    match = re.fullmatch(r"([0-9]{1,5})x([0-9]{1,5})", text.strip())
    if not match or not all(1 <= int(g) <= MAX_RESOLUTION for g in match.groups()):
        raise ClshadeError(f"{name} = {text[:40]!r}: expected WxH, each within [1, {MAX_RESOLUTION}] (e.g. 1920x1080)")
    return int(match[1]), int(match[2])


def fit_canvas(width: int, height: int, cap: tuple[int, int]) -> tuple[int, int]:
    """width × height scaled down, its aspect kept, to fit within cap (each side at least 1)."""
    scale = min(1.0, cap[0] / width, cap[1] / height)
    return max(1, min(cap[0], round(width * scale))), max(1, min(cap[1], round(height * scale)))


def material_params(registry: Registry) -> dict[str, Param]:
    """name → Param of the surface inputs (base colour, metallic: clshade.models.lobe.SURFACE_PARAMS)
    and of every parameter a lobe declares that a scene material holds (roughness, shininess,
    kd, ks, ka): the sliders. Read from the registry, so new lobes bring their parameters."""
    fields = Material.__dataclass_fields__
    out: dict[str, Param] = {p.name: p for p in SURFACE_PARAMS}
    for lobe in registry.lobes.values():
        for p in lobe.params:
            if p.name in fields and p.name not in out:
                out[p.name] = p
    return out


@dataclass(frozen=True)
class Limits:
    """What the scene allows: its material names, its lights' kinds, the parameter ranges,
    the distance range, the frame size (for the supersampling limit) and the lobes its
    models may name (the session's registry)."""
    materials: tuple[str, ...]
    light_kinds: tuple[str, ...]
    params: dict[str, Param]
    distance: tuple[float, float]
    width: int
    height: int
    registry: Registry
    skies: tuple[str, ...] = (SKY_NONE, SKY_WHITE)     # what the sky picker offers
    max_canvas: tuple[int, int] = MAX_CANVAS

    @classmethod
    def of(cls, scene: Scene, distance: float, width: int, height: int, registry: Registry,
           skies: tuple[str, ...] = (SKY_NONE, SKY_WHITE), max_canvas: tuple[int, int] = MAX_CANVAS) -> "Limits":
        named = tuple(m for m in scene.materials if "#" not in m)     # inline object materials have no [materials] table
        return cls(named, tuple(l.kind for l in scene.lights), material_params(registry),
                   (distance * ZOOM_RANGE[0], distance * ZOOM_RANGE[1]), width, height, registry, skies, max_canvas)


def parse_message(text: str | bytes) -> dict[str, Any]:
    """One message from the page: a JSON object of at most MAX_MESSAGE_BYTES."""
    if len(text) > MAX_MESSAGE_BYTES:
        raise ControlError(f"message of {len(text)} bytes: longer than {MAX_MESSAGE_BYTES}")

    def no_constant(name: str) -> None:
        raise ControlError(f"message: {name} is not a number JSON allows")

    try:
        value = json.loads(text, parse_constant=no_constant)
    except (ValueError, RecursionError) as exc:      # JSONDecodeError and bad UTF-8 are ValueErrors
        raise ControlError(f"message: not JSON ({exc})") from None
    if not isinstance(value, dict):
        raise ControlError(f"message: expected a JSON object, got {type(value).__name__}")
    return value


def _shown(value: Any) -> str:
    try:
        text = json.dumps(value) if not isinstance(value, float) else repr(value)
    except ValueError:      # an int of over 4300 digits, which str() refuses
        text = f"an integer of {value.bit_length()} bits"
    return text if len(text) <= 60 else text[:57] + "..."


def _fail(key: str, value: Any, why: str) -> ControlError:
    return ControlError(f"{key} = {_shown(value)}: {why}")


def _number(key: str, value: Any, low: float, high: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(key, value, "must be a number")
    try:
        number = float(value)           # an int past float's range (JSON's 10**400) overflows
    except OverflowError:
        number = math.inf
    if not math.isfinite(number) or not low <= number <= high:
        raise _fail(key, value, f"must be within [{low:g}, {high:g}]")
    return number


def _boolean(key: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise _fail(key, value, "must be true or false")
    return value


def _table(key: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise _fail(key, value, "must be an object")
    return value


def _model(key: str, value: Any, registry: Registry) -> tuple[str, Model]:
    """The spec and its Model (a lobe file it names is read now, once)."""
    if not isinstance(value, str) or not value.strip() or len(value) > MAX_MODEL_SPEC:
        raise _fail(key, value, f"must be a model name of 1 to {MAX_MODEL_SPEC} characters")
    try:
        model = registry.resolve(value)
    except ClshadeError as exc:
        raise _fail(key, value, str(exc).removeprefix(f"model {value!r}: ")) from None
    return value.strip(), model


def _direction(key: str, value: Any) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) != 3:
        raise _fail(key, value, "must be a list of 3 numbers")
    d = tuple(_number(f"{key}[{i}]", x, -1e6, 1e6) for i, x in enumerate(value))
    if math.hypot(*d) < 1e-6:
        raise _fail(key, value, "must not be (nearly) the zero vector")
    return d


def _param(key: str, value: Any, p: Param) -> float | tuple[float, float, float]:
    """A number within the parameter's range; for a colour, a list of 3 such numbers."""
    if p.kind != "color":
        return _number(key, value, p.low, p.high)
    if not isinstance(value, list) or len(value) != 3:
        raise _fail(key, value, "must be a list of 3 numbers (R, G, B)")
    r, g, b = (_number(f"{key}[{i}]", x, p.low, p.high) for i, x in enumerate(value))
    return r, g, b


def _materials(value: Any, limits: Limits) -> tuple:
    out = []
    for name, params in _table("materials", value).items():
        if name not in limits.materials:
            raise _fail(f"materials.{name}", params, f"no such material; the scene has {', '.join(limits.materials)}")
        row = []
        for param, v in _table(f"materials.{name}", params).items():
            if param not in limits.params:
                raise _fail(f"materials.{name}.{param}", v, f"not a lobe parameter ({', '.join(limits.params)})")
            row.append((param, _param(f"materials.{name}.{param}", v, limits.params[param])))
        out.append((name, tuple(sorted(row))))
    return tuple(sorted(out))


def _lights(value: Any, limits: Limits) -> tuple:
    out = []
    for index_text, light in _table("lights", value).items():
        key = f"lights.{index_text[:20]}"
        if not LIGHT_INDEX.fullmatch(index_text) or int(index_text) >= len(limits.light_kinds):
            raise _fail(key, light, f"no such light; the scene has {len(limits.light_kinds)} (0 to "
                                    f"{len(limits.light_kinds) - 1})")
        index = int(index_text)
        light = dict(_table(key, light))
        direction = light.pop("direction", None)
        scale = light.pop("scale", None)
        if light:
            raise _fail(f"{key}.{next(iter(light))}", next(iter(light.values())), "unknown key (direction, scale)")
        if direction is not None:
            if limits.light_kinds[index] == "point":
                raise _fail(f"{key}.direction", direction, "a point light has no direction")
            direction = _direction(f"{key}.direction", direction)
        if scale is not None:
            scale = _number(f"{key}.scale", scale, *LIGHT_SCALE_RANGE)
        out.append((index, direction, scale))
    return tuple(sorted(out))


def _choice(key: str, value: Any, choices: tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in choices:
        raise _fail(key, value, f"must be one of {', '.join(choices)}")
    return value


def _integer(key: str, value: Any, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise _fail(key, value, f"must be an integer within [{low}, {high}]")
    return value


def _sky(value: Any, limits: Limits) -> SkyControls:
    """The environment controls: every key of SKY_KEYS; the rungs those clshade.render.environment
    implements (DIFFUSE_RUNGS, SPECULAR_RUNGS)."""
    table = _table("environment", value)
    unknown = [k for k in table if k not in SKY_KEYS]
    if unknown:
        raise _fail(f"environment.{unknown[0][:40]}", table[unknown[0]], f"unknown key; known: {', '.join(SKY_KEYS)}")
    missing = [k for k in SKY_KEYS if k not in table]
    if missing:
        raise ControlError(f"environment: missing {', '.join(missing)}")
    sky = table["sky"]
    if sky is not None and (not isinstance(sky, str) or sky not in limits.skies):
        raise _fail("environment.sky", sky, f"no such sky; the picker has {', '.join(limits.skies)}")
    return SkyControls(
        sky=sky,
        diffuse=_choice("environment.diffuse", table["diffuse"], env.DIFFUSE_RUNGS),
        specular=_choice("environment.specular", table["specular"], env.SPECULAR_RUNGS),
        samples=_integer("environment.samples", table["samples"], 1, env.MAX_SAMPLES),
        rotation=_number("environment.rotation", table["rotation"], *SKY_ROTATION_RANGE),
        intensity=_number("environment.intensity", table["intensity"], *SKY_INTENSITY_RANGE))


def _canvas(state: dict[str, Any], limits: Limits) -> tuple[int | None, int | None]:
    """The canvas size the page asks for (both or neither of width and height), fitted within the cap."""
    if ("width" in state) != ("height" in state):
        raise ControlError("controls: width and height come together (the canvas size) or not at all")
    if "width" not in state:
        return None, None
    width = _integer("width", state["width"], 1, MAX_RESOLUTION)
    height = _integer("height", state["height"], 1, MAX_RESOLUTION)
    return fit_canvas(width, height, limits.max_canvas)


CONTROL_KEYS = ("azimuth", "elevation", "distance", "model_a", "model_b", "split", "diff", "exposure",
                "tonemap", "samples", "specular_aa", "materials", "lights", "environment", "width", "height")


def parse_controls(value: Any, limits: Limits) -> Controls:
    """Check a control state from the page (every key required except materials, lights, environment
    and the canvas size, width and height)."""
    state = _table("controls", value)
    unknown = [k for k in state if k not in CONTROL_KEYS]
    if unknown:
        raise _fail(unknown[0], state[unknown[0]], f"unknown control; known: {', '.join(CONTROL_KEYS)}")
    missing = [k for k in CONTROL_KEYS[:11] if k not in state]
    if missing:
        raise ControlError(f"controls: missing {', '.join(missing)}")
    tonemap = state["tonemap"]
    if tonemap not in TONEMAPS:
        raise _fail("tonemap", tonemap, f"must be one of {', '.join(TONEMAPS)}")
    samples = state["samples"]
    if isinstance(samples, bool) or not isinstance(samples, int) or not 1 <= samples <= MAX_SAMPLES:
        raise _fail("samples", samples, f"must be an integer within [1, {MAX_SAMPLES}]")
    width, height = _canvas(state, limits)
    w, h = (width or limits.width), (height or limits.height)
    if max(w, h) * samples > MAX_RESOLUTION:
        raise _fail("samples", samples, f"{w}x{h} × {samples} exceeds the raster limit {MAX_RESOLUTION}")
    azimuth = _number("azimuth", state["azimuth"], -MAX_AZIMUTH, MAX_AZIMUTH)
    elevation = _number("elevation", state["elevation"], -MAX_ELEVATION, MAX_ELEVATION)
    distance = _number("distance", state["distance"], *limits.distance)
    model_a, a = _model("model_a", state["model_a"], limits.registry)
    model_b, b = _model("model_b", state["model_b"], limits.registry)
    return Controls(
        azimuth=azimuth,
        elevation=elevation,
        distance=distance,
        model_a=model_a,
        model_b=model_b,
        split=_boolean("split", state["split"]),
        diff=_boolean("diff", state["diff"]),
        exposure=_number("exposure", state["exposure"], *EXPOSURE_RANGE),
        tonemap=tonemap,
        samples=samples,
        specular_aa=_boolean("specular_aa", state["specular_aa"]),
        materials=_materials(state.get("materials", {}), limits),
        lights=_lights(state.get("lights", {}), limits),
        environment=None if state.get("environment") is None else _sky(state["environment"], limits),
        width=width,
        height=height,
        resolved=((model_a, a), (model_b, b)),
    )
