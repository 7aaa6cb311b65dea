"""The torture grid of `clshade check stability`: hard inputs, built once here and
measured by clshade.verify.stability.

Every value is float32 on the device; the reference gets the same
float32-rounded inputs in float64. See clshade/verify/stability.py for the grid's
reading (roughness as r and as α, cosines, normals, Fresnel parameters).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from clshade.device.evaluate import Samples
from clshade.models.model import Model
from clshade.render.scene import GOLD_ETA, GOLD_K
from clshade.verify import reference as R

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


def shade_normals() -> np.ndarray:
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


# ------------------------------------------------ the reference of the grid


def _f32(x: np.ndarray) -> np.ndarray:
    return np.asarray(x, np.float32).astype(np.float64)


def reference_f(model: Model, s: Samples, alpha_floor: float = R.MIN_ALPHA) -> np.ndarray:
    """float64 f of the float32-rounded inputs: the frame oracle's composition
    (reference.surface_args + reference.brdf), true cosines, any Fresnel and f90."""
    n, l, v = _f32(s.n), _f32(s.l), _f32(s.v)
    if model.is_users:       # no formula in Python: the lobe's own float64 build
        return R.device_f64(model, n, l, v, s.base, s.roughness, s.metallic, s.materials)
    args = R.surface_args(model, _f32(s.base), _f32(s.roughness), _f32(s.metallic), _f32(s.materials), alpha_floor)
    with np.errstate(all="ignore"):
        return R.brdf(model.diffuse, model.specular, n, l, v, **args)
