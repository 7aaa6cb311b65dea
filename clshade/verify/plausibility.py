"""Physical plausibility of every preset, measured on the OpenCL device.

For each model, over a parameter sweep (white base colour), with every f value
from eval_brdf (kernels/eval.cl, exactly what renders):

* non-negativity — the minimum of f over every evaluated point;
* reciprocity — max |f(l, v) − f(v, l)| / max(f(l, v), f(v, l), FLOOR_REL·peak)
  over random pairs with n·l, n·v ≥ MIN_COSINE, both orders evaluated;
* energy conservation — the maximum directional albedo A(v) = ∫ f (n·l) dω_l
  over VIEW_COSINES, by a composite Gauss–Legendre rule in μ = n·l × φ whose
  panels are graded towards the mirror direction and the pole; the rule runs at
  two orders and |fine − coarse| is the stated quadrature error.

Verdicts: non-negative (min f ≥ 0, all finite), reciprocal (error ≤
RECIPROCITY_TOL), energy conserving (every lobe's albedo and the composed
model's albedo ≤ 1 + ENERGY_TOL); "physically based" = all three. Each lobe is
measured at its most reflective setting — the diffuse lobe with a white
diffuse colour, the specular lobe with F = 1 (metallic 1, white base: Schlick
with f0 = f90 = 1) or k_s = 1 — because that is where a lobe can create
energy. The composed model as it renders (metallic 0 with a white base, or the
study's k_d = 0.7, k_s = 0.3) is measured too: the metallic workflow couples
its lobes with k_d = (1 − F(n·l))(1 − F(n·v)) (kernels/compose.h).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from clshade.device.evaluate import Samples, constant_materials, eval_brdf
from clshade.verify import quadrature
from clshade.models.brdf_file import FAMILY as BRDF_FAMILY
from clshade.models.lobe import Lobe
from clshade.models.model import NONE, Model, presets
from clshade.models.registry import Registry
from clshade.device.runtime import Runtime, get_runtime

# Albedo may exceed 1 by this much and still count as conserving energy: the
# quadrature error estimate of the default sweep is ≤ 1e-5 (stated per row) and
# float32 accumulation ~1e-6; 1e-3 is also the closed-form checks' tolerance.
ENERGY_TOL = 1.0e-3
# Reciprocity holds to float32 rounding (measured ~1e-6); 1e-4 is the accuracy
# target of the kernels, so a real asymmetry (a one-sided clamp) stands out.
RECIPROCITY_TOL = 1.0e-4
# f below this fraction of the sweep's peak is compared in absolute terms.
FLOOR_REL = 1.0e-3
# Reciprocity pairs: cosines ≥ 0.02 (the accuracy tests' grazing limit).
MIN_COSINE = 0.02
RECIPROCITY_PAIRS = 4000

# The sweep. View cosines n·v: θv = 0°, 46°, 73°, 84°.
VIEW_COSINES = (1.0, 0.7, 0.3, 0.1)
# Roughness r: the diffuse lobes from 0 (Lambert/Burley's smooth end; Oren–Nayar
# peaks at albedo 1.01 near σ = 0.15 at grazing views); the microfacet lobes from
# 0.1 (α = 0.01, a lobe 0.02 rad wide that the graded panels resolve to ~1e-6).
DIFFUSE_ROUGHNESS = (0.0, 0.15, 0.25, 0.5, 0.75, 1.0)
MICROFACET_ROUGHNESS = (0.1, 0.25, 0.5, 0.75, 1.0)
SHININESS = (1.0, 8.0, 32.0, 128.0, 512.0)
# Quadrature: Gauss–Legendre order per panel (coarse; fine = 2×), grading
# levels towards the peak and their ratio (smallest panel RATIO**LEVELS).
ORDER = 6
LEVELS = 8
RATIO = 0.25


@dataclass(frozen=True)
class Sweep:
    """Which parameters and views a measurement covers."""
    diffuse_roughness: tuple[float, ...] = DIFFUSE_ROUGHNESS
    microfacet_roughness: tuple[float, ...] = MICROFACET_ROUGHNESS
    shininess: tuple[float, ...] = SHININESS
    view_cosines: tuple[float, ...] = VIEW_COSINES
    order: int = ORDER
    levels: int = LEVELS
    pairs: int = RECIPROCITY_PAIRS


# The reduced sweep behind `clshade models` (a few seconds): the settings where
# the full sweep finds each lobe's largest albedo (Oren–Nayar σ = 0.15 and
# Burley r = 1 at grazing, Phong n = 1, normalised Blinn–Phong n = 8).
QUICK = Sweep(diffuse_roughness=(0.15, 1.0), microfacet_roughness=(0.25, 1.0), shininess=(1.0, 8.0, 128.0),
              view_cosines=(1.0, 0.1), order=6, levels=6, pairs=500)


# ---- quadrature --------------------------------------------------------------

def hemisphere_rule(view_cos: float, order: int, levels: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes l (M, 3) and weights (M,) of ∫ g(l) (n·l) dω over the hemisphere of n = +z,
    for v = (√(1−μv²), 0, μv): clshade.verify.quadrature's rule (the reference's), graded
    (factor RATIO) towards the mirror direction and the pole. The (n·l) factor is in the weights."""
    n, t, b = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    l, w = quadrature.hemisphere_rule(n, t, b, view_cos, 0.0 if view_cos < 1.0 else None, order, order, levels, RATIO)
    return l.reshape(-1, 3), w.ravel()


def view_vector(view_cos: float) -> np.ndarray:
    return np.array([math.sqrt(max(1.0 - view_cos * view_cos, 0.0)), 0.0, view_cos])


# ---- configurations ------------------------------------------------------------

@dataclass(frozen=True)
class Setting:
    """One point of the sweep: the per-pixel and per-material parameters."""
    roughness: float = 0.5
    metallic: float = 0.0
    shininess: float = 32.0
    kd: float = 0.7
    ks: float = 0.3

    def describe(self, model: Model) -> str:
        uses = model.uses
        parts = []
        if "roughness" in uses:
            parts.append(f"r={self.roughness:g}")
        if "shininess" in uses:
            parts.append(f"n={self.shininess:g}")
        if "metallic" in uses and model.specular != NONE:
            parts.append(f"m={self.metallic:g}")
        if model.workflow == "kdks" and model.diffuse != NONE and model.specular != NONE:
            parts.append(f"kd={self.kd:g},ks={self.ks:g}")
        return " ".join(parts) or "-"


def _settings(model: Model, sweep: Sweep, *, lobe_only: bool) -> list[Setting]:
    """The sweep for a model: its roughness or shininess grid; lobe_only puts the
    specular lobe at F = 1 (metallic 1) or k_s = 1."""
    specular = model.specular_lobe
    if specular is not None and specular.family == BRDF_FAMILY:
        return [Setting()]          # a .brdf file's parameters are compiled in: one setting
    if specular is not None and specular.family == "empirical":
        kd, ks = (0.0, 1.0) if lobe_only else (0.7, 0.3)
        return [Setting(shininess=s, kd=kd, ks=ks) for s in sweep.shininess]
    if specular is not None:
        metallic = 1.0 if lobe_only else 0.0
        return [Setting(roughness=r, metallic=metallic) for r in sweep.microfacet_roughness]
    if "roughness" in model.uses:
        return [Setting(roughness=r, kd=1.0) for r in sweep.diffuse_roughness]
    return [Setting(kd=1.0)]


def _samples(l: np.ndarray, v: np.ndarray, settings: list[Setting]) -> Samples:
    """Samples for every setting × every (l, v) row, n = +z, white base."""
    m, p = len(l), len(settings)
    rep = lambda values: np.repeat(np.asarray(values, np.float64), m)   # noqa: E731
    mats = constant_materials(m * p, shininess=rep([s.shininess for s in settings]))
    mats[:, 0, 0] = rep([s.kd for s in settings])
    mats[:, 0, 1] = rep([s.ks for s in settings])
    n = np.broadcast_to([0.0, 0.0, 1.0], (m * p, 3))
    return Samples(n, np.tile(l, (p, 1)), np.tile(v, (p, 1)), np.ones((m * p, 3)),
                   rep([s.roughness for s in settings]), rep([s.metallic for s in settings]), mats)


@dataclass
class Measurement:
    """One model (or lobe) over its sweep."""
    model: str
    settings: list[str]
    min_f: float
    finite: bool
    max_reciprocity_error: float
    albedo: list[list[float]]          # [setting][view]
    albedo_error: list[list[float]]    # quadrature error estimate, same shape
    view_cosines: list[float]

    @property
    def max_albedo(self) -> float:
        return float(np.max(self.albedo))

    @property
    def argmax_albedo(self) -> str:
        i, j = np.unravel_index(int(np.argmax(self.albedo)), np.shape(self.albedo))
        return f"{self.settings[i]}, n·v={self.view_cosines[j]:g}"

    @property
    def max_quadrature_error(self) -> float:
        return float(np.max(self.albedo_error))


def measure(model: Model, settings: list[Setting], sweep: Sweep = Sweep(), runtime: Runtime | None = None,
            seed: int = 7) -> Measurement:
    """Albedo, reciprocity and the minimum of f for `model` over `settings` (white base)."""
    rt = runtime or get_runtime()
    min_f, finite = math.inf, True
    albedo = np.zeros((len(settings), len(sweep.view_cosines)))
    error = np.zeros_like(albedo)
    for j, mu_v in enumerate(sweep.view_cosines):
        v = view_vector(mu_v)
        values = []
        for order in (sweep.order, 2 * sweep.order):
            l, w = hemisphere_rule(mu_v, order, sweep.levels)
            f = eval_brdf(model, _samples(l, np.broadcast_to(v, l.shape), settings), rt)
            finite &= bool(np.isfinite(f).all())
            min_f = min(min_f, float(np.min(f)))
            f = f.astype(np.float64).reshape(len(settings), len(l), 3)
            values.append(np.einsum("m,pmc->pc", w, f).max(axis=1))
        albedo[:, j], error[:, j] = values[1], np.abs(values[1] - values[0])
    # Reciprocity: both orders of the same random pairs.
    rng = np.random.default_rng(seed)

    def hemi(count: int) -> np.ndarray:
        mu = rng.uniform(MIN_COSINE, 1.0, count)
        phi = rng.uniform(0.0, 2.0 * math.pi, count)
        s = np.sqrt(1.0 - mu * mu)
        return np.stack([s * np.cos(phi), s * np.sin(phi), mu], axis=1)

    a, b = hemi(sweep.pairs), hemi(sweep.pairs)
    # Half the pairs near the mirror configuration, where the narrow lobes live.
    mirror = b * np.array([-1.0, -1.0, 1.0]) + 0.02 * rng.normal(size=b.shape)
    mirror[:, 2] = np.maximum(mirror[:, 2], MIN_COSINE)
    a[: sweep.pairs // 2] = mirror[: sweep.pairs // 2]
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    f_ab = eval_brdf(model, _samples(a, b, settings), rt).astype(np.float64).reshape(len(settings), -1, 3)
    f_ba = eval_brdf(model, _samples(b, a, settings), rt).astype(np.float64).reshape(len(settings), -1, 3)
    finite &= bool(np.isfinite(f_ab).all() and np.isfinite(f_ba).all())
    min_f = min(min_f, float(f_ab.min()), float(f_ba.min()))
    floor = FLOOR_REL * np.maximum(f_ab.max(axis=(1, 2)), f_ba.max(axis=(1, 2)))[:, None, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        recip = np.abs(f_ab - f_ba) / np.maximum(np.maximum(f_ab, f_ba), floor)
    recip = np.where(f_ab == f_ba, 0.0, recip)
    return Measurement(model.id, [s.describe(model) for s in settings], min_f, finite,
                       float(np.nanmax(recip)) if recip.size else 0.0, albedo.tolist(), error.tolist(),
                       list(sweep.view_cosines))


# ---- verdicts --------------------------------------------------------------------

@dataclass
class Verdict:
    """One preset's row of the plausibility table."""
    preset: str
    name: str
    family: str
    min_f: float
    max_reciprocity_error: float
    max_albedo: float                 # the largest lobe albedo (the verdict's figure)
    max_albedo_at: str
    quadrature_error: float
    composed_albedo: float            # the model as it renders (metallic 0 / k_d 0.7, k_s 0.3)
    composed_albedo_at: str
    lobes: dict[str, tuple[float, str]] = field(default_factory=dict)   # lobe id → (max albedo, where)

    @property
    def non_negative(self) -> bool:
        return self.min_f >= 0.0 and math.isfinite(self.min_f)

    @property
    def reciprocal(self) -> bool:
        return self.max_reciprocity_error <= RECIPROCITY_TOL

    @property
    def energy_conserving(self) -> bool:
        return max(self.max_albedo, self.composed_albedo) <= 1.0 + ENERGY_TOL

    @property
    def physically_based(self) -> bool:
        return self.non_negative and self.reciprocal and self.energy_conserving

    def as_dict(self) -> dict:
        d = asdict(self)
        d.update(non_negative=self.non_negative, reciprocal=self.reciprocal,
                 energy_conserving=self.energy_conserving, physically_based=self.physically_based)
        return d


def lobe_model(lobe: Lobe, preset_model: Model) -> Model:
    """The lobe alone, in the preset's workflow and Fresnel."""
    if lobe.kind == "diffuse":
        return Model(lobe.id, NONE, preset_model.fresnel, preset_model.workflow, lobes=(lobe,))
    return Model(NONE, lobe.id, preset_model.fresnel, preset_model.workflow, lobes=(lobe,))


def evaluate_presets(sweep: Sweep = Sweep(), device: str | None = None,
                     models: list[Model] | None = None, progress=None,
                     registry: Registry | None = None) -> list[Verdict]:
    """Measure every preset and each user lobe of `registry` (or `models`): each lobe at its most
    reflective setting, and the composition as it renders. `progress(done, total)` after each preset."""
    rt = get_runtime(device)
    cache: dict[str, Measurement] = {}

    def lobe_measurement(lobe: Lobe, preset_model: Model) -> Measurement:
        model = lobe_model(lobe, preset_model)
        if model.id not in cache:
            cache[model.id] = measure(model, _settings(model, sweep, lobe_only=True), sweep, rt)
        return cache[model.id]

    out = []
    todo = list(models or presets() + (registry or Registry()).user_models())
    for model in todo:
        parts = {lobe.id: lobe_measurement(lobe, model) for lobe in model.lobes}
        if model.diffuse != NONE and model.specular != NONE:
            composed = measure(model, _settings(model, sweep, lobe_only=False), sweep, rt)
        else:
            composed = next(iter(parts.values()))
        everything = [*parts.values(), composed]
        worst = max(parts.values(), key=lambda m: m.max_albedo)
        out.append(Verdict(
            preset=model.id, name=model.label, family=model.family,
            min_f=min(m.min_f if m.finite else -math.inf for m in everything),
            max_reciprocity_error=max(m.max_reciprocity_error for m in everything),
            max_albedo=worst.max_albedo, max_albedo_at=f"{worst.model}: {worst.argmax_albedo}",
            quadrature_error=max(m.max_quadrature_error for m in everything),
            composed_albedo=composed.max_albedo, composed_albedo_at=composed.argmax_albedo,
            lobes={k: (m.max_albedo, m.argmax_albedo) for k, m in parts.items()}))
        if progress is not None:
            progress(len(out), len(todo))
    return out


def physically_based(device: str | None = None, progress=None) -> dict[str, bool]:
    """Preset id → the measured verdict, from the reduced sweep QUICK (cached in-process)."""
    if device not in _PHYSICALLY_BASED:
        _PHYSICALLY_BASED[device] = {v.preset: v.physically_based
                                     for v in evaluate_presets(QUICK, device, progress=progress)}
    return _PHYSICALLY_BASED[device]


_PHYSICALLY_BASED: dict[str | None, dict[str, bool]] = {}


def albedo(model: Model, setting: Setting, view_cos: float = 1.0, order: int = 2 * ORDER,
           levels: int = LEVELS, runtime: Runtime | None = None) -> tuple[float, float]:
    """Directional albedo of `model` (white base) on the device and its quadrature error."""
    sweep = Sweep(view_cosines=(view_cos,), order=order, levels=levels, pairs=2)
    m = measure(model, [setting], sweep, runtime)
    return m.albedo[0][0], m.albedo_error[0][0]


# ---- the method in words ---------------------------------------------------------


def describe_method(sweep: Sweep = Sweep()) -> list[str]:
    return [
        f"Sweep: white base; roughness {list(sweep.microfacet_roughness)} (microfacet), "
        f"{list(sweep.diffuse_roughness)} (diffuse); shininess {list(sweep.shininess)}; "
        f"view n·v {list(sweep.view_cosines)}.",
        f"Albedo: composite Gauss–Legendre in n·l × φ, order {sweep.order} and {2 * sweep.order} per panel, "
        f"panels graded ×{RATIO} over {sweep.levels} levels towards the mirror direction and the pole; "
        "the stated quadrature error is |order 2k − order k|.",
        f"Verdicts: non-negative = min f ≥ 0 and finite; reciprocal = error ≤ {RECIPROCITY_TOL:g} "
        f"({sweep.pairs} pairs per setting, n·l, n·v ≥ {MIN_COSINE}); energy conserving = every lobe's "
        f"albedo and the composed albedo ≤ 1 + {ENERGY_TOL:g} (diffuse lobe white, specular lobe at F = 1 "
        "or k_s = 1); physically based = all three. 'composed' is the model as it renders (metallic 0 with a "
        "white base, or k_d = 0.7, k_s = 0.3); the metallic workflow couples its lobes with "
        "k_d = (1 − F(n·l))(1 − F(n·v)).",
    ]
