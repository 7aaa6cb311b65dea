"""The NumPy side of the benchmark: what a NumPy user would write to shade the
same G-buffer, a minimal Lambert that guards it against becoming a straw man,
and the general float64 reference run in float32.

`numpy_shader(model, gb, scene, camera, features)` is the baseline the `× NumPy`
column divides by. Written as a NumPy user writes a deferred shading pass:
vectorised over pixels, float32, in place where it helps, and specialised to
the scene the way clshade's kernel variant is (only the scene's lights, its
one-value channels and material-table entries as constants, grey light and
ambient as scalars, no view vector for Lambert). Per frame it reads the
G-buffer's interleaved channels, gathers the covered pixels (or shades every
pixel: `prepare` times both once and keeps the faster), and writes an (H·W, 3)
RGB image with the scene's background in the empty pixels; coverage is the
G-buffer's (no alpha is written). The formulas are those of kernels/brdf.h,
surface.h and compose.h with their floors, in vectorised form. Scope:
directional lights and a constant ambient, Schlick Fresnel, no shadows,
emission, occlusion or specular AA; anything else raises Unsupported with the
reason (the bench then reports the reason instead of a time).

`minimal_lambert`: the smallest NumPy Lambert (one n·l per pixel, an in-place
maximum, scale, add, a broadcast multiply with the base colour; every pixel,
no background). The bench times it in the same rounds as the baseline's
Lambert: a ratio above SUSPECT_RATIO marks the NumPy column suspect.

`shade_reference_f32`: the frame oracle (clshade.verify.reference.radiance) in
float32 — general (every light kind, shadows, workflow), written for clarity;
timed as a separate column, "general reference in float32", not "NumPy".

NumPy's element-wise operations run on one thread (NUMPY_THREADS); the baseline and the
guard's minimal Lambert take their dot products element-wise too, not through OpenBLAS's
threaded products, whose speed depends on what the kernels' threads leave free.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from clshade.device.shade import camera_args
from clshade.device.variants import Features
from clshade.models.model import NONE, Model
from clshade.render.gbuffer import GBuffer
from clshade.render.scene import Camera, Scene
from clshade.render.shadows import ShadowMaps
from clshade.resources import constant
from clshade.verify.reference import radiance

NUMPY_THREADS = 1     # NumPy ufuncs are single-threaded
SUSPECT_RATIO = 1.5   # baseline Lambert / minimal Lambert above this: the NumPy column is suspect
LAYOUT_TRIALS = 5     # frames per layout, alternating, when numpy_shader picks covered-only or every pixel (median)
GUARD_FRAMES = 25     # pairs (baseline Lambert, minimal Lambert) the bench times, spread over its rounds

f32 = np.float32
INV_PI = f32(1.0 / math.pi)
# kernels/brdf.h, surface.h, shade.cl: the floors the baseline shares with the kernels (each explained there).
MIN_N_DOT_L, MIN_N_DOT_V, MIN_ALPHA = (f32(constant(k)) for k in ("MIN_N_DOT_L", "MIN_N_DOT_V", "MIN_ALPHA"))
MIN_HALF_LEN2, MIN_UNIT_LEN2 = f32(constant("MIN_HALF_LEN2")), f32(constant("MIN_UNIT_LEN2"))
MIN_POW_BASE, MIN_N_DOT_H_BECKMANN = f32(constant("MIN_POW_BASE")), f32(constant("MIN_N_DOT_H_BECKMANN"))
MIN_SHININESS = f32(constant("MIN_SHININESS"))
F0_DIELECTRIC = f32(constant("F0_DIELECTRIC"))
RECORD = np.dtype("V12")   # one pixel's three float32 channels: gathers and scatters move 12-byte records


class Unsupported(RuntimeError):
    """The baseline does not implement this model or scene (the message says what)."""


# ---------------------------------------------------------------- term functions (vectorised, float32)


def pow5(x: np.ndarray) -> np.ndarray:
    x2 = x * x
    return x2 * x2 * x


def schlick(c: np.ndarray, f0, f90) -> np.ndarray:
    """F_Schlick: f0 + (f90 − f0)(1 − c)⁵; c (K, 1), f0/f90 scalars or (K, 1|3)."""
    return f0 + (f90 - f0) * pow5(1 - c)


def fd_burley(g: "Geometry", s: "Surface") -> np.ndarray:
    f90 = 0.5 + 2 * s.alpha * g.vh * g.vh
    return (1 + (f90 - 1) * pow5(1 - g.nl)) * (1 + (f90 - 1) * pow5(1 - g.nv)) * INV_PI


def fd_oren_nayar(g: "Geometry", s: "Surface") -> np.ndarray:
    s2 = s.roughness * s.roughness
    a, b = 1 - 0.5 * s2 / (s2 + f32(0.33)), f32(0.45) * s2 / (s2 + f32(0.09))
    t = np.maximum(g.lv - g.nl * g.nv, 0) / np.maximum(np.maximum(g.nl, g.nv), MIN_N_DOT_V)
    return (a + b * t) * INV_PI


def power(x: np.ndarray, n) -> np.ndarray:
    """xⁿ for x in [0, 1] as the kernels' pow_runtime (base floored at MIN_POW_BASE)."""
    return np.power(np.clip(x, MIN_POW_BASE, 1), n)


def fs_phong(g: "Geometry", s: "Surface") -> np.ndarray:
    return np.where(g.rv > 0, power(g.rv, s.shininess), np.where(np.abs(s.shininess) < MIN_SHININESS, f32(1), f32(0)))


def fs_blinn_phong(g: "Geometry", s: "Surface") -> np.ndarray:
    return power(g.nh, s.shininess)


def d_ggx_den(g: "Geometry", a2) -> np.ndarray:
    d = g.sin2_nh + g.nh * g.nh * a2
    return math.pi * d * d


def fs_ggx_correlated(g: "Geometry", s: "Surface") -> np.ndarray:
    a2 = s.alpha * s.alpha
    gv = g.nl * np.sqrt(g.nv * g.nv * (1 - a2) + a2)
    gl = g.nv * np.sqrt(g.nl * g.nl * (1 - a2) + a2)
    return (a2 * f32(0.5)) / (d_ggx_den(g, a2) * (gv + gl))


def fs_walter_ggx(g: "Geometry", s: "Surface") -> np.ndarray:
    a2 = s.alpha * s.alpha
    sl = g.nl + np.sqrt(a2 + (1 - a2) * g.nl * g.nl)
    sv = g.nv + np.sqrt(a2 + (1 - a2) * g.nv * g.nv)
    return a2 / (d_ggx_den(g, a2) * (sl * sv))


def fs_ggx_smith_schlick(g: "Geometry", s: "Surface") -> np.ndarray:
    a2, k = s.alpha * s.alpha, f32(0.5) * s.alpha
    return (a2 * f32(0.25)) / (d_ggx_den(g, a2) * ((g.nl * (1 - k) + k) * (g.nv * (1 - k) + k)))


def fs_cook_torrance(g: "Geometry", s: "Surface") -> np.ndarray:
    c, m2 = np.maximum(g.nh, MIN_N_DOT_H_BECKMANN), s.alpha * s.alpha
    t = 1 / (c * c * m2)
    d = np.exp(-g.sin2_nh * t) * (t * t * m2 * INV_PI)
    b = np.maximum(g.vh, MIN_N_DOT_V)
    return d * np.minimum(2 * g.nh * np.minimum(g.nv, g.nl), b) / (4 * g.nl * g.nv * b)


# lobe → (f, what it needs: "v" the view vector, "r" the roughness, "lv", "rv", "h" (n·h, v·h),
# "sin2" (|n × h|²)). Empirical lobes: f without normalisation (the normalised variants scale it by
# NORMALISATION). Microfacet lobes: D·V (compose applies F).
DIFFUSE: dict[str, tuple[Callable | None, set[str]]] = {
    "lambert": (None, set()), "burley": (fd_burley, {"v", "r", "h"}), "oren_nayar": (fd_oren_nayar, {"v", "r", "lv"})}
MICROFACET = {"v", "r", "h", "sin2"}
SPECULAR: dict[str, tuple[Callable, set[str]]] = {
    "phong": (fs_phong, {"v", "rv"}), "phong_normalized": (fs_phong, {"v", "rv"}),
    "blinn_phong": (fs_blinn_phong, {"v", "h"}), "blinn_phong_normalized": (fs_blinn_phong, {"v", "h"}),
    "cook_torrance": (fs_cook_torrance, MICROFACET), "walter_ggx": (fs_walter_ggx, MICROFACET),
    "ggx_correlated": (fs_ggx_correlated, MICROFACET), "ggx_smith_schlick": (fs_ggx_smith_schlick, MICROFACET),
}
NORMALISATION = {"phong_normalized": (2.0, 0.5), "blinn_phong_normalized": (8.0, 0.125)}   # (n + a)·b/π


# ---------------------------------------------------------------- per-pixel inputs


@dataclass
class Geometry:
    """make_geometry (surface.h) for one light over K pixels; (K, 1) columns, only those asked for."""
    nl_raw: np.ndarray
    nl: np.ndarray | None
    nv: np.ndarray | None = None
    nh: np.ndarray | None = None
    sin2_nh: np.ndarray | None = None
    vh: np.ndarray | None = None
    lv: np.ndarray | None = None
    rv: np.ndarray | None = None


@dataclass
class Surface:
    """make_surface (surface.h): scalars where the scene has one value, else (K, 1) / (K, 3) columns."""
    diffuse_color: np.ndarray
    f0: object
    f90: object
    roughness: object
    alpha: object
    kd: object
    ks: object
    ka: object
    shininess: object


def column(x: np.ndarray) -> np.ndarray:
    return x.reshape(-1, 1)


def dot_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product of (K, 3) arrays, as (K, 1)."""
    return column(np.einsum("ij,ij->i", a, b))


def dot_light(a: np.ndarray, l: np.ndarray) -> np.ndarray:
    """(K, 3) rows · the vector l, as (K, 1), element-wise on one thread like the rest of the baseline.
    Not ``a @ l``: OpenBLAS's threaded gemv is faster alone, but inside the bench, between the
    kernels' dispatches, it made the baseline's Lambert slower than one thread (the straw-man guard
    marked the NumPy column suspect)."""
    out = a[:, 0] * l[0]
    out += a[:, 1] * l[1]
    out += a[:, 2] * l[2]
    return column(out)


def geometry(n: np.ndarray, v: np.ndarray | None, nv_raw: np.ndarray | None, l: np.ndarray,
             needs: set[str]) -> Geometry:
    """The cosines of one directional light l (unit, towards the light) that the model needs."""
    nl_raw = dot_light(n, l)
    g = Geometry(nl_raw, None)
    if "v" not in needs:                               # Lambert: n·l only
        return g
    g.nl = np.maximum(nl_raw, MIN_N_DOT_L)
    g.nv = np.maximum(nv_raw, MIN_N_DOT_V)
    lv = dot_light(v, l)
    g.lv = lv
    if "rv" in needs:
        g.rv = 2 * nl_raw * nv_raw - lv
    if "h" in needs:                                   # H = l + v: |H|² = 2 + 2 l·v, n·H, v·H from the cosines
        h_len2 = 2 + 2 * lv
        inv_len = 1 / np.sqrt(np.maximum(h_len2, MIN_HALF_LEN2))
        nH = nl_raw + nv_raw
        g.nh = np.clip(nH * inv_len, 0, 1)
        g.vh = np.clip((lv + 1) * inv_len, 0, 1)
        if "sin2" in needs:                            # |n × H|²: precise near the highlight's peak
            c = np.cross(n, v + l)
            sin2 = np.clip(dot_rows(c, c) * (inv_len * inv_len), 0, 1)
            g.sin2_nh = np.where((h_len2 < MIN_HALF_LEN2) | (nH <= 0), f32(1), sin2)
    return g


# ---------------------------------------------------------------- the baseline


@dataclass
class NumpyShader:
    """A prepared baseline: `run()` shades one frame, (H·W, 3) float32 RGB."""
    model: Model
    run: Callable[[], np.ndarray]
    layout: str            # "covered" (gathers the covered pixels) or "all" (every pixel)


def _grey(rgb) -> object:
    """A colour as a float32 scalar when its channels are equal, else a (1, 3) row."""
    c = np.asarray(rgb, np.float32)[:3]
    return f32(c[0]) if np.all(c == c[0]) else c.reshape(1, 3)


def check_supported(model: Model, scene: Scene, features: Features) -> None:
    """Raise Unsupported unless the baseline implements `model` on this scene."""
    if model.diffuse not in (*DIFFUSE, NONE) or model.specular not in (*SPECULAR, NONE):
        raise Unsupported(f"model {model.id}: no NumPy baseline for these lobes")
    if model.uses_fresnel and model.fresnel != "schlick":
        raise Unsupported(f"model {model.id}: the NumPy baseline implements Schlick's Fresnel only")
    if any(l.kind != "directional" for l in scene.lights):
        raise Unsupported("the NumPy baseline implements directional lights only")
    extra = [name for name in ("shadows", "emissive", "occlusion", "specular_aa", "general") if getattr(features, name)]
    if extra or scene.samples != 1:
        raise Unsupported(f"the NumPy baseline does not implement {', '.join(extra) or 'supersampling'}")


def numpy_shader(model: Model, gb: GBuffer, scene: Scene, camera: Camera, features: Features,
                 layout: str | None = None) -> NumpyShader:
    """The NumPy baseline of `model` on `gb` (half: the G-buffer rounded as the device reads it).
    `layout` "covered" or "all"; None: time both (LAYOUT_TRIALS frames each, alternating, so that a burst
    of load on the shared machine hits both) and keep the one with the lower median."""
    check_supported(model, scene, features)
    if features.half_gbuffer:
        gb = half_gbuffer(gb)
    frame = _frame_function(model, gb, scene, camera, dict(features.uniform))
    if layout is None:
        times: dict[str, list[float]] = {"covered": [], "all": []}
        frame(True), frame(False)
        for _ in range(LAYOUT_TRIALS):
            for name in times:
                t0 = time.perf_counter()
                frame(name == "covered")
                times[name].append(time.perf_counter() - t0)
        layout = min(times, key=lambda name: float(np.median(times[name])))
    return NumpyShader(model, lambda: frame(layout == "covered"), layout)


def _frame_function(model: Model, gb: GBuffer, scene: Scene, camera: Camera,
                    uniform: dict[str, float]) -> Callable[[bool], np.ndarray]:
    """One frame of `model`, specialised to the scene: per-frame work only inside `frame`."""
    ch = gb.channels
    depth = ch["depth"]
    normal = ch["normal"].reshape(-1, 3)
    records = {k: np.ascontiguousarray(ch[k].reshape(-1, 3)).view(RECORD).reshape(-1) for k in ("normal", "base")}
    background = np.array(scene.background[:3], np.float32)
    sky_image = np.tile(background, (gb.pixels, 1))           # the cleared frame (a constant of the scene)
    lights = [(np.array(-np.asarray(l.direction) / np.linalg.norm(l.direction), np.float32), _grey(l.color))
              for l in scene.lights]
    ambient = _grey(scene.ambient) if any(a > 0 for a in scene.ambient[:3]) else None
    diffuse, specular = DIFFUSE.get(model.diffuse), SPECULAR.get(model.specular)
    needs = (diffuse[1] if diffuse else set()) | (specular[1] if specular else set())
    fresnel = specular is not None and model.uses_fresnel
    metallic_wf = model.workflow == "metallic"
    table = gb.materials if len(gb.materials) else np.zeros((1, 4, 4), np.float32)
    same = np.all(table == table[0], axis=0)                # entries with one value in every material
    cam = np.stack(camera_args(camera)[1:]).astype(np.float32)[:, :3]
    col_ray = cam[0] + ((np.arange(gb.width, dtype=np.float32) + 0.5) * f32(2 / gb.width) - 1)[:, None] * cam[1]
    row_ray = (1 - (np.arange(gb.height, dtype=np.float32) + 0.5) * f32(2 / gb.height))[:, None] * cam[2]

    def channel(name: str, idx):
        """A one-component channel at the pixels: its uniform value, or a (K, 1) column."""
        if name in uniform:
            return f32(uniform[name])
        x = ch[name] if idx is None else np.take(ch[name], idx)
        return column(np.clip(x, 0, 1))

    def entry(mat_id, r: int, c: int):
        """Material-table entry (surface.h layout) per pixel: a scalar when every material agrees."""
        return table[0, r, c] if same[r, c] else column(np.take(table[:, r, c], mat_id))

    def view(at) -> np.ndarray:
        """(K, 3) unit vectors towards the eye at flat pixel indices `at` (None: every pixel), shade.cl's rays."""
        if at is None:
            ray = (col_ray[None, :, :] + row_ray[:, None, :]).reshape(-1, 3)
        else:
            row, col = np.divmod(at, gb.width)
            ray = np.take(col_ray, col, axis=0)
            ray += np.take(row_ray, row, axis=0)
        ray *= -1 / np.sqrt(dot_rows(ray, ray))
        return ray

    def normals(idx, v: np.ndarray | None) -> np.ndarray:
        """(K, 3) unit normals; a zero or unusable one faces the viewer (shade.cl)."""
        n = normal.copy() if idx is None else np.take(records["normal"], idx).view(np.float32).reshape(-1, 3)
        if gb.unit_normals:      # unit or zero: only a zero one has n.x == 0 and |n|² ≤ MIN_UNIT_LEN2
            maybe = np.flatnonzero(n[:, 0] == 0)
            if idx is None:      # every pixel: the empty ones (zero normals) are not shaded
                maybe = maybe[depth[maybe] > 0]
            bad = maybe[dot_rows(n[maybe], n[maybe])[:, 0] <= MIN_UNIT_LEN2]
        else:
            len2 = dot_rows(n, n)
            ok = len2 > MIN_UNIT_LEN2
            n *= np.where(ok, 1 / np.sqrt(np.where(ok, len2, 1)), 0)
            bad = np.flatnonzero(~ok[:, 0] if idx is not None else ~ok[:, 0] & (depth > 0))
        if len(bad):
            n[bad] = v[bad] if v is not None else view(bad if idx is None else idx[bad])
        return n

    def surface(base: np.ndarray, idx) -> Surface:
        mat_id = None if same.all() else (ch["material"] if idx is None else np.take(ch["material"], idx))
        rough = channel("roughness", idx) if "r" in needs else f32(0)
        alpha = np.maximum(rough * rough, MIN_ALPHA)
        f90 = entry(mat_id, 1, 1)
        if metallic_wf:
            m = channel("metallic", idx)
            dielectric = np.ndim(m) == 0 and m == 0        # surface.h: METALLIC_VALUE 0
            diffuse_color = base if dielectric else base * (1 - m)
            f0 = F0_DIELECTRIC if dielectric else F0_DIELECTRIC + (base - F0_DIELECTRIC) * m
            return Surface(diffuse_color, f0, f90, rough, alpha, f32(1), f32(1), f32(1), f32(0))
        ior = entry(mat_id, 1, 0)
        r0 = (ior - 1) / (ior + 1)
        return Surface(base, r0 * r0, f90, rough, alpha, entry(mat_id, 0, 0), entry(mat_id, 0, 1),
                       entry(mat_id, 0, 2), entry(mat_id, 0, 3))

    def add(total, x):
        """total + x, in place when x fits in total (total None: x)."""
        if total is None:
            return x
        if np.shape(total) == np.broadcast_shapes(np.shape(total), np.shape(x)) and isinstance(total, np.ndarray):
            total += x
            return total
        return total + x

    def frame(covered: bool) -> np.ndarray:
        idx = np.flatnonzero(depth > 0) if covered else None
        if idx is None:
            base = np.maximum(ch["base"].reshape(-1, 3), 0)
        else:
            base = np.take(records["base"], idx).view(np.float32).reshape(-1, 3)
            np.maximum(base, 0, out=base)
        v = view(idx) if "v" in needs else None
        n = normals(idx, v)
        nv_raw = dot_rows(n, v) if v is not None else None
        s = surface(base, idx)
        wd = ws = None                                     # L = diffuse_color · wd + ws
        for l, E in lights:
            g = geometry(n, v, nv_raw, l, needs)
            cos = np.maximum(g.nl_raw, 0, out=g.nl_raw)    # E·max(n·l, 0) is the irradiance (g is made)
            if specular is not None:
                fs = specular[0](g, s)
                if model.specular in NORMALISATION:
                    a, b = NORMALISATION[model.specular]
                    fs = fs * ((s.shininess + a) * (b * INV_PI))
                if fresnel:
                    fs = fs * schlick(g.vh, s.f0, s.f90)
                ws = add(ws, (s.ks * E) * fs * cos)
            if diffuse is not None:
                fd = INV_PI if diffuse[0] is None else diffuse[0](g, s)
                kd = (1 - schlick(g.nl, s.f0, s.f90)) * (1 - schlick(g.nv, s.f0, s.f90)) \
                    if fresnel and metallic_wf else s.kd
                weight = kd * fd * E
                if np.ndim(weight) == 0:                   # Lambert, grey light: scale n·l in place
                    cos *= weight
                    wd = add(wd, cos)
                else:
                    wd = add(wd, weight * cos)
        if ambient is not None:                            # compose.h ambient_term
            if diffuse is not None:
                wd = add(wd, s.ka * ambient * ((1 - s.f0) if fresnel and metallic_wf else s.kd))
            if specular is not None:
                ws = add(ws, s.ka * ambient * s.ks * s.f0)
        if wd is None:
            L = np.zeros_like(base)
        elif s.diffuse_color is base and np.shape(wd)[0] == len(base):   # base is this frame's copy: in place
            L = np.multiply(base, wd, out=base)
        else:
            L = s.diffuse_color * wd
        if ws is not None:
            L += ws
        if idx is None:
            L[depth <= 0] = background
            return L
        out = sky_image.copy()
        out.view(RECORD).reshape(-1)[idx] = np.ascontiguousarray(L, np.float32).view(RECORD).reshape(-1)
        return out

    return frame


# ---------------------------------------------------------------- the straw-man guard


def minimal_lambert(gb: GBuffer, scene: Scene) -> Callable[[], np.ndarray]:
    """The smallest NumPy Lambert of the scene's first light and ambient (grey light and ambient
    taken as their mean): every pixel, no background; the yardstick of the baseline's Lambert."""
    normal, base = gb.channels["normal"].reshape(-1, 3), gb.channels["base"].reshape(-1, 3)
    light = scene.lights[0]
    l = np.array(-np.asarray(light.direction) / np.linalg.norm(light.direction), np.float32)
    e, a = f32(np.mean(light.color[:3]) / math.pi), f32(np.mean(scene.ambient[:3]))

    def run() -> np.ndarray:
        nl = normal[:, 0] * l[0]              # one thread, as the baseline (NUMPY_THREADS): not a threaded gemv
        nl += normal[:, 1] * l[1]
        nl += normal[:, 2] * l[2]
        np.maximum(nl, 0, out=nl)
        nl *= e
        nl += a
        return base * nl[:, None]
    return run


def suspect(baseline_lambert_ms: list[float], minimal_ms: list[float]) -> tuple[float | None, bool | None]:
    """(baseline Lambert / minimal Lambert, whether that ratio marks the NumPy column suspect) from
    frames timed in pairs (one of each, back to back): the median of the pairs' ratios, robust to
    load that drifts between pairs; (None, None) without pairs."""
    pairs = [(a, b) for a, b in zip(baseline_lambert_ms, minimal_ms) if b > 0]
    if not pairs:
        return None, None
    ratio = float(np.median([a / b for a, b in pairs]))
    return ratio, ratio > SUSPECT_RATIO


# ---------------------------------------------------------------- the general reference in float32


def half_gbuffer(gb: GBuffer) -> GBuffer:
    """The G-buffer with normal and base colour rounded to half floats, as the device reads them."""
    channels = {**gb.channels, **{k: gb.channel(k, half=True).astype(np.float32) for k in ("normal", "base")}}
    return dataclasses.replace(gb, channels=channels, unit_normals=False)   # half normals are not unit


def shade_reference_f32(model: Model, gb: GBuffer, scene: Scene, camera: Camera, half: bool = False,
                        shadows: ShadowMaps | None = None) -> np.ndarray:
    """The general reference in float32: the shaded image, (H, W, 4) float32 — float32 radiance,
    coverage in alpha (the scene's background and its alpha 0 where empty, as the kernel writes
    them). With `shadows`, the shadow-map lookups are part of the work, as in the kernel."""
    rgb = radiance(half_gbuffer(gb) if half else gb, scene, model, dtype=np.float32, camera=camera, shadows=shadows)
    alpha = gb.coverage.astype(np.float32)[..., None]
    return np.concatenate([rgb, alpha], axis=-1)
