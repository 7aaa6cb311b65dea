"""The arithmetic every oracle term shares: the evaluation precision (float64, or float32 for the
NumPy baseline), products with 0 * inf = 0, colour channels, normalised vectors and the shading
geometry (n, l, v, h and their cosines), alpha from roughness."""
from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from clshade.verify.reference.constants import EPS_LENGTH

Array = NDArray[np.float64]

# Floating-point errors (0/0, x/0, overflow) are handled by each term explicitly: NumPy's warnings off.
_ERR = dict(divide="ignore", invalid="ignore", over="ignore", under="ignore")

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


def orthonormal_basis(n: Array) -> tuple[Array, Array]:
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
