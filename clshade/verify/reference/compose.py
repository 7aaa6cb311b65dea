"""Model composition in one place: the microfacet lobes D G F / (4 n.l n.v) from the terms, which lobe
carries Fresnel, and :func:`brdf`, the f of any diffuse + specular model in either workflow with any
Fresnel."""
from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from clshade.models.model import Model
from clshade.verify.reference.constants import (DIELECTRIC_F0, DIFFUSE_MODELS, EMPIRICAL_MODELS, FRESNEL_LOBES,
                                                INV_PI, MICROFACET_MODELS, SPECULAR_MODELS)
from clshade.verify.reference.terms import (blinn_phong, blinn_phong_normalized, d_beckmann, d_ggx, f_conductor,
                                            f_dielectric, f_schlick, fd_burley, fd_oren_nayar, g_cook_torrance,
                                            g_smith_ggx_correlated, g_smith_ggx_separable, g_smith_schlick, phong,
                                            phong_normalized)
from clshade.verify.reference.vectors import (_ERR, Array, _channels, _cos, _dot, _f, _mul0, _tint,
                                              alpha_from_roughness, geometry, reflect)


def uses_fresnel(model: Model) -> bool:
    """Whether the model's specular lobe carries F (its k_d then takes F's share): stated here
    for the built-in lobes; a user's lobe by its own declaration (it has no formula here)."""
    if model.is_users:
        return model.uses_fresnel
    return model.specular in FRESNEL_LOBES


# --------------------------------------------------------------------------
# microfacet specular lobes: D G F / (4 n.l n.v)
# --------------------------------------------------------------------------


def _microfacet(d: Array, g: Array, nl: Array, nv: Array, fresnel: ArrayLike) -> Array:
    nl, nv = _cos(nl), _cos(nv)
    ok = (nl > 0.0) & (nv > 0.0)
    # G/(n.l)/(n.v) divided one cosine at a time: G vanishes with each cosine, while
    # 4 (n.l)(n.v) underflows to 0 for cosines ~1e-200 (0/0 = NaN otherwise).
    nls, nvs = np.where(ok, nl, 1.0), np.where(ok, nv, 1.0)
    with np.errstate(**_ERR):
        core = np.where(ok, _mul0(d, g / (4.0 * nls) / nvs), 0.0)
    return _tint(core, fresnel)


def cook_torrance(
    nl: ArrayLike, nv: ArrayLike, nh: ArrayLike, vh: ArrayLike, alpha: ArrayLike,
    fresnel: ArrayLike = 1.0,
) -> Array:
    """Cook-Torrance 1982: D_beckmann(m = alpha) G_ct F / (4 n.l n.v)."""
    d = d_beckmann(nh, alpha)
    return _microfacet(d, g_cook_torrance(nh, nv, nl, vh), nl, nv, fresnel)


def walter_ggx(
    nl: ArrayLike, nv: ArrayLike, nh: ArrayLike, vh: ArrayLike, alpha: ArrayLike,
    fresnel: ArrayLike = 1.0,
) -> Array:
    """Walter 2007: D_ggx G1(l) G1(v) F / (4 n.l n.v).  (``vh`` unused.)"""
    return _microfacet(d_ggx(nh, alpha), g_smith_ggx_separable(nl, nv, alpha), nl, nv, fresnel)


def ggx_correlated(
    nl: ArrayLike, nv: ArrayLike, nh: ArrayLike, vh: ArrayLike, alpha: ArrayLike,
    fresnel: ArrayLike = 1.0,
) -> Array:
    """GGX with height-correlated Smith (Heitz 2014).  (``vh`` unused.)"""
    return _microfacet(d_ggx(nh, alpha), g_smith_ggx_correlated(nl, nv, alpha), nl, nv, fresnel)


def ggx_smith_schlick(
    nl: ArrayLike, nv: ArrayLike, nh: ArrayLike, vh: ArrayLike, alpha: ArrayLike,
    fresnel: ArrayLike = 1.0,
) -> Array:
    """GGX with Schlick-Smith G (k = alpha/2).  (``vh`` unused.)"""
    return _microfacet(d_ggx(nh, alpha), g_smith_schlick(nl, nv, alpha), nl, nv, fresnel)


# The formula of each lobe (the registry lists the lobes; these are their float64 terms).
_EMPIRICAL_FN = {"phong": (phong, "r.v"), "phong_normalized": (phong_normalized, "r.v"),
                 "blinn_phong": (blinn_phong, "n.h"), "blinn_phong_normalized": (blinn_phong_normalized, "n.h")}
_DIFFUSE_LOBES = ("lambert", "burley", "oren_nayar", "none")   # the branches of brdf()
_MICROFACET_FN = {
    "cook_torrance": cook_torrance,
    "walter_ggx": walter_ggx,
    "ggx_correlated": ggx_correlated,
    "ggx_smith_schlick": ggx_smith_schlick,
}


# --------------------------------------------------------------------------
# model composition
# --------------------------------------------------------------------------


def check_model(model: Model) -> Model:
    """`model` when :func:`brdf` has a formula for it; else ClshadeError naming the model, raised
    before a command that measures error against this oracle (bench, aa, check stability) spends
    its run on the device. The test is brdf's own validation, on one sample."""
    from clshade.errors import ClshadeError
    from clshade.render.scene import GOLD_ETA, GOLD_K
    if model.is_users:        # no formula here: its float64 reference is its own double build (device_f64)
        return model
    n = np.array([[0.0, 0.0, 1.0]])
    try:
        brdf(model.diffuse, model.specular, n, n, n, base_color=0.5, roughness=0.5, workflow=model.workflow,
             fresnel=model.fresnel, eta=GOLD_ETA, k=GOLD_K)
    except ValueError as exc:
        raise ClshadeError(f"model {model.id!r}: the float64 oracle has no formula for it ({exc}); "
                           f"`clshade render` shades it, error measurements cannot") from None
    return model


def brdf(
    diffuse: str,
    specular: str,
    n: ArrayLike,
    l: ArrayLike,
    v: ArrayLike,
    *,
    base_color: ArrayLike,
    roughness: ArrayLike,
    metallic: ArrayLike = 0.0,
    workflow: Literal["metallic", "kdks"] = "metallic",
    fresnel: Literal["schlick", "dielectric", "conductor"] = "schlick",
    ior: ArrayLike = 1.5,
    eta: ArrayLike | None = None,
    k: ArrayLike | None = None,
    f0: ArrayLike | None = None,
    f90: ArrayLike = 1.0,
    kd: ArrayLike = 1.0,
    ks: ArrayLike = 0.0,
    shininess: ArrayLike = 32.0,
    alpha_floor: ArrayLike = 0.0,
) -> Array:
    """RGB BRDF value f (without cosine), shape ``(..., 3)``.

    diffuse in :data:`DIFFUSE_MODELS`, specular in :data:`SPECULAR_MODELS`.
    ``alpha = alpha_from_roughness(roughness, alpha_floor)``; Oren-Nayar uses
    ``sigma = roughness``.

    Fresnel F (microfacet lobes only; channel-last):
      'schlick'    -- ``f_schlick(v.h, F0, f90)``, ``F0 = f0`` if given, else
                      ``mix(DIELECTRIC_F0, base_color, metallic)``;
      'dielectric' -- ``f_dielectric(v.h, ior)`` (metallic ignored for F);
      'conductor'  -- ``f_conductor(v.h, eta, k)`` (eta, k required).

    workflow 'metallic' (microfacet lobes or specular 'none'):
      ``f = (1 - F(n.l)) (1 - F(n.v)) base (1 - metallic) fd + D G F(v.h) / (4 n.l n.v)``:
      light the specular interface reflects on the way in or out does not
      reach the diffuse substrate (Shirley et al. 1997); without a
      microfacet lobe the weight is 1.
    workflow 'kdks' (the k_d + k_s = 1 study rule; any lobe):
      ``f = kd base fd + ks spec``; empirical lobes are white (no F),
      microfacet lobes still include F.
    Empirical lobes under 'metallic' raise ValueError.
    """
    if diffuse not in DIFFUSE_MODELS:
        raise ValueError(f"unknown diffuse model {diffuse!r}; expected one of {DIFFUSE_MODELS}")
    if specular not in SPECULAR_MODELS:
        raise ValueError(f"unknown specular model {specular!r}; expected one of {SPECULAR_MODELS}")
    if workflow not in ("metallic", "kdks"):
        raise ValueError(f"unknown workflow {workflow!r}; expected 'metallic' or 'kdks'")
    if fresnel not in ("schlick", "dielectric", "conductor"):
        raise ValueError(f"unknown fresnel {fresnel!r}")
    if specular not in (*_MICROFACET_FN, *_EMPIRICAL_FN, "none") or diffuse not in _DIFFUSE_LOBES:
        raise ValueError(f"lobe {diffuse!r}/{specular!r} has no float64 formula in clshade.verify.reference")
    if workflow == "metallic" and specular in EMPIRICAL_MODELS:
        raise ValueError(f"empirical lobe {specular!r} needs workflow='kdks'")
    if fresnel == "conductor" and specular in MICROFACET_MODELS and (eta is None or k is None):
        raise ValueError("fresnel='conductor' needs eta and k")

    g = geometry(n, l, v)
    base = _channels(base_color)
    r = _f(roughness)
    alpha = alpha_from_roughness(r, alpha_floor)
    metallic = _f(metallic)

    # ---- diffuse (scalar lobe, shape S) ----
    if diffuse == "lambert":
        fd = np.where(g.valid, _f(INV_PI), _f(0.0))
    elif diffuse == "burley":
        fd = fd_burley(g.nl, g.nv, g.vh, alpha)
    elif diffuse == "oren_nayar":
        fd = fd_oren_nayar(g.n, g.l, g.v, r)
    else:
        fd = np.zeros_like(g.nl)
    if workflow == "metallic":
        diffuse_colour = base * (1.0 - metallic)[..., None]
    else:
        diffuse_colour = base * _f(kd)[..., None]
    f_diffuse = _tint(fd, diffuse_colour)

    # ---- specular ----
    if specular == "none":
        f_spec = _f(np.zeros(1))
    elif specular in EMPIRICAL_MODELS:
        fn, about = _EMPIRICAL_FN[specular]
        if about == "r.v":
            lobe = fn(_cos(_dot(reflect(g.l, g.n), g.v)), _f(shininess))
        else:   # n.h: undefined without a half vector
            lobe = np.where(g.h_ok, fn(g.nh, _f(shininess)), 0.0)
        f_spec = _tint(lobe, _f(ks)[..., None])
    else:
        if fresnel == "schlick":
            if f0 is None:
                m = metallic[..., None]
                f0_c = DIELECTRIC_F0 * (1.0 - m) + base * m
            else:
                f0_c = _channels(f0)
            f90_c = _f(f90)
            f90_c = f90_c[..., None] if f90_c.ndim else f90_c
            fres = lambda c: f_schlick(c, f0_c, f90_c)  # noqa: E731
        elif fresnel == "dielectric":
            fres = lambda c: f_dielectric(c, _f(ior)[..., None])  # noqa: E731
        else:
            fres = lambda c: f_conductor(c, _channels(eta), _channels(k))  # noqa: E731
        fr = fres(g.vh)
        lobe = _MICROFACET_FN[specular](g.nl, g.nv, g.nh, g.vh, alpha, fr)
        lobe = np.where(g.h_ok[..., None], lobe, 0.0)
        f_spec = lobe if workflow == "metallic" else _mul0(_f(ks)[..., None], lobe)
        if workflow == "metallic":
            f_diffuse = f_diffuse * (1.0 - fres(g.nl)) * (1.0 - fres(g.nv))

    with np.errstate(**_ERR):
        out = f_diffuse + f_spec
    out = out + _f(np.zeros(g.nl.shape + (3,)))
    return np.where(g.valid[..., None], out, 0.0)
