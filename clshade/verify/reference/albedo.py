"""Directional albedo: f cos(theta) integrated over the hemisphere (graded composite Gauss-Legendre,
clshade.verify.quadrature), with an error estimate."""
from __future__ import annotations

import math
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike

from clshade.verify.quadrature import hemisphere_rule
from clshade.verify.reference.constants import EPS_TANGENT
from clshade.verify.reference.vectors import Array, _f, orthonormal_basis, normalize


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
    t, b = orthonormal_basis(nn)
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
