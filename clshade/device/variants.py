"""Kernel variants: a lighting model specialised for a scene's feature set.

The scene decides the features (light counts by kind, ambient, shadows,
textures, storage precision, math mode); the model decides which G-buffer
channels and material constants it reads. A variant carries exactly those: the
defines are written at the top of the assembled source, so code, kernel
arguments and channels of unused effects are absent from the program PoCL
compiles (shadow.h is not even assembled without shadows).

The *general kernel* (`Features.general`, -D GENERAL=1) is the opposite: one
program per model that reads every channel and takes the light list (with a
kind per light), the ambient switch and the shadow switch as runtime
arguments; a general Features keeps the scene's effects as the values of those
switches. Specialisation must never change results: every specialised variant
equals the general kernel with the same switches (tests/device/test_specialisation.py).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from clshade.models.lobe import BRDF_FILE
from clshade.models.model import NONE, Model
from clshade.errors import ClshadeError
from clshade.render import prefilter
from clshade.render.environment import LOBE_SAMPLING, SPLIT_SUM_RUNGS
from clshade.resources import kernels_dir

# The per-material constants (surface.h, MATERIAL_STRIDE float4 per material).
MATERIAL_LAYOUT = (("kd", "ks", "ka", "shininess"), ("ior", "f90", None, None),
                   ("eta", None), ("k", None))
TABLE_PARAMS = frozenset({"kd", "ks", "ka", "shininess", "ior", "f90", "eta", "k"})

FRESNEL_DEFINES = {"schlick": "FRESNEL_SCHLICK", "dielectric": "FRESNEL_DIELECTRIC",
                   "conductor": "FRESNEL_CONDUCTOR"}
WORKFLOW_DEFINES = {"metallic": "WORKFLOW_METALLIC", "kdks": "WORKFLOW_KDKS"}
# The define that carries a uniform channel's value into shade.cl (Features.uniform), by channel,
# in the kernels' argument order.
UNIFORM_DEFINES = {"roughness": "ROUGHNESS_VALUE", "metallic": "METALLIC_VALUE"}

FAST_MATH = "-cl-fast-relaxed-math"

# Entries that shade whole images (SIMD pixels per work-item, gbuffer.h I/O).
IMAGE_ENTRIES = ("shade.cl", "copy.cl")

# kernels/environment.h: a rung by name, and the specular lobe's sampling (render/environment.py).
ENV_RUNG_DEFINES = {"none": "ENV_NONE", "constant": "ENV_CONSTANT", "sh9": "ENV_SH9", "sampled": "ENV_SAMPLED",
                    "split_sum": "ENV_SPLIT_SUM", "split_sum_ms": "ENV_SPLIT_SUM_MS"}
# The split sum's normalisation of the empirical lobes' table (kernels/environment.h ENV_SPLIT_NORM).
ENV_SPLIT_NORM = {"phong": "1", "blinn_phong": "2"}
ENV_LOBE_DEFINES = {None: "ENV_LOBE_NONE", "ggx": "ENV_LOBE_GGX", "beckmann": "ENV_LOBE_BECKMANN",
                    "phong": "ENV_LOBE_PHONG", "blinn_phong": "ENV_LOBE_BLINN_PHONG"}


@dataclass(frozen=True)
class EnvironmentFeatures:
    """The sky of a frame (scenes/README.md, [environment]): the rungs it asks for, whether the
    sampled rung may draw from the map (not for a constant sky) and whether the sky is shown
    behind the scene. The sample count is a kernel argument, not a feature: N is a ladder of
    one program."""
    diffuse: str = "sh9"
    specular: str = "none"
    map_sampling: bool = True
    background: bool = False


@dataclass(frozen=True)
class Features:
    """What a scene calls for, plus the precision choices of a run."""
    num_dir: int = 0
    num_point: int = 0
    num_spot: int = 0
    ambient: bool = False
    shadows: bool = False          # shadow-map lookups (some light casts shadows)
    shadow_pcf: int = 1            # PCF kernel width (odd; 1 = one tap), compile-time
    textures: bool = False         # textures sampled into the G-buffer (no shading kernel code)
    emissive: bool = False         # emitted radiance channel, added unlit (compile-time, general kernel too)
    occlusion: bool = False        # ambient occlusion channel on the ambient term (compile-time, general too)
    half_gbuffer: bool = False
    fast_math: bool = False
    general: bool = False          # the general kernel; the fields above are its runtime switches
    raw_radiance: bool = False     # no MAX_RADIANCE clamp: NaN/Inf reach the output (stability check only)
    specular_aa: bool = False      # specular lobe widened by the normal's screen-space variance (compile-time)
    count_terms: bool = False      # the counting build (kernels/count.h): raw terms counted, one pixel per work-item
    # (channel, value) of one-component surface channels with one value over the whole scene
    # (clshade.render.gbuffer.uniform_channels): compiled in, not read per pixel (not by the general kernel)
    uniform: tuple[tuple[str, float], ...] = ()
    double: bool = False           # real = double (REAL_DOUBLE): the evaluation kernel's float64 build only
    # The material table and the roughness / metallic channels read at run time, never compiled in
    # (no MAT_M*, no uniform channels): a material edit is new data, not a new program (the live viewer)
    runtime_material: bool = False
    environment: EnvironmentFeatures | None = None   # light from the sky (kernels/environment.h), compile-time

    @property
    def num_lights(self) -> int:
        return self.num_dir + self.num_point + self.num_spot

    def describe(self) -> list[str]:
        out = []
        if self.general:
            out.append("kernel: GENERAL (runtime light loop, ambient and shadow switches, every channel read)")
        out.append(f"lights: {self.num_dir} directional, {self.num_point} point, {self.num_spot} spot")
        out.append(f"ambient: {'on' if self.ambient else 'off'}")
        out.append(f"shadows: {f'on (shadow maps, PCF {self.shadow_pcf}x{self.shadow_pcf})' if self.shadows else 'off'}")
        sampled = "on (sampled into the G-buffer, trilinear mipmaps, on the g-buffer line's path)"
        out.append(f"textures: {sampled if self.textures else 'off'}")
        out.append(f"emission: {'on (emissive channel added unlit)' if self.emissive else 'off'}")
        out.append(f"ambient occlusion: {'on (occlusion channel multiplies the ambient term)' if self.occlusion else 'off'}")
        out.append(f"G-buffer storage: {'half (normal, base colour)' if self.half_gbuffer else 'float32'}")
        out.append(f"math: {'fast-relaxed' if self.fast_math else 'precise'}")
        out.append(f"specular anti-aliasing: {'on (normal variance, kernels/specular_aa.h)' if self.specular_aa else 'off'}")
        env = self.environment
        out.append("environment: " + ("off" if env is None else
                   f"on (kernels/environment.h): diffuse {env.diffuse}, specular {env.specular}"
                   + (f" (a {prefilter.LEVELS}-level prefiltered mip chain in RGB9E5 × a {prefilter.DFG_SIZE}² DFG table"
                      + (", energy compensation" if env.specular == "split_sum_ms" else "") + ")"
                      if env.specular in SPLIT_SUM_RUNGS else "")
                   + (", sky behind the scene" if env.background else "")
                   + ("" if env.map_sampling or "sampled" not in (env.diffuse, env.specular)
                      else ", a constant sky: no map sampling")))
        if self.runtime_material:
            out.append("material: table, roughness and metallic read at run time (nothing compiled in)")
        if self.uniform and not self.general:
            out.append("uniform channels: " + ", ".join(f"{k} = {v:g}" for k, v in self.uniform)
                       + " (one value in the whole scene: compiled in, not read per pixel)")
        if self.raw_radiance:
            out.append("radiance: RAW (no MAX_RADIANCE clamp; NaN/Inf written as computed)")
        if self.count_terms:
            out.append("terms: COUNTED (kernels/count.h: NaN/Inf/negative/above-bound raw terms, SIMD 1)")
        out.append("output: exposure, tone map and sRGB encoding on the host (clshade/render/image.py)")
        return out


def _c_float(x: float) -> str:
    """A float32 literal that round-trips (9 significant digits)."""
    value = float(np.float32(x))
    text = f"{value:.9g}"
    if "e" not in text and "." not in text and "inf" not in text and "nan" not in text:
        text += ".0"
    return text + "f"


def used_table_columns(model: Model) -> np.ndarray:
    """Boolean mask (4, 4) of the material-table entries the model reads."""
    mask = np.zeros((4, 4), bool)
    uses = model.uses
    for r, names in enumerate(MATERIAL_LAYOUT):
        for c, name in enumerate(names):
            if name is None or name not in uses:
                continue
            if name in ("eta", "k"):
                mask[r, :3] = True
            else:
                mask[r, c] = True
    return mask


@dataclass(frozen=True)
class Variant:
    """One specialised program: model × features × the channels it reads."""
    model: Model
    features: Features
    channels: tuple[str, ...]
    baked_material: tuple[float, ...] | None = field(default=None)
    unit_normals: bool = False     # the G-buffer's normals are unit or zero (GBuffer.unit_normals)

    @classmethod
    def build(cls, model: Model, features: Features, material_table: np.ndarray,
              unit_normals: bool = False, tangents: bool = False) -> "Variant":
        """Choose channels: roughness/metallic when the model reads them and the scene does
        not give them one value everywhere (Features.uniform: then compiled in); the material id
        channel only when the materials differ in a constant the model reads (otherwise
        those constants are compiled in)."""
        if features.runtime_material:    # nothing compiled in: the scene's uniform values are not the program's
            features = replace(features, uniform=())
        extra = (("emissive",) if features.emissive else ()) + (("occlusion",) if features.occlusion else ())
        # The G-buffer's tangents (`tangents`: it has them) only for a lobe that reads the frame.
        extra += ("tangent",) if tangents and "tangents" in model.uses else ()
        # Half-float normals are unit only to half precision: normalised again in the kernel.
        unit = unit_normals and not features.half_gbuffer
        if features.general:
            return cls(model, features, ("depth", "normal", "base", "roughness", "metallic", *extra, "material"),
                       None, unit)
        uses = model.uses
        uniform = dict(features.uniform)
        channels = ["depth", "normal", "base"]
        channels += [name for name in UNIFORM_DEFINES if name in uses and name not in uniform]
        channels += extra         # before "material": the kernels' argument order (shade.cl, copy.cl)
        mask = used_table_columns(model)
        table = np.asarray(material_table, np.float32).reshape(-1, 4, 4)
        baked = None
        if len(table) and not features.runtime_material and np.all(table[:, mask] == table[0][mask]):
            row = table[0].copy()
            if "shininess" not in uses:
                # The exponent derived from roughness (Material.exponent), read by the empirical lobes
                # only: a roughness edit is then the same kernel, not a new build (the live viewer's
                # sliders). The other entries stay: the kernel reads some the mask leaves out (the
                # k_d + k_s workflow's F0 from ior in the ambient term).
                row[0, 3] = 0.0
            baked = tuple(float(x) for x in row.ravel())
        elif len(table):
            channels.append("material")
        else:
            baked = tuple(float(x) for x in np.zeros(16))
        return cls(model, features, tuple(channels), baked, unit)

    @property
    def has_material(self) -> bool:
        return "material" in self.channels

    @property
    def specular_aa(self) -> bool:
        """Specular anti-aliasing is compiled in: the scene asks and the model has a specular lobe."""
        return self.features.specular_aa and self.model.specular != NONE

    def defines(self) -> dict[str, str]:
        f, m = self.features, self.model
        effects = {"HAS_EMISSIVE": str(int(f.emissive)), "HAS_OCCLUSION": str(int(f.occlusion)),
                   "HAS_TANGENT": str(int("tangent" in self.channels))}
        raw = {"RAW_RADIANCE": "1"} if f.raw_radiance else {}
        if f.count_terms:
            raw["COUNT_TERMS"] = "1"
        aa = {"SPECULAR_AA": "1"} if self.specular_aa else {}
        sky = environment_defines(m, f.environment)    # compile-time in the general kernel too
        # The normals' contract is the G-buffer's, not a scene effect: the general kernel shares it.
        unit = {"UNIT_NORMALS": "1"} if self.unit_normals else {}
        if f.general:
            return {"GENERAL": "1", **effects, **aa, **sky, **unit, **geometry_defines(m), "HAS_DIFFUSE": str(int(m.diffuse != NONE)),
                    "HAS_SPECULAR": str(int(m.specular != NONE)),
                    "SPECULAR_FRESNEL": str(int(m.uses_fresnel)),
                    "FRESNEL": FRESNEL_DEFINES[m.fresnel], "WORKFLOW": WORKFLOW_DEFINES[m.workflow], **raw}
        d = {
            "NUM_DIR": str(f.num_dir), "NUM_POINT": str(f.num_point), "NUM_SPOT": str(f.num_spot),
            "HAS_AMBIENT": str(int(f.ambient)),
            "HAS_SHADOWS": str(int(f.shadows)),
            "HAS_ROUGHNESS": str(int("roughness" in self.channels)),
            "HAS_METALLIC": str(int("metallic" in self.channels)),
            "HAS_MATERIAL": str(int(self.has_material)),
            **effects,
            "HAS_DIFFUSE": str(int(m.diffuse != NONE)),
            "HAS_SPECULAR": str(int(m.specular != NONE)),
            "SPECULAR_FRESNEL": str(int(m.uses_fresnel)),
            "FRESNEL": FRESNEL_DEFINES[m.fresnel],
            "WORKFLOW": WORKFLOW_DEFINES[m.workflow],
        }
        d.update(geometry_defines(m))
        if f.double:
            d["REAL_DOUBLE"] = "1"
        for name, value in f.uniform:
            if name in m.uses:
                d[UNIFORM_DEFINES[name]] = _c_float(value)
        d.update(unit)
        if f.shadows:
            d["SHADOW_PCF"] = str(f.shadow_pcf)
        if f.half_gbuffer:
            d["HALF_GBUFFER"] = "1"
        d.update(raw)
        d.update(aa)
        d.update(sky)
        if self.baked_material is not None:
            values = np.asarray(self.baked_material, np.float32).reshape(4, 4)
            for r in range(4):
                d[f"MAT_M{r}"] = "(float4)(" + ", ".join(_c_float(x) for x in values[r]) + ")"
        return d

    def options(self) -> tuple[str, ...]:
        return (FAST_MATH,) if self.features.fast_math else ()

    def source(self, entry: str = "shade.cl", simd: int = 1) -> str:
        """The assembled program for `entry`; `simd` pixels per work-item (kernels/simd.h)
        for the image kernels shade.cl and copy.cl (eval.cl evaluates one sample each)."""
        headers: tuple[str, ...] = ()
        defines = self.defines()
        if entry in IMAGE_ENTRIES:
            defines = {"SIMD": str(simd), **defines}
            headers = ("gbuffer.h",)
            if entry == "shade.cl" and (self.features.shadows or self.features.general):
                headers += ("shadow.h",)
            if entry == "shade.cl" and self.specular_aa:
                headers += ("specular_aa.h",)
            if entry == "shade.cl" and self.features.environment is not None:
                headers += ("environment.h",)
        return assemble(self.model, defines, entry, headers=headers)

    @property
    def key(self) -> tuple:
        """What makes a variant distinct (the cache adds the device): model and its lobes' code
        (two registries may hold different lobes of one id), features, channels, baked constants,
        the normals' contract and build options."""
        return (self.model.id, tuple(lobe.code for lobe in self.model.lobes), self.features, self.channels,
                self.baked_material, self.unit_normals, self.options())


def lobe_sampling(model: Model) -> str | None:
    """The distribution the sampled rung draws for the model's specular lobe (LOBE_SAMPLING), None
    for a model without one or a lobe of the user's (cosine and map sampling only)."""
    lobe = model.specular_lobe
    return None if lobe is None or lobe.is_users else LOBE_SAMPLING.get(lobe.id)


def environment_rungs(model: Model, env: EnvironmentFeatures) -> tuple[str, str]:
    """(diffuse, specular) rungs the kernel runs: "none" for a lobe the model lacks."""
    return (env.diffuse if model.diffuse != NONE else "none", env.specular if model.specular != NONE else "none")


def environment_strategies(model: Model, env: EnvironmentFeatures) -> tuple[str, ...]:
    """The sampled rung's strategies, in kernels/environment.h's round-robin order (none without one)."""
    diffuse, specular = environment_rungs(model, env)
    if "sampled" not in (diffuse, specular):
        return ()
    lobe = lobe_sampling(model) if specular == "sampled" else None
    out = ("cosine",) if diffuse == "sampled" or lobe is None else ()
    out += (lobe,) if lobe is not None else ()
    return out + (("map",) if env.map_sampling else ())


def environment_defines(model: Model, env: EnvironmentFeatures | None) -> dict[str, str]:
    """kernels/environment.h's defines for the model under the sky `env` (none without one)."""
    if env is None:
        return {}
    diffuse, specular = environment_rungs(model, env)
    d = {"HAS_ENVIRONMENT": "1", "ENV_DIFFUSE": ENV_RUNG_DEFINES[diffuse], "ENV_SPECULAR": ENV_RUNG_DEFINES[specular]}
    strategies = environment_strategies(model, env)
    if strategies:
        d["ENV_LOBE_SAMPLING"] = ENV_LOBE_DEFINES[lobe_sampling(model) if specular == "sampled" else None]
        d["ENV_COSINE_SAMPLING"] = str(int("cosine" in strategies))
        d["ENV_MAP_SAMPLING"] = str(int("map" in strategies))
    if specular in SPLIT_SUM_RUNGS:
        d.update(split_sum_defines(model, specular))
    if env.background:
        d["ENV_BACKGROUND"] = "1"
    return d


def split_family(model: Model, rung: str) -> str:
    """The prefilter family of the model's specular lobe for a split-sum rung; refused in one line
    for a lobe without one (a user's)."""
    fam = lobe_sampling(model)
    if fam is None:
        lobe = model.specular_lobe.id if model.specular_lobe is not None else model.specular
        raise ClshadeError(f"model {model.id!r}: environment.specular = {rung!r} prefilters the sky for built-in "
                           f"specular lobes only (GGX, Beckmann, Phong, Blinn–Phong), not {lobe!r}: "
                           f"use specular = 'sampled'")
    return fam


def split_sum_defines(model: Model, rung: str) -> dict[str, str]:
    """kernels/environment.h's split-sum defines of the model's specular lobe."""
    fam = split_family(model, rung)
    lobe = model.specular_lobe.id
    return {"ENV_SPLIT_FAMILY": ENV_LOBE_DEFINES[fam], "ENV_SPLIT_FRESNEL": str(int(lobe in prefilter.FRESNEL_LOBES)),
            "ENV_SPLIT_NORM": ENV_SPLIT_NORM.get(lobe, "0"), "ENV_LEVELS": str(prefilter.LEVELS),
            "ENV_DFG_SIZE": str(prefilter.DFG_SIZE)}


def geometry_defines(model: Model) -> dict[str, str]:
    """The Geometry's optional members the model's lobes read (surface.h)."""
    uses = model.uses
    d = {}
    if "vectors" in uses or "tangents" in uses:
        d["GEOMETRY_VECTORS"] = "1"
    if "tangents" in uses:
        d["GEOMETRY_TANGENTS"] = "1"
    return d


def _read(name: str) -> str:
    path = kernels_dir() / name
    return f'#line 1 "{name}"\n' + path.read_text(encoding="utf-8") + "\n"


def assemble(model: Model, defines: dict[str, str], entry: str, headers: tuple[str, ...] = ()) -> str:
    """Concatenate the kernel sources in dependency order, with #line markers so
    that build errors name the file: defines, simd.h, brdf.h, count.h, surface.h, the diffuse and
    specular model files, compose.h, the `headers` (gbuffer.h, shadow.h), then
    the entry file."""
    head = "".join(f"#define {k} {v}\n" for k, v in defines.items())
    parts = [head, _read("simd.h"), _read("brdf.h"), _read("count.h"), _read("surface.h")]
    if any(lobe.origin == BRDF_FILE for lobe in model.lobes):
        parts.append(_read("glsl.h"))      # the GLSL built-ins of translated shaders
    parts += [lobe.code for lobe in model.lobes]
    parts += [_read("compose.h"), *(_read(h) for h in headers), _read(entry)]
    return "".join(parts)
