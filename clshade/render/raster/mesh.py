"""The rasterizer's input mesh, checked once, and its per-face constants kept between frames:
each face's plane (world space), from which a camera's back faces are dropped before any
per-corner work (a dot product per face instead of the triangle setup)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: A culled face is dropped before triangle setup when, seen from the camera's centre, it faces
#: away by more than this: ``n·(eye − a) < −BACKFACE_PRECULL_COS · |e1| |e2| (|C_xyz| + |C_w| |a|)``
#: (n = e1 × e2, a its first corner, C the camera centre in homogeneous coordinates; the left side
#: is at least the face's sine times the cosine of its view angle times |eye − a|, the right side
#: a bound of that product). Such a face would project clockwise (area2 > 0) in triangle setup:
#: the sign of its projected area is that of ``C·plane`` exactly (Cauchy–Binet), and one part in
#: 1e6 is far beyond the round-off of either side (~1e-11 of a sub-pixel triangle's screen
#: extent), so the pre-cull drops only what setup would drop. Faces nearer to edge-on, with
#: non-finite or degenerate corners, go through setup's own test. ``inf`` turns the pre-cull off.
BACKFACE_PRECULL_COS: float = 1e-6


_WITHOUT = np.array([[j for j in range(4) if j != i] for i in range(4)])    # (4, 3) columns kept


def camera_centre(mvp: NDArray[np.float64]) -> NDArray[np.float64]:
    """The homogeneous centre of projection C of ``mvp`` (the null vector of its x, y, w rows M,
    signed): by Cauchy–Binet, ``det(M [a b c; 1 1 1]) = C · (n, −n·a)`` with n = (b − a) × (c − a)
    for any points a, b, c; the face projects clockwise (a back face) exactly when that is < 0."""
    m = mvp[[0, 1, 3]]
    minors = np.linalg.det(m[:, _WITHOUT].transpose(1, 0, 2))     # the 3x3 minors without column i
    return minors * np.array([1.0, -1.0, 1.0, -1.0])


@dataclass
class FaceBatch:
    """The faces ``f0:f1`` of a mesh as triangle setup reads them: their corners' vertex indices,
    one contiguous row per corner (fast gathers), and their planes (made on first use)."""
    f0: int
    f1: int
    corners: NDArray[np.int64]                  # (3, f1 - f0)
    planes: NDArray[np.float64] | None = None   # (5, f1 - f0): RasterMesh.planes_of


class RasterMesh:
    """A triangle mesh as :func:`clshade.render.raster.rasterize_mesh` takes it: the checked
    arrays and, per batch of faces, their corners and planes (made on first use).

    ``keep`` (many views of one mesh): the arrays are private read-only copies and each batch's
    corners and planes are kept for the next view (they cannot go stale). Without it (one view,
    :func:`rasterize`): the arrays are used as given (no copy) and the batches made per call,
    so that the memory of one call stays that of a batch of faces."""

    def __init__(self, vertices: ArrayLike, faces: ArrayLike, cull_backfaces: bool | ArrayLike = True,
                 keep: bool = True) -> None:
        verts = np.array(vertices, dtype=np.float64) if keep else np.asarray(vertices, dtype=np.float64)
        if verts.ndim != 2 or verts.shape[1] != 3:
            raise ValueError(f"vertices must have shape (V, 3), got {verts.shape}")
        tris = np.asarray(faces)
        if tris.size == 0:
            tris = tris.reshape(0, 3)
        if tris.ndim != 2 or tris.shape[1] != 3:
            raise ValueError(f"faces must have shape (F, 3), got {tris.shape}")
        if tris.dtype.kind not in "iu":
            raise ValueError(f"faces must be integers, got dtype {tris.dtype}")
        tris = tris.astype(np.int64, copy=keep)
        n_faces = tris.shape[0]
        if n_faces and (tris.min() < 0 or tris.max() >= verts.shape[0]):
            raise ValueError("face indices out of range")
        if isinstance(cull_backfaces, (bool, np.bool_)):
            cull = np.full(n_faces, bool(cull_backfaces))
        else:
            cull = np.array(cull_backfaces, dtype=bool)
            if cull.shape != (n_faces,):
                raise ValueError(f"cull_backfaces array must have shape ({n_faces},), got {cull.shape}")
        self.keep = keep
        # (3, V): x, y, z rows; contiguous when kept (faster per-row products), else views.
        self.columns = np.ascontiguousarray(verts.T) if keep else verts.T
        self.vertices, self.faces, self.cull = verts.view(), tris.view(), cull
        self.any_cull = bool(cull.any())
        for a in (self.vertices, self.columns, self.faces, self.cull):
            a.flags.writeable = False               # a view of the caller's array: theirs stays writeable
        self._batches: dict[tuple[int, int], FaceBatch] = {}

    def __len__(self) -> int:
        return self.faces.shape[0]

    def batch(self, f0: int, f1: int) -> FaceBatch:
        """The faces ``f0:f1`` (kept for the next call when ``keep``)."""
        batch = self._batches.get((f0, f1))
        if batch is None:
            corners = np.ascontiguousarray(self.faces[f0:f1].T)
            corners.flags.writeable = False
            batch = FaceBatch(f0, f1, corners)
            if self.keep:
                self._batches[(f0, f1)] = batch
        return batch

    def planes_of(self, batch: FaceBatch) -> NDArray[np.float64]:
        """(5, n): the plane (n, −n·a) of each face of `batch` divided by |e1| |e2|, and |a|."""
        if batch.planes is None:
            with np.errstate(all="ignore"):
                a, b, c = (np.take(self.vertices, batch.corners[k], axis=0) for k in range(3))
                e1, e2 = b - a, c - a
                n = np.cross(e1, e2)
                scale = np.sqrt(np.einsum("ij,ij->i", e1, e1) * np.einsum("ij,ij->i", e2, e2))
                n /= scale[:, None]                        # NaN for a degenerate face: never pre-culled
                out = np.empty((5, len(n)))
                out[:3] = n.T
                out[3] = -np.einsum("ij,ij->i", n, a)
                out[4] = np.sqrt(np.einsum("ij,ij->i", a, a))
            out.flags.writeable = False
            batch.planes = out
        return batch.planes

    def candidates(self, eye: NDArray[np.float64], f0: int, f1: int) -> NDArray[np.int64]:
        """The faces of ``f0:f1`` that are not pre-culled back faces for the camera centre `eye`
        (camera_centre), ascending. Only a kept mesh pre-culls: making the planes for one view
        costs about what they save in triangle setup."""
        if not self.keep or not self.any_cull or not np.isfinite(BACKFACE_PRECULL_COS):
            return np.arange(f0, f1, dtype=np.int64)
        p = self.planes_of(self.batch(f0, f1))
        with np.errstate(all="ignore"):
            s = p[0] * eye[0]
            s += p[1] * eye[1]
            s += p[2] * eye[2]
            s += p[3] * eye[3]
            bound = p[4] * (abs(eye[3]) * BACKFACE_PRECULL_COS)
            bound += float(np.sqrt(eye[:3] @ eye[:3])) * BACKFACE_PRECULL_COS
            back = s < -bound
        back &= self.cull[f0:f1]
        return np.flatnonzero(~back) + f0
