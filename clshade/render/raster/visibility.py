"""The visibility buffer: per pixel the triangle that won the depth resolve, before any
barycentric is computed (Burns & Hunt, "The Visibility Buffer", JCGT 2013). A later pass
computes the winners' barycentrics, depth and attributes from it and the triangles' setup:
``fragments()`` here in NumPy (rasterize_mesh's Fragments, bit for bit), the live viewer's
G-buffer kernel on the device (clshade/device/visibility.py, kernels/visibility.cl)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from clshade.render.raster.fragments import Fragments, no_fragments
from clshade.render.raster.resolve import winners
from clshade.render.raster.triangles import Tris


@dataclass
class Visibility:
    """One view's visibility buffer.

    Attributes:
        width, height: image size.
        tri: ``(H·W,)`` int32 index into `tris` of the winning triangle, -1 where none.
        tris: the triangle setup of the view's one face batch (None: no triangle survived).
        w_is_depth: the projection's clip w is the view depth (any perspective matrix).
    """
    width: int
    height: int
    tri: NDArray[np.int32]
    tris: Tris | None
    w_is_depth: bool = True

    @classmethod
    def empty(cls, width: int, height: int, w_is_depth: bool = True) -> Visibility:
        return cls(width, height, np.full(width * height, -1, np.int32), None, w_is_depth)

    def fragments(self) -> Fragments:
        """The winners' face, depth and barycentrics: rasterize_mesh's result, bit for bit."""
        pixels = np.flatnonzero(self.tri >= 0)
        if self.tris is None or not len(pixels):
            return no_fragments(self.height, self.width)
        with np.errstate(all="ignore"):
            face, depth, bary = winners(self.tris, pixels, self.tri[pixels].astype(np.int64), self.width,
                                        self.w_is_depth)
        return Fragments(self.height, self.width, pixels, face.astype(np.int32), depth.astype(np.float32),
                         bary.astype(np.float32))
