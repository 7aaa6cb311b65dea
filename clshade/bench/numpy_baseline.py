"""The shading pass in vectorised NumPy float32: the baseline a Python user
would otherwise write, and the second implementation the benchmark times.

It mirrors kernels/shade.cl term by term (same clamps, same per-pixel
reconstruction of n, l, v from the G-buffer and camera) on the covered pixels
only, so it does no work on background pixels (the kernel does): the measured
OpenCL/NumPy ratio is therefore a conservative one.
"""
from __future__ import annotations

import numpy as np

from clshade.render.gbuffer import GBuffer
from clshade.models import NONE, Model
from clshade.render.scene import Camera, Scene
from clshade.device.shade import camera_args, pack_lights, scene_features

F = np.float32
# The kernels' named constants (kernels/brdf.h, surface.h, shade.cl).
MIN_ALPHA, MIN_N_DOT_V, MIN_N_DOT_L = F(1e-4), F(1e-4), F(1e-4)
MIN_HALF_LEN2, MIN_N_DOT_H_BECKMANN, MIN_POW_BASE = F(1e-12), F(1e-3), F(1e-30)
MIN_LIGHT_DIST2, F0_DIELECTRIC, MAX_RADIANCE = F(1e-8), F(0.04), F(3.0e38)
PI, INV_PI = F(np.pi), F(1.0 / np.pi)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def pixel_inputs(gb: GBuffer, camera: Camera, half: bool = False) -> dict[str, np.ndarray]:
    """Per covered pixel, as shade.cl reads them: index, ray, v, n, base, roughness,
    metallic, material id, depth (float32; `half` rounds normal/base to float16 first)."""
    idx = np.flatnonzero(gb.channels["depth"] > 0)
    _, fwd, right, up = (a[:3] for a in camera_args(camera))
    px, py = (idx % gb.width).astype(F), (idx // gb.width).astype(F)
    sx = (px + F(0.5)) * F(2.0 / gb.width) - F(1)
    sy = F(1) - (py + F(0.5)) * F(2.0 / gb.height)
    ray = fwd + sx[:, None] * right + sy[:, None] * up
    v = -ray / np.sqrt(_dot(ray, ray))[:, None]
    n = gb.channel("normal", half).reshape(-1, 3)[idx].astype(F)
    len2 = _dot(n, n)
    n = np.where((len2 > F(1e-20))[:, None], n / np.sqrt(np.maximum(len2, F(1e-30)))[:, None], v)
    base = np.maximum(gb.channel("base", half).reshape(-1, 3)[idx].astype(F), F(0))
    return dict(idx=idx, ray=ray, v=v, n=n, base=base, depth=gb.channels["depth"][idx],
                roughness=np.clip(gb.channels["roughness"][idx], 0, 1),
                metallic=np.clip(gb.channels["metallic"][idx], 0, 1),
                material=gb.channels["material"][idx].astype(np.intp))


def _pow(x: np.ndarray, n: np.ndarray) -> np.ndarray:
    return np.exp2(n * np.log2(np.maximum(x, MIN_POW_BASE)))


def _fresnel(model: Model, vh: np.ndarray, s: dict[str, np.ndarray]) -> np.ndarray:
    """fresnel_cos() of surface.h at incidence cosine `vh`, (K, 3)."""
    c = vh[:, None]
    if model.fresnel == "dielectric":
        eta = s["ior"][:, None]
        g2 = eta * eta - F(1) + c * c
        g = np.sqrt(np.maximum(g2, F(0)))
        a = (g - c) / (g + c + F(1e-30))
        b = (c * (g + c) - F(1)) / (c * (g - c) + F(1))
        return np.where(g2 < 0, F(1), np.clip(F(0.5) * a * a * (F(1) + b * b), 0, 1))
    if model.fresnel == "conductor":
        eta, k = s["eta"], s["k"]
        c2 = c * c
        s2 = F(1) - c2
        t0 = eta * eta - k * k - s2
        a2b2 = np.sqrt(t0 * t0 + F(4) * eta * eta * k * k)
        t1 = a2b2 + c2
        a = np.sqrt(np.maximum(F(0.5) * (a2b2 + t0), F(0)))
        t2 = F(2) * c * a
        rs = (t1 - t2) / (t1 + t2)
        t3 = c2 * a2b2 + s2 * s2
        t4 = t2 * s2
        rp = rs * (t3 - t4) / (t3 + t4)
        return np.clip(F(0.5) * (rp + rs), 0, 1)
    x = F(1) - c
    x2 = x * x
    return s["f0"] + (s["f90"][:, None] - s["f0"]) * (x2 * x2 * x)


def _specular(model: Model, g: dict[str, np.ndarray], s: dict[str, np.ndarray]) -> np.ndarray:
    """k_s-less specular lobe, (K, 3)."""
    lobe, alpha = model.specular, s["alpha"]
    nl, nv, nh, sin2, vh = g["nl"], g["nv"], g["nh"], g["sin2_nh"], g["vh"]
    if lobe in ("phong", "phong_normalized", "blinn_phong", "blinn_phong_normalized"):
        sh = s["shininess"]
        f = _pow(np.maximum(g["rv"], F(0)), sh) if lobe.startswith("phong") else _pow(nh, sh)
        if lobe == "phong_normalized":
            f = f * (sh + F(2)) * F(0.5 / np.pi)
        elif lobe == "blinn_phong_normalized":
            f = f * (sh + F(8)) * F(0.125 / np.pi)
        return np.repeat(f[:, None], 3, axis=1)
    a2 = alpha * alpha
    if lobe == "cook_torrance":
        c = np.maximum(nh, MIN_N_DOT_H_BECKMANN)
        c2 = c * c
        D = np.exp(-sin2 / (c2 * a2)) / (PI * a2 * c2 * c2)
        G = np.minimum(F(1), F(2) * nh * np.minimum(nv, nl) / np.maximum(vh, MIN_N_DOT_V))
        V = G / (F(4) * nl * nv)
    else:
        d = sin2 + nh * nh * a2
        D = a2 / (PI * d * d)
        if lobe == "ggx_correlated":
            V = F(0.5) / (nl * np.sqrt(nv * nv * (F(1) - a2) + a2) + nv * np.sqrt(nl * nl * (F(1) - a2) + a2))
        elif lobe == "walter_ggx":
            V = F(1) / ((nl + np.sqrt(a2 + (F(1) - a2) * nl * nl)) * (nv + np.sqrt(a2 + (F(1) - a2) * nv * nv)))
        else:  # ggx_smith_schlick
            k = F(0.5) * alpha
            V = F(0.25) / ((nl * (F(1) - k) + k) * (nv * (F(1) - k) + k))
    return (D * V)[:, None] * _fresnel(model, vh, s)


def _diffuse(model: Model, g: dict[str, np.ndarray], s: dict[str, np.ndarray]) -> np.ndarray:
    nl, nv = g["nl"], g["nv"]
    if model.diffuse == "burley":
        f90 = F(0.5) + F(2) * s["alpha"] * g["vh"] * g["vh"]
        p = lambda x: x * x * x * x * x  # noqa: E731
        return (F(1) + (f90 - F(1)) * p(F(1) - nl)) * (F(1) + (f90 - F(1)) * p(F(1) - nv)) * INV_PI
    if model.diffuse == "oren_nayar":
        s2 = s["roughness"] * s["roughness"]
        A = F(1) - F(0.5) * s2 / (s2 + F(0.33))
        B = F(0.45) * s2 / (s2 + F(0.09))
        t = np.maximum(F(0), g["lv"] - nl * nv) / np.maximum(np.maximum(nl, nv), MIN_N_DOT_V)
        return (A + B * t) * INV_PI
    return np.full_like(nl, INV_PI)


def surface(model: Model, px: dict[str, np.ndarray], table: np.ndarray) -> dict[str, np.ndarray]:
    """make_surface() of surface.h for every pixel; `table` is the (M, 4, 4) material table."""
    rows = table[px["material"]] if len(table) else np.zeros((len(px["idx"]), 4, 4), F)
    base, r, m = px["base"], px["roughness"], px["metallic"]
    s = dict(base=base, roughness=r, alpha=np.maximum(r * r, MIN_ALPHA), shininess=rows[:, 0, 3],
             ior=rows[:, 1, 0], f90=rows[:, 1, 1], eta=rows[:, 2, :3], k=rows[:, 3, :3])
    if model.workflow == "metallic":
        s["diffuse_color"] = base * (F(1) - m)[:, None]
        s["f0"] = F0_DIELECTRIC + (base - F0_DIELECTRIC) * m[:, None]
        s["kd"] = s["ks"] = s["ka"] = np.ones_like(r)
    else:
        r0 = (s["ior"] - F(1)) / (s["ior"] + F(1))
        s["diffuse_color"] = base
        s["f0"] = np.repeat((r0 * r0)[:, None], 3, axis=1)
        s["kd"], s["ks"], s["ka"] = rows[:, 0, 0], rows[:, 0, 1], rows[:, 0, 2]
    return s


def light_list(scene: Scene, px: dict[str, np.ndarray], cam_pos: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(l, E) per light in shade.cl order: unit direction towards the light and irradiance."""
    rows = pack_lights(scene.lights)
    feats = scene_features(scene)
    out, o = [], 0
    P = cam_pos + px["depth"][:, None] * px["ray"]
    for _ in range(feats.num_dir):
        l = np.broadcast_to(-rows[o, :3], P.shape)
        out.append((l, np.broadcast_to(rows[o + 1, :3], P.shape)))
        o += 2
    for kind in ("point", "spot"):
        for _ in range(feats.num_point if kind == "point" else feats.num_spot):
            d = rows[o, :3] - P
            d2 = np.maximum(_dot(d, d), MIN_LIGHT_DIST2)
            l = d / np.sqrt(d2)[:, None]
            E = rows[o + 1, :3] / d2[:, None]
            if kind == "spot":
                cos_o, cos_i = rows[o, 3], rows[o + 1, 3]
                t = np.clip((_dot(-l, np.broadcast_to(rows[o + 2, :3], l.shape)) - cos_o)
                            / max(cos_i - cos_o, F(1e-6)), 0, 1)
                E = E * (t * t)[:, None]
            out.append((l, E))
            o += 2 if kind == "point" else 3
    return out


def geometry(n: np.ndarray, l: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
    """make_geometry() of surface.h."""
    nv_raw, nl_raw = _dot(n, v), _dot(n, l)
    h = l + v
    h = h / np.sqrt(np.maximum(_dot(h, h), MIN_HALF_LEN2))[:, None]
    c = np.cross(n, h)
    lv = _dot(l, v)
    return dict(nl_raw=nl_raw, nl=np.maximum(nl_raw, MIN_N_DOT_L), nv=np.maximum(nv_raw, MIN_N_DOT_V),
                nh=np.clip(_dot(n, h), 0, 1), sin2_nh=np.clip(_dot(c, c), 0, 1), vh=np.clip(_dot(v, h), 0, 1),
                lv=lv, rv=F(2) * nl_raw * nv_raw - lv)


def _coupled(model: Model) -> bool:
    """Metallic workflow with a Fresnel-bearing specular lobe: k_d follows Fresnel (compose.h)."""
    return model.workflow == "metallic" and model.specular != NONE and model.uses_fresnel


def shade_numpy(model: Model, gb: GBuffer, scene: Scene, camera: Camera, half: bool = False) -> np.ndarray:
    """The image of shade.cl, (H, W, 4) float32, computed in NumPy float32."""
    px = pixel_inputs(gb, camera, half)
    s = surface(model, px, gb.materials.astype(F))
    cam_pos = camera_args(camera)[0][:3]
    L = np.zeros((len(px["idx"]), 3), F)
    for l, E in light_list(scene, px, cam_pos):
        g = geometry(px["n"], l, px["v"])
        f = np.zeros_like(L)
        if model.diffuse != NONE:
            kd = s["kd"][:, None]
            if _coupled(model):   # compose.h: k_d = (1 − F(n·l))(1 − F(n·v))
                kd = (F(1) - _fresnel(model, g["nl"], s)) * (F(1) - _fresnel(model, g["nv"], s))
            f += (kd * _diffuse(model, g, s)[:, None]) * s["diffuse_color"]
        if model.specular != NONE:
            f += s["ks"][:, None] * _specular(model, g, s)
        lo = f * (E * g["nl"][:, None])
        L += np.where((g["nl_raw"] > 0)[:, None], lo, F(0))
    if any(a > 0 for a in scene.ambient):
        r = np.zeros_like(L)
        if model.diffuse != NONE:
            kd = F(1) - s["f0"] if _coupled(model) else s["kd"][:, None]
            r += kd * s["diffuse_color"]
        if model.specular != NONE:
            r += s["ks"][:, None] * s["f0"]
        L += (s["ka"][:, None] * np.asarray(scene.ambient, F)) * r
    image = np.empty((gb.pixels, 4), F)
    image[:] = np.array([*scene.background, 0.0], F)
    image[px["idx"], :3] = np.minimum(L, MAX_RADIANCE)
    image[px["idx"], 3] = 1
    return image.reshape(gb.height, gb.width, 4)
