"""The frame oracle: the whole shading pass at image level. The covered pixels of a G-buffer with
their view geometry, each light's direction and irradiance, the shadow lookup in the kernel's
shadow maps, ambient and emitted light, and :func:`radiance`, the image the kernel should write."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from clshade.models.model import NONE, Model
from clshade.render.gbuffer import GBuffer
from clshade.render.scene import Camera, Scene
from clshade.render.shadows import ShadowMaps, shadow_visibility as _map_visibility
from clshade.render.transforms import pixel_rays
from clshade.verify.reference.compose import brdf, uses_fresnel
from clshade.verify.reference.constants import (DIELECTRIC_F0, MIN_ALPHA, MIN_LIGHT_DIST2, MIN_SHININESS,
                                                SHADOW_BIAS_TEXELS, SHADOW_NORMAL_OFFSET_TEXELS)
from clshade.verify.reference.vectors import _ERR, Array, _dot, _f, normalize, precision

# The shadow lookup's offsets as the oracle states them (constants.py), never shadow.h's defaults.
_SHADOW_OFFSETS = dict(normal_offset=SHADOW_NORMAL_OFFSET_TEXELS, bias=SHADOW_BIAS_TEXELS)


@dataclass(frozen=True)
class Pixels:
    """The covered pixels of a G-buffer as the shading pass sees them (K pixels)."""

    index: NDArray[np.intp]   # (K,) flat pixel index, row 0 at the top
    P: Array                  # (K, 3) world position: eye + depth along the camera axis
    n: Array                  # (K, 3) unit shading normal (the viewer's direction where unusable)
    v: Array                  # (K, 3) unit direction towards the eye
    base: Array               # (K, 3) base colour, >= 0
    roughness: Array          # (K,) in [0, 1]
    metallic: Array           # (K,) in [0, 1]
    material: Array           # (K, 4, 4) the pixel's row of the material table (surface.h layout)
    tangent: Array | None = None   # (K, 3) the G-buffer's mesh tangent, where it carries one


def pixels(gbuffer: GBuffer, camera: Camera) -> Pixels:
    """Read the covered pixels of ``gbuffer`` (depth > 0) with their view geometry.

    The eye ray of pixel (i, j) passes through its centre (j + 0.5, i + 0.5)
    (scenes/README.md; :func:`clshade.render.transforms.pixel_rays`); the
    G-buffer depth is measured along the camera axis, so the point is
    ``eye + d * depth / (d . forward)``.  Inputs are clamped to their documented
    ranges (base >= 0, roughness and metallic in [0, 1]).
    """
    ch = gbuffer.channels
    index = np.flatnonzero(ch["depth"] > 0)
    cam = camera.with_size(gbuffer.width, gbuffer.height)
    _, d = pixel_rays(cam.view_matrix(), cam.projection_matrix(), cam.width, cam.height, index)
    fwd = cam.basis()[0]
    P = np.asarray(cam.position, np.float64) + d * (ch["depth"][index].astype(np.float64) / _dot(d, fwd))[:, None]
    v = _f(-d)
    n, ok = normalize(_f(ch["normal"].reshape(-1, 3)[index]))
    n = np.where(ok[:, None], n, v)
    rows = gbuffer.materials[ch["material"][index].astype(np.intp)] if len(gbuffer.materials) \
        else np.zeros((len(index), 4, 4), np.float32)
    return Pixels(index, _f(P), n, v, np.maximum(_f(ch["base"].reshape(-1, 3)[index]), 0.0),
                  np.clip(_f(ch["roughness"][index]), 0.0, 1.0), np.clip(_f(ch["metallic"][index]), 0.0, 1.0),
                  _f(rows), _f(ch["tangent"].reshape(-1, 3)[index]) if "tangent" in ch else None)


def spot_cone(cos_axis: ArrayLike, cos_outer: float, cos_inner: float) -> Array:
    """Spot falloff (scenes/README.md): 1 inside the inner angle, 0 outside the outer,
    ``t**2`` between, t the position of the cosine between the two cone cosines."""
    c = _f(cos_axis)
    if cos_inner <= cos_outer:           # no transition band: a hard edge at the outer cone
        return np.where(c >= cos_outer, _f(1.0), _f(0.0))
    t = np.clip((c - cos_outer) / (cos_inner - cos_outer), 0.0, 1.0)
    return t * t


def light_rays(scene: Scene, px: Pixels) -> Iterator[tuple[int, Array, Array]]:
    """(scene light index, unit direction towards the light l (K, 3), irradiance E (K, 3))
    per light, in scene order: directional E = irradiance; point and spot
    E = intensity / r**2 (r**2 floored at the kernels' MIN_LIGHT_DIST2, a light on the
    surface), spot times :func:`spot_cone`."""
    min_d2 = MIN_LIGHT_DIST2
    for i, light in enumerate(scene.lights):
        colour = _f(light.color)
        if light.kind == "directional":
            l, _ = normalize(-_f(light.direction))
            yield i, np.broadcast_to(l, px.P.shape), np.broadcast_to(colour, px.P.shape)
            continue
        d = _f(light.position) - px.P
        d2 = np.maximum(_dot(d, d), min_d2)
        l = d / np.sqrt(d2)[:, None]
        E = colour / d2[:, None]
        if light.kind == "spot":
            axis, _ = normalize(_f(light.direction))
            cone = spot_cone(-_dot(l, axis), math.cos(math.radians(light.outer_angle)),
                             math.cos(math.radians(light.inner_angle)))
            E = E * cone[:, None]
        yield i, l, E


def kernel_shininess(shininess: ArrayLike) -> Array:
    """The exponent as the kernels read it (kernels/brdf.h shininess_is_zero): |n| below
    MIN_SHININESS is 0, the value a build that flushes denormals sees."""
    s = _f(shininess)
    return np.where(np.abs(s) < MIN_SHININESS, 0.0, s)


def surface_args(model: Model, base: ArrayLike, roughness: ArrayLike, metallic: ArrayLike, material: ArrayLike,
                 alpha_floor: float) -> dict:
    """Keyword arguments of :func:`brdf` for a clshade model at K points: base (K, 3),
    roughness and metallic (K,), material (K, 4, 4) rows of the material table
    (surface.h layout: kd, ks, ka, shininess | ior, f90 | eta | k). Metallic
    workflow: F0 from base and metallic; k_d + k_s = 1: the material's kd, ks and
    F0 = ((ior - 1)/(ior + 1))**2. Shininess as the kernels read it (kernel_shininess)."""
    m = _f(material)
    args = dict(base_color=_f(base), roughness=_f(roughness), metallic=_f(metallic), workflow=model.workflow,
                fresnel=model.fresnel, ior=m[:, 1, 0], f90=m[:, 1, 1], eta=m[:, 2, :3], k=m[:, 3, :3],
                shininess=kernel_shininess(m[:, 0, 3]), alpha_floor=alpha_floor)
    if model.workflow == "kdks":
        r0 = (m[:, 1, 0] - 1.0) / (m[:, 1, 0] + 1.0)
        args.update(kd=m[:, 0, 0], ks=m[:, 0, 1], f0=(r0 * r0)[:, None])
    return args


def normal_reflectance(model: Model, px: Pixels) -> Array:
    """F0, the reflectance at normal incidence of the workflow (scenes/README.md):
    ``mix(0.04, base, metallic)`` (metallic), ``((ior - 1)/(ior + 1))**2`` (k_d + k_s = 1)."""
    if model.workflow == "kdks":
        r0 = (px.material[:, 1, 0] - 1.0) / (px.material[:, 1, 0] + 1.0)
        return np.broadcast_to((r0 * r0)[:, None], px.base.shape)
    m = px.metallic[:, None]
    return DIELECTRIC_F0 * (1.0 - m) + px.base * m


def ambient(model: Model, px: Pixels, A: ArrayLike) -> Array:
    """Constant ambient radiance A reflected (scenes/README.md): ``k_a A (k_d diffuse + k_s F0)``.

    Metallic workflow: diffuse colour ``base (1 - metallic)``, k_a = k_s = 1, and
    k_d = 1 - F0 when a Fresnel-bearing specular lobe takes F0's share (1 otherwise);
    k_d + k_s = 1 workflow: the material's k_a, k_d, k_s and diffuse colour = base.
    A model without a diffuse (specular) lobe has no diffuse (F0) part.
    """
    f0 = normal_reflectance(model, px)
    m = px.material
    if model.workflow == "kdks":
        ka, ks, diffuse = m[:, 0, 2], m[:, 0, 1], px.base * m[:, 0, 0][:, None]
    else:
        ka, ks = np.ones_like(px.roughness), np.ones_like(px.roughness)
        colour = px.base * (1.0 - px.metallic)[:, None]
        diffuse = colour * (1.0 - f0) if uses_fresnel(model) else colour
    out = _f(np.zeros(px.base.shape))
    if model.diffuse != NONE:
        out = out + diffuse
    if model.specular != NONE:
        out = out + ks[:, None] * f0
    return (ka[:, None] * _f(A)) * out


def device_f64(model: Model, n: ArrayLike, l: ArrayLike, v: ArrayLike, base: ArrayLike, roughness: ArrayLike,
               metallic: ArrayLike, material: ArrayLike, tangent: ArrayLike | None = None) -> Array:
    """f of a model with a user's lobe, which has no formula here: its double-precision build
    on the device (clshade.device.evaluate, the same source as the float32 kernel in
    float64), at the float32-rounded inputs the kernel sees. (K, 3) float64."""
    from clshade.device.evaluate import Samples, eval_brdf
    f4 = lambda x: np.ascontiguousarray(np.asarray(x, np.float32))   # noqa: E731
    samples = Samples(f4(n), f4(l), f4(v), f4(base), f4(roughness), f4(metallic), f4(material),
                      None if tangent is None else f4(tangent))
    return eval_brdf(model, samples, double=True)


def radiance(
    gbuffer: GBuffer,
    scene: Scene,
    model: Model,
    *,
    visibility: ArrayLike | None = None,
    dtype: type = np.float64,
    camera: Camera | None = None,
    alpha_floor: float | None = None,
    shadows: ShadowMaps | None = None,
) -> Array:
    """The radiance the shading pass should write, (H, W, 3), in ``dtype``.

    Covered pixels: ``sum over lights of f(n, l, v) * max(n.l, 0) * E * visibility``
    plus :func:`ambient` (times the G-buffer's ambient occlusion when it has one) plus
    the emitted radiance (when the G-buffer has an emissive channel); f is :func:`brdf` of ``model`` (either workflow, any
    Fresnel) with the pixel's G-buffer inputs (textures are already sampled into
    them) and material-table row; lights as in :func:`light_rays`.  Empty pixels:
    the scene's background.  ``visibility`` is ``(num_lights, H, W)`` in [0, 1]
    (scene order; :func:`visibility` computes it from the shadow maps the kernel
    reads); None = unshadowed, unless ``shadows`` (the frame's shadow maps) is given:
    then the lookup is done here.  ``alpha_floor`` defaults to the kernels' MIN_ALPHA
    (documented: roughness below 0.01 renders as 0.01).  Nothing is clamped
    at the top (the kernels' MAX_RADIANCE is not part of the physics).  f = 0 where
    n.v <= 0 (the kernels floor n.v instead: compare where n.v > 0).
    ``dtype=np.float32`` is the NumPy baseline: the same code in single precision.
    """
    camera = scene.camera if camera is None else camera
    alpha_floor = MIN_ALPHA if alpha_floor is None else alpha_floor
    h, w = gbuffer.height, gbuffer.width
    with precision(dtype):
        px = pixels(gbuffer, camera)
        if visibility is not None:
            vis = _f(visibility).reshape(len(scene.lights), -1)[:, px.index]
        else:   # looked up here (or unshadowed): the same as visibility(gbuffer, scene, shadows, camera)
            vis = None if shadows is None else _f(_map_visibility(shadows, px.P, px.n, **_SHADOW_OFFSETS))
        args = surface_args(model, px.base, px.roughness, px.metallic, px.material, alpha_floor)
        L = _f(np.zeros((len(px.index), 3)))
        for i, l, E in light_rays(scene, px):
            if vis is not None:
                E = E * vis[i][:, None]
            nl = _dot(px.n, l)
            lit = np.flatnonzero((nl > 0.0) & (E.max(axis=1) > 0.0))    # the work this light needs
            if not len(lit):
                continue
            sub = {k: (a[lit] if isinstance(a, np.ndarray) and a.ndim and len(a) == len(px.index) else a)
                   for k, a in args.items()}
            if model.is_users:
                f = _f(device_f64(model, px.n[lit], l[lit], px.v[lit], px.base[lit], px.roughness[lit],
                                  px.metallic[lit], px.material[lit],
                                  None if px.tangent is None else px.tangent[lit]))
            else:
                f = brdf(model.diffuse, model.specular, px.n[lit], l[lit], px.v[lit], **sub)
            with np.errstate(**_ERR):
                L[lit] += f * (E[lit] * nl[lit][:, None])
        if any(a > 0 for a in scene.ambient):
            reflected = ambient(model, px, scene.ambient)
            if "occlusion" in gbuffer.channels:      # glTF occlusion: the ambient term only
                reflected = reflected * np.clip(_f(gbuffer.channels["occlusion"][px.index]), 0.0, 1.0)[:, None]
            L = L + reflected
        if "emissive" in gbuffer.channels:           # emitted radiance, added unlit
            L = L + np.maximum(_f(gbuffer.channels["emissive"].reshape(-1, 3)[px.index]), 0.0)
        out = np.empty((h * w, 3), dtype)
        out[:] = np.asarray(scene.background, dtype)
        out[px.index] = L
    return out.reshape(h, w, 3)


def visibility(gbuffer: GBuffer, scene: Scene, shadows: ShadowMaps | None, camera: Camera | None = None,
               *, offset: tuple[float, float] = (0.0, 0.0)) -> Array | None:
    """(num_lights, H, W) shadow factor of every covered pixel, looked up in the shadow
    maps the kernel reads (:func:`clshade.render.shadows.shadow_visibility`, float64);
    1 for lights without a map and for empty pixels; None without shadow maps.
    ``offset`` shifts the lookup by that many map texels (to find pixels at a texel edge)."""
    if shadows is None:
        return None
    camera = scene.camera if camera is None else camera
    px = pixels(gbuffer, camera)
    out = np.ones((len(scene.lights), gbuffer.pixels))
    out[:, px.index] = _map_visibility(shadows, px.P, px.n, offset=offset, **_SHADOW_OFFSETS)
    return out.reshape(len(scene.lights), gbuffer.height, gbuffer.width)
