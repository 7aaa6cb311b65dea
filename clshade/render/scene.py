"""Scene files: TOML → small, validated data objects (camera, lights, materials, objects).

The format is documented key by key in scenes/README.md. Every error names the
file, the key path and the offending value; unknown keys get the nearest valid
key as a suggestion.
"""
from __future__ import annotations

import difflib
import math
import os
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from clshade import budget
from clshade.budget import MAX_COORDINATE, MAX_LIGHTS
from clshade.errors import ClshadeError, located
from clshade.models.registry import Registry
from clshade.resources import scenes_dir
from clshade.render import environment as env
from clshade.render.transforms import look_at, perspective, unit

TONEMAPS = ("none", "reinhard", "aces")
PRIMITIVES = ("sphere", "box", "cylinder", "cone", "plane", "torus", "capsule")
MAX_MATERIALS = 256          # the material id channel is one byte
MAX_RESOLUTION = 16384
EXPOSURE_RANGE = (-64.0, 64.0)   # stops; 2^±64 keeps radiance × 2^exposure finite in float32 display math
# Shadow maps: 1024² resolves a 10 m ground plane to 1 cm texels and costs
# about 0.3 s to rasterise on the host; PCF 3 (3×3 taps) softens the texel stairs.
DEFAULT_SHADOW_MAP_SIZE = 1024
SHADOW_MAP_SIZES = (64, 8192)
DEFAULT_SHADOW_PCF = 3
SHADOW_PCF_SIZES = (1, 3, 5, 7)     # odd kernel widths; 1 = a single tap (no filtering)
# Default conductor: gold at R, G, B ≈ 650, 550, 450 nm (Johnson & Christy 1972).
GOLD_ETA = (0.18, 0.42, 1.37)
GOLD_K = (3.42, 2.35, 1.77)
# Supersampling: N×N samples per pixel (clshade/render/samples.py); the device
# shades an N²-times larger G-buffer, so N is kept small.
MAX_SAMPLES = 8


@dataclass(frozen=True)
class Camera:
    position: np.ndarray
    target: np.ndarray
    up: np.ndarray
    fov: float                 # vertical field of view, degrees
    width: int
    height: int
    near: float = 0.05
    far: float = 1000.0
    # A band of rows of a taller frame: (first row, full frame height); None = the whole frame.
    # The projection maps the band's rows onto NDC [-1, 1] (see band()).
    crop: tuple[int, int] | None = None
    # Sub-pixel offset of the image plane in pixels of the full frame (x right, y down):
    # pixel centres sample the image at (j + 0.5 + shift[0], i + 0.5 + shift[1]).
    # Jittered frames (clshade/render/samples.py) use it; (0, 0) is the plain camera.
    shift: tuple[float, float] = (0.0, 0.0)

    @property
    def aspect(self) -> float:
        return self.width / (self.crop[1] if self.crop else self.height)

    @property
    def full_height(self) -> int:
        return self.crop[1] if self.crop else self.height

    def band(self, first_row: int, rows: int) -> "Camera":
        """The camera of rows [first_row, first_row + rows) of this frame: same view, a
        projection whose NDC y range is that band (pixel centres unchanged, row 0 = first_row)."""
        base = self.crop[0] if self.crop else 0
        return replace(self, height=rows, crop=(base + first_row, self.full_height))

    def band_ndc(self) -> tuple[float, float]:
        """(centre, half extent) of the band's NDC y range in the full frame ((0, 1) uncropped)."""
        if not self.crop:
            return 0.0, 1.0
        first, full = self.crop
        top, bottom = 1.0 - 2.0 * first / full, 1.0 - 2.0 * (first + self.height) / full
        return (top + bottom) / 2.0, (top - bottom) / 2.0

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unit forward, right and up vectors (right-handed, +Y up by default): the
        rows of the view matrix, so rasterizer and shading kernel agree."""
        m = self.view_matrix()
        return -m[2, :3], m[0, :3], m[1, :3]

    def view_matrix(self) -> np.ndarray:
        """World → camera (camera looks down −Z)."""
        return look_at(self.position, self.target, self.up)

    def projection_matrix(self) -> np.ndarray:
        """OpenGL perspective projection (clip space, NDC z in [−1, 1]), moved by `shift`; for
        a band, followed by the map of the band's NDC y range onto [−1, 1] (y' = (y − centre·w) / half)."""
        m = perspective(self.fov, self.aspect, self.near, self.far)
        if self.shift != (0.0, 0.0):
            m[0] -= (2.0 * self.shift[0] / self.width) * m[3]
            m[1] += (2.0 * self.shift[1] / self.full_height) * m[3]
        if self.crop:
            centre, half = self.band_ndc()
            crop = np.eye(4)
            crop[1, 1], crop[1, 3] = 1.0 / half, -centre / half
            m = crop @ m
        return m

    def with_size(self, width: int | None, height: int | None) -> "Camera":
        if self.crop and (width or self.width, height or self.height) != (self.width, self.height):
            raise ValueError("a band camera cannot be resized")
        return replace(self, width=width or self.width, height=height or self.height)


@dataclass(frozen=True)
class Light:
    kind: str                  # directional | point | spot
    color: np.ndarray          # irradiance (directional, W/m²) or intensity (W/sr)
    direction: np.ndarray | None = None   # unit, the direction light travels
    position: np.ndarray | None = None
    inner_angle: float = 0.0   # spot: full intensity inside, degrees from the axis
    outer_angle: float = 0.0   # spot: zero outside
    shadows: bool = False      # casts shadows (directional and spot lights; shadow maps)


@dataclass(frozen=True)
class Material:
    name: str
    base_color: tuple[float, float, float] = (0.8, 0.8, 0.8)
    roughness: float = 0.5
    metallic: float = 0.0
    shininess: float | None = None   # None → derived from roughness: n = 2/α² − 2
    ks: float = 0.3
    kd: float | None = None          # None → 1 − ks (the study's k_d + k_s = 1)
    ka: float = 1.0
    ior: float = 1.5
    f90: float = 1.0
    eta: tuple[float, float, float] = GOLD_ETA
    k: tuple[float, float, float] = GOLD_K
    double_sided: bool = False
    emissive: tuple[float, float, float] = (0.0, 0.0, 0.0)   # emitted radiance, linear RGB (added unlit)
    # Texture files (resolved paths), glTF metallic-roughness semantics: the
    # texture multiplies the factor (base_color, roughness, metallic) above.
    base_color_texture: Path | None = None          # sRGB RGB(A)
    metallic_roughness_texture: Path | None = None  # linear: G = roughness, B = metallic
    normal_texture: Path | None = None              # linear tangent-space normal, +Y = +V (glTF)
    normal_scale: float = 1.0                       # scales the map's X and Y (glTF normalTexture.scale)
    uv_scale: float = 1.0                           # texture repeats per unit of UV

    @property
    def textures(self) -> dict[str, Path]:
        """Texture key → file, for the textures this material names."""
        return {k: getattr(self, k) for k in TEXTURE_KEYS if getattr(self, k) is not None}

    @property
    def exponent(self) -> float:
        """The Phong exponent: given, or the Beckmann-equivalent 2/α² − 2 (Walter 2007),
        capped at SHININESS_FROM_ROUGHNESS_MAX."""
        if self.shininess is not None:
            return self.shininess
        alpha2 = max(self.roughness ** 4, 1e-12)
        return float(min(max(2.0 / alpha2 - 2.0, 0.0), SHININESS_FROM_ROUGHNESS_MAX))

    def constants(self) -> dict[str, Any]:
        return dict(kd=1.0 - self.ks if self.kd is None else self.kd, ks=self.ks, ka=self.ka,
                    shininess=self.exponent, ior=self.ior, f90=self.f90, eta=self.eta, k=self.k)


TEXTURE_KEYS = ("base_color_texture", "metallic_roughness_texture", "normal_texture")


# Roughness 0 maps to an infinitely sharp Phong lobe; the cap keeps it a lobe
# float32 can render (the same width as GGX at roughness ≈ 0.12).
SHININESS_FROM_ROUGHNESS_MAX = 1.0e4


@dataclass(frozen=True)
class SceneObject:
    name: str
    material: str
    mesh: Path | None = None
    primitive: str | None = None
    params: dict[str, Any] = field(default_factory=dict)
    translate: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotate: tuple[float, float, float] = (0.0, 0.0, 0.0)   # degrees about X, then Y, then Z
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    mesh_material: bool = False   # use the mesh file's glTF PBR materials (factors, textures)
    crease_angle: float | None = None   # degrees; None → the default (meshes.SHARP_EDGE_DEGREES)
    smooth: bool | None = None          # True: one normal per position, False: flat faces, None: crease_angle

    def matrix(self) -> np.ndarray:
        """Object → world: translate · Rz · Ry · Rx · scale."""
        rx, ry, rz = (math.radians(a) for a in self.rotate)
        cx, sx, cy, sy, cz, sz = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry), math.cos(rz), math.sin(rz)
        Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        m = np.eye(4)
        m[:3, :3] = Rz @ Ry @ Rx @ np.diag(self.scale)
        m[:3, 3] = self.translate
        return m


@dataclass(frozen=True)
class Scene:
    path: Path | None
    camera: Camera
    lights: tuple[Light, ...]
    materials: dict[str, Material]
    objects: tuple[SceneObject, ...]
    background: tuple[float, float, float] = (0.0, 0.0, 0.0)
    ambient: tuple[float, float, float] = (0.0, 0.0, 0.0)
    exposure: float = 0.0
    tonemap: str = "aces"
    model: str = "ggx_correlated"
    shadow_map_size: int = DEFAULT_SHADOW_MAP_SIZE
    shadow_pcf: int = DEFAULT_SHADOW_PCF
    samples: int = 1                 # N×N samples per pixel, box-filtered (supersampling)
    specular_aa: bool = False        # roughness widened from the normal's screen-space variance
    lobes: tuple[Path, ...] = ()     # the user's lobe folders it names (render.lobes): Registry.with_lobes
    environment: env.EnvironmentSpec | None = None   # light from the whole sky ([environment])
    environment_background: bool = False             # uncovered pixels show the sky (background = "environment")

    @property
    def shadow_lights(self) -> tuple[int, ...]:
        """Indices of the lights that cast shadows."""
        return tuple(i for i, l in enumerate(self.lights) if l.shadows)

    @property
    def material_names(self) -> list[str]:
        return list(self.materials)

    def inputs(self) -> list[Path]:
        """Files the scene reads: the scene itself and its meshes."""
        out = [self.path] if self.path else []
        out += [o.mesh for o in self.objects if o.mesh is not None]
        out += [p for m in self.materials.values() for p in m.textures.values()]
        if self.environment is not None and self.environment.map is not None:
            out.append(self.environment.map)
        return out


# ---------------------------------------------------------------- validation


class _Reader:
    """Reads one TOML table with typed getters; reports unknown keys."""

    def __init__(self, file: Path | str, table: Any, where: str) -> None:
        if not isinstance(table, dict):
            raise located(f"expected a table, got {type(table).__name__}", file, where, table, has_value=True)
        self.file, self.table, self.where = file, table, where
        self.seen: set[str] = set()

    def _key(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def error(self, key: str, message: str) -> ClshadeError:
        return located(message, self.file, self._key(key), self.table.get(key), has_value=key in self.table)

    def raw(self, key: str, default: Any = None) -> Any:
        self.seen.add(key)
        return self.table.get(key, default)

    def number(self, key: str, default: float | None = None, low: float = -math.inf,
               high: float = math.inf, required: bool = False) -> float | None:
        value = self.raw(key)
        if value is None:
            if required:
                raise located("is required", self.file, self._key(key))
            return default
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(key, f"must be a number, got {type(value).__name__}")
        if not math.isfinite(value) or not (low <= value <= high):
            raise self.error(key, f"must be within [{low:g}, {high:g}]")
        return float(value)

    def integer(self, key: str, default: int, low: int, high: int) -> int:
        value = self.raw(key)
        if value is None:
            return default
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"must be an integer, got {type(value).__name__}")
        if not (low <= value <= high):
            raise self.error(key, f"must be within [{low}, {high}]")
        return value

    def vector(self, key: str, default: Any = None, low: float = -math.inf, high: float = math.inf,
               required: bool = False, nonzero: bool = False, allow_scalar: bool = False) -> tuple[float, float, float] | None:
        value = self.raw(key)
        if value is None:
            if required:
                raise located("is required", self.file, self._key(key))
            return default
        if allow_scalar and isinstance(value, (int, float)) and not isinstance(value, bool):
            value = [value] * 3
        if (not isinstance(value, list) or len(value) != 3
                or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in value)):
            raise self.error(key, "must be a list of 3 numbers" + (" or a number" if allow_scalar else ""))
        if any(not math.isfinite(x) or not (low <= x <= high) for x in value):
            raise self.error(key, f"components must be within [{low:g}, {high:g}]")
        if nonzero and all(x == 0 for x in value):
            raise self.error(key, "must not be the zero vector")
        return tuple(float(x) for x in value)

    def direction(self, key: str, default: Any = None, required: bool = False) -> np.ndarray | None:
        """A non-zero vector as a unit vector (transforms.unit: exact for lengths from subnormal
        to 1e308, where dividing by the Euclidean norm over- or underflows)."""
        value = self.vector(key, default, required=required, nonzero=True)
        return None if value is None else unit(value)

    def input_file(self, key: str, what: str) -> Path | None:
        """A file named relative to the scene file; it must be a regular file (budget.regular_file)."""
        value = self.string(key)
        if value is None:
            return None
        path = Path(value) if Path(value).is_absolute() else (Path(self.file).parent / value).resolve()
        try:
            return budget.regular_file(path, what)
        except ClshadeError as exc:
            raise self.error(key, str(exc).removeprefix(f"{path}: ")) from None

    def string(self, key: str, default: str | None = None, choices: tuple[str, ...] | None = None,
               required: bool = False) -> str | None:
        value = self.raw(key)
        if value is None:
            if required:
                raise located("is required", self.file, self._key(key))
            return default
        if not isinstance(value, str):
            raise self.error(key, f"must be a string, got {type(value).__name__}")
        if choices and value not in choices:
            near = difflib.get_close_matches(value, choices, n=1)
            hint = f"; did you mean {near[0]!r}?" if near else ""
            raise self.error(key, f"must be one of {', '.join(choices)}{hint}")
        return value

    def boolean(self, key: str, default: bool) -> bool:
        value = self.raw(key)
        if value is None:
            return default
        if not isinstance(value, bool):
            raise self.error(key, "must be true or false")
        return value

    def finish(self) -> None:
        """Reject keys that were never read, suggesting the nearest valid one."""
        for key in self.table:
            if key not in self.seen:
                near = difflib.get_close_matches(key, sorted(self.seen), n=1, cutoff=0.5)
                hint = f"; did you mean {near[0]!r}?" if near else f"; valid keys: {', '.join(sorted(self.seen))}"
                raise located(f"unknown key{hint}", self.file, self._key(key))


PRIMITIVE_PARAMS: dict[str, dict[str, tuple[float, float, float]]] = {
    # name: {param: (default, low, high)}
    "sphere": {"radius": (1.0, 1e-6, 1e6), "subdivisions": (4, 0, 7)},
    "box": {"size": (1.0, 1e-6, 1e6)},
    "cylinder": {"radius": (0.5, 1e-6, 1e6), "height": (1.0, 1e-6, 1e6), "sections": (48, 3, 1024)},
    "cone": {"radius": (0.5, 1e-6, 1e6), "height": (1.0, 1e-6, 1e6), "sections": (48, 3, 1024)},
    "capsule": {"radius": (0.5, 1e-6, 1e6), "height": (1.0, 0.0, 1e6), "sections": (32, 3, 1024)},
    "plane": {"size": (10.0, 1e-6, 1e6)},
    "torus": {"major_radius": (1.0, 1e-6, 1e6), "minor_radius": (0.25, 1e-6, 1e6), "sections": (48, 3, 1024)},
}


def _material(file: Path | str, table: Any, name: str, where: str) -> Material:
    r = _Reader(file, table, where)
    m = Material(
        name=name,
        base_color=r.vector("base_color", (0.8, 0.8, 0.8), 0.0, 1e6),
        roughness=r.number("roughness", 0.5, 0.0, 1.0),
        metallic=r.number("metallic", 0.0, 0.0, 1.0),
        shininess=r.number("shininess", None, 0.0, 1e6),
        ks=r.number("ks", 0.3, 0.0, 1.0),
        kd=r.number("kd", None, 0.0, 1.0),
        ka=r.number("ka", 1.0, 0.0, 1e6),
        ior=r.number("ior", 1.5, 1.0, 10.0),
        f90=r.number("f90", 1.0, 0.0, 1.0),
        eta=r.vector("eta", GOLD_ETA, 0.0, 100.0),
        k=r.vector("k", GOLD_K, 0.0, 100.0),
        double_sided=r.boolean("double_sided", False),
        emissive=r.vector("emissive", (0.0, 0.0, 0.0), 0.0, 1e6, allow_scalar=True),
        **{key: _texture_path(file, r, key) for key in TEXTURE_KEYS},
        normal_scale=r.number("normal_scale", 1.0, 0.0, 100.0),
        uv_scale=r.number("uv_scale", 1.0, 1e-6, 1e6),
    )
    r.finish()
    return m


def _texture_path(file: Path | str, r: "_Reader", key: str) -> Path | None:
    """A texture file named relative to the scene file; it must be a regular file."""
    return r.input_file(key, "texture file")


def _light(file: Path | str, table: Any, where: str, shadows_default: bool = False) -> Light:
    r = _Reader(file, table, where)
    kind = r.string("type", required=True, choices=("directional", "point", "spot"))
    shadows = r.boolean("shadows", shadows_default)
    if shadows and kind == "point":
        hint = ("set shadows = false on this light" if "shadows" not in r.table
                else "remove shadows = true")
        raise located(f"point lights cannot cast shadows (cube shadow maps are not supported); {hint}",
                      file, f"{where}.shadows", shadows, has_value=True)
    if kind == "directional":
        light = Light(kind, np.array(r.vector("irradiance", (1.0, 1.0, 1.0), 0.0, 1e30, allow_scalar=True)),
                      direction=r.direction("direction", required=True))
    else:
        pos = np.array(r.vector("position", required=True, low=-MAX_COORDINATE, high=MAX_COORDINATE))
        color = np.array(r.vector("intensity", (1.0, 1.0, 1.0), 0.0, 1e30, allow_scalar=True))
        if kind == "point":
            light = Light(kind, color, position=pos)
        else:
            d = r.direction("direction", required=True)
            outer = r.number("outer_angle", 30.0, 0.0, 90.0)
            inner = r.number("inner_angle", 0.8 * outer, 0.0, outer)
            light = Light(kind, color, direction=d, position=pos,
                          inner_angle=inner, outer_angle=outer)
    r.finish()
    return replace(light, shadows=shadows)


def _object(file: Path, table: Any, where: str, materials: dict[str, Material]) -> SceneObject:
    r = _Reader(file, table, where)
    name = r.string("name", where)
    mesh = r.string("mesh")
    primitive = r.string("primitive", choices=PRIMITIVES)
    if (mesh is None) == (primitive is None):
        raise located("needs exactly one of 'mesh' or 'primitive'", file, where)
    params: dict[str, Any] = {}
    if primitive:
        for key, (default, low, high) in PRIMITIVE_PARAMS[primitive].items():
            if isinstance(default, int):
                params[key] = r.integer(key, default, int(low), int(high))
            elif key == "size" and primitive == "box":
                params[key] = r.vector(key, (default,) * 3, low, high, allow_scalar=True)
            else:
                params[key] = r.number(key, default, low, high)
    mesh_path = r.input_file("mesh", "mesh file") if mesh is not None else None
    mat = r.raw("material", None)
    if mat is None:
        raise located("is required", file, f"{where}.material")
    if isinstance(mat, str):
        if mat not in materials:
            near = difflib.get_close_matches(mat, list(materials), n=1)
            hint = f"; did you mean {near[0]!r}?" if near else f"; defined: {', '.join(materials) or 'none'}"
            raise located(f"names no material in [materials]{hint}", file, f"{where}.material", mat, has_value=True)
        mat_name = mat
    else:
        mat_name = f"{name}#material"
        materials[mat_name] = _material(file, mat, mat_name, f"{where}.material")
    obj = SceneObject(
        name=name, material=mat_name, mesh=mesh_path, primitive=primitive, params=params,
        translate=r.vector("translate", (0.0, 0.0, 0.0), -MAX_COORDINATE, MAX_COORDINATE),
        rotate=r.vector("rotate", (0.0, 0.0, 0.0), -360.0, 360.0),
        scale=r.vector("scale", (1.0, 1.0, 1.0), 1e-9, 1e9, allow_scalar=True),
        mesh_material=r.boolean("mesh_material", False),
        crease_angle=r.number("crease_angle", None, 0.0, 180.0),
        smooth=r.raw("smooth", None),
    )
    if obj.smooth is not None:
        r.boolean("smooth", False)   # type check
        if obj.crease_angle is not None:
            raise located("set either smooth or crease_angle, not both", file, f"{where}.crease_angle",
                          obj.crease_angle, has_value=True)
    if obj.mesh_material and mesh_path is not None and mesh_path.suffix.lower() not in (".gltf", ".glb"):
        raise located("needs a glTF mesh (.gltf or .glb)", file, f"{where}.mesh_material", True, has_value=True)
    if obj.mesh_material and primitive:
        raise located("applies to mesh files only", file, f"{where}.mesh_material", True, has_value=True)
    r.finish()
    return obj


def parse_scene(text: str, file: Path | str = "<scene>", registry: Registry | None = None) -> Scene:
    """Validate a scene from TOML text. Relative mesh paths resolve against the file's folder;
    render.model is checked against `registry` (default: the built-in lobes) and the scene's lobes."""
    file = Path(file) if not isinstance(file, Path) else file
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message = str(exc)
        if "line" not in message:   # "(at end of document)": give the position too
            lines = text.split("\n")
            message += f" (line {len(lines)}, column {len(lines[-1]) + 1})"
        raise ClshadeError(f"{file}: malformed TOML: {message}") from exc
    return scene_from_data(data, file, registry)


def camera_from_data(data: dict[str, Any], file: Path | str = "<scene>") -> Camera:
    """The checked camera of a scene's parsed tables (scene_from_data's own; the live viewer
    parses only the camera when nothing else changed)."""
    file = Path(file) if not isinstance(file, Path) else file
    top = _Reader(file, data, "")
    cam = _Reader(file, top.raw("camera", None) or _missing(file, "camera"), "camera")
    camera = Camera(
        position=np.array(cam.vector("position", required=True, low=-MAX_COORDINATE, high=MAX_COORDINATE)),
        target=np.array(cam.vector("target", (0.0, 0.0, 0.0), -MAX_COORDINATE, MAX_COORDINATE)),
        up=cam.direction("up", (0.0, 1.0, 0.0)),
        fov=cam.number("fov", 45.0, 1e-3, 179.0),
        width=cam.integer("width", 640, 1, MAX_RESOLUTION),
        height=cam.integer("height", 480, 1, MAX_RESOLUTION),
        near=cam.number("near", 0.05, 1e-6, 1e6),
        far=cam.number("far", 1000.0, 1e-6, 1e12),
    )
    cam.finish()
    if camera.far <= camera.near:
        raise located("must be greater than camera.near", file, "camera.far", camera.far, has_value=True)
    fwd = camera.target - camera.position
    if np.linalg.norm(fwd) == 0:
        raise located("equals camera.position", file, "camera.target", list(camera.target), has_value=True)
    if np.linalg.norm(np.cross(fwd, camera.up)) < 1e-9 * np.linalg.norm(fwd) * np.linalg.norm(camera.up):
        raise located("is parallel to the view direction", file, "camera.up", list(camera.up), has_value=True)
    return camera


def scene_from_data(data: dict[str, Any], file: Path | str = "<scene>", registry: Registry | None = None) -> Scene:
    """Validate a scene from its parsed TOML tables (what tomllib returns; `clshade view`
    edits them and parses each edit without writing TOML text in between). Nothing outside the
    returned Scene changes: its lobe folders are a field, for the caller's Registry."""
    file = Path(file) if not isinstance(file, Path) else file
    top = _Reader(file, data, "")
    camera = camera_from_data(data, file)
    top.raw("camera", None)

    rnd = _Reader(file, top.raw("render", {}), "render")
    environment_background = rnd.raw("background") == "environment"
    if isinstance(rnd.raw("background"), str) and not environment_background:
        raise rnd.error("background", 'must be a list of 3 numbers or "environment"')
    background = (0.0, 0.0, 0.0) if environment_background else rnd.vector("background", (0.0, 0.0, 0.0), 0.0, 1e6)
    ambient = rnd.vector("ambient", (0.0, 0.0, 0.0), 0.0, 1e6, allow_scalar=True)
    exposure = rnd.number("exposure", 0.0, *EXPOSURE_RANGE)
    tonemap = rnd.string("tonemap", "aces", TONEMAPS)
    lobes_dir = rnd.string("lobes")
    lobes: tuple[Path, ...] = ()
    if lobes_dir is not None:       # the user's lobes, named relative to the scene file
        folder = Path(lobes_dir) if Path(lobes_dir).is_absolute() else Path(file).parent / lobes_dir
        if not folder.exists():
            raise rnd.error("lobes", "no such folder")
        lobes = (folder.resolve(),)
    registry = (registry or Registry()).with_lobes(*lobes)
    if lobes:
        registry.lobes      # read here: an error in a lobe file is its own, not render.model's
    model = rnd.string("model", "ggx_correlated")
    if Path(model).suffix in (".brdf", ".cl") and not Path(model).is_absolute():
        model = str(Path(file).parent / model)     # a lobe file named relative to the scene
    try:
        registry.resolve(model)
    except ClshadeError as exc:       # "model 'x': why" → "file: render.model = 'x': why"
        raise rnd.error("model", str(exc).removeprefix(f"model {model!r}: ")) from exc
    shadows = rnd.boolean("shadows", False)
    shadow_map_size = rnd.integer("shadow_map_size", DEFAULT_SHADOW_MAP_SIZE, *SHADOW_MAP_SIZES)
    shadow_pcf = rnd.integer("shadow_pcf", DEFAULT_SHADOW_PCF, SHADOW_PCF_SIZES[0], SHADOW_PCF_SIZES[-1])
    if shadow_pcf not in SHADOW_PCF_SIZES:
        raise rnd.error("shadow_pcf", f"must be one of {', '.join(map(str, SHADOW_PCF_SIZES))} (an odd kernel width)")
    samples = rnd.integer("samples", 1, 1, MAX_SAMPLES)
    specular_aa = rnd.boolean("specular_aa", False)
    rnd.finish()

    lights_raw = top.raw("lights", [])
    if not isinstance(lights_raw, list):
        raise located("must be an array of tables ([[lights]])", file, "lights")
    if len(lights_raw) > MAX_LIGHTS:
        raise located(f"{len(lights_raw)} lights exceed the limit of {MAX_LIGHTS}", file, "lights")
    lights = tuple(_light(file, t, f"lights[{i}]", shadows) for i, t in enumerate(lights_raw))
    casting = sum(light.shadows for light in lights)
    if casting:
        try:
            budget.shadow_texels(casting, shadow_map_size)
        except ClshadeError as exc:
            raise rnd.error("shadow_map_size", str(exc)) from None

    mats_raw = top.raw("materials", {})
    mats_reader = _Reader(file, mats_raw, "materials")
    materials = {name: _material(file, t, name, f"materials.{name}") for name, t in mats_reader.table.items()}

    objs_raw = top.raw("objects", [])
    if not isinstance(objs_raw, list):
        raise located("must be an array of tables ([[objects]])", file, "objects")
    objects = tuple(_object(file, t, f"objects[{i}]", materials) for i, t in enumerate(objs_raw))
    environment = _environment(file, top.raw("environment")) if "environment" in top.table else None
    if environment_background and environment is None:
        raise located("needs an [environment] table to show", file, "render.background", "environment",
                      has_value=True)
    top.finish()
    if len(materials) > MAX_MATERIALS:
        raise located(f"at most {MAX_MATERIALS} materials are supported, got {len(materials)}", file, "materials")
    return Scene(path=file if file.exists() else None, camera=camera, lights=lights, materials=materials,
                 objects=objects, background=background, ambient=ambient, exposure=exposure,
                 tonemap=tonemap, model=model, shadow_map_size=shadow_map_size, shadow_pcf=shadow_pcf,
                 samples=samples, specular_aa=specular_aa, lobes=lobes, environment=environment,
                 environment_background=environment_background)


def _environment(file: Path, table: Any) -> env.EnvironmentSpec:
    """The [environment] table (scenes/README.md): a map file or a uniform colour, its scale and
    rotation, and the rungs; a map is read and checked here (env.read_map: cached)."""
    r = _Reader(file, table, "environment")
    path = r.input_file("map", "environment map")
    uniform = r.vector("uniform", None, 0.0, 1e30, allow_scalar=True)
    if (path is None) == (uniform is None):
        raise located("needs exactly one of 'map' (a file) or 'uniform' (a colour)", file, "environment")
    specular = r.string("specular", env.DEFAULT_SPECULAR, env.SPECULAR_RUNGS)
    spec = env.EnvironmentSpec(
        map=path, uniform=uniform,
        intensity=r.number("intensity", 1.0, 0.0, 1e30),
        rotation=r.number("rotation", 0.0, -360.0, 360.0),
        diffuse=r.string("diffuse", env.DEFAULT_DIFFUSE, env.DIFFUSE_RUNGS),
        specular=specular,
        samples=r.integer("samples", env.DEFAULT_SAMPLES, 1, env.MAX_SAMPLES))
    r.finish()
    if path is not None:
        env.read_map(path, file, "environment.map")
    return spec


def _missing(file: Path, key: str) -> None:
    raise located("is required", file, key)


def load_scene(path: str | Path, registry: Registry | None = None) -> Scene:
    """Read and validate a scene file (a regular file of at most budget.MAX_SCENE_FILE_BYTES);
    `registry` as for parse_scene."""
    path = Path(path)
    if not os.path.lexists(path):
        bundled = scenes_dir() / path.name
        hint = f" (the bundled scene of that name is {bundled})" if os.path.isfile(bundled) else ""
        raise ClshadeError(f"{path}: scene file not found{hint}")
    text = budget.read_text(path, "scene file", budget.MAX_SCENE_FILE_BYTES)
    return parse_scene(text, path.resolve(), registry)
