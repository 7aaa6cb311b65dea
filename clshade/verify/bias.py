"""The bias of each named floor of the kernels, measured through the whole shade path.

One function, :func:`floor_bias`, is the only measurement of these biases; every
doc quotes its figures (`clshade check stability` and benchmarks/docgen/models_doc.py call it).

How: a one-row G-buffer of flat pixels (n = +z exactly) is shaded by the real
shading kernel (kernels/shade.cl, the scene's specialised variant) under one
directional light of irradiance E = 1. The camera looks along −v with a field of
view of 1e-20 degrees, so every pixel sees the same v (to ~1e-21) and n·l = l_z,
n·v = v_z are exact in float32. The pixels differ in roughness and metallic. The
float64 reference radiance is f₆₄ · max(n·l, 0) · E with f₆₄ from
:func:`clshade.verify.torture.reference_f` on the same float32 inputs. For each
floor the cases are the inputs where it acts; the bias is the largest radiance
error per unit irradiance |L₃₂ − L₆₄| / E there (and the relative error beside it).

MIN_ALPHA is an energy floor (r < 0.01 renders as α = 1e-4, the limit α → 0 is a
mirror): its bias is |1 − directional albedo| of the F = 1 specular lobe at r = 0,
the albedo integrated by quadrature over f evaluated on the device with the same
composition (kernels/compose.h brdf()) the shading kernel runs.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from clshade.device.evaluate import Samples, constant_materials, eval_brdf
from clshade.device.runtime import Runtime, get_runtime
from clshade.device.shade import Shader, scene_features
from clshade.models.model import Model, preset
from clshade.models.registry import Registry
from clshade.render.gbuffer import GBuffer, material_row
from clshade.render.scene import Camera, Light, Material, Scene
from clshade.verify import reference as R
from clshade.verify.torture import reference_f

# Field of view of the measuring camera: every pixel's view ray is the camera axis to ~1e-21, far below the
# smallest cosine measured (4e-16), while cam_right/cam_up (∝ tan(fov/2)) stay normal float32 numbers.
NARROW_FOV_DEG = 1.0e-20
ROUGHNESS = (0.045, 0.3, 0.6, 1.0)
METALLIC = (0.0, 1.0)
BASE = (0.8, 0.6, 0.4)
MODELS = ("lambert", "oren_nayar", "burley", "phong", "phong_normalized", "blinn_phong",
          "blinn_phong_normalized", "cook_torrance", "walter_ggx", "ggx_correlated", "ggx_smith_schlick")


def direction(cosine: float, azimuth: float) -> np.ndarray:
    """Unit vector at angle arccos(cosine) from +z (the pixels' normal), azimuth about z."""
    s = math.sqrt(max(1.0 - cosine * cosine, 0.0))
    return np.array([s * math.cos(azimuth), s * math.sin(azimuth), cosine])


def shade_flat(model: Model, l: np.ndarray, v: np.ndarray, roughness: np.ndarray, metallic: np.ndarray,
               base: tuple[float, float, float] = BASE, irradiance: float = 1.0, material: Material | None = None,
               runtime: Runtime | None = None) -> tuple[np.ndarray, Samples]:
    """Shade one row of flat pixels (n = +z) lit by one directional light from l, seen from v,
    with the real shading kernel. Returns the (N, 3) float32 radiance and the float32 inputs."""
    rt = runtime or get_runtime()
    count = len(roughness)
    material = material or Material("bias", base_color=base)
    v = np.asarray(v, np.float64)
    up = np.array([0.0, 1.0, 0.0]) if abs(v[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    camera = Camera(position=v.copy(), target=np.zeros(3), up=up, fov=NARROW_FOV_DEG, width=count, height=1)
    light = Light("directional", np.full(3, float(irradiance)), direction=-np.asarray(l, np.float64))
    scene = Scene(path=None, camera=camera, lights=(light,), materials={"bias": material}, objects=())
    channels = {
        "depth": np.ones(count, np.float32),
        "normal": np.tile(np.array([0.0, 0.0, 1.0], np.float32), count),
        "base": np.tile(np.asarray(base, np.float32), count),
        "roughness": np.asarray(roughness, np.float32),
        "metallic": np.asarray(metallic, np.float32),
        "material": np.zeros(count, np.uint8),
    }
    table = material_row(material.constants())[None]
    gb = GBuffer(count, 1, channels, table, np.ones((1, count), bool))
    image = Shader(rt, gb, scene, camera).render(model, scene_features(scene))
    fwd = camera.basis()[0].astype(np.float32).astype(np.float64)
    samples = Samples(n=np.tile([0.0, 0.0, 1.0], (count, 1)),
                      l=np.tile(-light.direction.astype(np.float32), (count, 1)),
                      v=np.tile(-fwd / np.linalg.norm(fwd), (count, 1)),
                      base=np.tile(np.asarray(base, np.float64), (count, 1)), roughness=np.asarray(roughness, float),
                      metallic=np.asarray(metallic, float), materials=np.repeat(table, count, axis=0))
    return image[0, :, :3], samples


def reference_radiance(model: Model, samples: Samples, irradiance: float = 1.0) -> np.ndarray:
    """float64 L = f · max(n·l, 0) · E for flat pixels (n = +z) of float32 inputs."""
    nl = np.maximum(samples.l[:, 2].astype(np.float32).astype(np.float64), 0.0)
    return reference_f(model, samples) * (nl * irradiance)[:, None]


def _grid() -> tuple[np.ndarray, np.ndarray]:
    r, m = np.meshgrid(ROUGHNESS, METALLIC)
    return r.ravel(), m.ravel()


def _measure(name: str, value: float, active: str, cases: list[tuple[str, float, float, float]],
             rt: Runtime, kernel_only: bool = False) -> dict[str, Any]:
    """Worst radiance error per unit irradiance over (model, n·l, n·v, azimuth of v) cases;
    `kernel_only`: the kernel's radiance itself (where the unclamped reference diverges)."""
    rough, metal = _grid()
    worst_abs, where, count = 0.0, "", 0
    for model_name, nl, nv, phi in cases:
        model = Registry().resolve(model_name)
        got, s = shade_flat(model, direction(nl, 0.0), direction(nv, phi), rough, metal, runtime=rt)
        want = np.zeros(got.shape) if kernel_only else reference_radiance(model, s)
        err = np.abs(got.astype(np.float64) - want)
        count += len(rough)
        i = np.unravel_index(int(np.argmax(err)), err.shape)
        if err[i] >= worst_abs:
            worst_abs = float(err[i])
            where = (f"{model_name}, r = {rough[i[0]]:g}, metallic = {metal[i[0]]:g}, n·l = {nl:g}, n·v = {nv:g}, "
                     f"azimuth {math.degrees(phi):.0f}°: L32 {got[i]:.4g} vs L64 {want[i]:.4g}")
    measure = ("largest kernel radiance per unit irradiance L32 / E where it acts (the unclamped reference "
               "diverges there)" if kernel_only else "max |L32 − L64| / E")
    return dict(clamp=name, value=value, active=active, cases=count, bias=worst_abs,
                measure=measure + " through the shade kernel (flat pixels, one directional light)", worst=where)


def _min_alpha_bias(rt: Runtime) -> dict[str, Any]:
    worst, where = 0.0, ""
    for name in ("ggx_correlated", "walter_ggx", "cook_torrance"):
        model = preset(name).with_options(workflow="metallic")
        spec_only = Model("none", model.specular, model.fresnel, model.workflow, lobes=model.lobes)
        for cv in (1.0, 0.5):
            v = direction(cv, 0.0)

            def fn(nn, ll, vv, _m=spec_only):
                k = len(ll)
                s = Samples(np.broadcast_to(nn[0], (k, 3)), ll, vv, np.ones((k, 3)), np.zeros(k), np.ones(k),
                            constant_materials(k, f90=1.0))
                return eval_brdf(_m, s, rt)[:, 0]
            albedo = float(R.directional_albedo(fn, 8, v=v, levels=12, ratio=0.25))
            if abs(1.0 - albedo) >= worst:
                worst, where = abs(1.0 - albedo), f"{name}, n·v = {cv:g}: albedo {albedo:.6f}"
    return dict(clamp="MIN_ALPHA", value=1e-4, active="roughness r < 0.01", cases=6, bias=worst,
                measure="|1 − directional albedo| of the F = 1 specular lobe at r = 0 (the α → 0 limit is a mirror "
                        "of albedo 1); f on the device through compose.h", worst=where)


def floor_bias(runtime: Runtime | None = None) -> list[dict[str, Any]]:
    """Each named floor of kernels/brdf.h: where it acts, and its measured bias (see the module doc)."""
    rt = runtime or get_runtime()
    small = (1e-7, 1e-6, 1e-5, 5e-5, 9.9e-5)
    out = [_min_alpha_bias(rt)]
    out.append(_measure("MIN_N_DOT_L", 1e-4, "0 < n·l < 1e-4",
                        [(m, c, o, phi) for m in MODELS for c in small for o in (1.0, 0.5) for phi in (0.0, math.pi)],
                        rt))
    out.append(_measure("MIN_N_DOT_V", 1e-4, "0 < n·v < 1e-4",
                        [(m, o, c, phi) for m in MODELS for c in small for o in (1.0, 0.5) for phi in (0.0, math.pi)],
                        rt))
    out.append(_measure("MIN_HALF_LEN2", 1e-30, "|l + v|² < 1e-30 (n·l + n·v < 1e-15)",
                        [(m, c, c, math.pi) for m in ("ggx_correlated", "walter_ggx", "cook_torrance",
                                                      "blinn_phong_normalized") for c in (1e-16, 4e-16)], rt,
                        kernel_only=True))
    out.append(_measure("MIN_N_DOT_H_BECKMANN", 1e-3, "n·h < 1e-3 (both directions grazing, 90° apart)",
                        [("cook_torrance", c, c, math.pi / 2) for c in (2e-4, 5e-4)], rt))
    out.append(_measure("MIN_POW_BASE", 1e-30, "r·v ≤ 0 (Phong base 0: 0ⁿ is selected, the floor keeps the unused "
                                               "lanes' log2 finite)",
                        [(m, c, c, 0.0) for m in ("phong", "phong_normalized") for c in (0.3, 0.5, 0.8)], rt))
    return out


def as_dict(rows: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """floor_bias() keyed by floor name."""
    return {row["clamp"]: row for row in rows}


__all__ = ["floor_bias", "shade_flat", "reference_radiance", "direction", "as_dict"]
