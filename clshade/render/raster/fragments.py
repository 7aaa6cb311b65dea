"""The rasterizer's result: the covered pixels with their face, depth and barycentrics,
full-frame arrays made from them on first use."""
from __future__ import annotations

from functools import cached_property

import numpy as np
from numpy.typing import NDArray


class Fragments:
    """Per-pixel result of :func:`rasterize`, held as its list of covered pixels
    (what the G-buffer works on) with full-frame arrays made from it on first use.

    Attributes:
        pixels: ``(K,)`` int64 flat indices (row-major) of the covered pixels, ascending.
        face: ``(K,)`` int32 index of the visible input face of each.
        face_depth: ``(K,)`` float32 view-space depth ``-z_view`` (> 0) of each.
        face_bary: ``(3, K)`` float32 perspective-correct barycentrics w.r.t. the
            original face's 3 vertices (sum 1), one row per vertex.
        tri_id: ``(H, W)`` int32 face per pixel, -1 where no triangle covers the
            pixel centre (made on first use, as are the two below).
        depth: ``(H, W)`` float32 depth, 0 where empty.
        bary_planes: ``(3, H, W)`` float32 barycentrics, 0 where empty.
    """

    def __init__(self, height: int, width: int, pixels: NDArray[np.int64], face: NDArray[np.int32],
                 face_depth: NDArray[np.float32], face_bary: NDArray[np.float32]) -> None:
        self.shape = (int(height), int(width))
        self.pixels, self.face, self.face_depth, self.face_bary = pixels, face, face_depth, face_bary

    @classmethod
    def from_frame(cls, tri_id: NDArray[np.int32], depth: NDArray[np.float32],
                   bary_planes: NDArray[np.float32]) -> Fragments:
        """From full-frame arrays (tri_id -1 where empty)."""
        pixels = np.flatnonzero(tri_id.reshape(-1) >= 0)
        frags = cls(*tri_id.shape, pixels, np.take(tri_id, pixels), np.take(depth, pixels),
                    np.stack([np.take(plane, pixels) for plane in bary_planes]))
        frags.__dict__.update(tri_id=tri_id, depth=depth, bary_planes=bary_planes)
        return frags

    def _frame(self, fill: float, values: NDArray, dtype: type) -> NDArray:
        out = np.full(self.shape[0] * self.shape[1], fill, dtype)
        out[self.pixels] = values
        return out.reshape(self.shape)

    @cached_property
    def tri_id(self) -> NDArray[np.int32]:
        return self._frame(-1, self.face, np.int32)

    @cached_property
    def depth(self) -> NDArray[np.float32]:
        return self._frame(0.0, self.face_depth, np.float32)

    @cached_property
    def bary_planes(self) -> NDArray[np.float32]:
        return np.stack([self._frame(0.0, b, np.float32) for b in self.face_bary])

    @property
    def bary(self) -> NDArray[np.float32]:
        """``(H, W, 3)`` view of :attr:`bary_planes` (not contiguous)."""
        return np.moveaxis(self.bary_planes, 0, -1)

    @property
    def coverage(self) -> NDArray[np.bool_]:
        """``(H, W)`` bool, True where a triangle covers the pixel."""
        return self.tri_id >= 0


def no_fragments(height: int, width: int) -> Fragments:
    return Fragments(height, width, np.zeros(0, np.int64), np.zeros(0, np.int32), np.zeros(0, np.float32),
                     np.zeros((3, 0), np.float32))
