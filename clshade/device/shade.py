"""The shading pass: upload a G-buffer once, then dispatch kernel variants on it.

`Shader` owns the device copies of the G-buffer channels a run needs, the
light and material tables, and the output buffer; `dispatch()` enqueues one
variant and returns its OpenCL event (the benchmark reads profiling times
from it), `render()` also reads the image back.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from clshade.device import counts
from clshade.render.gbuffer import GBuffer, uniform_channels
from clshade.render.meshes import Geometry
from clshade.models.model import Model
from clshade.device.resolve import Resolver
from clshade.device.runtime import Runtime
from clshade.render.arrays import padded
from clshade.render.scene import Camera, Light, Scene
from clshade.render.shadows import ShadowMaps
from clshade.device.variants import EnvironmentFeatures, Features, Variant, environment_rungs, split_family
from clshade.render import prefilter
from clshade.render.environment import SPLIT_SUM_RUNGS, Environment, prepare_spec

LIGHT_ORDER = ("directional", "point", "spot")
LIGHT_KIND = {"directional": 0, "point": 1, "spot": 2}      # LIGHT_* in shade.cl (general kernel)


def scene_features(scene: Scene, half_gbuffer: bool = False, fast_math: bool = False,
                   geometry: Geometry | None = None, general: bool = False) -> Features:
    """The feature set a scene calls for (textures need the geometry: glTF materials are
    known only once the meshes are loaded). `general` asks for the general kernel with
    these effects as its runtime switches."""
    count = {k: sum(1 for l in scene.lights if l.kind == k) for k in LIGHT_ORDER}
    shadows = bool(scene.shadow_lights)
    ambient = any(a > 0 for a in scene.ambient)
    sky = None
    if scene.environment is not None:
        spec = scene.environment
        sky = EnvironmentFeatures(spec.diffuse, spec.specular, not prepare_spec(spec, scene.path).constant,
                                  scene.environment_background)
    return Features(num_dir=count["directional"], num_point=count["point"], num_spot=count["spot"],
                    ambient=ambient, shadows=shadows,
                    shadow_pcf=scene.shadow_pcf if shadows else 1,
                    textures=bool(geometry is not None and geometry.has_textures),
                    emissive=bool(geometry is not None and geometry.has_emission),
                    occlusion=bool((ambient or sky is not None) and geometry is not None and geometry.has_occlusion),
                    half_gbuffer=half_gbuffer, fast_math=fast_math, general=general,
                    specular_aa=scene.specular_aa, environment=sky,
                    uniform=uniform_channels(geometry, list(scene.materials.values())) if geometry is not None else ())


def _slot(slots: tuple[int, ...] | None, index: int) -> float:
    return float(slots[index]) if slots is not None else -1.0


def pack_lights(lights: tuple[Light, ...] | list[Light], slots: tuple[int, ...] | None = None) -> np.ndarray:
    """Lights as float4 rows in the layout of shade.cl (directional, point, spot);
    `slots` gives each light's shadow map index (−1 = none)."""
    rows: list[list[float]] = []
    for kind in LIGHT_ORDER:
        for index, light in ((i, l) for i, l in enumerate(lights) if l.kind == kind):
            color = [float(c) for c in light.color]
            if kind == "directional":
                rows += [[*light.direction, 0.0], [*color, _slot(slots, index)]]
            elif kind == "point":
                rows += [[*light.position, 0.0], [*color, 0.0]]
            else:
                cos_outer = math.cos(math.radians(light.outer_angle))
                cos_inner = math.cos(math.radians(light.inner_angle))
                rows += [[*light.position, cos_outer], [*color, cos_inner], [*light.direction, _slot(slots, index)]]
    return np.array(rows or [[0.0] * 4], np.float32)


def pack_lights_general(lights: tuple[Light, ...] | list[Light], slots: tuple[int, ...] | None = None) -> np.ndarray:
    """Lights for the general kernel: 4 float4 per light with its kind (shade.cl), in
    the order of the specialised layout so that sums run in the same order."""
    rows: list[list[float]] = []
    for kind in LIGHT_ORDER:
        for index, light in ((i, l) for i, l in enumerate(lights) if l.kind == kind):
            where = light.direction if kind == "directional" else light.position
            axis = light.direction if kind == "spot" else np.zeros(3)
            cos_outer = math.cos(math.radians(light.outer_angle)) if kind == "spot" else 0.0
            cos_inner = math.cos(math.radians(light.inner_angle)) if kind == "spot" else 0.0
            rows += [[*where, LIGHT_KIND[kind]], [*(float(c) for c in light.color), _slot(slots, index)],
                     [*axis, cos_outer], [cos_inner, 0.0, 0.0, 0.0]]
    return np.array(rows or [[0.0] * 4], np.float32)


def camera_args(camera: Camera) -> list[np.ndarray]:
    """cam_pos, cam_fwd and the pre-scaled cam_right / cam_up of shade.cl. For a band of a
    taller frame (Camera.band) the kernel's band-relative sy maps to the frame's centre + half·sy,
    folded into cam_fwd and cam_up. A camera `shift` (sub-pixel jitter) moves every ray by the
    same image-plane offset, so it goes into cam_fwd too (the ray's component along the view
    axis stays 1)."""
    fwd, right, up = camera.basis()
    t = math.tan(math.radians(camera.fov) / 2)
    centre, half = camera.band_ndc()
    f4 = lambda v: np.array([*v, 0.0], np.float32)  # noqa: E731
    cam_fwd = fwd + up * t * centre
    if camera.shift != (0.0, 0.0):
        cam_fwd = cam_fwd + (2.0 * camera.shift[0] / camera.width) * (right * t * camera.aspect) \
            - (2.0 * camera.shift[1] / camera.full_height) * (up * t)
    return [f4(camera.position), f4(cam_fwd), f4(right * t * camera.aspect), f4(up * t * half)]


@dataclass
class Dispatch:
    """A built variant bound to its arguments, ready to enqueue."""
    variant: Variant
    kernel: object
    global_size: int
    local_size: int           # the work-group size of its build (the model family's choice: Runtime.for_model)
    entry: str = "shade"


class Shader:
    """Device-side state for shading one G-buffer with one or more variants."""

    def __init__(self, runtime: Runtime, gbuffer: GBuffer, scene: Scene, camera: Camera | None = None,
                 shadows: ShadowMaps | None = None) -> None:
        """With `scene.samples` N > 1 the G-buffer is the N·W × N·H supersampled raster
        (clshade/pipeline.py): every enqueue shades it and resolves N×N blocks on the
        device, and read() returns the W × H image."""
        self.rt, self.gb, self.scene = runtime, gbuffer, scene
        self.camera = camera or scene.camera
        self.shadows = shadows
        self._buffers: dict[tuple[str, bool], object] = {}
        slots = shadows.light_slot if shadows is not None else None
        self.lights = runtime.to_device(pack_lights(scene.lights, slots))
        self.lights_general = runtime.to_device(pack_lights_general(scene.lights, slots))
        if shadows is not None:
            self.shadow_maps = runtime.to_device(shadows.maps.reshape(-1))
            self.shadow_params = runtime.to_device(shadows.params.reshape(-1, 4))
        else:   # the general kernel binds these even with its shadow switch off
            self.shadow_maps = runtime.to_device(np.zeros(1, np.float32))
            self.shadow_params = runtime.to_device(np.zeros((1, 4), np.float32))
        self.materials = runtime.to_device(self._table(gbuffer))
        #: The shaded samples (float4 each); on a CPU device `_out_host` is their memory (read_samples(copy=False)).
        self.out, self._out_host = runtime.host_output(padded(gbuffer.pixels) * 4)
        self.background = np.array([*scene.background, 0.0], np.float32)
        self.ambient = np.array([*scene.ambient, 0.0], np.float32)
        self._dispatches: dict[tuple, Dispatch] = {}
        self._unbound: set[tuple] = set()      # dispatches whose arguments name a G-buffer before rebind()
        self.term_counts = counts.zeros(runtime)   # the counting build's counters (Features.count_terms)
        self.environment: Environment | None = None
        if scene.environment is not None:
            self.environment = prepare_spec(scene.environment, scene.path)
            self.env_params = runtime.to_device(self.environment.params())
            self.env_map = runtime.to_device(self.environment.texels())
            self.env_cdf = runtime.to_device(self.environment.cdf())
        self._split_tables: dict[tuple[str, str], object] = {}   # the split sum's, uploaded when first asked
        self.samples = scene.samples
        self.resolver = None
        if self.samples > 1:
            n = self.samples
            if gbuffer.width % n or gbuffer.height % n:
                raise ValueError(f"a {gbuffer.width}x{gbuffer.height} G-buffer is not {n}x{n} samples per pixel")
            self.resolver = Resolver(runtime, gbuffer.width // n, gbuffer.height // n, n, self.out)

    def buffer(self, name: str, half: bool = False):
        """The device copy of one G-buffer channel (uploaded once): its planes (x plane,
        y plane, z plane for three components; gbuffer.h), zero-padded to a multiple of
        the kernels' widest SIMD width (padding pixels have depth 0: empty)."""
        key = (name, half and name in ("normal", "base"))
        if key not in self._buffers:
            planes = self.gb.plane(name)
            if key[1]:
                self._buffers[key] = self.rt.to_device(planes.astype(np.float16).reshape(-1))
            else:   # the G-buffer's own planes (aligned, never changed once built): shared, not copied
                self._buffers[key] = self.rt.share(planes.reshape(-1))
        return self._buffers[key]

    def variant(self, model: Model, features: Features) -> Variant:
        return Variant.build(model, features, self.gb.materials, self.gb.unit_normals, "tangent" in self.gb.channels)

    def prepare(self, model: Model, features: Features, entry: str = "shade") -> Dispatch:
        """Build (once) and bind the kernel for (model, features); `entry` is shade or copy."""
        variant = self.variant(model, features)
        rt = self.rt.for_model(model)                # the build choice of the model's family
        simd = 1 if features.count_terms else rt.simd   # count.h counts one pixel per work-item
        key = (variant.key, entry, rt.info.spec, simd, rt.options, rt.local_size)
        if key in self._dispatches:
            dispatch = self._dispatches[key]
            if key in self._unbound:        # prepared before a rebind(): its arguments set again
                dispatch.kernel.set_args(*self._arguments(dispatch))
                self._unbound.discard(key)
            return dispatch
        built = rt.kernel(variant.source(f"{entry}.cl", simd), entry, variant.options(),
                          label=f"{model.id} ({entry})")
        # The runtime shares one kernel object per program; arguments are state of the
        # kernel object, so every dispatch binds its own (another Shader, or the same
        # program with other runtime switches, must not rebind ours).
        cl = self.rt.cl
        kernel = cl.Kernel(built.get_info(cl.kernel_info.PROGRAM), entry)
        dispatch = Dispatch(variant, kernel, rt.global_size((self.gb.pixels + simd - 1) // simd), rt.local_size,
                            entry)
        kernel.set_args(*self._arguments(dispatch))
        self._dispatches[key] = dispatch
        return dispatch

    def _arguments(self, dispatch: Dispatch) -> list[object]:
        """The kernel arguments of a dispatch on this Shader's G-buffer, camera and tables."""
        variant, entry = dispatch.variant, dispatch.entry
        features = variant.features
        half = features.half_gbuffer
        n = self.gb.pixels
        args: list[object] = [np.uint32(n), np.uint32(padded(n))]
        if entry == "shade":
            args += [np.uint32(self.gb.width), np.float32(2.0 / self.gb.width), np.float32(2.0 / self.gb.height)]
            args += camera_args(self.camera)
        args += [self.buffer(c, half) for c in variant.channels]
        if entry == "shade":
            if variant.has_material:
                args.append(self.materials)
            if features.shadows and self.shadows is None:
                raise ValueError("a variant with shadows needs the shadow maps (Shader(..., shadows=...))")
            if features.general:
                args += [np.uint32(len(self.scene.lights)), self.lights_general,
                         np.uint32(features.ambient), self.ambient,
                         np.uint32(features.shadows), np.int32(features.shadow_pcf // 2),
                         np.uint32(self.shadows.size if self.shadows else 0), self.shadow_maps, self.shadow_params]
            else:
                if features.num_lights:
                    args.append(self.lights)
                if features.shadows:
                    args += [np.uint32(self.shadows.size), self.shadow_maps, self.shadow_params]
                if features.ambient:
                    args.append(self.ambient)
            if features.environment is not None:
                args += self._environment_arguments(variant)
        # Both entries write the background where no pixel is covered (copy.cl says why).
        args += [self.background, self.out]
        if features.count_terms:
            args.append(self.term_counts)
        return args

    def _environment_arguments(self, variant: Variant) -> list[object]:
        """The sky's arguments of shade.cl (kernels/environment.h): its tables, the sample count N of
        the sampled rung and the index of this G-buffer's first pixel in the whole frame (a band's
        rows start further down), so that each pixel's samples are the same however the frame is cut;
        for a split-sum rung, the model's mip chain and DFG table."""
        if self.environment is None:
            raise ValueError("a variant with an environment needs a scene with one")
        first = self.camera.crop[0] * self.gb.width if self.camera.crop else 0
        args = [self.env_params, self.env_map, self.env_cdf, np.uint32(self.scene.environment.samples),
                np.uint32(first)]
        _, specular = environment_rungs(variant.model, variant.features.environment)
        if specular in SPLIT_SUM_RUNGS:
            args += self._split_sum_tables(variant.model, specular)
        return args

    def _split_sum_tables(self, model, rung: str) -> list[object]:
        """The device copies of the model's prefiltered mip chain (its level table, its texels) and
        DFG table (clshade/render/prefilter.py), uploaded once per lobe family and lobe."""
        fam, lobe = split_family(model, rung), model.specular_lobe.id
        if ("chain", fam) not in self._split_tables:
            chain = prefilter.mip_chain(self.environment.radiance, fam)
            self._split_tables["chain", fam] = (self.rt.to_device(chain.table().reshape(-1)),
                                                self.rt.to_device(chain.texels()))
        if ("dfg", lobe) not in self._split_tables:
            self._split_tables["dfg", lobe] = self.rt.to_device(prefilter.dfg_words(lobe))
        return [*self._split_tables["chain", fam], self._split_tables["dfg", lobe]]

    def rebind(self, gbuffer: GBuffer, scene: Scene, camera: Camera | None = None) -> None:
        """Shade another G-buffer of the same size with the same lights, shadow maps,
        background, ambient and sky data (the live viewer's next frame): the planes that changed
        are shared again, the material table uploaded again when it changed, the sky's params
        written again when only its rotation changed, and every prepared dispatch gets its
        arguments set again when prepare() next returns it. No kernel is built or created; a
        variant the new G-buffer calls for (another baked table) is built by prepare() as usual."""
        if (gbuffer.width, gbuffer.height) != (self.gb.width, self.gb.height):
            raise ValueError(f"rebind: a {gbuffer.width}x{gbuffer.height} G-buffer on a "
                             f"{self.gb.width}x{self.gb.height} Shader")
        if self.environment is not None and scene.environment not in (None, self.scene.environment):
            turned = prepare_spec(scene.environment, scene.path)
            if turned.radiance is not self.environment.radiance and \
                    not np.array_equal(turned.radiance, self.environment.radiance):
                raise ValueError("rebind: another sky's data (map, colour or intensity): a new Shader uploads it")
            if turned.rotation != self.environment.rotation:
                self.environment = turned
                self.rt.cl.enqueue_copy(self.rt.queue, self.env_params, turned.params())
        old, self.gb, self.scene, self.camera = self.gb, gbuffer, scene, camera or scene.camera
        self._buffers = {key: buffer for key, buffer in self._buffers.items()
                         if gbuffer.shares_plane(old, key[0])}
        if not np.array_equal(old.materials, gbuffer.materials):
            self.materials = self.rt.to_device(self._table(gbuffer))
        self._unbound = set(self._dispatches)

    @staticmethod
    def _table(gbuffer: GBuffer) -> np.ndarray:
        table = gbuffer.materials if len(gbuffer.materials) else np.zeros((1, 4, 4), np.float32)
        return table.astype(np.float32)

    def enqueue(self, dispatch: Dispatch):
        """Enqueue one frame; returns the OpenCL event (shading and resolve as one
        event when supersampling)."""
        event = self.rt.cl.enqueue_nd_range_kernel(self.rt.queue, dispatch.kernel, (dispatch.global_size,),
                                                   (dispatch.local_size,))
        return self.resolver.enqueue(event) if self.resolver is not None else event

    def read(self, copy: bool = True) -> np.ndarray:
        """The last output as an (H, W, 4) float32 image (RGB radiance, coverage; with
        supersampling the resolved pixels, alpha the covered fraction). `copy=False`: where the
        output lives in host memory (CPU devices, no supersampling) the image is that memory itself,
        read in place: valid until the next dispatch writes it (a stream of frames that consumes
        each image before the next); elsewhere a copy as usual."""
        if self.resolver is not None:
            return self.resolver.read()
        return self.read_samples(copy)

    def read_samples(self, copy: bool = True) -> np.ndarray:
        """The last shaded G-buffer (one value per sample) as (H, W, 4) float32 (`copy`: see read)."""
        shape = (self.gb.height, self.gb.width, 4)
        if not copy and self._out_host is not None:
            self.rt.read_in_place((self.out, self._out_host))
            return self._out_host[:shape[0] * shape[1] * 4].reshape(shape)
        image = np.empty(shape, np.float32)
        self.rt.cl.enqueue_copy(self.rt.queue, image, self.out)
        return image

    def render(self, model: Model, features: Features) -> np.ndarray:
        dispatch = self.prepare(model, features)
        self.enqueue(dispatch).wait()
        return self.read()

    def render_counted(self, model: Model, features: Features) -> tuple[np.ndarray, dict[str, dict[str, int]]]:
        """render() in the counting build (kernels/count.h), with that frame's term counters."""
        self.rt.cl.enqueue_fill_buffer(self.rt.queue, self.term_counts, np.uint32(0), 0,
                                       self.term_counts.size).wait()
        image = self.render(model, dataclasses.replace(features, count_terms=True))
        return image, counts.read(self.rt, self.term_counts)
