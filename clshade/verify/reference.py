"""Independent float64 NumPy reference of every BRDF term and model in clshade.

Written from the papers, not from the OpenCL kernels, so that the float32
kernels can be checked against it (target: 1e-4 relative).  Everything is
vectorised over leading array dimensions and evaluated in float64.

Conventions
-----------
* Directions ``n``, ``l``, ``v`` are ``(..., 3)`` arrays pointing *away* from
  the surface; they need not be normalised (they are normalised here).  A
  zero-length vector (length <= :data:`EPS_LENGTH`) makes the result 0, never
  NaN.  All cosines are dot products of the normalised vectors.
* ``l`` or ``v`` below the surface (``n.l <= 0`` or ``n.v <= 0``) gives f = 0.
* Half vector ``h = normalize(l + v)``; if ``|l + v| = 0`` the specular terms
  are 0.
* ``roughness`` r in [0, 1] is perceptual; ``alpha = r**2``.  The reference
  evaluates alpha *as given*; the only floor is the ``alpha_floor`` argument,
  applied in one place, :func:`alpha_from_roughness` (``max(r**2, floor)``,
  default 0 = no floor).  Callers comparing with kernels pass the kernels'
  floor (e.g. ``MIN_ALPHA``).  The floored alpha is used by every alpha-based
  term (D, G, Burley's F90).  Oren-Nayar uses ``sigma = r`` (radians, not
  squared, not floored).
* f is the BRDF *without* the cosine: outgoing radiance for one light is
  ``L = f * (n.l) * E``.
* At alpha = 0 the microfacet lobes are a Dirac delta: D (and so the lobe) is
  0 everywhere except exactly at the mirror configuration (``n.h == 1``),
  where it is ``+inf``.  Products are formed so that ``0 * inf = 0`` (e.g. a
  zero Fresnel or ``ks = 0``), never NaN.
* Colour-valued arguments (``f0``, ``f90``, ``eta``, ``k``, ``fresnel``,
  ``base_color``) are scalars or arrays whose **last axis is the channel axis**
  (length 3, or 1 to broadcast).  Scalar-valued per-point arguments (cosines,
  ``alpha``, ``roughness``, ``metallic``, ``kd``, ``ks``, ``shininess``,
  ``ior`` in :func:`brdf`) broadcast over the leading dimensions.  A term fed
  a non-scalar colour argument returns ``(..., C)``.

Terms (one pure function per term)
----------------------------------
========================  ====================================================
``d_ggx``                 Walter et al. 2007 / Trowbridge-Reitz 1975
``d_beckmann``            Beckmann; Cook & Torrance 1982 (m = alpha)
``g_cook_torrance``       Cook & Torrance 1982 V-cavity
``g1_smith_ggx``          Walter et al. 2007 eq. 34 (separable: G1(l)G1(v))
``g_smith_ggx_correlated``  Heitz 2014, height-correlated, via Lambda
``g_smith_schlick``       Schlick 1994 with k = alpha/2
``f_schlick``             Schlick 1994
``f_dielectric``          exact unpolarised Fresnel (s/p amplitudes)
``f_conductor``           exact unpolarised Fresnel, complex IOR eta + i k
``fd_lambert``            1/pi
``fd_burley``             Burley 2012 (Disney)
``fd_oren_nayar``         Oren & Nayar 1994, qualitative model, explicit angles
``phong`` ...             Phong 1975 / Blinn 1977 and the energy-normalised
                          variants (n+2)/(2pi), (n+8)/(8pi)
========================  ====================================================

Models are composed in one place, :func:`brdf`.  :func:`directional_albedo`
integrates ``f cos(theta)`` over the hemisphere with a graded composite
Gauss-Legendre rule and reports an error estimate.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Callable, Iterator, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from clshade.models import NONE, Model
from clshade.render.gbuffer import GBuffer
from clshade.render.scene import Camera, Scene
from clshade.render.shadows import ShadowMaps, shadow_visibility as _map_visibility
from clshade.render.transforms import pixel_rays
from clshade.verify.quadrature import hemisphere_rule

__all__ = [
    "EPS_LENGTH",
    "EPS_TANGENT",
    "DIELECTRIC_F0",
    "DIFFUSE_MODELS",
    "SPECULAR_MODELS",
    "MICROFACET_MODELS",
    "EMPIRICAL_MODELS",
    "Geometry",
    "normalize",
    "reflect",
    "geometry",
    "alpha_from_roughness",
    "d_ggx",
    "d_beckmann",
    "g_cook_torrance",
    "g1_smith_ggx",
    "lambda_ggx",
    "g_smith_ggx_separable",
    "g_smith_ggx_correlated",
    "g_smith_schlick",
    "f_schlick",
    "f_dielectric",
    "f_conductor",
    "fd_lambert",
    "fd_burley",
    "fd_oren_nayar",
    "phong",
    "blinn_phong",
    "phong_normalized",
    "blinn_phong_normalized",
    "cook_torrance",
    "walter_ggx",
    "ggx_correlated",
    "ggx_smith_schlick",
    "brdf",
    "directional_albedo",
]

Array = NDArray[np.float64]

# A vector shorter than this is treated as zero length: its squared length
# (<= 1e-300) is at the bottom of the normal float64 range (~2.2e-308), so its
# direction cannot be recovered reliably.  Unit l + v shorter than this means
# l == -v to rounding.
EPS_LENGTH: float = 1e-150

# Oren-Nayar: if the tangent-plane projection of l or v (= sin(theta)) is
# shorter than this, the azimuth is undefined and the B term is set to 0.  The
# dropped term is <= B * sin(alpha) * tan(beta) <= ~1e-12, so this is
# continuous to that level.
EPS_TANGENT: float = 1e-12

# Schlick F0 of a generic dielectric (IOR ~1.5) in the metallic workflow.
DIELECTRIC_F0: float = 0.04

INV_PI: float = 1.0 / math.pi

# ---- what the oracle states on its own (never read from kernels/) ----------
# The kernels' documented constants and model composition, written here so that a
# wrong value on the kernel side is not inherited by the truth it is checked against;
# tests/test_oracle_constants.py compares each with the kernels' (and the model
# registry's) and fails on any difference, so a change on one side shows.

# shade.cl MIN_LIGHT_DIST2: a point or spot light's squared distance is floored here
# (a light on the surface shades finitely).
MIN_LIGHT_DIST2: float = 1e-8
# brdf.h MIN_ALPHA: the documented floor of α = r² (roughness below 0.01 renders as
# 0.01); radiance() applies it unless given another alpha_floor.
MIN_ALPHA: float = 1e-4
# shadow.h: the shadow lookup moves the point (PCF radius + SHADOW_NORMAL_OFFSET_TEXELS)
# texels along its normal and compares its depth less SHADOW_BIAS_TEXELS texels.
SHADOW_NORMAL_OFFSET_TEXELS: float = 1.0
SHADOW_BIAS_TEXELS: float = 0.5

# The lobes with a float64 formula here, by family (kernels/models/*.cl declare kind and
# family), and the lobes whose f_s carries a Fresnel factor (their `uses: fresnel`).
DIFFUSE_MODELS: tuple[str, ...] = ("burley", "lambert", "oren_nayar", NONE)
MICROFACET_MODELS: tuple[str, ...] = ("cook_torrance", "ggx_correlated", "ggx_smith_schlick", "walter_ggx")
EMPIRICAL_MODELS: tuple[str, ...] = ("blinn_phong", "blinn_phong_normalized", "phong", "phong_normalized")
SPECULAR_MODELS: tuple[str, ...] = EMPIRICAL_MODELS + MICROFACET_MODELS + ("none",)
FRESNEL_LOBES: frozenset[str] = frozenset(MICROFACET_MODELS)


_SHADOW_OFFSETS = dict(normal_offset=SHADOW_NORMAL_OFFSET_TEXELS, bias=SHADOW_BIAS_TEXELS)


def uses_fresnel(model: Model) -> bool:
    """Whether the model's specular lobe carries F (its k_d then takes F's share): stated here
    for the built-in lobes; a user's lobe by its own declaration (it has no formula here)."""
    if model.is_users:
        return model.uses_fresnel
    return model.specular in FRESNEL_LOBES

_ERR = dict(divide="ignore", invalid="ignore", over="ignore", under="ignore")


# --------------------------------------------------------------------------
# small helpers
# --------------------------------------------------------------------------


# The floating-point type every term computes in: float64 (the reference), or
# float32 for the NumPy baseline (clshade.bench), the same code instantiated in
# single precision by :func:`precision`.
_DTYPE: ContextVar[type] = ContextVar("clshade_reference_dtype", default=np.float64)


@contextmanager
def precision(dtype: type) -> Iterator[None]:
    """Evaluate the reference's terms in ``dtype`` (np.float64 or np.float32) inside the block."""
    token = _DTYPE.set(np.dtype(dtype).type)
    try:
        yield
    finally:
        _DTYPE.reset(token)


def _f(x: ArrayLike) -> Array:
    return np.asarray(x, dtype=_DTYPE.get())


def _dot(a: Array, b: Array) -> Array:
    return np.sum(a * b, axis=-1)


def _cos(x: ArrayLike) -> Array:
    """A cosine clipped to [-1, 1] (rounding after normalisation)."""
    return np.clip(_f(x), -1.0, 1.0)


def _mul0(a: ArrayLike, b: ArrayLike) -> Array:
    """a * b with 0 * inf = 0 (used where a delta lobe meets a zero factor)."""
    a, b = _f(a), _f(b)
    with np.errstate(**_ERR):
        p = a * b
    return np.where((a == 0.0) | (b == 0.0), 0.0, p)


def _tint(scalar: ArrayLike, colour: ArrayLike) -> Array:
    """scalar (...) times colour (channel-last, or a scalar), 0 * inf = 0."""
    scalar, colour = _f(scalar), _f(colour)
    if colour.ndim == 0:
        return _mul0(scalar, colour)
    return _mul0(scalar[..., None], colour)


def _channels(x: ArrayLike) -> Array:
    """Colour argument as a channel-last array (a scalar becomes shape (1,))."""
    x = _f(x)
    return x[None] if x.ndim == 0 else x


def normalize(x: ArrayLike) -> tuple[Array, NDArray[np.bool_]]:
    """Return ``(unit, ok)``; ``unit`` is 0 where ``|x| <= EPS_LENGTH``."""
    x = _f(x)
    length = np.sqrt(_dot(x, x))
    ok = np.isfinite(length) & (length > EPS_LENGTH)
    safe = np.where(ok, length, 1.0)
    unit = np.where(ok[..., None], x / safe[..., None], 0.0)
    return unit, ok


def reflect(l: ArrayLike, n: ArrayLike) -> Array:
    """Mirror of ``l`` about unit ``n``: ``r = 2 (n.l) n - l`` (= reflect(-l))."""
    l, n = _f(l), _f(n)
    return 2.0 * _dot(n, l)[..., None] * n - l


def _orthonormal_basis(n: Array) -> tuple[Array, Array]:
    """Tangent frame (t, b) for unit n (Duff et al. 2017, branchless ONB)."""
    nx, ny, nz = n[..., 0], n[..., 1], n[..., 2]
    sign = np.where(nz >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    t = np.stack([1.0 + sign * nx * nx * a, sign * b, -sign * nx], axis=-1)
    bt = np.stack([b, sign + ny * ny * a, -ny], axis=-1)
    return t, bt


@dataclass(frozen=True)
class Geometry:
    """Normalised shading geometry (all arrays broadcast to one shape ``S``)."""

    n: Array  # (S, 3) unit normal
    l: Array  # (S, 3) unit light direction
    v: Array  # (S, 3) unit view direction
    h: Array  # (S, 3) unit half vector (0 where |l+v| = 0)
    nl: Array  # (S,) cosines in [-1, 1]
    nv: Array
    nh: Array
    vh: Array  # = l.h
    valid: NDArray[np.bool_]  # (S,) vectors non-zero and nl > 0 and nv > 0
    h_ok: NDArray[np.bool_]  # (S,) |l+v| > 0


def geometry(n: ArrayLike, l: ArrayLike, v: ArrayLike) -> Geometry:
    """Normalise ``n, l, v``, form ``h`` and the cosines."""
    n, l, v = np.broadcast_arrays(_f(n), _f(l), _f(v))
    n, ok_n = normalize(n)
    l, ok_l = normalize(l)
    v, ok_v = normalize(v)
    h, h_ok = normalize(l + v)
    nl, nv = _cos(_dot(n, l)), _cos(_dot(n, v))
    nh, vh = _cos(_dot(n, h)), _cos(_dot(v, h))
    valid = ok_n & ok_l & ok_v & (nl > 0.0) & (nv > 0.0)
    return Geometry(n, l, v, h, nl, nv, nh, vh, valid, h_ok & valid)


def alpha_from_roughness(roughness: ArrayLike, alpha_floor: ArrayLike = 0.0) -> Array:
    """``alpha = max(r**2, alpha_floor)`` -- the one place the floor is applied."""
    r = _f(roughness)
    return np.maximum(r * r, _f(alpha_floor))


# --------------------------------------------------------------------------
# normal distribution functions
# --------------------------------------------------------------------------


def d_ggx(nh: ArrayLike, alpha: ArrayLike) -> Array:
    """GGX / Trowbridge-Reitz NDF, ``a^2 / (pi ((n.h)^2 (a^2-1) + 1)^2)``.

    0 for ``n.h <= 0``.  alpha = 0: 0 except ``+inf`` at ``n.h == 1`` (delta).
    """
    c = np.clip(_f(nh), 0.0, 1.0)
    a2 = _f(alpha) ** 2
    # (n.h)^2 (a^2 - 1) + 1 == (n.h)^2 a^2 + (1 - n.h)(1 + n.h): no cancellation
    den = c * c * a2 + (1.0 - c) * (1.0 + c)
    with np.errstate(**_ERR):
        d = a2 / (math.pi * den * den)
    d = np.where(den > 0.0, d, np.inf)  # only a2 == 0 and c == 1 reach here
    d = np.where((a2 == 0.0) & (c < 1.0), 0.0, d)
    return np.where(c > 0.0, d, 0.0)


def d_beckmann(nh: ArrayLike, m: ArrayLike) -> Array:
    """Beckmann NDF, ``exp(-tan^2 / m^2) / (pi m^2 cos^4)`` (m = alpha).

    Evaluated in the log domain (no 0/0 near grazing).  0 for ``n.h <= 0``;
    m = 0: 0 except ``+inf`` at ``n.h == 1``.
    """
    c = np.clip(_f(nh), 0.0, 1.0)
    m = _f(m)
    c, m = np.broadcast_arrays(c, m)
    pos = (c > 0.0) & (m > 0.0)
    cs = np.where(pos, c, 1.0)
    ms = np.where(pos, m, 1.0)
    tan2 = (1.0 - cs) * (1.0 + cs) / (cs * cs)
    with np.errstate(**_ERR):
        logd = -tan2 / (ms * ms) - math.log(math.pi) - 2.0 * np.log(ms) - 4.0 * np.log(cs)
        d = np.exp(logd)
    delta = np.where(c == 1.0, _f(np.inf), _f(0.0))
    return np.where(pos, d, np.where(m == 0.0, delta, 0.0) * (c > 0.0))


# --------------------------------------------------------------------------
# masking-shadowing
# --------------------------------------------------------------------------


def g_cook_torrance(nh: ArrayLike, nv: ArrayLike, nl: ArrayLike, vh: ArrayLike) -> Array:
    """Cook-Torrance V-cavity G = min(1, 2(n.h)(n.v)/(v.h), 2(n.h)(n.l)/(v.h)).

    0 if any cosine is <= 0.
    """
    nh, nv, nl, vh = (np.clip(_f(x), 0.0, 1.0) for x in (nh, nv, nl, vh))
    ok = (nh > 0.0) & (nv > 0.0) & (nl > 0.0) & (vh > 0.0)
    vhs = np.where(ok, vh, 1.0)
    g = np.minimum(1.0, np.minimum(2.0 * nh * nv / vhs, 2.0 * nh * nl / vhs))
    return np.where(ok, g, 0.0)


def g1_smith_ggx(nx: ArrayLike, alpha: ArrayLike) -> Array:
    """Smith G1 for GGX (Walter 2007): ``2 c / (c + sqrt(a^2 + (1-a^2) c^2))``; 0 for c <= 0."""
    c = np.clip(_f(nx), 0.0, 1.0)
    a = _f(alpha)
    a2 = a * a
    with np.errstate(**_ERR):
        # hypot form: c*c would underflow for tiny c (giving 2c/c = 2 at a = 0)
        root = np.where(a2 <= 1.0, np.hypot(a, c * np.sqrt(np.maximum(1.0 - a2, 0.0))),
                        np.sqrt(a2 + (1.0 - a2) * c * c))
        g = 2.0 * c / (c + root)
    return np.where(c > 0.0, g, 0.0)


def lambda_ggx(nx: ArrayLike, alpha: ArrayLike) -> Array:
    """Smith Lambda for GGX (Heitz 2014): ``(-1 + sqrt(1 + a^2 tan^2)) / 2``.

    Computed as ``x / (2 (1 + sqrt(1 + x)))``, ``x = a^2 tan^2`` (same value,
    no cancellation for small x).  ``+inf`` for ``n.x <= 0``.
    """
    c = np.clip(_f(nx), 0.0, 1.0)
    a2 = _f(alpha) ** 2
    c, a2 = np.broadcast_arrays(c, a2)
    pos = c > 0.0
    cs = np.where(pos, c, 1.0)
    tan2 = (1.0 - cs) * (1.0 + cs) / (cs * cs)
    with np.errstate(**_ERR):
        x = np.where(a2 == 0.0, 0.0, a2 * tan2)
        lam = x / (2.0 * (1.0 + np.sqrt(1.0 + x)))
    lam = np.where(np.isinf(x), np.inf, lam)
    return np.where(pos, lam, np.inf)


def g_smith_ggx_separable(nl: ArrayLike, nv: ArrayLike, alpha: ArrayLike) -> Array:
    """Separable Smith G = G1(l) G1(v) (Walter 2007)."""
    return g1_smith_ggx(nl, alpha) * g1_smith_ggx(nv, alpha)


def g_smith_ggx_correlated(nl: ArrayLike, nv: ArrayLike, alpha: ArrayLike) -> Array:
    """Height-correlated Smith G2 = 1 / (1 + Lambda(v) + Lambda(l)) (Heitz 2014)."""
    with np.errstate(**_ERR):
        return 1.0 / (1.0 + lambda_ggx(nv, alpha) + lambda_ggx(nl, alpha))


def g_smith_schlick(nl: ArrayLike, nv: ArrayLike, alpha: ArrayLike) -> Array:
    """Schlick-Smith G with k = alpha/2: prod of ``c / (c (1-k) + k)``; 0 for c <= 0."""
    k = 0.5 * _f(alpha)

    def g1(x: ArrayLike) -> Array:
        c = np.clip(_f(x), 0.0, 1.0)
        den = c * (1.0 - k) + k
        with np.errstate(**_ERR):
            g = c / den
        return np.where(c > 0.0, g, 0.0)

    return g1(nl) * g1(nv)


# --------------------------------------------------------------------------
# Fresnel
# --------------------------------------------------------------------------


def _channel_cos(c: Array, *colours: Array) -> Array:
    """Add a channel axis to cosine ``c`` if any colour argument has one."""
    return c[..., None] if any(x.ndim > 0 for x in colours) else c


def f_schlick(vh: ArrayLike, f0: ArrayLike, f90: ArrayLike = 1.0) -> Array:
    """Schlick: ``f0 + (f90 - f0)(1 - v.h)^5`` (v.h clipped to [0, 1])."""
    f0, f90 = _f(f0), _f(f90)
    c = _channel_cos(np.clip(_f(vh), 0.0, 1.0), f0, f90)
    return f0 + (f90 - f0) * (1.0 - c) ** 5


def f_dielectric(vh: ArrayLike, ior: ArrayLike) -> Array:
    """Exact unpolarised Fresnel reflectance of a dielectric, relative IOR eta.

    s/p amplitudes: ``r_s = (c - eta ct)/(c + eta ct)``,
    ``r_p = (eta c - ct)/(eta c + ct)``, ``F = (r_s^2 + r_p^2)/2`` with Snell
    ``ct = sqrt(1 - (1 - c^2)/eta^2)``; total internal reflection -> 1.
    (Equivalent to Walter 2007 eq. 22 / Cook-Torrance's g-form.)
    """
    eta = _f(ior)
    c = _channel_cos(np.clip(_f(vh), 0.0, 1.0), eta)
    with np.errstate(**_ERR):
        sin2t = (1.0 - c) * (1.0 + c) / (eta * eta)
        tir = ~(sin2t < 1.0)  # also catches eta <= 0 / NaN
        ct = np.sqrt(np.where(tir, 0.0, 1.0 - sin2t))
        rs = (c - eta * ct) / (c + eta * ct)
        rp = (eta * c - ct) / (eta * c + ct)
        f = 0.5 * (rs * rs + rp * rp)
    return np.where(tir, 1.0, f)


def f_conductor(vh: ArrayLike, eta: ArrayLike, k: ArrayLike) -> Array:
    """Exact unpolarised Fresnel reflectance for complex IOR ``eta + i k``.

    Complex Snell: ``w = n cos(theta_t) = sqrt(n^2 - sin^2(theta_i))``
    (principal root, Re w >= 0: decaying transmitted wave);
    ``r_s = (c - w)/(c + w)``, ``r_p = (n^2 c - w)/(n^2 c + w)``,
    ``F = (|r_s|^2 + |r_p|^2) / 2``.  ``eta``/``k`` are channel-last colours.
    """
    eta, k = _f(eta), _f(k)
    c = _channel_cos(np.clip(_f(vh), 0.0, 1.0), eta, k)
    n = eta + 1j * k
    n2 = n * n
    s2 = (1.0 - c) * (1.0 + c)
    w = np.sqrt(n2 - s2 + 0j)
    with np.errstate(**_ERR):
        rs = (c - w) / (c + w)
        rp = (n2 * c - w) / (n2 * c + w)
        f = 0.5 * (np.abs(rs) ** 2 + np.abs(rp) ** 2)
    return np.where(np.isfinite(f), f, 1.0)  # 0/0 only at n = 1, grazing


# --------------------------------------------------------------------------
# diffuse terms
# --------------------------------------------------------------------------


def fd_lambert() -> float:
    """Lambert: 1/pi."""
    return INV_PI


def fd_burley(nl: ArrayLike, nv: ArrayLike, lh: ArrayLike, alpha: ArrayLike) -> Array:
    """Burley 2012: (1/pi)(1 + (F90-1)(1-n.l)^5)(1 + (F90-1)(1-n.v)^5), F90 = 0.5 + 2 a (l.h)^2.

    0 if ``n.l <= 0`` or ``n.v <= 0``.
    """
    nl, nv = _cos(nl), _cos(nv)
    lh = np.clip(_f(lh), 0.0, 1.0)
    f90 = 0.5 + 2.0 * _f(alpha) * lh * lh
    fl = 1.0 + (f90 - 1.0) * (1.0 - np.clip(nl, 0.0, 1.0)) ** 5
    fv = 1.0 + (f90 - 1.0) * (1.0 - np.clip(nv, 0.0, 1.0)) ** 5
    return np.where((nl > 0.0) & (nv > 0.0), INV_PI * fl * fv, 0.0)


def fd_oren_nayar(n: ArrayLike, l: ArrayLike, v: ArrayLike, sigma: ArrayLike) -> Array:
    """Oren-Nayar 1994 qualitative model with explicit angles.

    ``(1/pi)(A + B max(0, cos(phi_i - phi_o)) sin(a) tan(b))``,
    ``A = 1 - 0.5 s^2/(s^2+0.33)``, ``B = 0.45 s^2/(s^2+0.09)``,
    ``a = max(theta_i, theta_o)``, ``b = min(...)``.  Polar angles by arccos,
    azimuths by arctan2 in a tangent frame of n.  B term 0 if l or v is along
    n; 0 below the surface.  ``sigma`` in radians (= roughness r).
    """
    n, l, v = np.broadcast_arrays(_f(n), _f(l), _f(v))
    n, ok_n = normalize(n)
    l, ok_l = normalize(l)
    v, ok_v = normalize(v)
    cos_i, cos_o = _cos(_dot(n, l)), _cos(_dot(n, v))
    valid = ok_n & ok_l & ok_v & (cos_i > 0.0) & (cos_o > 0.0)
    theta_i, theta_o = np.arccos(cos_i), np.arccos(cos_o)
    t, b = _orthonormal_basis(n)
    li, lj = _dot(l, t), _dot(l, b)
    vi, vj = _dot(v, t), _dot(v, b)
    phi_i, phi_o = np.arctan2(lj, li), np.arctan2(vj, vi)
    along_n = (np.hypot(li, lj) <= EPS_TANGENT) | (np.hypot(vi, vj) <= EPS_TANGENT)
    s2 = _f(sigma) ** 2
    a_coef = 1.0 - 0.5 * s2 / (s2 + 0.33)
    b_coef = 0.45 * s2 / (s2 + 0.09)
    big = np.maximum(theta_i, theta_o)
    small = np.minimum(theta_i, theta_o)
    with np.errstate(**_ERR):
        b_term = b_coef * np.maximum(0.0, np.cos(phi_i - phi_o)) * np.sin(big) * np.tan(small)
    b_term = np.where(along_n | ~valid, 0.0, b_term)
    return np.where(valid, INV_PI * (a_coef + b_term), 0.0)


# --------------------------------------------------------------------------
# empirical specular lobes (f without cosine; 0**0 = 1)
# --------------------------------------------------------------------------


def phong(rv: ArrayLike, shininess: ArrayLike) -> Array:
    """Phong lobe ``max(0, r.v)^n``, ``r = 2(n.l)n - l``."""
    return np.power(np.clip(_f(rv), 0.0, 1.0), _f(shininess))


def blinn_phong(nh: ArrayLike, shininess: ArrayLike) -> Array:
    """Blinn-Phong lobe ``max(0, n.h)^n``."""
    return np.power(np.clip(_f(nh), 0.0, 1.0), _f(shininess))


def phong_normalized(rv: ArrayLike, shininess: ArrayLike) -> Array:
    """Energy-normalised Phong ``(n+2)/(2 pi) max(0, r.v)^n``."""
    s = _f(shininess)
    return (s + 2.0) / (2.0 * math.pi) * phong(rv, s)


def blinn_phong_normalized(nh: ArrayLike, shininess: ArrayLike) -> Array:
    """Normalised Blinn-Phong ``(n+8)/(8 pi) max(0, n.h)^n``."""
    s = _f(shininess)
    return (s + 8.0) / (8.0 * math.pi) * blinn_phong(nh, s)


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


# --------------------------------------------------------------------------
# directional albedo
# --------------------------------------------------------------------------


def directional_albedo(
    fn: Callable[[Array, Array, Array], ArrayLike],
    n_theta: int = 12,
    *,
    v: ArrayLike = (0.0, 0.0, 1.0),
    n: ArrayLike = (0.0, 0.0, 1.0),
    n_phi: int | None = None,
    levels: int = 10,
    ratio: float = 0.2,
    return_error: bool = False,
) -> float | Array | tuple[float | Array, float]:
    """Directional albedo ``A(v) = int_{H(n)} f(n, l, v) (n.l) dw_l``.

    ``fn(n, l, v)`` gets ``(M, 3)`` unit arrays and returns ``(M,)`` or
    ``(M, C)``; the result is a float or a ``(C,)`` array.

    Quadrature: ``dw = d(mu) d(phi)`` with ``mu = n.l`` in [0, 1] and phi the
    azimuth about n; composite Gauss-Legendre with ``n_theta`` (mu) and
    ``n_phi`` (phi, default ``n_theta``) nodes per panel.  Panels are graded
    geometrically (``levels`` levels, factor ``ratio``; smallest panel
    ``ratio**levels`` ~ 1e-7 by default) towards the mirror direction
    ``mu = n.v``, ``phi = phi_v + pi`` where narrow lobes and the Oren-Nayar
    theta_i = theta_o kink sit, and towards the pole ``mu = 1`` (where
    ``theta = arccos(mu)`` makes azimuth-dependent integrands behave like
    ``sqrt(1 - mu)``), with extra breaks at ``phi_v +- pi/2`` (Oren-Nayar's
    max(0, cos dphi) kink); for v along n the phi panels are uniform.  Narrow
    lobes down to angular width ~1e-4 rad are resolved to ~1e-9.

    Error: the rule is evaluated at (n_theta, n_phi) and at twice the orders;
    the finer value is returned and ``|fine - coarse|`` (max over channels) is
    the stated error (``return_error=True`` returns ``(value, error)``).
    Gauss-Legendre converges exponentially on smooth panels, so this bounds
    the error of the finer value conservatively; for the smooth lobes here
    (Lambert, Burley, Oren-Nayar, GGX, Beckmann, normalised Phong at v = n)
    the true error is ~1e-10 or below.  Integrands with kinks off the panel
    breaks (Cook-Torrance's min(), Phong's max(0, r.v) cut for v off n)
    converge algebraically; the estimate then still reflects that.
    """
    n_phi = n_theta if n_phi is None else n_phi
    nn, ok_n = normalize(np.asarray(n, dtype=np.float64).reshape(3))
    vv, ok_v = normalize(np.asarray(v, dtype=np.float64).reshape(3))
    if not (ok_n and ok_v):
        raise ValueError("n and v must be non-zero")
    t, b = _orthonormal_basis(nn)
    mu_v = float(np.clip(nn @ vv, 0.0, 1.0))
    vt, vb = float(vv @ t), float(vv @ b)
    phi_v = math.atan2(vb, vt) if math.hypot(vt, vb) > EPS_TANGENT else None

    def rule(o_mu: int, o_phi: int) -> Array:
        l, weights = hemisphere_rule(nn, t, b, mu_v, phi_v, o_mu, o_phi, levels, ratio)
        shape = l.shape[:2]
        l = l.reshape(-1, 3)
        f = _f(fn(np.broadcast_to(nn, l.shape), l, np.broadcast_to(vv, l.shape)))
        f = f.reshape(shape + f.shape[1:])
        return np.tensordot(weights, f, axes=([0, 1], [0, 1]))

    coarse = rule(n_theta, n_phi)
    fine = rule(2 * n_theta, 2 * n_phi)
    err = float(np.max(np.abs(fine - coarse)))
    value: float | Array = float(fine) if fine.ndim == 0 else fine
    return (value, err) if return_error else value


# --------------------------------------------------------------------------
# the frame oracle: the whole shading pass at image level
# --------------------------------------------------------------------------


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


def surface_args(model: Model, base: ArrayLike, roughness: ArrayLike, metallic: ArrayLike, material: ArrayLike,
                 alpha_floor: float) -> dict:
    """Keyword arguments of :func:`brdf` for a clshade model at K points: base (K, 3),
    roughness and metallic (K,), material (K, 4, 4) rows of the material table
    (surface.h layout: kd, ks, ka, shininess | ior, f90 | eta | k). Metallic
    workflow: F0 from base and metallic; k_d + k_s = 1: the material's kd, ks and
    F0 = ((ior - 1)/(ior + 1))**2."""
    m = _f(material)
    args = dict(base_color=_f(base), roughness=_f(roughness), metallic=_f(metallic), workflow=model.workflow,
                fresnel=model.fresnel, ior=m[:, 1, 0], f90=m[:, 1, 1], eta=m[:, 2, :3], k=m[:, 3, :3],
                shininess=m[:, 0, 3], alpha_floor=alpha_floor)
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
