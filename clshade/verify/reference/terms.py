"""The BRDF terms, one pure function each, written from the papers (not from the kernels): normal
distributions, masking-shadowing, Fresnel, the diffuse terms and the empirical specular lobes.
clshade.verify.reference.compose combines them into models."""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from clshade.verify.reference.constants import EPS_TANGENT, INV_PI
from clshade.verify.reference.vectors import (_ERR, Array, _cos, _dot, _f, orthonormal_basis,
                                              normalize)


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
    t, b = orthonormal_basis(n)
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
