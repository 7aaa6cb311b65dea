"""The frames of `clshade view`: the page's controls → scene → the real pipeline
(clshade.pipeline's stages: geometry → rasterize → G-buffer → shading kernel) → 8-bit
frames, with every stage's result kept and reused while its inputs stay the same.

What a change costs, by what it changes:

- camera (orbit, zoom) or samples: rasterize, G-buffer, upload, shade;
- a material's roughness: the roughness plane of that material's pixels is written
  again (no raster; a material with textures rebuilds its G-buffer from the kept raster);
- shininess, kd, ks, ka, lights: the material or light table is uploaded again; shade;
- model, exposure, tone map: shade (or only the display transform) on the same G-buffer.

A frame is made in two halves, prepare() (scene, geometry, rasterize) and finish() (the rest),
which the server runs on two threads: the next state is rasterized while the last is shaded.

Device times come from clshade.bench.run (the same dispatch timing and frame statistics
as `clshade bench`), the error from the same float64 oracle (clshade.verify.reference).
"""
from __future__ import annotations

import dataclasses
import math
import os
import re
import tempfile
import threading
import tomllib
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from clshade.bench.run import compared_pixels, frame_stats, grazing_pixels, relative_error
from clshade.compare import difference, false_colour
from clshade.device.display import Display
from clshade.device.runtime import get_runtime
from clshade.device.shade import Shader, scene_features
from clshade.device.timing import timed_dispatch
from clshade.device.variants import environment_defines
from clshade.diagnostics import note
from clshade.errors import ClshadeError
from clshade.models.lobe import SURFACE_PARAMS
from clshade.models.model import PRESETS, presets
from clshade.models.registry import Registry, lobe_path
from clshade.pipeline import DEVICE_GBUFFER_STAGE, GBufferStage, Timings
from clshade.render.gbuffer import GBuffer, face_planes, material_table
from clshade.render.arrays import PlanePool, keep_freed_memory
from clshade.render.image import check_output_path, to_display, write_encoded
from clshade.render.meshes import build_geometry
from clshade.render.raster import Fragments, RasterMesh, ViewSetup
from clshade.render.samples import supersampled
from clshade.render.scene import MAX_RESOLUTION, Scene, camera_from_data, load_scene, parse_scene, scene_from_data
from clshade.render.shadows import build_shadow_maps
from clshade.render import environment as env
from clshade.verify import environment_oracle, reference
from clshade.view.controls import MAX_CANVAS, SKY_NONE, SKY_WHITE, Controls, Limits
from clshade.view.document import applied, dumps, relocated

#: Frames of each model kept for its statistics (avg FPS, 1 % low): about two seconds of dragging.
HISTORY = 120
#: Names "save" accepts: one file name stem in the output folder, no path (matched whole: fullmatch,
#: as `$` would let a trailing newline through).
SAVE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
#: Colours of the difference view's scale bar on the page.
RAMP_STEPS = 160
#: Per-pixel G-buffer channels a material fills from its own values (G-buffer rebuilt or patched):
#: (channel, the Material field it takes, its components).
CHANNEL_FIELDS = (("base", "base_color", 3), ("roughness", "roughness", 1), ("metallic", "metallic", 1))
#: Where the sky picker looks for maps: the scene's folder and these subfolders of it.
SKY_FOLDERS = (".", "environments")
#: Map files the picker lists (what clshade.render.environment.read_map reads as HDR).
SKY_SUFFIXES = (".exr", ".hdr")
#: Pixels the sky-error button's truth integrates per step (the page shows its progress between steps).
SKY_ERROR_STEP = 16


@dataclass(frozen=True)
class Orbit:
    """The orbit camera: about the scene camera's target and up axis, azimuth 0 and the
    scene camera's elevation and distance at the start."""
    target: np.ndarray
    up: np.ndarray
    east: np.ndarray          # horizontal unit vector towards the scene camera (azimuth 0)
    north: np.ndarray         # up × east
    elevation: float          # degrees, of the scene camera
    distance: float

    @classmethod
    def of(cls, camera) -> "Orbit":
        target = np.asarray(camera.target, float)
        up = np.asarray(camera.up, float) / np.linalg.norm(camera.up)
        offset = np.asarray(camera.position, float) - target
        distance = float(np.linalg.norm(offset))
        height = float(offset @ up)
        flat = offset - height * up          # the scene parser refuses a view parallel to up: never zero
        east = flat / np.linalg.norm(flat)
        return cls(target, up, east, np.cross(up, east),
                   math.degrees(math.asin(max(-1.0, min(1.0, height / distance)))), distance)

    def position(self, azimuth: float, elevation: float, distance: float) -> np.ndarray:
        a, e = math.radians(azimuth), math.radians(elevation)
        ring = math.cos(a) * self.east + math.sin(a) * self.north
        return self.target + distance * (math.cos(e) * ring + math.sin(e) * self.up)


@dataclass
class ViewFrame:
    """One frame for the page: RGBA8 views ('a', and 'b' / 'diff' when asked), timings."""
    width: int
    height: int
    views: dict[str, np.ndarray]
    stages: Timings
    stats: dict[str, dict[str, float]]          # cost label (cost_label) → frame_stats of its recent frames
    models: dict[str, str]                      # view → model id
    diff_scale: float | None = None
    reshade_only: bool = False
    costs: dict[str, str] = field(default_factory=dict)         # view → its cost label (a key of stats)
    environment: dict | None = None             # the sky and rungs shaded (rung_info), None without a sky
    ladder: dict[str, float] = field(default_factory=dict)      # cost label → mean device ms, every rung seen


def rung_label(spec: env.EnvironmentSpec | None) -> str:
    """The rungs of a sky as the cost table names them (diffuse|specular, ×N when a rung samples); ''
    without a sky."""
    if spec is None:
        return ""
    return f"{spec.diffuse}|{spec.specular}" + (f" ×{spec.samples}" if spec.sampled else "")


def cost_label(model_id: str, spec: env.EnvironmentSpec | None) -> str:
    """The key a model's frame times are kept under: one per model and rung combination."""
    rungs = rung_label(spec)
    return f"{model_id} [{rungs}]" if rungs else model_id


def rung_info(scene: Scene, features, model) -> dict | None:
    """What the page shows of the sky a frame was shaded with: the map, its rungs and the defines
    of model A's kernel variant under it (clshade.device.variants.environment_defines: what is compiled)."""
    spec = scene.environment
    if spec is None:
        return None
    defines = environment_defines(model, features.environment)
    return dict(sky=spec.map.name if spec.map is not None else "uniform " + ", ".join(f"{c:g}" for c in spec.uniform),
                diffuse=spec.diffuse, specular=spec.specular, samples=spec.samples, rotation=spec.rotation,
                intensity=spec.intensity, rungs=rung_label(spec),
                variant=" ".join(f"{k}={v}" for k, v in defines.items()))


def sky_files(folder: Path) -> tuple[str, ...]:
    """The maps the sky picker offers: files of SKY_SUFFIXES in SKY_FOLDERS of the scene's folder,
    as paths relative to it (what [environment] map takes)."""
    out = []
    for sub in SKY_FOLDERS:
        where = (folder / sub).resolve()
        if where.is_dir():
            out += [p.relative_to(folder.resolve()).as_posix() for p in sorted(where.iterdir())
                    if p.suffix.lower() in SKY_SUFFIXES and p.is_file()]
    return tuple(out)


@dataclass
class SkyErrorJob:
    """The sky-error button's work, taken from one frame on the render thread (copies, so that the
    frames that follow cannot change it) and integrated off it, step by step
    (clshade.verify.environment_oracle.truth, cut into steps of SKY_ERROR_STEP pixels)."""
    label: str
    model: object
    pixels: reference.Pixels
    environment: env.Environment
    occlusion: np.ndarray       # (K,) the AO channel at the pixels (1 without one)
    rest: np.ndarray            # (K, 3) the frame oracle's lights, ambient and emission at the pixels
    image: np.ndarray           # the frame as shaded, float
    subdivisions: int = environment_oracle.DEFAULT_SUBDIVISIONS
    sky: list = field(default_factory=list)

    @property
    def total(self) -> int:
        return len(self.pixels.index)

    def steps(self):
        """Integrate SKY_ERROR_STEP pixels per step; yields (pixels done, total)."""
        px = self.pixels
        fields = [f.name for f in dataclasses.fields(px)]
        for start in range(0, self.total, SKY_ERROR_STEP):
            part = slice(start, start + SKY_ERROR_STEP)
            chunk = reference.Pixels(**{k: None if getattr(px, k) is None else getattr(px, k)[part] for k in fields})
            self.sky.append(environment_oracle.sky_integral(self.model, chunk, self.environment, self.subdivisions))
            yield min(start + SKY_ERROR_STEP, self.total), self.total

    def result(self) -> dict:
        """The error of the frame against the truth (environment_oracle.errors), once every step ran."""
        sky = np.concatenate(self.sky) if self.sky else np.zeros((0, 3))
        truth = environment_oracle.Truth(self.pixels.index, np.sum(self.pixels.n * self.pixels.v, axis=1),
                                         self.rest + sky * self.occlusion[:, None], self.subdivisions)
        return dict(type="sky_error", label=self.label,
                    **environment_oracle.errors(self.image, truth))


@dataclass
class Prepared:
    """A state through ViewSession.prepare (the raster stage), for ViewSession.finish."""
    controls: Controls
    scene: Scene
    geometry: object
    geometry_key: object
    camera: object
    fragments: object
    timings: Timings


@dataclass
class _Kept:
    """The last result of a stage and the key of the inputs it was made from."""
    key: object = None
    value: object = None
    extra: dict = field(default_factory=dict)


def _geometry_key(scene: Scene) -> tuple:
    """What build_geometry reads of the materials (textures and their factors, culling, emission)."""
    return tuple((name, m.double_sided, tuple(sorted((k, str(p)) for k, p in m.textures.items())), m.emissive,
                  (m.base_color, m.roughness, m.metallic, m.normal_scale, m.uv_scale) if m.textures else None)
                 for name, m in scene.materials.items())


def _face_key(mats: list) -> tuple:
    """What gbuffer.face_planes reads of the materials."""
    return tuple((tuple(m.base_color), m.roughness, m.metallic, tuple(m.emissive)) for m in mats)


def _same_but_camera(a: dict, b: dict) -> bool:
    """Whether two scene documents have the same tables but (maybe) the camera (the tables
    applied() did not touch are shared, so the comparison is short)."""
    return a.keys() == b.keys() and all(a[k] == b[k] for k in a if k != "camera")


def _lights_key(scene: Scene) -> tuple:
    return tuple((l.kind, tuple(l.color), None if l.direction is None else tuple(l.direction),
                  None if l.position is None else tuple(l.position), l.inner_angle, l.outer_angle, l.shadows)
                 for l in scene.lights)


def _sky_data_key(spec: env.EnvironmentSpec | None) -> tuple | None:
    """What the Shader uploads of a sky (clshade.render.environment.data_key: the map and its file's
    stamp, its colour and intensity); not its rotation (Shader.rebind writes the params again), the
    rungs (a variant each) nor the sample count (an argument)."""
    return None if spec is None else env.data_key(spec)


def _channel_values(scene: Scene) -> np.ndarray:
    """(materials, components of CHANNEL_FIELDS) float32: the per-pixel values each material writes."""
    width = sum(n for _, _, n in CHANNEL_FIELDS)
    return np.array([np.concatenate([np.ravel(getattr(m, f)) for _, f, _ in CHANNEL_FIELDS])
                     for m in scene.materials.values()], np.float32).reshape(-1, width)


def material_pixels(gbuffer: GBuffer, pixels: np.ndarray, count: int) -> list[np.ndarray]:
    """The covered `pixels` of each of `count` materials (made once per raster)."""
    material = gbuffer.plane("material")[0][pixels]
    order = np.argsort(material, kind="stable")
    bounds = np.searchsorted(material[order], np.arange(count + 1))
    return [pixels[order[bounds[i]:bounds[i + 1]]] for i in range(count)]


def patched_gbuffer(gbuffer: GBuffer, groups: list[np.ndarray], old: np.ndarray, new: np.ndarray,
                    table: np.ndarray, pool: PlanePool | None = None) -> GBuffer:
    """`gbuffer` for changed material values, without the raster: the base colour, roughness
    and metallic planes rewritten on the covered pixels of each material whose value changed
    (`groups`: material_pixels; as build_gbuffer writes them for an untextured scene, which
    leaves the base colour of a pixel with non-finite inputs 0), and the new material table.
    Planes that did not change are shared, not copied."""
    planes = {name: gbuffer.plane(name) for name in gbuffer.channels}
    covered = gbuffer.coverage.ravel() if gbuffer.nonfinite_pixels else None
    start = 0
    for name, _, width in CHANNEL_FIELDS:
        columns = slice(start, start + width)
        start += width
        changed = np.flatnonzero((old[:, columns] != new[:, columns]).any(axis=1))
        if not len(changed):
            continue
        plane = pool.copy(planes[name]) if pool is not None else planes[name].copy()
        for index in changed:
            rows = groups[index]
            if name == "base" and covered is not None:
                rows = rows[covered[rows]]
            for c in range(width):
                plane[c][rows] = new[index, columns.start + c]
        planes[name] = plane
    return GBuffer.from_planes(gbuffer.width, gbuffer.height, planes, table, gbuffer.coverage,
                               gbuffer.nonfinite_pixels, unit_normals=gbuffer.unit_normals)


class ViewSession:
    """One scene explored in the viewer: its document, the kept stages and each model's recent times."""

    def __init__(self, scene_path: str | Path, out_dir: str | Path, width: int | None = None,
                 height: int | None = None, device: str | None = None, device_gbuffer: bool = True,
                 registry: Registry | None = None, max_canvas: tuple[int, int] = MAX_CANVAS,
                 sky_error_pixels: int = environment_oracle.DEFAULT_PIXELS) -> None:
        """`registry`: the command's lobes (default: the built-ins); the scene's lobe folders are added.
        `width`, `height`: the frame size until the page asks for its canvas's (the page keeps it when
        they are given); `max_canvas`: the largest canvas rendered; `sky_error_pixels`: the pixels the
        sky-error button integrates (environment_oracle.oracle_pixels).
        The page may name lobe files and folders only inside the scene's folder, the lobe folders
        given to the command or the scene (--lobes, $CLSHADE_LOBES, render.lobes) and the scene's own
        model file (Registry.confined), a relative one taken from the scene's folder."""
        self.base_scene = load_scene(scene_path, registry)
        self.path = Path(scene_path).resolve()
        given = (registry or Registry()).with_lobes(*self.base_scene.lobes)
        own = lobe_path(self.base_scene.model)         # render.model naming a lobe file or folder
        self.model = self.base_scene.model if own is None else str(own.resolve())
        self.registry = given.confined(self.path.parent, *([own] if own is not None else []))
        self.base_doc = tomllib.loads(self.path.read_text(encoding="utf-8"))
        for name, value in (("--width", width), ("--height", height)):
            if value is not None and not 1 <= value <= MAX_RESOLUTION:
                raise ClshadeError(f"{name} = {value}: must be within [1, {MAX_RESOLUTION}]")
        camera = self.base_scene.camera.with_size(width, height)
        self.width, self.height = camera.width, camera.height
        self.fixed_size = width is not None or height is not None
        self.sky_error_pixels = sky_error_pixels
        spec = self.base_scene.environment
        own = [] if spec is None or spec.map is None else [Path(os.path.relpath(spec.map, self.path.parent)).as_posix()]
        self.skies = (SKY_NONE, SKY_WHITE, *dict.fromkeys(own + list(sky_files(self.path.parent))))
        self.out_dir = Path(out_dir).resolve()
        if not self.out_dir.is_dir():
            raise ClshadeError(f"{out_dir}: output folder does not exist")
        self.orbit = Orbit.of(camera)
        self.limits = Limits.of(self.base_scene, self.orbit.distance, self.width, self.height, self.registry,
                                self.skies, max_canvas)
        self.runtime = get_runtime(device)
        self.display = Display(self.runtime)
        keep_freed_memory()             # frame after frame: no page faults on the stages' temporaries
        self.history: dict[str, deque] = {}
        self._geometry, self._raster, self._shadows = _Kept(), _Kept(), _Kept()
        self._gbuffer, self._shader, self._faces = _Kept(), _Kept(), _Kept()
        # Orbit frames through the frame pipeline's G-buffer stage: the host rasterizer stops after the
        # triangle setup and the device makes the visibility buffer and the G-buffer where verified
        # (clshade.device.visibility; build_gbuffer's planes, bit for bit).
        self.device_gbuffer = device_gbuffer
        #: Why the device path was turned off (its first frame differed from the host's, or it
        #: failed to build), else None.
        self.device_gbuffer_off: str | None = None
        self._planes = PlanePool()      # the G-buffers' planes, their memory used again
        self._pool_size: tuple[int, int] | None = None      # the (supersampled) frame size of its blocks
        self.last: dict[str, object] = {}
        self._parsed: tuple[dict, Scene] | None = None     # the last document parsed and its scene
        self._preparing = threading.Lock()

    # ------------------------------------------------------------ what the page starts from

    def initial_controls(self) -> dict:
        s = self.base_scene
        other = "phong" if s.model != "phong" else "ggx_correlated"
        return dict(azimuth=0.0, elevation=self.orbit.elevation, distance=self.orbit.distance, model_a=self.model,
                    model_b=other, split=False, diff=False, exposure=s.exposure, tonemap=s.tonemap,
                    samples=s.samples, specular_aa=s.specular_aa, materials={}, lights={},
                    environment=self.initial_sky())

    def initial_sky(self) -> dict:
        """The environment controls of the scene as written (sky None: the scene's own map or colour)."""
        spec = self.base_scene.environment or env.EnvironmentSpec(uniform=(1.0, 1.0, 1.0))
        return dict(sky=None if self.base_scene.environment is not None else SKY_NONE, diffuse=spec.diffuse,
                    specular=spec.specular, samples=spec.samples, rotation=spec.rotation, intensity=spec.intensity)

    def canvas_size(self, controls: Controls) -> tuple[int, int]:
        """The frame size of a state: the page's canvas (capped when it was checked), else the session's."""
        if controls.width is None or controls.height is None:
            return self.width, self.height
        return controls.width, controls.height

    def hello(self) -> dict:
        """The registry, the scene's editable values and the starting controls, for the page."""
        s = self.base_scene
        return dict(
            type="hello", scene=self.path.name, width=self.width, height=self.height,
            presets=[dict(id=k, name=m.label, diffuse=m.diffuse, specular=m.specular)
                     for k, m in zip(_preset_ids(), presets())],
            lobes=[dict(id=l.id, name=l.name, kind=l.kind, params=[dict(name=p.name, min=p.low, max=p.high,
                                                                        default=p.default, text=p.description)
                                                                   for p in l.params]) for l in self.registry.lobes.values()],
            params={k: dict(min=p.low, max=p.high, default=p.default, kind=p.kind, text=p.description)
                    for k, p in self.limits.params.items()},
            surface=[p.name for p in SURFACE_PARAMS],
            materials={name: _material_values(s.materials[name]) for name in self.limits.materials},
            lights=[dict(kind=l.kind, direction=None if l.direction is None else [float(x) for x in l.direction])
                    for l in s.lights],
            distance=list(self.limits.distance), controls=self.initial_controls(),
            fixed_size=self.fixed_size, max_canvas=list(self.limits.max_canvas),
            skies=list(self.skies), scene_sky=None if s.environment is None else s.environment.describe(),
            rungs=dict(diffuse=list(env.DIFFUSE_RUNGS), specular=list(env.SPECULAR_RUNGS), max_samples=env.MAX_SAMPLES),
            ramp=np.round(false_colour(np.linspace(0.0, 1.0, RAMP_STEPS)) * 255).astype(int).tolist(),
            orbit=dict(east=self.orbit.east.tolist(), north=self.orbit.north.tolist(), up=self.orbit.up.tolist()))

    def scene(self, controls: Controls) -> tuple[Scene, dict]:
        """The scene the controls describe, through the scene parser (its checks and messages)."""
        position = self.orbit.position(controls.azimuth, controls.elevation, controls.distance)
        doc = applied(self.base_doc, controls, position, *self.canvas_size(controls))
        # The tables as tomllib reads back dumps(doc) (tests/view/test_view.py: the round trip is exact).
        last = self._parsed
        if last is not None and _same_but_camera(last[0], doc):     # orbit, zoom: only the camera is parsed
            scene = dataclasses.replace(last[1], camera=camera_from_data(doc, self.path))
        else:
            scene = scene_from_data(doc, self.path, self.registry)
        self._parsed = (doc, scene)
        return scene, doc

    # ------------------------------------------------------------ the stages, kept

    def _stage(self, kept: _Kept, key, make, timings: Timings, name: str):
        if kept.key != key or kept.value is None:
            with timings.stage(name):
                kept.value = make()
            kept.key = key
        return kept.value

    def prepare(self, controls: Controls) -> Prepared:
        """The raster stage of a frame (scene, geometry, rasterize): the first half of render(),
        which the server runs for the next state while the previous one is still being shaded
        (it touches only the scene, geometry and raster stages; finish() only the others)."""
        with self._preparing:               # one prepare at a time, from whichever thread
            timings = Timings()
            with timings.stage("scene"):
                scene, _ = self.scene(controls)
            geometry = self._stage(self._geometry, _geometry_key(scene), lambda: build_geometry(scene), timings,
                                   "geometry")
            camera = supersampled(scene.camera, scene.samples)
            raster_key = (id(geometry), tuple(camera.position), camera.width, camera.height)
            fragments = self._stage(self._raster, raster_key, lambda: self._rasterize(geometry, camera), timings,
                                    "rasterize")
            return Prepared(controls, scene, geometry, self._geometry.key, camera, fragments, timings)

    def frame_state(self, p: Prepared):
        """(shadows, gbuffer, shader) for a prepared state."""
        scene, geometry, camera, timings = p.scene, p.geometry, p.camera, p.timings
        shadows = None
        if scene.shadow_lights:
            shadows = self._stage(self._shadows, (id(geometry), _lights_key(scene), scene.shadow_map_size,
                                                  scene.shadow_pcf), lambda: build_shadow_maps(scene, geometry),
                                  timings, "shadow maps")
        gbuffer = self._gbuffer_for(scene, geometry, p.geometry_key, p.fragments, camera, timings)
        shader = self._shader_for(scene, gbuffer, camera, shadows, timings)
        return shadows, gbuffer, shader

    def _rasterize(self, geometry, camera) -> Fragments | ViewSetup:
        """The frame pipeline's raster stage (clshade.pipeline.GBufferStage): the triangle setup
        where the device makes the rest of the raster and the G-buffer (doubles and 64-bit atomics,
        textures it can sample, triangles its keys number, its check passed), else the fragments."""
        return self._frame_stage(geometry).raster(camera)

    def _frame_stage(self, geometry) -> GBufferStage:
        """The frame pipeline's raster and G-buffer stages of `geometry` (its raster mesh, device
        tables and the path's check made once per geometry)."""
        kept = self._geometry.extra
        if kept.get("stage_of") is not geometry:
            kept["stage"] = GBufferStage(geometry, self.runtime, "auto" if self.device_gbuffer else "host")
            kept["stage_of"] = geometry
        return kept["stage"]

    def _mesh_of(self, geometry) -> RasterMesh:
        """The RasterMesh of `geometry` (its checks and face planes made once per geometry)."""
        return self._frame_stage(geometry).mesh

    def _shader_for(self, scene: Scene, gbuffer: GBuffer, camera, shadows, timings: Timings) -> Shader:
        """The kept Shader (its device tables and bound kernels) rebound to a new G-buffer
        (Shader.rebind: no kernel built or created); a new Shader when the lights, the shadow
        maps, background, ambient, the sample count, the frame size or the sky's data changed (the
        rungs are kernel variants, chosen at dispatch; the sky's sample count a kernel argument,
        set again by a rebind)."""
        kept = self._shader
        key = (_lights_key(scene), id(shadows), tuple(scene.background), tuple(scene.ambient), scene.samples,
               gbuffer.width, gbuffer.height, _sky_data_key(scene.environment))
        if kept.key != key or kept.value is None:
            with timings.stage("upload"):
                kept.value = Shader(self.runtime, gbuffer, scene, camera, shadows)
            kept.key = key
        elif (kept.value.gb is not gbuffer or kept.extra.get("camera") != tuple(camera.position)
              or kept.extra.get("sky") != scene.environment):
            with timings.stage("bind"):
                kept.value.rebind(gbuffer, scene, camera)
        kept.extra["camera"] = tuple(camera.position)
        kept.extra["sky"] = scene.environment
        return kept.value

    def _gbuffer_for(self, scene: Scene, geometry, geometry_key, fragments, camera, timings: Timings) -> GBuffer:
        """The kept G-buffer when only table values changed (new table), patched planes when a
        per-pixel material value changed in an untextured scene, else built from the kept raster."""
        kept = self._gbuffer
        raster = fragments                  # the prepared raster this G-buffer is kept for
        values = _channel_values(scene)
        table = material_table(scene)
        same_raster = kept.extra.get("fragments") is fragments
        if same_raster and np.array_equal(kept.extra["table"], table) and np.array_equal(kept.extra["values"], values):
            return kept.value
        groups = kept.extra.get("groups") if same_raster else None
        cover = kept.extra.get("cover") if same_raster else None     # DeviceGBuffer.build's (visibility)
        if same_raster and geometry.face_texture is None and kept.extra["values"].shape == values.shape:
            with timings.stage("g-buffer patch"):
                if groups is None:
                    pixels = np.flatnonzero(kept.extra["cover"]) if isinstance(fragments, ViewSetup) \
                        else fragments.pixels
                    groups = material_pixels(kept.value, pixels, len(values))
                gbuffer = patched_gbuffer(kept.value, groups, kept.extra["values"], values, table, self._planes)
        else:
            mats = list(scene.materials.values())
            faces = self._stage(self._faces, (geometry_key, _face_key(mats)), lambda: face_planes(geometry, mats),
                                timings, "face tables")
            stage = self._frame_stage(geometry)
            gbuffer, host, cover = stage.build(scene, camera, fragments, timings, faces, table, self._planes)
            if isinstance(fragments, ViewSetup) and host is not None:     # the device path was just turned off
                cover = np.zeros(camera.width * camera.height, np.uint8)
                cover[host.pixels] = 1
                self.device_gbuffer, self.device_gbuffer_off = False, stage.path.reason
                note("viewer", f"the device's visibility buffer is off on {self.runtime.info.description}, the "
                               f"host rasterizes: {stage.path.reason}")
        kept.value, kept.extra = gbuffer, dict(fragments=raster, table=table, values=values, groups=groups,
                                               cover=cover)
        return gbuffer

    # ------------------------------------------------------------ frames

    def render(self, controls: Controls) -> ViewFrame:
        return self.finish(self.prepare(controls))

    def finish(self, p: Prepared, copy: bool = True) -> ViewFrame:
        """The rest of a frame after prepare(): G-buffer, shading, display transform, read back.
        `copy=False`: the views are the display's outputs read in place where they live in host
        memory (Display.read): valid until the next frame (the server packs each frame before
        the next one renders)."""
        controls, scene, geometry, camera, timings = p.controls, p.scene, p.geometry, p.camera, p.timings
        model_a, model_b = controls.models(self.registry)
        self._resized(camera.width, camera.height)
        shadows, gbuffer, shader = self.frame_state(p)
        # Material values read at run time: a slider moves data, never builds a program (Features).
        features = dataclasses.replace(scene_features(scene, geometry=geometry), runtime_material=True)
        shown = {"a": model_a}
        if controls.split or controls.diff:
            shown["b"] = model_b
        views: dict[str, np.ndarray] = {}
        radiance = shader.resolver.out if shader.resolver is not None else shader.out
        width, height = scene.camera.width, scene.camera.height
        labels = {view: cost_label(model.id, scene.environment) for view, model in shown.items()}
        for view, model in shown.items():
            with timings.stage("variant"):          # the kernel for (model, features): built once, then looked up
                dispatch = shader.prepare(model, features)
            with timings.stage("shade"):
                device_ms, host_ms = timed_dispatch(shader, dispatch)
            self.history.setdefault(labels[view], deque(maxlen=HISTORY)).append((device_ms, host_ms))
            with timings.stage("display"):
                event, out = self.display.enqueue(radiance, width * height, scene.tonemap, scene.exposure,
                                                  slot=view)
                event.wait()
            with timings.stage("read back"):
                views[view] = self.display.read(out, height, width, copy)
        scale = None
        if controls.diff:
            with timings.stage("difference"):
                views["diff"], scale = difference_rgba(views["a"], views["b"])
        self.last = dict(scene=scene, gbuffer=gbuffer, shader=shader, camera=camera, shadows=shadows,
                         features=features, models=shown)
        stats = {}
        for label in labels.values():
            times = np.array(self.history[label])
            stats[label] = frame_stats(times[:, 0], times[:, 1]) | dict(frames=len(times))
        return ViewFrame(width, height, views, timings, stats, {k: m.id for k, m in shown.items()}, scale,
                         reshade_only=not any(s in timings for s in ("rasterize", "g-buffer", DEVICE_GBUFFER_STAGE)),
                         costs=labels, environment=rung_info(scene, features, model_a), ladder=self.ladder())

    def ladder(self) -> dict[str, float]:
        """Mean device ms per frame of every model and rung combination shaded so far (its recent frames)."""
        return {label: float(np.mean([t[0] for t in times])) for label, times in self.history.items() if times}

    def _resized(self, width: int, height: int) -> None:
        """A new frame size (the page's canvas followed its window): the plane pool's blocks of the
        old size are let go (the pool keeps blocks of the sizes it hands out)."""
        if self._pool_size != (width, height):
            self._planes, self._pool_size = PlanePool(), (width, height)

    def oracle(self, controls: Controls) -> dict:
        """For the current view, per shown model: the error against the float64 frame oracle
        (as `clshade bench` measures it) and the raw radiance's NaN / Inf / negative counts
        before any clamp (as `clshade check stability` counts them)."""
        self.render(controls)
        last = self.last
        gbuffer, shader, scene, camera = last["gbuffer"], last["shader"], last["scene"], last["camera"]
        features = last["features"]
        idx = compared_pixels(gbuffer, camera)
        visibility = (reference.visibility(gbuffer, scene, last["shadows"], camera) if features.shadows else None)
        covered = gbuffer.coverage.ravel()
        out = dict(type="oracle", covered_samples=int(covered.sum()), grazing_samples=grazing_pixels(gbuffer, camera),
                   nonfinite_inputs=int(gbuffer.nonfinite_pixels), models={})
        for view, model in last["models"].items():
            shader.render(model, features)
            L = reference.radiance(gbuffer, scene, model, visibility=visibility, camera=camera)
            worst, mean = relative_error(shader.read_samples(), idx, L.reshape(-1, 3)[idx])
            shader.render(model, dataclasses.replace(features, raw_radiance=True))
            raw = shader.read_samples()[..., :3].reshape(-1, 3)[covered]
            out["models"][view] = dict(model=model.id, max_rel_error=worst, mean_rel_error=mean,
                                       nan=int(np.isnan(raw).sum()), inf=int(np.isinf(raw).sum()),
                                       negative=int((raw < 0).sum()))
        return out

    def sky_error_job(self, controls: Controls) -> SkyErrorJob:
        """The sky-error button's job for model A of the current view, at one sample per pixel (the
        truth is of the pixels' centres): the frame shaded and its oracle pixels copied here, on the
        render thread; SkyErrorJob.steps integrates the truth off it."""
        controls = dataclasses.replace(controls, samples=1)
        self.render(controls)
        last = self.last
        scene, gbuffer, camera, shader = last["scene"], last["gbuffer"], last["camera"], last["shader"]
        if scene.environment is None:
            raise ClshadeError("sky error: the view has no environment (pick a sky)")
        model = last["models"]["a"]
        shader.render(model, last["features"])
        image = np.array(shader.read(), np.float64)
        px = environment_oracle.oracle_pixels(gbuffer, camera, self.sky_error_pixels)
        occlusion = np.ones(len(px.index))
        if "occlusion" in gbuffer.channels:
            occlusion = np.clip(gbuffer.channels["occlusion"][px.index].astype(np.float64), 0.0, 1.0)
        rest = reference.radiance(gbuffer, scene, model, camera=camera, shadows=last["shadows"])
        rest = rest.reshape(-1, 3)[px.index]
        return SkyErrorJob(cost_label(model.id, scene.environment), model, px,
                           env.prepare_spec(scene.environment, scene.path), occlusion, rest, image)

    # ------------------------------------------------------------ save

    def save(self, controls: Controls, name: str) -> dict:
        """Write NAME.toml (the current view as a scene), NAME.png and NAME.exr of model A (and
        NAME_b.png of model B when the split shows it) into the output folder; `clshade render
        NAME.toml -o NAME.png` writes the same pixels."""
        if not isinstance(name, str) or not SAVE_NAME.fullmatch(name):
            raise ClshadeError(f"save name {str(name)[:70]!r}: use 1 to 64 letters, digits, '_', '-' or '.', "
                               f"starting with a letter or digit")
        scene, doc = self.scene(controls)
        files = {suffix: self.out_dir / f"{name}{suffix}" for suffix in (".toml", ".png", ".exr")}
        protected = [p.resolve() for p in scene.inputs()]
        for path in files.values():
            if path.resolve() in protected:
                raise ClshadeError(f"{path}: refusing to overwrite an input of the scene")
        for suffix in (".png", ".exr"):
            check_output_path(files[suffix], protected)
        text = dumps(relocated(doc, self.path.parent, self.out_dir))
        parse_scene(text, files[".toml"], self.registry)     # what `clshade render` will read: it must load
        self.render(controls)
        shader, last = self.last["shader"], self.last
        commands = []
        for view, model in last["models"].items():
            shader.render(model, last["features"])
            image = shader.read()
            suffix = "" if view == "a" else "_b"
            png = self.out_dir / f"{name}{suffix}.png"
            write_encoded(png, to_display(image, scene.tonemap, scene.exposure), protected)
            model_flag = "" if view == "a" else f" -m '{controls.model_b}'"
            commands.append(f"clshade render {files['.toml'].name}{model_flag} -o {png.name}")
            if view == "a":
                write_encoded(files[".exr"], image.astype(np.float32), protected)
                commands.append(f"clshade render {files['.toml'].name} -o {files['.exr'].name}")
        _write_text(files[".toml"], text)
        return dict(type="saved", folder=str(self.out_dir),
                    files=sorted(p.name for p in self.out_dir.glob(f"{name}*") if p.name.startswith(name + ".")
                                 or p.name.startswith(name + "_b.")),
                    commands=commands)


def _preset_ids() -> list[str]:
    return list(PRESETS)


def _material_values(m) -> dict[str, float]:
    """The lobe parameters as the material gives them (derived shininess and kd included)."""
    constants = m.constants()
    return dict(base_color=[float(c) for c in m.base_color], roughness=m.roughness, metallic=m.metallic,
                shininess=constants["shininess"], kd=constants["kd"], ks=constants["ks"], ka=constants["ka"])


def difference_rgba(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """|A − B| of the displayed values, false colour (clshade.compare.difference), as RGBA8, and its scale."""
    colour, scale = difference(a[..., :3].astype(np.float32) / 255.0, b[..., :3].astype(np.float32) / 255.0)
    rgba = np.empty(a.shape, np.uint8)
    rgba[..., :3] = np.round(colour * 255.0)
    rgba[..., 3] = 255
    return rgba, scale


def _write_text(path: Path, text: str) -> None:
    """Write atomically (a temporary file in the folder, then a rename)."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
