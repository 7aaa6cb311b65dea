"""Accuracy of the float32 kernels against the float64 reference (clshade.verify.reference).

Two levels, both evaluated on the OpenCL device:

* terms — every term function of kernels/brdf.h on its own (kernels/terms.cl);
* models — a lighting model exactly as it renders (kernels/eval.cl via
  clshade.device.evaluate.eval_brdf), against reference.brdf.

Every input is rounded to float32 *before* the reference sees it: the kernel
sees float32, so the comparison measures the kernel's arithmetic, not the
rounding of its inputs (e.g. the cancellation in 1 − metallic).

Metric: ``err = |f − g| / max(|g|, FLOOR_REL · peak)``, max over samples and
channels, where g is the reference, f the kernel and ``peak`` the lobe's peak
for the sample's parameters (for models: the larger of g and g at the mirror
direction of v; for terms: the term's maximum over its angular input). Values
far below the peak (darker than 1e-3 of it) are thus held to an absolute
tolerance of 1e-3 · peak · target instead of a relative one.

Documented limits of the comparison (hard cases outside them are the
clamps' business, measured in :func:`clamp_bias`):
  n·l, n·v ≥ MIN_COSINE; roughness ≥ MIN_ROUGHNESS and
  α · min(n·l, n·v) ≥ MIN_ALPHA_COSINE for microfacet lobes; shininess ≤
  MAX_SHININESS for the model-level Phong lobes. Samples drawn outside the last
  limit (the float32 half vector's conditioning) are reported apart as
  `hard_max_rel_err`.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from clshade.verify import reference as R
from clshade.errors import ClshadeError
from clshade.verify.reference.vectors import orthonormal_basis
from clshade.device.evaluate import Samples, eval_brdf
from clshade.models.model import NONE, Model, presets
from clshade.models.registry import Registry
from clshade.resources import constant, kernels_dir
from clshade.device.runtime import Runtime, get_runtime

# Target of every comparison: 1e-4 relative, ~800 float32 ulps, leaving room
# for the 5–20 roundings of a composed lobe and the 3-ulp exp2/log2 of OpenCL.
TARGET = 1.0e-4
# Values below this fraction of the lobe's peak are compared in absolute terms
# (an 8-bit image cannot show them; float32 cancellation in the tails of
# Schlick's (1 − v·h)⁵ or a Phong power makes their relative error meaningless).
FLOOR_REL = 1.0e-3
# Grazing limit: below n·x = 0.02 (θ > 88.9°) the cosines themselves carry a
# relative rounding error of ~1e-5 and the kernels' MIN_N_DOT_* floors approach.
MIN_COSINE = 0.02
# Microfacet lobes below r = 0.05 (α = 0.0025) peak at D ≈ 5e4 within 0.003 rad;
# a float32 half vector (error ~1e-7 rad) then moves D by more than 1e-4.
MIN_ROUGHNESS = 0.05
# Model-level Phong/Blinn–Phong: (r·v)ⁿ amplifies the ~7e-7 absolute error of
# r·v formed from float32 vectors (normalised on the device) by n: 1.5e-4 at
# n = 200 measured; n ≤ 128 keeps it under 1e-4 near the peak.
MAX_SHININESS = 128.0
# Narrow microfacet lobes at grazing angles: the float32 half vector
# normalize(l + v) has a direction error of ~1e-7 / (n·v) rad (|l + v| → 2 n·v at
# the mirror), and D amplifies it by ~2/α near its peak (Beckmann's exponent
# more). Measured max error: 8.6e-4 (GGX) and 1.5e-3 (Beckmann) at α ≈ 0.003,
# n·l ≈ n·v ≈ 0.02; α · min(n·l, n·v) ≥ 5e-3 keeps both under 1e-4. This is the
# conditioning of float32 directions, not a term: tests/device/test_terms.py feeds D
# its n·h directly and stays at ~1e-6.
MIN_ALPHA_COSINE = 5.0e-3
# Default number of random samples per model or term.
SAMPLES = 100_000

# Random parameter ranges (inputs outside the ranges that change nothing are not sampled).
IOR_RANGE = (1.05, 3.0)          # dielectric η; kdks F0 = ((η−1)/(η+1))²
CONDUCTOR_ETA_RANGE = (0.05, 3.0)
CONDUCTOR_K_RANGE = (0.0, 6.0)


@dataclass(frozen=True)
class Accuracy:
    """The result of one comparison."""
    name: str
    samples: int
    max_rel_err: float
    median_rel_err: float
    worst_input: str        # a readable description of the worst sample
    hard_max_rel_err: float | None = None   # models: max also over the hard cases outside the limits
    hard_samples: int = 0

    @property
    def ok(self) -> bool:
        return self.max_rel_err <= TARGET


def _rel_err(f: np.ndarray, g: np.ndarray, floor: np.ndarray) -> np.ndarray:
    """Per-sample max over channels of |f − g| / max(|g|, floor)."""
    f = np.asarray(f, np.float64).reshape(len(floor), -1)
    g = np.asarray(g, np.float64).reshape(len(floor), -1)
    den = np.maximum(np.abs(g), np.asarray(floor, np.float64)[:, None])
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.abs(f - g) / den
    err = np.where(f == g, 0.0, err)           # exact matches, including 0 == 0
    err = np.where(np.isfinite(err), err, np.inf)
    return err.max(axis=1)


def _summary(name: str, err: np.ndarray, describe: Callable[[int], str],
             inside: np.ndarray | None = None) -> Accuracy:
    inside = np.ones(len(err), bool) if inside is None else inside
    index = np.flatnonzero(inside)
    worst = int(index[np.argmax(err[index])])
    hard = None if inside.all() else float(err.max())
    return Accuracy(name, len(index), float(err[worst]), float(np.median(err[index])), describe(worst),
                    hard, int((~inside).sum()))


def f32(x) -> np.ndarray:
    """Round to float32 and return as float64: what the kernel sees, for the reference."""
    return np.asarray(x, np.float64).astype(np.float32).astype(np.float64)


# ---- terms -----------------------------------------------------------------

@dataclass
class TermCase:
    """Inputs of one term kernel (float32 slots x, y, z), the reference and the floor."""
    x: np.ndarray        # (N, 4)
    y: np.ndarray        # (N, 4)
    z: np.ndarray        # (N, 4)
    expected: np.ndarray  # (N, C) float64
    floor: np.ndarray     # (N,)
    channels: int = 1


def _slots(count: int, *columns: np.ndarray) -> np.ndarray:
    out = np.zeros((count, 4), np.float32)
    for i, c in enumerate(columns):
        out[:, i] = c
    return out


def _colour(x: np.ndarray) -> np.ndarray:
    out = np.zeros((len(x), 4), np.float32)
    out[:, :3] = x
    return out


def _peaked_cos(rng: np.random.Generator, count: int, width: np.ndarray) -> np.ndarray:
    """Cosines: half uniform in [0, 1], half within a few `width` radians of the pole."""
    theta = np.abs(rng.normal(size=count)) * 3.0 * width
    near = np.cos(np.minimum(theta, 0.5 * math.pi))
    return np.where(rng.random(count) < 0.5, rng.uniform(0.0, 1.0, count), near)


def _roughness_alpha(rng: np.random.Generator, count: int, low: float) -> np.ndarray:
    return f32(np.maximum(rng.uniform(low, 1.0, count) ** 2, constant("MIN_ALPHA")))


def _cosines(rng: np.random.Generator, count: int) -> np.ndarray:
    return f32(rng.uniform(MIN_COSINE, 1.0, count))


def _unit_hemisphere(rng: np.random.Generator, mu: np.ndarray) -> np.ndarray:
    """Unit vectors about +z with the given cosines and uniform azimuth."""
    phi = rng.uniform(0.0, 2.0 * math.pi, len(mu))
    s = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    return np.stack([s * np.cos(phi), s * np.sin(phi), mu], axis=1)


def _geometry_case(rng: np.random.Generator, count: int):
    """float32 n = z, l, v with n·l, n·v ≥ MIN_COSINE, and their float64 cosines."""
    l = f32(_unit_hemisphere(rng, rng.uniform(MIN_COSINE, 1.0, count)))
    v = f32(_unit_hemisphere(rng, rng.uniform(MIN_COSINE, 1.0, count)))
    ln, vn = R.normalize(l)[0], R.normalize(v)[0]
    h = R.normalize(ln + vn)[0]
    return l, v, ln[:, 2], vn[:, 2], h[:, 2], np.sum(vn * h, axis=1), np.sum(ln * vn, axis=1)


def _d_case(rng, count, reference, peak_of) -> TermCase:
    alpha = _roughness_alpha(rng, count, MIN_ROUGHNESS)
    nh = f32(_peaked_cos(rng, count, alpha))
    sin2 = f32((1.0 - nh) * (1.0 + nh))
    return TermCase(_slots(count, nh, sin2, alpha), _colour(np.zeros((count, 3))), _colour(np.zeros((count, 3))),
                    reference(nh, alpha)[:, None], FLOOR_REL * peak_of(alpha))


def _v_case(rng, count, g) -> TermCase:
    alpha = _roughness_alpha(rng, count, 0.0)
    nl, nv = _cosines(rng, count), _cosines(rng, count)
    zero = _colour(np.zeros((count, 3)))
    return TermCase(_slots(count, nl, nv, alpha), zero, zero, (g(nl, nv, alpha) / (4.0 * nl * nv))[:, None],
                    np.zeros(count))


def _term_cases() -> dict[str, Callable[[np.random.Generator, int], TermCase]]:
    zero = lambda n: _colour(np.zeros((n, 3)))   # noqa: E731

    def cook_torrance(rng, n):
        _, _, nl, nv, nh, vh, _ = _geometry_case(rng, n)
        nl, nv, nh, vh = (f32(x) for x in (nl, nv, nh, vh))
        return TermCase(_slots(n, nl, nv, nh, vh), zero(n), zero(n),
                        (R.g_cook_torrance(nh, nv, nl, vh) / (4.0 * nl * nv))[:, None], np.zeros(n))

    def schlick(rng, n):
        vh, f90 = f32(rng.uniform(0.0, 1.0, n)), f32(rng.uniform(0.0, 1.0, n))
        f0 = f32(rng.uniform(0.0, 1.0, (n, 3)))
        peak = np.maximum(f0.max(axis=1), f90)
        return TermCase(_slots(n, vh, f90), _colour(f0), zero(n), R.f_schlick(vh, f0, f90[:, None]),
                        FLOOR_REL * peak, 3)

    def dielectric(rng, n):
        c = f32(rng.uniform(0.0, 1.0, n))
        eta = f32(rng.uniform(*IOR_RANGE, n))
        return TermCase(_slots(n, c, eta), zero(n), zero(n), R.f_dielectric(c, eta[:, None]),
                        np.full(n, FLOOR_REL))    # peak: F → 1 at grazing

    def conductor(rng, n):
        c = f32(rng.uniform(0.0, 1.0, n))
        eta = f32(rng.uniform(*CONDUCTOR_ETA_RANGE, (n, 3)))
        k = f32(np.where(rng.random((n, 3)) < 0.5, rng.uniform(*CONDUCTOR_K_RANGE, (n, 3)),
                         np.exp(rng.uniform(math.log(1e-4), 0.0, (n, 3)))))   # and nearly lossless ones
        return TermCase(_slots(n, c), _colour(eta), _colour(k), R.f_conductor(c, eta, k), np.full(n, FLOOR_REL), 3)

    def lambert(rng, n):
        return TermCase(_slots(n), zero(n), zero(n), np.full((n, 1), R.fd_lambert()), np.zeros(n))

    def burley(rng, n):
        nl, nv = _cosines(rng, n), _cosines(rng, n)
        lh = f32(rng.uniform(0.0, 1.0, n))
        alpha = _roughness_alpha(rng, n, 0.0)
        return TermCase(_slots(n, nl, nv, lh, alpha), zero(n), zero(n), R.fd_burley(nl, nv, lh, alpha)[:, None],
                        np.zeros(n))

    def oren_nayar(rng, n):
        l, v, nl, nv, _, _, lv = _geometry_case(rng, n)
        sigma = f32(rng.uniform(0.0, 1.0, n))
        normal = np.broadcast_to([0.0, 0.0, 1.0], l.shape)
        return TermCase(_slots(n, f32(nl), f32(nv), f32(lv), sigma), zero(n), zero(n),
                        R.fd_oren_nayar(normal, l, v, sigma)[:, None], np.zeros(n))

    def power(reference):
        def case(rng, n):
            shininess = f32(np.where(rng.random(n) < 0.05, 0.0, np.exp(rng.uniform(0.0, math.log(1e4), n))))
            x = f32(_peaked_cos(rng, n, 1.0 / np.sqrt(shininess + 1.0)))
            return TermCase(_slots(n, x, shininess), zero(n), zero(n), reference(x, shininess)[:, None],
                            np.full(n, FLOOR_REL))   # peak 1 at x = 1
        return case

    return {
        "D_GGX": lambda rng, n: _d_case(rng, n, R.d_ggx, lambda a: 1.0 / (math.pi * a * a)),
        "D_Beckmann": lambda rng, n: _d_case(rng, n, R.d_beckmann,
                                             lambda m: np.maximum(1.0 / (math.pi * m * m), 0.1)),
        "V_SmithGGXCorrelated": lambda rng, n: _v_case(rng, n, R.g_smith_ggx_correlated),
        "V_SmithGGXSeparable": lambda rng, n: _v_case(rng, n, R.g_smith_ggx_separable),
        "V_SmithSchlickGGX": lambda rng, n: _v_case(rng, n, R.g_smith_schlick),
        "V_CookTorrance": cook_torrance,
        "F_Schlick": schlick,
        "F_Dielectric": dielectric,
        "F_Dielectric_unclamped": dielectric,     # the value the counting build checks (kernels/count.h)
        "F_Conductor": conductor,
        "F_Conductor_unclamped": conductor,
        "Fd_Lambert": lambert,
        "Fd_Burley": burley,
        "Fd_OrenNayar": oren_nayar,
        "Fs_Phong": power(R.phong),
        "Fs_BlinnPhong": power(R.blinn_phong),
    }


# The term functions with a kernel in terms.cl and a reference case above.
TERMS: dict[str, Callable[[np.random.Generator, int], TermCase]] = _term_cases()

_TERM_FN = re.compile(r"^INLINE\s+(?:real|vec3)\s+((?:D|V|F|Fd|Fs)_\w+)\s*\(", re.M)


def brdf_term_functions() -> list[str]:
    """Names of the term functions declared in kernels/brdf.h (D_*, V_*, F_*, Fd_*, Fs_*)."""
    return _TERM_FN.findall((kernels_dir() / "brdf.h").read_text(encoding="utf-8"))


def term_source() -> str:
    """simd.h (SIMD = 1), brdf.h and terms.cl, with #line markers naming the files."""
    parts = []
    for name in ("simd.h", "brdf.h", "terms.cl"):
        parts.append(f'#line 1 "{name}"\n' + (kernels_dir() / name).read_text(encoding="utf-8") + "\n")
    return "".join(parts)


def eval_term(name: str, x: np.ndarray, y: np.ndarray, z: np.ndarray, runtime: Runtime | None = None) -> np.ndarray:
    """Run term_<name> of terms.cl on the device; returns (N, 4) float32."""
    rt = runtime or get_runtime()
    cl = rt.cl
    kernel = rt.kernel(term_source(), f"term_{name}", (), label=f"terms.cl ({name})")
    count = len(x)
    bufs = [rt.to_device(np.ascontiguousarray(a, np.float32)) for a in (x, y, z)]
    out = rt.empty(count * 16)
    kernel.set_args(np.uint32(count), *bufs, out)
    cl.enqueue_nd_range_kernel(rt.queue, kernel, (rt.global_size(count),), (rt.local_size,)).wait()
    result = np.empty((count, 4), np.float32)
    cl.enqueue_copy(rt.queue, result, out)
    return result


def term_accuracy(name: str, count: int = SAMPLES, seed: int = 1, runtime: Runtime | None = None) -> Accuracy:
    """Compare term `name` of brdf.h with its float64 reference on `count` random inputs."""
    if name not in TERMS:
        raise ClshadeError(f"term {name!r}: no reference case; known: {', '.join(TERMS)}")
    case = TERMS[name](np.random.default_rng(seed), count)
    f = eval_term(name, case.x, case.y, case.z, runtime)[:, :case.channels]
    err = _rel_err(f, case.expected, case.floor)

    def describe(i: int) -> str:
        args = ", ".join(f"{a:.9g}" for a in case.x[i])
        extra = "" if case.channels == 1 else f"; y = {case.y[i, :3].tolist()}, z = {case.z[i, :3].tolist()}"
        return f"x = ({args}){extra}: kernel {f[i].tolist()}, reference {case.expected[i].tolist()}"

    return _summary(name, err, describe)


# ---- models ----------------------------------------------------------------

def accuracy_models() -> list[Model]:
    """What the accuracy table covers: every preset, each microfacet preset with each
    Fresnel, the diffuse/specular pairs of the study and the Smith–Schlick rung."""
    out: list[Model] = []
    for model in presets():
        if model.uses_fresnel:
            out += [model.with_options(fresnel=fr) for fr in ("schlick", "dielectric", "conductor")]
        else:
            out.append(model)
    out += [Registry().resolve(s) for s in ("oren_nayar+ggx_correlated", "lambert+ggx_correlated", "burley+walter_ggx",
                                 "lambert+ggx_smith_schlick", "lambert+ggx_correlated/kdks")]
    unique = {m.id: m for m in reversed(out)}        # lambert+ggx_correlated is the ggx_correlated preset
    return [unique[i] for i in dict.fromkeys(m.id for m in out)]


def _rotate_to(n: np.ndarray, local: np.ndarray) -> np.ndarray:
    """Express vectors given in the +z frame in the frame of unit normals n."""
    t, b = orthonormal_basis(n)
    return local[:, :1] * t + local[:, 1:2] * b + local[:, 2:3] * n


@dataclass
class ModelCase:
    """Random samples for one model, as the device and the reference see them."""
    samples: Samples
    reference: dict           # keyword arguments of reference.brdf (float32-rounded)


def model_case(model: Model, count: int, rng: np.random.Generator) -> ModelCase:
    """`count` random (n, l, v, parameters) within the documented limits; half of the
    samples of a specular model put l near the mirror direction of v (the peak)."""
    microfacet = model.family == "microfacet"
    specular = model.specular != NONE
    n = R.normalize(rng.normal(size=(count, 3)))[0]
    roughness = f32(rng.uniform(MIN_ROUGHNESS if microfacet else 0.0, 1.0, count))
    shininess = f32(np.where(rng.random(count) < 0.05, 0.0,
                             np.exp(rng.uniform(0.0, math.log(MAX_SHININESS), count))))
    v_local = _unit_hemisphere(rng, rng.uniform(MIN_COSINE, 1.0, count))
    l_local = _unit_hemisphere(rng, rng.uniform(MIN_COSINE, 1.0, count))
    if specular:
        # Near the peak: reflect v about a normal tilted by ~ the lobe's width.
        width = np.maximum(roughness, constant("MIN_ALPHA")) ** 2 if microfacet else 1.0 / np.sqrt(shininess + 1.0)
        tilt = _unit_hemisphere(rng, np.cos(np.minimum(np.abs(rng.normal(size=count)) * 2.0 * width, 1.5)))
        mirror = 2.0 * np.sum(v_local * tilt, axis=1, keepdims=True) * tilt - v_local
        use = (rng.random(count) < 0.5) & (mirror[:, 2] >= MIN_COSINE)
        l_local = np.where(use[:, None], mirror, l_local)
    l, v = f32(_rotate_to(n, l_local)), f32(_rotate_to(n, v_local))
    n = f32(n)
    base = f32(rng.uniform(0.0, 1.0, (count, 3)))
    metallic = f32(rng.uniform(0.0, 1.0, count))
    mats = np.zeros((count, 4, 4), np.float32)
    mats[:, 0, 0] = rng.uniform(0.0, 1.0, count)          # kd
    mats[:, 0, 1] = rng.uniform(0.0, 1.0, count)          # ks
    mats[:, 0, 2] = 1.0                                   # ka
    mats[:, 0, 3] = shininess
    mats[:, 1, 0] = rng.uniform(*IOR_RANGE, count)        # ior
    mats[:, 1, 1] = np.where(rng.random(count) < 0.5, 1.0, rng.uniform(0.0, 1.0, count))   # Schlick f90
    mats[:, 2, :3] = rng.uniform(*CONDUCTOR_ETA_RANGE, (count, 3))
    mats[:, 3, :3] = rng.uniform(*CONDUCTOR_K_RANGE, (count, 3))
    samples = Samples(n, l, v, base, roughness, metallic, mats)
    m = mats.astype(np.float64)
    ior = m[:, 1, 0]
    ref = dict(base_color=base, roughness=roughness, metallic=metallic, workflow=model.workflow,
               fresnel=model.fresnel, ior=ior, eta=m[:, 2, :3], k=m[:, 3, :3], kd=m[:, 0, 0], ks=m[:, 0, 1],
               shininess=m[:, 0, 3], f90=m[:, 1, 1], alpha_floor=constant("MIN_ALPHA"))
    if model.workflow == "kdks" and model.uses_fresnel:
        ref["f0"] = (((ior - 1.0) / (ior + 1.0)) ** 2)[:, None]
    return ModelCase(samples, ref)


def reference_brdf(model: Model, n: np.ndarray, l: np.ndarray, v: np.ndarray, ref: dict) -> np.ndarray:
    """reference.brdf for a clshade Model."""
    return R.brdf(model.diffuse, model.specular, n, l, v, **ref)


# The float64 references a float32 lobe is measured against.
ORACLE, FP64 = "oracle", "fp64"


def model_accuracy(model: Model, count: int = SAMPLES, seed: int = 1, runtime: Runtime | None = None,
                   reference: str | None = None) -> Accuracy:
    """Compare eval_brdf (precise math) with a float64 reference on ≥ `count` random samples
    inside the documented limits; the hard cases drawn outside them are reported apart.
    `reference`: ORACLE (reference.brdf, the independent Python formulas; the default for
    built-in models) or FP64 (the lobe's own double-precision device build; the only one a
    user's lobe has)."""
    reference = reference or (FP64 if model.is_users else ORACLE)
    microfacet = model.family == "microfacet"
    total = int(count * 1.2) if microfacet else count    # ~11 % fall below MIN_ALPHA_COSINE
    case = model_case(model, total, np.random.default_rng(seed))
    s = case.samples
    n, l, v = (np.asarray(x, np.float64) for x in (s.n, s.l, s.v))
    f = eval_brdf(model, s, runtime)
    nn = R.normalize(n)[0]
    mirror = R.reflect(R.normalize(v)[0], nn)
    if reference == FP64:
        g = eval_brdf(model, s, runtime, double=True)
        g_mirror = eval_brdf(model, replace(s, l=mirror.astype(np.float32)), runtime, double=True)
    else:
        g = reference_brdf(model, n, l, v, case.reference)
        g_mirror = reference_brdf(model, n, mirror, v, case.reference)
    peak = np.maximum(g.max(axis=1), g_mirror.max(axis=1))
    err = _rel_err(f, g, FLOOR_REL * peak)
    nl = np.sum(nn * R.normalize(l)[0], axis=1)
    nv = np.sum(nn * R.normalize(v)[0], axis=1)
    inside = np.ones(len(err), bool)
    if microfacet:
        alpha = np.maximum(np.asarray(s.roughness, np.float64) ** 2, constant("MIN_ALPHA"))
        inside = alpha * np.minimum(nl, nv) >= MIN_ALPHA_COSINE

    def describe(i: int) -> str:
        mat = s.materials[i]
        return (f"n·l = {nl[i]:.4g}, n·v = {nv[i]:.4g}, "
                f"r = {s.roughness[i]:.4g}, metallic = {s.metallic[i]:.4g}, base = {s.base[i].tolist()}, "
                f"shininess = {mat[0, 3]:.4g}, ior = {mat[1, 0]:.4g}: kernel {f[i].tolist()}, reference {g[i].tolist()}")

    return _summary(model.id, err, describe, inside)


def oracle_agreement(model: Model, count: int = SAMPLES, seed: int = 1, runtime: Runtime | None = None) -> Accuracy:
    """The double-precision device build of a built-in model against the Python oracle on the
    samples of model_accuracy: where both float64 references exist, how far apart they are
    (bounded by the float constants of the shared kernel source, e.g. π as a float)."""
    case = model_case(model, count, np.random.default_rng(seed))
    s = case.samples
    n, l, v = (np.asarray(x, np.float64) for x in (s.n, s.l, s.v))
    f = eval_brdf(model, s, runtime, double=True)
    g = reference_brdf(model, n, l, v, case.reference)
    err = _rel_err(f, g, FLOOR_REL * np.maximum(g.max(axis=1), np.finfo(np.float64).tiny))
    return _summary(model.id, err, lambda i: f"device {f[i].tolist()}, oracle {g[i].tolist()}")
