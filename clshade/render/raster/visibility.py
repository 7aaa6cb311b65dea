"""A view's triangle setup for a visibility-buffer pass (Burns & Hunt, "The Visibility
Buffer", JCGT 2013): the triangles' edge functions, depth planes, pixel boxes and
perspective-correct weights, with the packed depth keys' layout, from which a later pass does
the coverage tests, the depth resolve and the winners' barycentrics on its own — the live
viewer's visibility buffer and G-buffer on the device (clshade/device/visibility.py,
kernels/visibility.cl), rasterize_mesh's fragments bit for bit."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from clshade.render.raster.tiles import NDC_DEPTH_EPS, TILE
from clshade.render.raster.triangles import Tris


@dataclass
class ViewSetup:
    """One view's triangle setup (setup_view).

    Attributes:
        width, height: image size.
        tris: the triangles of the view, its face batches joined in order (None: no triangle survived setup).
        w_is_depth: the projection's clip w is the view depth (any perspective matrix).
        tri_bits, z_scale: the packed keys' layout (z_scale: resolve.key_layout's for the face batches;
            tri_bits: resolve.view_tri_bits's for the view's triangles): a fragment's key is
            ``(int64((clip(z_ndc, -1, 1) + 1) · z_scale) << tri_bits) | triangle``, kept when
            ``-1 - depth_eps <= z_ndc <= 1 + depth_eps``; the least key of a pixel wins.
        mvp: projection @ view (float64 4x4), as gbuffer.uv_derivatives forms it: the device's
            texture footprints (None where the setup was made without it).
    """
    width: int
    height: int
    tris: Tris | None
    w_is_depth: bool
    tri_bits: int
    z_scale: float
    depth_eps: float = NDC_DEPTH_EPS
    tile: int = TILE
    mvp: np.ndarray | None = None
