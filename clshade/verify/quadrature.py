"""The one hemisphere quadrature: composite Gauss–Legendre in μ = n·l and the
azimuth φ, panels graded geometrically towards the features of BRDF integrands.

Used by the float64 reference (reference.directional_albedo) and by the device
plausibility sweep (plausibility.hemisphere_rule), so both integrate with the
same rule.
"""
from __future__ import annotations

import math

import numpy as np


def graded_breaks(lo: float, hi: float, centres: tuple[float, ...], levels: int, ratio: float) -> np.ndarray:
    """Panel breakpoints on [lo, hi] geometrically graded (factor `ratio`, `levels` levels)
    towards each centre."""
    pts = [lo, hi, *centres]
    for centre in centres:
        for end in (lo, hi):
            d = end - centre
            if d != 0.0:
                pts += [centre + d * ratio**j for j in range(1, levels + 1)]
    return np.unique(np.clip(np.asarray(pts, np.float64), lo, hi))


def composite_gauss_legendre(breaks: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of composite Gauss–Legendre of `order` nodes on each panel."""
    x, w = np.polynomial.legendre.leggauss(order)
    a, b = breaks[:-1, None], breaks[1:, None]
    half = 0.5 * (b - a)
    return (a + half * (x + 1.0)).ravel(), (half * w).ravel()


def hemisphere_rule(n: np.ndarray, t: np.ndarray, b: np.ndarray, mu_v: float, phi_v: float | None,
                    order_mu: int, order_phi: int, levels: int, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes l (M_mu, M_phi, 3) and weights (M_mu, M_phi) of ∫ g(l) (n·l) dω over the
    hemisphere of unit n with tangent frame (t, b); the (n·l) factor is in the weights.

    μ panels are graded towards the mirror cosine μ_v = n·v and the pole μ = 1 (where
    θ = arccos μ makes azimuth-dependent integrands behave like √(1 − μ)); φ panels towards
    the mirror azimuth φ_v + π, with breaks at φ_v + π ± π/2 (Oren–Nayar's max(0, cos Δφ)
    kink). `phi_v` None (v along n): uniform φ panels."""
    mu, w_mu = composite_gauss_legendre(graded_breaks(0.0, 1.0, (mu_v, 1.0), levels, ratio), order_mu)
    if phi_v is not None:
        pb = graded_breaks(-math.pi, math.pi, (0.0,), levels, ratio)
        phi_breaks = np.unique(np.concatenate([pb, [-0.5 * math.pi, 0.5 * math.pi]])) + phi_v + math.pi
    else:
        phi_breaks = np.linspace(0.0, 2.0 * math.pi, 5)
    phi, w_phi = composite_gauss_legendre(phi_breaks, order_phi)
    sin_t = np.sqrt((1.0 - mu) * (1.0 + mu))
    l = (sin_t[:, None, None] * (np.cos(phi)[None, :, None] * t + np.sin(phi)[None, :, None] * b)
         + mu[:, None, None] * n)
    return l, (w_mu * mu)[:, None] * w_phi[None, :]
