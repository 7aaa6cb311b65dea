"""The torture grid: hard inputs for every preset model, on the device, against
the float64 reference — `clshade check stability`.

Contract checked: every finite input gives a finite, non-negative output, in
both the precise and the fast-math (-cl-fast-relaxed-math) builds, for the
BRDF alone (kernels/eval.cl) and for whole pixels through the shading pass
(kernels/shade.cl, a hand-made G-buffer) with light intensities 0, 1e-30 and
1e30.

Grid (every value is float32 on the device; the reference gets the same
float32-rounded inputs in float64):

* ROUGHNESS_GRID, read twice: as perceptual roughness r, and as α = r² (the
  device is given r = √α). Oren–Nayar's σ is r.
* SHININESS_GRID for the empirical lobes; COSINE_GRID for n·l and n·v, with l
  in the plane of v (l = v when the cosines match), opposite (l = the mirror
  of v when they match) and at 90° azimuth, plus l = −v (zero half vector).
* normals: unit, scaled by 1e3 and 1e-3 (unnormalised), 1e-39 (denormal
  length², flushed) and zero; denormal parameters (roughness, shininess, base).
* F0 ∈ {0, 1}: base colour 0/1 with metallic 0/1, and f90 ∈ {0, 1};
  IOR_GRID for the exact dielectric Fresnel, η ∈ IOR_GRID with k = 0 and
  gold for the conductor.

Deviation from the reference (alpha_floor = MIN_ALPHA) is measured where the
reference and the kernel describe the same configuration: both cosines > 0
and a normal the kernel can normalise (zero and denormal normals shade as
n = v by design; for n·v ≤ 0 the kernel floors n·v at MIN_N_DOT_V by design
— only finiteness and sign are checked there).
"""
from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from clshade.verify import reference as R
from clshade.device.evaluate import Samples, eval_brdf
from clshade.models import FRESNELS, Model, presets
from clshade.device.runtime import Runtime, get_runtime
from clshade.render.scene import GOLD_ETA, GOLD_K

# ------------------------------------------------------------------ the grid

ROUGHNESS_GRID: tuple[float, ...] = (0.0, 1e-8, 1e-4, 0.002, 0.045, 0.5, 1.0)
SHININESS_GRID: tuple[float, ...] = (0.0, 1.0, 1e4, 1e6)
COSINE_GRID: tuple[float, ...] = (1.0, 0.5, 1e-3, 1e-7, 0.0, -1e-7, -0.5)
IOR_GRID: tuple[float, ...] = (1.0, 1.0001, 1.5, 3.0)
LIGHT_INTENSITIES: tuple[float, ...] = (0.0, 1e-30, 1e30)
# Smallest positive float32 denormal range value used as an input.
DENORMAL = 1e-40
# Normal scales: unit, unnormalised both ways, a length whose square is a
# float32 denormal (flushed: shades as n = v), and zero.
NORMAL_SCALES: dict[str, float] = {"unit": 1.0, "x1e3": 1e3, "x1e-3": 1e-3, "denormal": 1e-39, "zero": 0.0}
# Values the kernel floors (brdf.h); kept here only to label where a clamp is active.
MIN_ALPHA = 1e-4
MIN_COSINE = 1e-4
# Deviations are relative to max(|f64|, DEVIATION_FLOOR): below 1e-3 sr⁻¹ a
# BRDF value is invisible next to any lit pixel, and a relative error of a
# value that the reference itself rounds to ~0 carries no information.
DEVIATION_FLOOR = 1e-3
# Microfacet/diffuse lobes may only deviate by float32 rounding where no clamp
# is active: the acceptance bound of the precise build (fast math is reported, not bounded).
PRECISE_TOLERANCE = 1e-3


def _dirs(cos: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    """Unit vectors with n·x = cos (n = +z) at the given azimuth (radians)."""
    s = np.sqrt(np.maximum(1.0 - cos * cos, 0.0))
    return np.stack([s * np.cos(azimuth), s * np.sin(azimuth), cos], axis=-1)


@dataclass
class Grid:
    """Geometry × normal cases, repeated for every parameter row."""
    n: np.ndarray
    l: np.ndarray
    v: np.ndarray
    labels: dict[str, np.ndarray]

    def __len__(self) -> int:
        return len(self.n)


def geometry_grid() -> Grid:
    """Every (n·l, n·v, azimuth) case and L = −V, times every normal scale."""
    cl, cv = np.meshgrid(COSINE_GRID, COSINE_GRID, indexing="ij")
    cl, cv = cl.ravel(), cv.ravel()
    ls, vs, lab_l, lab_v, lab_az = [], [], [], [], []
    for name, phi in (("same", 0.0), ("opposite", math.pi), ("perpendicular", 0.5 * math.pi)):
        ls.append(_dirs(cl, np.full_like(cl, phi)))
        vs.append(_dirs(cv, np.zeros_like(cv)))
        lab_l.append(cl)
        lab_v.append(cv)
        lab_az += [name] * len(cl)
    c = np.asarray(COSINE_GRID)
    v = _dirs(c, np.zeros_like(c))
    ls.append(-v)
    vs.append(v)
    lab_l.append(-c)
    lab_v.append(c)
    lab_az += ["l=-v"] * len(c)
    l, v = np.concatenate(ls), np.concatenate(vs)
    nl, nv = np.concatenate(lab_l), np.concatenate(lab_v)
    az = np.array(lab_az)
    rows = len(l)
    n_all, l_all, v_all, scale_lab = [], [], [], []
    for name, scale in NORMAL_SCALES.items():
        n_all.append(np.tile([0.0, 0.0, scale], (rows, 1)))
        l_all.append(l)
        v_all.append(v)
        scale_lab += [name] * rows
    # Denormal direction components: tiny x/y added to n, l and v.
    n_all.append(np.tile([DENORMAL, -DENORMAL, 1.0], (rows, 1)))
    l_all.append(l + [DENORMAL, DENORMAL, 0.0])
    v_all.append(v + [-DENORMAL, 0.0, 0.0])
    scale_lab += ["denormal-components"] * rows
    k = len(NORMAL_SCALES) + 1
    labels = {"n.l": np.tile(nl, k), "n.v": np.tile(nv, k), "azimuth": np.tile(az, k), "normal": np.array(scale_lab)}
    return Grid(np.concatenate(n_all), np.concatenate(l_all), np.concatenate(v_all), labels)


def roughness_values() -> list[tuple[str, float]]:
    """(label, perceptual roughness r): the grid as r, then as α (r = √α)."""
    out = [(f"r={x:g}", x) for x in ROUGHNESS_GRID]
    out += [(f"alpha={x:g}", math.sqrt(x)) for x in ROUGHNESS_GRID if x not in (0.0, 1.0)]
    out.append(("r=denormal", DENORMAL))
    return out


def parameter_rows(model: Model) -> list[dict[str, Any]]:
    """Parameter combinations for one model (its lobes decide which matter)."""
    uses = model.uses
    rows: list[dict[str, Any]] = []
    colours = [(b, m) for b in (0.0, 1.0) for m in (0.0, 1.0)] + [(DENORMAL, 0.0)]
    rough = roughness_values() if "roughness" in uses else [("r=0.5", 0.5)]
    for rl, r in rough:
        for base, metallic in colours:
            common = dict(roughness_label=rl, roughness=r, base=base, metallic=metallic, f90=1.0, ior=1.5,
                          eta=GOLD_ETA, k=GOLD_K, eta_label="gold", kd=0.7, ks=0.3, shininess=32.0)
            if "shininess" in uses:
                for s in (*SHININESS_GRID, DENORMAL):
                    for kd, ks in ((0.7, 0.3), (0.0, 1.0), (1.0, 0.0)):
                        rows.append({**common, "shininess": s, "kd": kd, "ks": ks})
            elif model.uses_fresnel and model.fresnel == "schlick":
                rows += [{**common, "f90": f90} for f90 in (0.0, 1.0)]
            elif model.uses_fresnel and model.fresnel == "dielectric":
                rows += [{**common, "ior": ior} for ior in IOR_GRID]
            elif model.uses_fresnel and model.fresnel == "conductor":
                rows += [{**common, "eta": (e, e, e), "k": (0.0, 0.0, 0.0), "eta_label": f"eta={e:g},k=0"}
                         for e in IOR_GRID]
                rows.append(common)
            else:
                rows.append(common)
    return rows


def build_samples(model: Model, grid: Grid) -> tuple[Samples, dict[str, np.ndarray]]:
    """The full sample set of one model: every parameter row × every geometry."""
    rows = parameter_rows(model)
    g, p = len(grid), len(rows)
    col = lambda key: np.repeat(np.array([r[key] for r in rows], dtype=object if isinstance(rows[0][key], (str, tuple)) else float), g)  # noqa: E731
    count = g * p
    mats = np.zeros((count, 4, 4), np.float32)
    mats[:, 0, 0] = col("kd")
    mats[:, 0, 1] = col("ks")
    mats[:, 0, 2] = 1.0
    mats[:, 0, 3] = col("shininess")
    mats[:, 1, 0] = col("ior")
    mats[:, 1, 1] = col("f90")
    mats[:, 2, :3] = np.repeat(np.array([r["eta"] for r in rows], float), g, axis=0)
    mats[:, 3, :3] = np.repeat(np.array([r["k"] for r in rows], float), g, axis=0)
    base = np.repeat(np.array([r["base"] for r in rows], float), g)
    samples = Samples(n=np.tile(grid.n, (p, 1)), l=np.tile(grid.l, (p, 1)), v=np.tile(grid.v, (p, 1)),
                      base=np.repeat(base[:, None], 3, axis=1), roughness=col("roughness"),
                      metallic=col("metallic"), materials=mats)
    labels = {k: np.tile(v, p) for k, v in grid.labels.items()}
    for key in ("roughness_label", "base", "metallic", "f90", "ior", "eta_label", "kd", "ks", "shininess"):
        labels[key] = col(key)
    return samples, labels


# ------------------------------------------------------------- the reference


def _f32(x: np.ndarray) -> np.ndarray:
    return np.asarray(x, np.float32).astype(np.float64)


def reference_f(model: Model, s: Samples, alpha_floor: float = MIN_ALPHA) -> np.ndarray:
    """float64 f of the float32-rounded inputs; Schlick with f90 ≠ 1 by linearity in F."""
    n, l, v = _f32(s.n), _f32(s.l), _f32(s.v)
    m = _f32(s.materials)
    base, r, metal = _f32(s.base), _f32(s.roughness), _f32(s.metallic)
    kw = dict(base_color=base, roughness=r, metallic=metal, alpha_floor=alpha_floor,
              workflow=model.workflow, kd=m[:, 0, 0], ks=m[:, 0, 1], shininess=m[:, 0, 3])
    with np.errstate(all="ignore"):
        if model.specular == "none" or model.workflow == "kdks" and not model.uses_fresnel:
            return R.brdf(model.diffuse, model.specular, n, l, v, **kw)
        diffuse = R.brdf(model.diffuse, "none", n, l, v, **kw) if model.diffuse != "none" else 0.0
        if model.workflow == "metallic":
            # The metallic workflow weights diffuse by (1 − F(n·l))(1 − F(n·v)) (compose.h),
            # with the kernel's cosine floors.
            geo = R.geometry(n, l, v)

            def fres(c: np.ndarray) -> np.ndarray:
                if model.fresnel == "schlick":
                    f0 = 0.04 * (1.0 - metal[:, None]) + base * metal[:, None]
                    return f0 + (m[:, 1, 1][:, None] - f0) * (1.0 - np.clip(c, 0, 1))[:, None] ** 5
                if model.fresnel == "dielectric":
                    return R.f_dielectric(c, m[:, 1, 0][:, None])     # per-sample IOR, one channel
                return R.f_conductor(c, m[:, 2, :3], m[:, 3, :3])
            diffuse = diffuse * (1.0 - fres(np.maximum(geo.nl, MIN_COSINE))) * (1.0 - fres(np.maximum(geo.nv, MIN_COSINE)))
        if model.fresnel == "schlick":
            f0 = 0.04 * (1.0 - metal[:, None]) + base * metal[:, None]
            one = R.brdf("none", model.specular, n, l, v, f0=np.ones_like(base), **kw)
            zero = R.brdf("none", model.specular, n, l, v, f0=np.zeros_like(base), **kw)
            return diffuse + f0 * one + (m[:, 1, 1][:, None] - f0) * zero
        spec = R.brdf("none", model.specular, n, l, v, fresnel=model.fresnel, ior=m[:, 1, 0],
                      eta=m[:, 2, :3], k=m[:, 3, :3], **kw)
        return diffuse + spec


# --------------------------------------------------------------- the report


@dataclass
class ModelResult:
    """One model × Fresnel × math mode."""
    model: str
    fast_math: bool
    cases: int = 0
    nonfinite: int = 0
    negative: int = 0
    max_deviation: float = 0.0
    max_deviation_at: dict[str, Any] = field(default_factory=dict)
    max_deviation_unclamped: float = 0.0
    max_deviation_unclamped_at: dict[str, Any] = field(default_factory=dict)
    first_bad: dict[str, Any] = field(default_factory=dict)


def _where(labels: dict[str, np.ndarray], i: int, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    out = {k: (v[i].item() if hasattr(v[i], "item") else v[i]) for k, v in labels.items()}
    return {**out, **(extra or {})}


def grid_models() -> list[Model]:
    """Every preset; microfacet presets with each Fresnel."""
    out = []
    for m in presets():
        out += [m.with_options(fresnel=f) for f in FRESNELS] if m.uses_fresnel else [m]
    return out


def run_model(model: Model, grid: Grid, rt: Runtime, fast_math: bool,
              ref_cache: dict[str, np.ndarray]) -> ModelResult:
    """Evaluate the grid for one model on the device and compare with the reference."""
    samples, labels = build_samples(model, grid)
    f = eval_brdf(model, samples, rt, fast_math=fast_math).astype(np.float64)
    res = ModelResult(model.id, fast_math, cases=len(samples))
    finite = np.isfinite(f).all(1)
    negative = (f < 0).any(1)
    res.nonfinite, res.negative = int((~finite).sum()), int(negative.sum())
    bad = np.flatnonzero(~finite | negative)
    if len(bad):
        res.first_bad = _where(labels, int(bad[0]), {"f": f[bad[0]].tolist()})
    if model.id not in ref_cache:
        ref_cache[model.id] = reference_f(model, samples)
    ref = ref_cache[model.id]
    nl, nv = labels["n.l"], labels["n.v"]
    comparable = (nl > 0) & (nv > 0) & np.isin(labels["normal"], ("unit", "x1e3", "x1e-3", "denormal-components"))
    dev = np.max(np.abs(f - ref) / np.maximum(np.abs(ref), DEVIATION_FLOOR), axis=1)
    dev = np.where(comparable & finite, dev, 0.0)
    if dev.size:
        i = int(np.argmax(dev))
        res.max_deviation = float(dev[i])
        res.max_deviation_at = _where(labels, i, {"f32": f[i].tolist(), "f64": ref[i].tolist()})
        # MIN_POW_BASE acts where the Phong/Blinn–Phong base is 0 (x = 0 evaluates as
        # 1e-30): a visible bias only for exponents below 0.5 (see clamp_bias).
        unit = lambda x: x / np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-300)  # noqa: E731
        un, ul, uv = unit(_f32(samples.n)), unit(_f32(samples.l)), unit(_f32(samples.v))
        rv = 2 * np.sum(un * ul, 1) * np.sum(un * uv, 1) - np.sum(ul * uv, 1)
        pow_base = rv if model.specular.startswith("phong") else np.sum(un * unit(ul + uv), 1)
        pow_zero = (model.family == "empirical") & (pow_base <= 0) & (labels["shininess"] < 0.5)
        unclamped = comparable & (nl >= MIN_COSINE) & (nv >= MIN_COSINE) & ~pow_zero
        du = np.where(unclamped, dev, 0.0)
        j = int(np.argmax(du))
        res.max_deviation_unclamped = float(du[j])
        res.max_deviation_unclamped_at = _where(labels, j, {"f32": f[j].tolist(), "f64": ref[j].tolist()})
    return res


# ----------------------------------------------- whole pixels (shade kernel)


@dataclass
class ShadeResult:
    model: str
    fast_math: bool
    pixels: int = 0
    nonfinite: int = 0
    negative: int = 0
    max_radiance: float = 0.0


def _shade_normals() -> np.ndarray:
    """Normals for the shading grid: a Fibonacci sphere (front and back facing),
    exact cases for the lights used, unnormalised, denormal and zero."""
    k = 48
    i = np.arange(k) + 0.5
    z = 1.0 - 2.0 * i / k
    phi = math.pi * (1.0 + 5.0 ** 0.5) * i
    sphere = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], 1)
    special = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0], [1, 1, 1], [0, 0, 1e3], [0, 0, 1e-3],
                        [0, 0, 1e-39], [0, 0, 0], [DENORMAL, DENORMAL, 1.0], [1e-7, 0, 1], [1, 0, 1e-7]], float)
    return np.concatenate([sphere, special])


def run_shade(model: Model, rt: Runtime, fast_math: bool) -> ShadeResult:
    """Render a hand-made G-buffer through the shading pass with 0, 1e-30 and 1e30 lights
    (four directional, a point light on the surface point, a far point light, a spot) and ambient."""
    from clshade.render.gbuffer import GBuffer, material_table
    from clshade.render.scene import Camera, Light, Material, Scene
    from clshade.device.shade import Shader, scene_features

    normals = _shade_normals()
    params = [(r, b, m) for r in (0.0, DENORMAL, 1e-4, 0.045, 0.5, 1.0) for b in (0.0, 1.0) for m in (0.0, 1.0)]
    width, height = len(normals), len(params)
    n = np.tile(normals, (height, 1))
    rough = np.repeat([p[0] for p in params], width).astype(np.float32)
    base = np.repeat(np.repeat([p[1] for p in params], width)[:, None], 3, 1).astype(np.float32)
    metal = np.repeat([p[2] for p in params], width).astype(np.float32)
    npix = width * height
    channels = {"depth": np.full(npix, 10.0, np.float32), "normal": n.astype(np.float32).reshape(-1),
                "base": base.reshape(-1), "roughness": rough, "metallic": metal,
                "material": np.zeros(npix, np.uint8)}
    # Camera 10 units up +z looking at the origin with a tiny field of view: v ≈ +z everywhere.
    camera = Camera(position=np.array([0.0, 0.0, 10.0]), target=np.zeros(3), up=np.array([0.0, 1.0, 0.0]),
                    fov=1e-3, width=width, height=height)
    res = ShadeResult(model.id, fast_math)
    shininess_values = (0.0, 1e6) if "shininess" in model.uses else (32.0,)
    directions = [np.array(d) / np.linalg.norm(d) for d in ([0, 0, -1.0], [0, 0, 1.0], [1.0, 0, 0], [-1.0, -1.0, -1.0])]
    for shininess in shininess_values:
        material = Material("m", shininess=shininess, ior=1.0 if shininess else 3.0, f90=0.0 if shininess else 1.0)
        for e in LIGHT_INTENSITIES:
            rgb = np.full(3, e)
            # Light along −v, along v (l = −v), grazing and oblique; a point light on the
            # surface point itself (MIN_LIGHT_DIST2) and one far away; a spot. All at once,
            # so that 1e30 lights also overflow the sum (clamped to MAX_RADIANCE).
            lights = tuple(Light("directional", rgb, direction=d) for d in directions) + (
                Light("point", rgb, position=np.zeros(3)), Light("point", rgb, position=10.0 * directions[3]),
                Light("spot", rgb, direction=directions[3], position=-5.0 * directions[3], inner_angle=0.0,
                      outer_angle=90.0))
            scene = Scene(path=None, camera=camera, lights=lights, materials={"m": material}, objects=(),
                          ambient=(1.0, 1.0, 1.0))
            gb = GBuffer(width, height, channels, material_table(scene), np.ones((height, width), bool))
            image = Shader(rt, gb, scene, camera).render(model, scene_features(scene, fast_math=fast_math))
            rgb_out = image[..., :3].astype(np.float64)
            res.pixels += npix
            res.nonfinite += int((~np.isfinite(rgb_out).all(-1)).sum())
            res.negative += int((rgb_out < 0).any(-1).sum())
            fin = rgb_out[np.isfinite(rgb_out)]
            if fin.size:
                res.max_radiance = max(res.max_radiance, float(fin.max()))
    return res


# ----------------------------------------------------- clamps and continuity


def clamp_bias(rt: Runtime) -> list[dict[str, Any]]:
    """Bias of each named floor of brdf.h where it acts: the one measurement,
    clshade.verify.bias.floor_bias (through the shade kernel, precise build)."""
    from clshade.verify.bias import floor_bias   # bias.py uses reference_f from this module
    return floor_bias(rt)


def continuity(rt: Runtime) -> list[dict[str, Any]]:
    """Largest relative step between neighbouring roughness samples around r = 0.01
    (where the α floor stops acting) and between r = 0 and r = 0.01 (must be 0)."""
    from clshade.device.evaluate import constant_materials
    from clshade.models import preset
    out = []
    r = np.concatenate([np.linspace(0.0, 0.02, 201), [0.0099999, 0.01, 0.0100001]])
    r.sort()
    for name in ("ggx_correlated", "walter_ggx", "cook_torrance", "burley"):
        model = preset(name)
        worst = (0.0, "")
        for cv, cl, phi in ((1.0, 1.0, 0.0), (0.5, 0.5, math.pi), (0.7, 0.69999, math.pi)):
            l = np.broadcast_to(_dirs(np.array([cl]), np.array([phi]))[0], (len(r), 3))
            v = np.broadcast_to(_dirs(np.array([cv]), np.array([0.0]))[0], (len(r), 3))
            s = Samples(np.broadcast_to([0.0, 0.0, 1.0], (len(r), 3)), l, v, np.ones((len(r), 3)), r,
                        np.ones(len(r)), constant_materials(len(r)))
            f = eval_brdf(model, s, rt)[:, 0].astype(np.float64)
            flat = float(np.max(np.abs(f[r <= 0.01] - f[0])) / max(abs(f[0]), 1e-30))
            steps = np.abs(np.diff(f)) / np.maximum(np.abs(f[:-1]), 1e-30)
            i = int(np.argmax(steps))
            if steps[i] >= worst[0]:
                worst = (float(steps[i]), f"n·v = {cv:g}, n·l = {cl:g}: r {r[i]:.7g} → {r[i + 1]:.7g}, "
                         f"{f[i]:.6g} → {f[i + 1]:.6g}; spread over r ≤ 0.01: {flat:.2g}")
        out.append(dict(model=name, check="roughness sweep 0 … 0.02 (step 1e-4)", max_relative_step=worst[0],
                        where=worst[1]))
    # Shininess → 0: 0⁰ = 1, continuous from n = 1e-6 to n = 0 in Phong and Blinn–Phong.
    for name in ("phong", "blinn_phong"):
        model = preset(name)
        sh = np.array([0.0, 1e-6, 1e-3])
        k = len(sh)
        l = np.broadcast_to(_dirs(np.array([0.5]), np.array([0.5 * math.pi]))[0], (k, 3))
        v = np.broadcast_to(_dirs(np.array([0.5]), np.array([0.0]))[0], (k, 3))
        s = Samples(np.broadcast_to([0.0, 0.0, 1.0], (k, 3)), l, v, np.zeros((k, 3)), np.full(k, 0.5), np.zeros(k),
                    constant_materials(k, kd=0.0, ks=1.0, shininess=sh))
        f = eval_brdf(model, s, rt)[:, 0].astype(np.float64)
        out.append(dict(model=name, check="shininess 0 → 1e-6 → 1e-3 (0⁰ = 1)",
                        max_relative_step=float(np.max(np.abs(np.diff(f))) / max(abs(f[0]), 1e-30)),
                        where=", ".join(f"n={a:g}: {b:.7g}" for a, b in zip(sh, f))))
    return out


# ---------------------------------------------------------------- the check


@dataclass
class Report:
    results: list[ModelResult]
    shading: list[ShadeResult]
    clamps: list[dict[str, Any]]
    continuity: list[dict[str, Any]]
    device: str
    seconds: float

    @property
    def cases(self) -> int:
        return sum(r.cases for r in self.results) + sum(s.pixels for s in self.shading)

    @property
    def nonfinite(self) -> int:
        return sum(r.nonfinite for r in self.results) + sum(s.nonfinite for s in self.shading)

    @property
    def negative(self) -> int:
        return sum(r.negative for r in self.results) + sum(s.negative for s in self.shading)

    @property
    def ok(self) -> bool:
        return self.nonfinite == 0 and self.negative == 0

    def as_dict(self) -> dict[str, Any]:
        from dataclasses import asdict
        return dict(ok=self.ok, cases=self.cases, nonfinite=self.nonfinite, negative=self.negative,
                    device=self.device, seconds=self.seconds, grid=dict(
                        roughness=ROUGHNESS_GRID, roughness_reading="each value as r and as α = r²",
                        shininess=SHININESS_GRID, cosines=COSINE_GRID, ior=IOR_GRID,
                        light_intensities=LIGHT_INTENSITIES, normals=list(NORMAL_SCALES),
                        deviation="|f32 − f64| / max(|f64|, %g), reference alpha_floor = %g" % (DEVIATION_FLOOR, MIN_ALPHA)),
                    models=[asdict(r) for r in self.results], shading=[asdict(s) for s in self.shading],
                    clamps=self.clamps, continuity=self.continuity)


def run(models: list[Model] | None = None, device: str | None = None, runtime: Runtime | None = None,
        fast_math: tuple[bool, ...] = (False, True), shading: bool = True, extras: bool = True) -> Report:
    """Run the whole grid (both builds), the shading pass, the clamp biases and the continuity checks."""
    start = time.perf_counter()
    rt = runtime or get_runtime(device)
    grid = geometry_grid()
    models = models if models is not None else grid_models()
    results, shades, cache = [], [], {}
    for model in models:
        for fm in fast_math:
            results.append(run_model(model, grid, rt, fm, cache))
            if shading:
                shades.append(run_shade(model, rt, fm))
    clamps = clamp_bias(rt) if extras else []
    cont = continuity(rt) if extras else []
    return Report(results, shades, clamps, cont, rt.info.description, time.perf_counter() - start)


def format_report(rep: Report) -> str:
    lines = [f"device: {rep.device}",
             f"cases run: {rep.cases} ({sum(r.cases for r in rep.results)} BRDF evaluations, "
             f"{sum(s.pixels for s in rep.shading)} shaded pixels)",
             f"NaN/Inf: {rep.nonfinite} (must be 0)", f"negative: {rep.negative} (must be 0)", "",
             "largest deviation from the float64 reference, |f32 − f64| / max(|f64|, %g):" % DEVIATION_FLOOR,
             f"  {'model':34s} {'build':8s} {'all':>9s} {'cos≥1e-4':>9s}  where (all)"]
    for r in rep.results:
        at = r.max_deviation_at
        where = ", ".join(f"{k}={at[k]}" for k in ("n.l", "n.v", "azimuth", "normal", "roughness_label", "base",
                                                    "metallic", "f90", "ior", "eta_label", "shininess") if k in at)
        lines.append(f"  {r.model:34s} {'fast' if r.fast_math else 'precise':8s} {r.max_deviation:9.2e} "
                     f"{r.max_deviation_unclamped:9.2e}  {where}")
        if r.first_bad:
            lines.append(f"    BAD: {r.first_bad}")
    if rep.shading:
        lines.append("")
        lines.append("shading pass (lights 0, 1e-30, 1e30; directional, point on the surface, point, spot; ambient):")
        for s in rep.shading:
            lines.append(f"  {s.model:34s} {'fast' if s.fast_math else 'precise':8s} pixels {s.pixels:7d}  "
                         f"NaN/Inf {s.nonfinite}  negative {s.negative}  max radiance {s.max_radiance:.3g}")
    if rep.clamps:
        lines += ["", "clamp bias (precise build, against the unclamped float64 reference):"]
        for c in rep.clamps:
            lines.append(f"  {c['clamp']:22s} {c['value']:<8g} active when {c['active']}: bias {c['bias']:.3g}")
            lines.append(f"  {'':22s} measure: {c['measure']}; worst: {c['worst']}")
    if rep.continuity:
        lines += ["", "continuity near the limits:"]
        for c in rep.continuity:
            lines.append(f"  {c['model']:16s} {c['check']}: max relative step {c['max_relative_step']:.3g} ({c['where']})")
    lines += ["", f"{'OK' if rep.ok else 'FAILED'} in {rep.seconds:.1f} s"]
    return "\n".join(lines)


def cmd_stability(args: argparse.Namespace) -> int:
    from clshade.models import resolve_many
    models = None
    if args.model:
        models = []
        for m in resolve_many(args.model):
            models += [m.with_options(fresnel=f) for f in FRESNELS] if m.uses_fresnel else [m]
    rep = run(models, device=args.device)
    if args.json:
        print(json.dumps(rep.as_dict(), indent=2, ensure_ascii=False, default=str))
    else:
        print(format_report(rep))
    return 0 if rep.ok else 1


def add_parser(sub: argparse._SubParsersAction, checks: argparse._SubParsersAction) -> None:
    """`clshade check stability [--json] [--device D] [--model M]`."""
    p = checks.add_parser("stability", help="torture grid: finite, non-negative outputs; deviation and clamp bias",
                          description=__doc__.split("\n\n")[0])
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument("--device", metavar="D", help="OpenCL device (see `clshade devices`)")
    p.add_argument("--model", metavar="M", help="restrict to these models (comma-separated; default: every preset, "
                   "microfacet presets with each Fresnel)")
    p.set_defaults(func=cmd_stability)
