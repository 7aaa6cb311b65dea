"""Vectorised NumPy triangle rasterizer producing per-pixel fragments.

The rasterizer knows nothing about lighting or materials (PyTorch3D style): it
turns a triangle mesh, a view and an OpenGL projection into, per pixel, the
index of the visible face, its view-space depth and perspective-correct
barycentrics with respect to that face's three vertices.

Pipeline (no Python loop per triangle or per pixel):

1. vertices → clip space (``proj @ view``), float64;
2. faces are processed in batches of :data:`FACE_BATCH`; trivially invisible
   faces (non-finite, fully outside one frustum plane) are dropped;
3. faces crossing the near plane (``z_clip + w_clip = 0``, i.e. ``w = near``
   for a perspective matrix) are clipped Sutherland–Hodgman style into one or
   two triangles, each clipped vertex carrying its barycentric coordinates in
   the original face (folded into the triangle's barycentric coefficients);
4. per triangle: screen-space edge functions in float64 (written so that an
   edge shared by two triangles gives exactly negated values, plus a top-left
   tie rule: watertight, no pixel covered twice), a depth plane, a pixel
   bounding box; boxes larger than :data:`TILE` are split into tiles, and
   full tiles inside all three edges are marked interior (no edge tests);
5. boxes/tiles are grouped by power-of-two size class ``(sy, sx)`` and tested
   against the pixel centres of a dense ``(sy, sx, n)`` grid by broadcasting
   (one add, one compare and one ``and`` per edge and candidate pixel; the
   tile axis is innermost so NumPy's loops are long), in chunks of at most
   ``min(max_fragments, GRID_CHUNK_CELLS)`` candidate pixels;
6. covered fragments are depth-resolved with ``np.minimum.at`` on int64
   keys packing (NDC depth quantised to 2**-44, triangle index; equal keys:
   the lower index wins); only the winning fragments of a batch get their
   perspective-correct barycentrics and view depth computed.

Steps 3–6 run on worker threads (clshade.render.arrays; NumPy releases the
GIL in its loops): the triangle setup in parts of the batch, the grids of
step 5 shared out with one key array per thread (merged by a minimum), the
winners in chunks. The result does not depend on the thread count.
The output is the list of covered pixels (what the G-buffer reads);
full-frame arrays are made from it on demand (:class:`Fragments`).

Pixel conventions: row 0 is the top of the image; pixel ``(i, j)`` has its
centre at NDC ``x = (j + 0.5) / W * 2 - 1``, ``y = 1 - (i + 0.5) / H * 2``.
Front faces are counter-clockwise in NDC.
"""
from __future__ import annotations

import dataclasses
import threading
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from clshade.render.arrays import chunks, run_chunked, run_tasks, workers_for

__all__ = ["Fragments", "rasterize"]

# --------------------------------------------------------------------------
# Tolerances (every epsilon is named here, with the reason it exists)
# --------------------------------------------------------------------------

#: A triangle is degenerate (dropped) when the sine of the screen-space angle
#: between its edges is below this: such a sliver is thinner than float64
#: round-off can resolve (its barycentrics would be noise) and in practice
#: covers no pixel centre.  Exactly zero-area triangles are always dropped.
DEGENERATE_SIN_EPS: float = 1e-10

#: Fragments are kept when ``-1 - eps <= z_ndc <= 1 + eps``.  Vertices created
#: by near-plane clipping lie on ``z_ndc = -1`` only up to a few ulps, so the
#: depth range test must not reject them on round-off.
NDC_DEPTH_EPS: float = 1e-9

#: Edge-function threshold of edges that do *not* own ties (top-left rule):
#: ``E >= TIE_EPS`` means ``E > 0`` for any value a pixel-scale edge function
#: can take, while ``E >= 0.0`` is used for the edges that own ties.  The
#: smallest *normal* double is used (not the smallest subnormal) so the rule
#: survives flush-to-zero/denormals-are-zero floating-point modes.
TIE_EPS: float = float(np.finfo(np.float64).tiny)

#: A tile of a large triangle is skipped when, for one edge, all its corner
#: pixel centres are farther than this (in pixels) outside that edge.  The
#: margin keeps the cull conservative against round-off in the corner values.
TILE_CULL_MARGIN_PX: float = 1e-6

# --------------------------------------------------------------------------
# Tuning constants (not tolerances)
# --------------------------------------------------------------------------

#: Largest bounding-box side processed as one dense grid; larger boxes are
#: split into TILE x TILE tiles.  Must be a power of two.
TILE: int = 32
_TILE_LOG2: int = TILE.bit_length() - 1

#: Maximum faces per batch: bounds the per-triangle working memory (a few
#: hundred bytes per face) independently of the mesh size.  Small enough for
#: the batch temporaries to be recycled by malloc instead of being returned to
#: the OS and page-faulted in again (a large cost on virtual machines).
FACE_BATCH: int = 1 << 16

#: Preferred number of candidate pixels per dense grid chunk (cache friendly);
#: the effective chunk is ``min(max_fragments, GRID_CHUNK_CELLS)`` (but at
#: least one grid of the size class being processed).
GRID_CHUNK_CELLS: int = 1 << 17

#: Tiles generated at a time (bounds memory when many triangles are large).
MAX_TILES: int = 1 << 18

#: A batch's triangle setup is split over the worker threads from this many
#: faces (its per-face work is ~100 times a per-pixel operation's).
SETUP_PARALLEL_MIN_FACES: int = 4096

#: Winning fragments whose barycentrics are computed at a time (cache sized).
WINNER_CHUNK: int = 1 << 16

#: Key arrays of frames up to this many pixels are kept for the next call (they
#: are left all-empty): the frames of a moving camera reuse them instead of
#: allocating and filling 8 bytes a pixel per worker thread every frame.
KEEP_KEYS_MAX_PIXELS: int = 1 << 22

_EMPTY_KEY = np.iinfo(np.int64).max
_spare_keys: list[NDArray[np.int64]] = []
_spare_lock = threading.Lock()
_KEY_BITS = 62  # packed keys stay below 2**62: non-negative, no overflow


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


def _no_fragments(height: int, width: int) -> Fragments:
    return Fragments(height, width, np.zeros(0, np.int64), np.zeros(0, np.int32), np.zeros(0, np.float32),
                     np.zeros((3, 0), np.float32))


# --------------------------------------------------------------------------
# Public entry point
# --------------------------------------------------------------------------


def rasterize(
    vertices: ArrayLike,
    faces: ArrayLike,
    view: ArrayLike,
    proj: ArrayLike,
    width: int,
    height: int,
    cull_backfaces: bool | np.ndarray = True,
    max_fragments: int = 8_000_000,
) -> Fragments:
    """Rasterize a triangle mesh into per-pixel fragments.

    Args:
        vertices: ``(V, 3)`` world-space positions.
        faces: ``(F, 3)`` vertex indices.
        view: 4x4 world→camera matrix (camera looks down -Z, +Y up).
        proj: 4x4 OpenGL projection matrix (column vectors:
            ``p_clip = proj @ view @ [x, y, z, 1]``).
        width, height: image size in pixels.
        cull_backfaces: True drops faces that are clockwise in NDC, False keeps
            all, a ``(F,)`` bool array culls per face (True = cull).
        max_fragments: upper bound on candidate pixels alive at a time.

    Returns:
        :class:`Fragments`; nearest fragment (smallest depth) wins, only depths
        between the near and far planes are kept.  A pixel is covered when its
        centre is inside a triangle; centres exactly on an edge follow the
        top-left rule, so adjacent triangles never both (or neither) cover it.
        Faces crossing the near plane are clipped; faces behind the camera,
        degenerate or with non-finite vertices are dropped silently.

    Raises:
        ValueError: on malformed shapes, non-integer or out-of-range faces.
    """
    width, height = int(width), int(height)
    if width < 1 or height < 1:
        raise ValueError(f"image size must be positive, got {width}x{height}")
    if int(max_fragments) < 1:
        raise ValueError("max_fragments must be >= 1")
    verts = np.asarray(vertices, dtype=np.float64)
    if verts.ndim != 2 or verts.shape[1] != 3:
        raise ValueError(f"vertices must have shape (V, 3), got {verts.shape}")
    tris = np.asarray(faces)
    if tris.size == 0:
        tris = tris.reshape(0, 3)
    if tris.ndim != 2 or tris.shape[1] != 3:
        raise ValueError(f"faces must have shape (F, 3), got {tris.shape}")
    if tris.dtype.kind not in "iu":
        raise ValueError(f"faces must be integers, got dtype {tris.dtype}")
    tris = tris.astype(np.int64, copy=False)
    n_faces = tris.shape[0]
    if n_faces and (tris.min() < 0 or tris.max() >= verts.shape[0]):
        raise ValueError("face indices out of range")
    view_m = np.asarray(view, dtype=np.float64)
    proj_m = np.asarray(proj, dtype=np.float64)
    if view_m.shape != (4, 4) or proj_m.shape != (4, 4):
        raise ValueError("view and proj must be 4x4 matrices")
    if isinstance(cull_backfaces, (bool, np.bool_)):
        cull = np.full(n_faces, bool(cull_backfaces))
    else:
        cull = np.asarray(cull_backfaces, dtype=bool)
        if cull.shape != (n_faces,):
            raise ValueError(f"cull_backfaces array must have shape ({n_faces},), got {cull.shape}")

    if n_faces == 0:
        return _no_fragments(height, width)

    with np.errstate(all="ignore"):  # non-finite input is dropped, never warned about
        mvp = proj_m @ view_m
        vx, vy, vz = verts[:, 0], verts[:, 1], verts[:, 2]
        # Per-row products (not a BLAS matmul: no thread pool, no extra copy).
        clip_t = np.empty((4, len(verts)))  # (4, V) clip coordinates
        for k in range(4):
            clip_t[k] = vx * mvp[k, 0] + vy * mvp[k, 1] + vz * mvp[k, 2] + mvp[k, 3]
        vdepth = -(vx * view_m[2, 0] + vy * view_m[2, 1] + vz * view_m[2, 2] + view_m[2, 3])  # -z_view
        vfinite = np.isfinite(vdepth)
        for k in range(4):
            vfinite &= np.isfinite(clip_t[k])
        w_is_depth = bool(np.array_equal(proj_m[3], [0.0, 0.0, -1.0, 0.0]))
        n_batches = -(-n_faces // FACE_BATCH)
        state = _Resolve(width, height, int(max_fragments), w_is_depth, several_batches=n_batches > 1)
        bounds = np.linspace(0, n_faces, n_batches + 1).round().astype(int)  # balanced batches
        if n_batches == 1:  # the batch's winners are the result
            result = _raster_batch(state, clip_t, vdepth, vfinite, tris, cull, 0, n_faces, None) \
                or _no_fragments(height, width)
        else:  # later batches overwrite nearer pixels: winners go to full-frame arrays
            frame = (np.full((height, width), -1, np.int32), np.zeros((height, width), np.float32),
                     np.zeros((3, height, width), np.float32))
            for f0, f1 in zip(bounds[:-1].tolist(), bounds[1:].tolist()):
                _raster_batch(state, clip_t, vdepth, vfinite, tris, cull, f0, f1, frame)
            result = Fragments.from_frame(*frame)
    state.release()  # not reached on an exception: arrays left mid-batch are dropped
    return result


# --------------------------------------------------------------------------
# Internals
# --------------------------------------------------------------------------


class _Resolve:
    """Depth-resolve state shared by all face batches."""

    def __init__(self, width: int, height: int, max_fragments: int, w_is_depth: bool,
                 several_batches: bool) -> None:
        self.width = width
        self.height = height
        self.w_is_depth = w_is_depth
        self.chunk_cells = min(max_fragments, GRID_CHUNK_CELLS)
        n_pix = width * height
        # Quantised depth of the current winner of each pixel (across batches;
        # not needed when there is one batch).
        self.best_q = np.full(n_pix, _EMPTY_KEY, dtype=np.int64) if several_batches else None
        # Packed (depth, triangle) keys of the batch being rasterized, one
        # array per worker thread (each resolves its share of the candidate
        # grids with np.minimum.at; the arrays are merged by a minimum); reset
        # to empty (only the touched rows) after each batch.
        self.keys: list[NDArray[np.int64]] = []
        self.key_arrays(1)
        # Bits of a packed key holding the triangle index: near-plane
        # clipping at most doubles a batch's FACE_BATCH faces.
        self.tri_bits = max(1, (2 * FACE_BATCH - 1).bit_length())

    def key_arrays(self, count: int) -> list[NDArray[np.int64]]:
        """`count` key arrays (the first is the merge target): spare ones of an earlier call, else new."""
        n_pix = self.width * self.height
        while len(self.keys) < count:
            with _spare_lock:
                spare = next((i for i, a in enumerate(_spare_keys) if a.size == n_pix), None)
                keys = _spare_keys.pop(spare) if spare is not None else None
            self.keys.append(keys if keys is not None else np.full(n_pix, _EMPTY_KEY, dtype=np.int64))
        return self.keys[:count]

    def release(self) -> None:
        """Keep the (all-empty again) key arrays for the next call when the frame is small enough."""
        if self.width * self.height <= KEEP_KEYS_MAX_PIXELS:
            with _spare_lock:
                _spare_keys[:] = [a for a in _spare_keys if a.size == self.keys[0].size] + self.keys
        self.keys = []


@dataclass
class _Tris:
    """Screen-space setup of the (clipped) triangles of one batch.

    Per-vertex / per-edge arrays are ``(3, T)`` so that each row is a
    contiguous 1-D array (fast gathers).
    """

    face: NDArray[np.int64]  # (T,) original face index
    face0: int  # first face of the batch
    face_depth: NDArray[np.float64]  # (3, n_batch) view depth of the batch's face vertices
    n_unclipped: int  # the first n_unclipped triangles are whole faces, the rest near-plane clipped
    persp_a: NDArray[np.float64]  # (3, T) perspective-correct barycentric weights of the
    persp_b: NDArray[np.float64]  #   ORIGINAL face's vertices, affine in (X, Y) up to a
    persp_c: NDArray[np.float64]  #   common factor (normalised per pixel): a X + (b Y + c)
    edge_a: NDArray[np.float64]  # (3, T) edge i: E_i = A X + (B Y + C), >= 0 inside
    edge_b: NDArray[np.float64]
    edge_c: NDArray[np.float64]
    edge_thr: NDArray[np.float64]  # (3, T) 0.0 (edge owns ties) or TIE_EPS
    area2: NDArray[np.float64]  # (T,) twice the screen-space area (pixels^2)
    z_a: NDArray[np.float64]  # (T,) NDC depth plane z = z_a X + (z_b Y + z_c)
    z_b: NDArray[np.float64]
    z_c: NDArray[np.float64]
    col0: NDArray[np.int64]  # (T,) pixel bounding box (inclusive)
    col1: NDArray[np.int64]
    row0: NDArray[np.int64]
    row1: NDArray[np.int64]


def _clip_near(
    p: NDArray[np.float64], dist: NDArray[np.float64], face: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """Clip triangles crossing the near plane (Sutherland–Hodgman, one plane).

    Args:
        p: ``(n, 3, 4)`` clip coordinates; every triangle has one or two
            vertices with ``dist = z + w < 0`` (outside).
        dist: ``(n, 3)`` signed distances ``z + w``.
        face: ``(n,)`` original face indices.

    Returns:
        ``(p_out (k, 3, 4), face_out (k,), bary (k, 3, 3))`` where
        ``bary[k, v]`` are the barycentrics of output vertex ``v`` in the
        original face.  Winding is preserved.  Intersections are always
        computed from the inside vertex towards the outside one, so two faces
        sharing a clipped edge get bit-identical new vertices (no cracks).
    """
    inside = dist >= 0.0
    n_in = inside.sum(axis=1)
    ar = np.arange(3)
    outs_p: list[NDArray[np.float64]] = []
    outs_f: list[NDArray[np.int64]] = []
    outs_b: list[NDArray[np.float64]] = []

    def rotated(mask: NDArray[np.bool_], first: NDArray[np.int64]):
        # Cyclic rotation (keeps the winding) putting vertex `first` at 0.
        order = (first[:, None] + ar[None, :]) % 3
        pr = np.take_along_axis(p[mask], order[:, :, None], axis=1)
        dr = np.take_along_axis(dist[mask], order, axis=1)
        return order, pr, dr

    def to_original(order: NDArray[np.int64], bary_rot: NDArray[np.float64]) -> NDArray[np.float64]:
        # bary_rot[k, v, j] weights rotated vertex j, i.e. original order[k, j].
        res = np.empty_like(bary_rot)
        np.put_along_axis(res, np.broadcast_to(order[:, None, :], bary_rot.shape), bary_rot, axis=2)
        return res

    one = n_in == 1
    if one.any():  # a inside, b and c outside -> triangle (a, ab, ac)
        order, pr, dr = rotated(one, np.argmax(inside[one], axis=1))
        a, b, c = pr[:, 0], pr[:, 1], pr[:, 2]
        da, db, dc = dr[:, 0], dr[:, 1], dr[:, 2]
        tb = da / (da - db)
        tc = da / (da - dc)
        pab = a + tb[:, None] * (b - a)
        pac = a + tc[:, None] * (c - a)
        outs_p.append(np.stack([a, pab, pac], axis=1))
        outs_f.append(face[one])
        br = np.zeros((len(tb), 3, 3))
        br[:, 0, 0] = 1.0
        br[:, 1, 0] = 1.0 - tb
        br[:, 1, 1] = tb
        br[:, 2, 0] = 1.0 - tc
        br[:, 2, 2] = tc
        outs_b.append(to_original(order, br))

    two = n_in == 2
    if two.any():  # a outside -> quad (ab, b, c, ac) -> (ab, b, c) + (ab, c, ac)
        order, pr, dr = rotated(two, np.argmin(inside[two], axis=1))
        a, b, c = pr[:, 0], pr[:, 1], pr[:, 2]
        da, db, dc = dr[:, 0], dr[:, 1], dr[:, 2]
        tb = db / (db - da)
        tc = dc / (dc - da)
        pab = b + tb[:, None] * (a - b)
        pac = c + tc[:, None] * (a - c)
        outs_p.append(np.stack([pab, b, c], axis=1))
        outs_p.append(np.stack([pab, c, pac], axis=1))
        outs_f += [face[two], face[two]]
        m = len(tb)
        q_ab = np.zeros((m, 3))
        q_ab[:, 0] = tb
        q_ab[:, 1] = 1.0 - tb
        q_ac = np.zeros((m, 3))
        q_ac[:, 0] = tc
        q_ac[:, 2] = 1.0 - tc
        e_b = np.broadcast_to(np.array([0.0, 1.0, 0.0]), (m, 3))
        e_c = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (m, 3))
        outs_b.append(to_original(order, np.stack([q_ab, e_b, e_c], axis=1)))
        outs_b.append(to_original(order, np.stack([q_ab, e_c, q_ac], axis=1)))

    if not outs_p:
        return np.zeros((0, 3, 4)), np.zeros(0, dtype=np.int64), np.zeros((0, 3, 3))
    return np.concatenate(outs_p), np.concatenate(outs_f), np.concatenate(outs_b)


def _cols(a: NDArray, idx: NDArray[np.int64]) -> NDArray:
    """``a[:, idx]`` (np.take along axis 1 is several times faster)."""
    return np.take(a, idx, axis=1)


def _all3(a: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """``a.all(axis=0)`` for a ``(3, n)`` array (faster than a reduction)."""
    return a[0] & a[1] & a[2]


def _setup(
    clip_t: NDArray[np.float64],
    vfinite: NDArray[np.bool_],
    vdepth: NDArray[np.float64],
    tris: NDArray[np.int64],
    cull: NDArray[np.bool_],
    f0: int,
    f1: int,
    width: int,
    height: int,
) -> _Tris | None:
    """Cull, clip, project and set up edge functions for faces ``f0:f1``."""
    fv = np.ascontiguousarray(tris[f0:f1].T)  # (3, n) vertex indices
    face = np.arange(f0, f1, dtype=np.int64)
    x, y, z, w = (clip_t[k][fv] for k in range(4))  # (3, n) each
    dist = z + w  # near plane: dist >= 0 is visible
    inside = dist >= 0.0
    # Trivial rejects: all 3 vertices outside one frustum plane (a linear
    # test, valid even for vertices behind the camera).
    ok = _all3(vfinite[fv]) & (inside[0] | inside[1] | inside[2])
    ok &= ~_all3(z > w)
    ok &= ~_all3(x > w)
    ok &= ~_all3(x < -w)
    ok &= ~_all3(y > w)
    ok &= ~_all3(y < -w)
    full = ok & _all3(inside)
    part = ok & ~full
    x0, y0, z0, w0, face0 = x, y, z, w, face
    if not full.all():
        keep = np.flatnonzero(full)
        x, y, z, w, face = _cols(x, keep), _cols(y, keep), _cols(z, keep), _cols(w, keep), face[keep]
    slot = np.full(len(face), -1, dtype=np.int64)
    clip_bary = np.zeros((0, 3, 3))
    if part.any():  # near-plane clipping (rare, so done on (m, 3, 4) stacks)
        sub = np.flatnonzero(part)
        pc, fc, clip_bary = _clip_near(
            np.stack([_cols(a, sub).T for a in (x0, y0, z0, w0)], axis=-1), _cols(dist, sub).T, face0[sub])
        x, y, z, w = (np.concatenate([a, pc[:, :, k].T], axis=1) for k, a in enumerate((x, y, z, w)))
        face = np.concatenate([face, fc])
        slot = np.concatenate([slot, np.arange(len(fc), dtype=np.int64)])
    if len(face) == 0:
        return None

    inv_w = 1.0 / w
    sx = (x * inv_w + 1.0) * (0.5 * width)  # (3, T) pixel X, rightwards
    sy = (1.0 - y * inv_w) * (0.5 * height)  # (3, T) pixel Y, downwards
    e1x, e1y = sx[1] - sx[0], sy[1] - sy[0]
    e2x, e2y = sx[2] - sx[0], sy[2] - sy[0]
    area2 = e1x * e2y - e1y * e2x  # Y-down frame: < 0 for CCW-in-NDC (front) faces
    scale = np.sqrt((e1x * e1x + e1y * e1y) * (e2x * e2x + e2y * e2y))
    # Pixel bounding box: centres j + 0.5 within [min, max], clamped to the image.
    c0 = np.maximum(np.ceil(np.minimum(np.minimum(sx[0], sx[1]), sx[2]) - 0.5), 0.0)
    c1 = np.minimum(np.floor(np.maximum(np.maximum(sx[0], sx[1]), sx[2]) - 0.5), width - 1.0)
    r0 = np.maximum(np.ceil(np.minimum(np.minimum(sy[0], sy[1]), sy[2]) - 0.5), 0.0)
    r1 = np.minimum(np.floor(np.maximum(np.maximum(sy[0], sy[1]), sy[2]) - 0.5), height - 1.0)
    # Drop: non-finite (overflow, w -> 0: area2/scale become inf/nan and the
    # comparisons below False), degenerate, culled, or covering no pixel centre.
    ok = _all3(w > 0.0) & np.isfinite(area2) & np.isfinite(scale)
    ok &= (area2 != 0.0) & (np.abs(area2) > DEGENERATE_SIN_EPS * scale)
    ok &= ~(cull[face] & (area2 > 0.0))  # back face = clockwise in NDC
    ok &= (c1 >= c0) & (r1 >= r0)
    if not ok.all():
        keep = np.flatnonzero(ok)
        if len(keep) == 0:
            return None
        face, slot, area2 = face[keep], slot[keep], area2[keep]
        w, z, inv_w, sx, sy = (_cols(a, keep) for a in (w, z, inv_w, sx, sy))
        e1x, e1y, e2x, e2y = e1x[keep], e1y[keep], e2x[keep], e2y[keep]
        c0, c1, r0, r1 = c0[keep], c1[keep], r0[keep], r1[keep]
    # NDC-depth plane z(X, Y) = za X + (zb Y + zc), relative to vertex 0 for accuracy.
    sz = z * inv_w
    dz1, dz2 = sz[1] - sz[0], sz[2] - sz[0]
    za = (dz1 * e2y - dz2 * e1y) / area2
    zb = (dz2 * e1x - dz1 * e2x) / area2
    zc = sz[0] - za * sx[0] - zb * sy[0]
    ok = np.isfinite(za) & np.isfinite(zb) & np.isfinite(zc)
    if not ok.all():  # only with absurd depth ranges (overflow)
        keep = np.flatnonzero(ok)
        if len(keep) == 0:
            return None
        face, slot, area2, za, zb, zc = face[keep], slot[keep], area2[keep], za[keep], zb[keep], zc[keep]
        w, sx, sy = (_cols(a, keep) for a in (w, sx, sy))
        c0, c1, r0, r1 = c0[keep], c1[keep], r0[keep], r1[keep]
    # Edge i is opposite vertex i, from vertex a = i+1 to b = i+2 (mod 3):
    # E_i = A X + (B Y + C), A = Ya - Yb, B = Xb - Xa, C = Xa Yb - Xb Ya.
    # The reversed edge (b, a) of a neighbour gives exactly -A, -B, -C, hence
    # exactly -E_i at every pixel: shared edges are watertight.
    ia, ib = [1, 2, 0], [2, 0, 1]
    xa, xb, ya, yb = sx[ia], sx[ib], sy[ia], sy[ib]
    sgn = np.where(area2 > 0.0, 1.0, -1.0)  # make E >= 0 inside (exact)
    ea = (ya - yb) * sgn
    eb = (xb - xa) * sgn
    ec = (xa * yb - xb * ya) * sgn
    # Top-left rule: an edge owns the pixel centres exactly on it if the
    # interior is to its right (A > 0: a "left" edge) or, for a horizontal
    # edge, below it (A == 0, B > 0: a "top" edge).  The two triangles
    # sharing an edge have negated (A, B), so exactly one of them owns it.
    owns = (ea > 0.0) | ((ea == 0.0) & (eb > 0.0))
    thr = np.where(owns, 0.0, TIE_EPS)

    # Perspective-correct weights: screen-space barycentrics (edge functions)
    # divided by clip w, up to a common factor.  A clipped triangle's weights
    # of its own vertices v map to the original face's vertices j through
    # clip_bary[k, v, j]; that map is linear, so it is folded into the affine
    # coefficients here, once per triangle instead of once per pixel.
    persp = np.stack([ea / w, eb / w, ec / w])  # (coefficient, vertex, T)
    clipped = np.flatnonzero(slot >= 0)
    if len(clipped):
        persp[:, :, clipped] = np.einsum("cvm,mvj->cjm", persp[:, :, clipped], clip_bary[slot[clipped]])

    return _Tris(
        face=face, face0=f0, face_depth=np.take(vdepth, fv), n_unclipped=int(np.count_nonzero(slot < 0)),
        persp_a=persp[0], persp_b=persp[1], persp_c=persp[2],
        edge_a=ea, edge_b=eb, edge_c=ec, edge_thr=thr, area2=np.abs(area2),
        z_a=za, z_b=zb, z_c=zc,
        col0=c0.astype(np.int64), col1=c1.astype(np.int64),
        row0=r0.astype(np.int64), row1=r1.astype(np.int64),
    )


def _make_tiles(t: _Tris, t0: int, t1: int) -> tuple[NDArray[np.int64], ...]:
    """Split the pixel boxes of triangles ``t0:t1`` into tiles of at most TILE x TILE.

    Returns ``(tri, x0, y0, bw, bh, interior)`` per tile.  Tiles of large
    triangles lying entirely outside one of their edges are culled; full
    TILE x TILE tiles whose every pixel centre is inside all three edges (by
    more than the margin) are flagged ``interior``: they need no edge tests.
    """
    col0, row0 = t.col0[t0:t1], t.row0[t0:t1]
    bw = t.col1[t0:t1] - col0 + 1
    bh = t.row1[t0:t1] - row0 + 1
    big = (bw > TILE) | (bh > TILE)
    if not big.any():
        return np.arange(t0, t1), col0, row0, bw, bh, np.zeros(t1 - t0, bool)
    small = np.flatnonzero(~big)
    bi = np.flatnonzero(big)
    ntx = (bw[bi] + TILE - 1) >> _TILE_LOG2
    nty = (bh[bi] + TILE - 1) >> _TILE_LOG2
    cnt = ntx * nty
    rep = np.repeat(np.arange(len(bi)), cnt)
    k = np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    ti = bi[rep] + t0
    ky, kx = np.divmod(k, ntx[rep])
    bx0 = t.col0[ti] + (kx << _TILE_LOG2)
    by0 = t.row0[ti] + (ky << _TILE_LOG2)
    bbw = np.minimum(TILE, t.col1[ti] - bx0 + 1)
    bbh = np.minimum(TILE, t.row1[ti] - by0 + 1)
    # Conservative tile cull: all 4 corner pixel centres outside one edge.
    xs = (bx0 + 0.5, bx0 + (bbw - 0.5))
    ys = (by0 + 0.5, by0 + (bbh - 0.5))
    keep = np.ones(len(ti), dtype=bool)
    interior = (bbw == TILE) & (bbh == TILE)
    for i in range(3):
        a, b, c = t.edge_a[i][ti], t.edge_b[i][ti], t.edge_c[i][ti]
        corners = (a * xs[0] + (b * ys[0] + c), a * xs[1] + (b * ys[0] + c),
                   a * xs[0] + (b * ys[1] + c), a * xs[1] + (b * ys[1] + c))
        margin = TILE_CULL_MARGIN_PX * (np.abs(a) + np.abs(b))
        # An affine function's extremes over the box are at its corners.
        keep &= np.maximum(np.maximum(corners[0], corners[1]), np.maximum(corners[2], corners[3])) >= -margin
        interior &= np.minimum(np.minimum(corners[0], corners[1]), np.minimum(corners[2], corners[3])) >= margin
    return (np.concatenate([small + t0, ti[keep]]), np.concatenate([col0[small], bx0[keep]]),
            np.concatenate([row0[small], by0[keep]]), np.concatenate([bw[small], bbw[keep]]),
            np.concatenate([bh[small], bbh[keep]]), np.concatenate([np.zeros(len(small), bool), interior[keep]]))


_CEIL_LOG2 = np.zeros(TILE + 1, dtype=np.int64)
for _k in range(1, _TILE_LOG2 + 1):
    _CEIL_LOG2[(1 << (_k - 1)) + 1: (1 << _k) + 1] = _k
del _k


def _raster_batch(
    state: _Resolve,
    clip_t: NDArray[np.float64],
    vdepth: NDArray[np.float64],
    vfinite: NDArray[np.bool_],
    tris: NDArray[np.int64],
    cull: NDArray[np.bool_],
    f0: int,
    f1: int,
    frame: tuple[NDArray[np.int32], NDArray[np.float32], NDArray[np.float32]] | None,
) -> Fragments | None:
    """Rasterize faces ``f0:f1``: their winners as Fragments (``frame`` None, the only
    batch) or merged into the full-frame arrays ``frame`` = (tri_id, depth, bary planes)."""
    width = state.width
    t = _setup_parallel(clip_t, vfinite, vdepth, tris, cull, f0, f1, width, state.height)
    if t is None:
        return None
    # Key = (quantised NDC depth << tri_bits) | triangle: min key = nearest.
    # The quantisation is the same for every batch (depths are compared
    # across batches): tri_bits covers the largest possible batch.
    tri_bits = state.tri_bits
    z_scale = float((1 << (_KEY_BITS - tri_bits)) - 1) * 0.5

    # Triangle groups of at most ~MAX_TILES tiles bound the tile arrays'
    # memory even when many triangles are large.
    n_tiles = (((t.col1 - t.col0) >> _TILE_LOG2) + 1) * (((t.row1 - t.row0) >> _TILE_LOG2) + 1)
    cum = np.cumsum(n_tiles)
    used = 1
    t0 = 0
    while t0 < len(cum):
        base = int(cum[t0 - 1]) if t0 else 0
        t1 = max(t0 + 1, int(np.searchsorted(cum, base + MAX_TILES, side="right")))
        used = max(used, _raster_tiles(state, t, _make_tiles(t, t0, t1), tri_bits, z_scale))
        t0 = t1

    hit, k = _resolved(state, used, int(t.row0.min()) * width, (int(t.row1.max()) + 1) * width)
    if len(hit) == 0:
        return None
    if state.best_q is not None:
        # Merge with previous batches: strictly nearer wins (ties: earlier batch).
        kq = k >> tri_bits
        better = kq < state.best_q[hit]
        if not better.all():
            hit, k, kq = hit[better], k[better], kq[better]
        state.best_q[hit] = kq
    tri_mask = (1 << tri_bits) - 1
    face = np.empty(len(hit), np.int32)
    depth = np.empty(len(hit), np.float32)
    bary = np.empty((3, len(hit)), np.float32)

    def winners(part: slice) -> None:
        face[part], depth[part], bary[:, part] = _winners(t, hit[part], k[part] & tri_mask, width, state.w_is_depth)
        if frame is not None:
            frame[0].reshape(-1)[hit[part]] = face[part]
            frame[1].reshape(-1)[hit[part]] = depth[part]
            for j in range(3):
                frame[2][j].reshape(-1)[hit[part]] = bary[j, part]

    run_chunked(len(hit), winners, max_chunk=WINNER_CHUNK)
    return Fragments(state.height, width, hit, face, depth, bary) if frame is None else None


def _resolved(state: _Resolve, used: int, lo: int, hi: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The pixels in ``lo:hi`` that a batch covered (ascending) and their winning keys, the
    `used` workers' key arrays merged (the smaller key wins, as in one array) and left empty
    again. Runs in chunks of pixels on the worker threads: merge and count, then extract."""
    keys, *others = state.key_arrays(used)
    ranges = [slice(lo + p.start, lo + p.stop) for p in chunks(hi - lo, 2 * workers_for(hi - lo))]
    masks: list[NDArray[np.bool_]] = [np.zeros(0, bool)] * len(ranges)

    def merge(i: int) -> None:
        r = ranges[i]
        for other in others:
            np.minimum(keys[r], other[r], out=keys[r])
            other[r] = _EMPTY_KEY
        masks[i] = keys[r] != _EMPTY_KEY

    run_tasks([lambda i=i: merge(i) for i in range(len(ranges))])
    counts = [int(np.count_nonzero(m)) for m in masks]
    starts = np.concatenate([[0], np.cumsum(counts)]).tolist()
    hit = np.empty(starts[-1], np.int64)
    k = np.empty(starts[-1], np.int64)

    def extract(i: int) -> None:
        out = slice(starts[i], starts[i + 1])
        hit[out] = np.flatnonzero(masks[i]) + ranges[i].start
        k[out] = keys[hit[out]]
        keys[hit[out]] = _EMPTY_KEY

    run_tasks([lambda i=i: extract(i) for i in range(len(ranges))])
    return hit, k


def _setup_parallel(
    clip_t: NDArray[np.float64],
    vfinite: NDArray[np.bool_],
    vdepth: NDArray[np.float64],
    tris: NDArray[np.int64],
    cull: NDArray[np.bool_],
    f0: int,
    f1: int,
    width: int,
    height: int,
) -> _Tris | None:
    """:func:`_setup` of faces ``f0:f1`` in parts on the worker threads, joined in the order one
    call gives (whole faces by index, then the clipped triangles by face index), so that triangle
    indices (the depth ties' order) do not depend on the number of threads."""
    workers = workers_for(f1 - f0, SETUP_PARALLEL_MIN_FACES)
    if workers == 1:
        return _setup(clip_t, vfinite, vdepth, tris, cull, f0, f1, width, height)
    parts: list[_Tris | None] = [None] * workers
    spans = [slice(f0 + p.start, f0 + p.stop) for p in chunks(f1 - f0, workers)]

    def setup(i: int) -> None:
        parts[i] = _setup(clip_t, vfinite, vdepth, tris, cull, spans[i].start, spans[i].stop, width, height)

    run_tasks([lambda i=i: setup(i) for i in range(len(spans))], workers)
    done = [p for p in parts if p is not None]
    if not done:
        return None
    offsets = np.cumsum([0] + [len(p.face) for p in done]).tolist()
    order = np.concatenate([np.arange(o, o + p.n_unclipped) for o, p in zip(offsets, done)]
                           + [np.arange(o + p.n_unclipped, o + len(p.face)) for o, p in zip(offsets, done)])
    joined = {f.name: np.take(np.concatenate([getattr(p, f.name) for p in done], axis=-1), order, axis=-1)
              for f in dataclasses.fields(_Tris) if f.name not in ("face0", "face_depth", "n_unclipped")}
    return _Tris(face0=f0, face_depth=np.take(vdepth, np.ascontiguousarray(tris[f0:f1].T)),
                 n_unclipped=sum(p.n_unclipped for p in done), **joined)


def _raster_tiles(
    state: _Resolve, t: _Tris, tiles: tuple[NDArray[np.int64], ...], tri_bits: int, z_scale: float
) -> int:
    """Test the pixel centres of ``tiles`` against their triangles; resolve into the key arrays.

    The tiles are grouped by size class into chunks of candidate pixels; the
    chunks are shared out to the worker threads (largest first, each to the
    least loaded worker), each resolving into its own key array.  Returns how
    many key arrays were written (the caller merges them).
    """
    tile_tri, tx0, ty0, tbw, tbh, interior = tiles
    n_cls = _TILE_LOG2 + 1
    # Size classes (grid height, width); interior tiles (all TILE x TILE) get the class after them.
    cls = np.where(interior, n_cls * n_cls, _CEIL_LOG2[tbh] * n_cls + _CEIL_LOG2[tbw])
    order = np.argsort(cls, kind="stable")
    counts = np.bincount(cls, minlength=n_cls * n_cls + 1)
    starts = np.concatenate([[0], np.cumsum(counts)])
    work: list[tuple[int, int, NDArray[np.int64], bool]] = []  # (log2 grid width, height, tiles, interior)
    for c in np.flatnonzero(counts):
        lsy, lsx = divmod(int(c), n_cls) if c < n_cls * n_cls else (_TILE_LOG2, _TILE_LOG2)
        per_chunk = max(1, state.chunk_cells >> (lsx + lsy))
        sel_all = order[starts[c]: starts[c + 1]]
        work += [(lsx, lsy, sel_all[s: s + per_chunk], c == n_cls * n_cls)
                 for s in range(0, len(sel_all), per_chunk)]
    cells = [len(sel) << (lsx + lsy) for lsx, lsy, sel, _ in work]
    workers = min(workers_for(sum(cells)), len(work))
    shares: list[list[int]] = [[] for _ in range(workers)]
    load = [0] * workers
    for i in sorted(range(len(work)), key=cells.__getitem__, reverse=True):
        w = load.index(min(load))
        shares[w].append(i)
        load[w] += cells[i]
    keys = state.key_arrays(workers)
    run_tasks([lambda share=share, k=k: [_test_grid(state, t, tiles, *work[i], k, tri_bits, z_scale) for i in share]
               for share, k in zip(shares, keys)], workers)
    return workers


def _test_grid(
    state: _Resolve, t: _Tris, tiles: tuple[NDArray[np.int64], ...], lsx: int, lsy: int,
    sel: NDArray[np.int64], interior: bool, keys: NDArray[np.int64], tri_bits: int, z_scale: float
) -> None:
    """Test tiles ``sel`` (all of one size class, grids of 2**lsx x 2**lsy) and resolve into `keys`;
    ``interior`` tiles (full grids inside their triangle) skip the edge tests."""
    tile_tri, tx0, ty0, tbw, tbh, _ = tiles
    width = state.width
    lo_z, hi_z = -1.0 - NDC_DEPTH_EPS, 1.0 + NDC_DEPTH_EPS
    gx, gy = 1 << lsx, 1 << lsy
    cols = np.arange(gx)[:, None]
    rows = np.arange(gy)[:, None]
    n = len(sel)
    ti = tile_tri[sel]
    # Grids are laid out (row, column, tile): the innermost axis runs
    # over the n tiles, so every broadcast loop is long and contiguous.
    xabs = tx0[sel] + cols  # (gx, n) pixel column
    yabs = ty0[sel] + rows  # (gy, n) pixel row
    xc = xabs + 0.5
    yc = yabs + 0.5
    if interior:
        z = (t.z_a[ti] * xc)[None, :, :] + (t.z_b[ti] * yc + t.z_c[ti])[:, None, :]  # (gy, gx, n)
        pix = (yabs * width)[:, None, :] + xabs[None, :, :]
        key_tri = np.broadcast_to(ti, z.shape)
        good = (z >= lo_z) & (z <= hi_z)
        if not good.all():
            z, pix, key_tri = z[good], pix[good], key_tri[good]
        np.clip(z, -1.0, 1.0, out=z)
        q = ((z + 1.0) * z_scale).astype(np.int64)
        np.minimum.at(keys, pix.ravel(), ((q << tri_bits) | key_tri).ravel())
        return
    if gx > 1:  # columns beyond the box: NaN fails every edge test
        xc[cols >= tbw[sel]] = np.nan
    if gy > 1:
        yc[rows >= tbh[sel]] = np.nan
    inside = np.empty((gy, gx, n), dtype=bool)
    tmp_e = np.empty((gy, gx, n), dtype=np.float64)
    tmp_m = np.empty((gy, gx, n), dtype=bool)
    for i in range(3):
        ax = t.edge_a[i][ti] * xc  # (gx, n)
        byc = t.edge_b[i][ti] * yc + t.edge_c[i][ti]  # (gy, n)
        np.add(ax[None, :, :], byc[:, None, :], out=tmp_e)
        thr = t.edge_thr[i][ti]
        if i == 0:
            np.greater_equal(tmp_e, thr, out=inside)
        else:
            np.greater_equal(tmp_e, thr, out=tmp_m)
            inside &= tmp_m
    idx = np.flatnonzero(inside)
    if len(idx) == 0:
        return
    rc, tl = np.divmod(idx, n)  # rc = row * gx + column; tl = tile in chunk
    ri = (rc >> lsx) * n + tl  # flat index into (gy, n)
    ci = (rc & (gx - 1)) * n + tl  # flat index into (gx, n)
    zx = t.z_a[ti] * xc
    zy = t.z_b[ti] * yc + t.z_c[ti]
    z = zx.ravel()[ci] + zy.ravel()[ri]
    good = (z >= lo_z) & (z <= hi_z)  # between the near and far planes
    if not good.all():
        ri, ci, tl, z = ri[good], ci[good], tl[good], z[good]
    pix = (yabs * width).ravel()[ri] + xabs.ravel()[ci]
    np.clip(z, -1.0, 1.0, out=z)
    q = ((z + 1.0) * z_scale).astype(np.int64)
    np.minimum.at(keys, pix, (q << tri_bits) | ti[tl])


def _winners(
    t: _Tris,
    pix: NDArray[np.int64],
    tri: NDArray[np.int64],
    width: int,
    w_is_depth: bool,
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """Face, depth and perspective-correct barycentrics ``(3, K)`` of the winning fragments.

    ``w_is_depth``: the projection's last row is ``(0, 0, -1, 0)`` (any
    perspective matrix), so clip ``w`` is the view depth.
    """
    # Row and column through float64 (pix < 2**53): the quotient is correctly rounded and
    # stays below the next integer (px/width <= 1 - 1/width), so floor() is the exact row;
    # twice as fast as an int64 divmod.
    pf = pix.astype(np.float64)
    py = np.floor(pf / width)
    px = pf - py * width + 0.5
    py += 0.5
    b = np.empty((3, len(pix)))
    for j in range(3):
        e = np.take(t.persp_a[j], tri) * px + (np.take(t.persp_b[j], tri) * py + np.take(t.persp_c[j], tri))
        np.maximum(e, 0.0, out=b[j])
    s = b[0] + b[1] + b[2]
    # s <= 0 or non-finite: only reachable by round-off/overflow on
    # near-degenerate slivers or absurd coordinates; fall back to the centroid.
    bad = ~(s > 0.0) | ~np.isfinite(s)
    if bad.any():
        b[:, bad] = 1.0
        s[bad] = 3.0
    if w_is_depth:
        # w_clip = -z_view: the perspective-correct depth 1 / sum(lambda_i / w_i)
        # is sum(E_i) / sum(E_i / w_i), and sum(E_i) is twice the triangle area.
        depth = np.take(t.area2, tri) / s
    b /= s
    face = np.take(t.face, tri)
    if not w_is_depth or bad.any():  # general projection: interpolate -z_view
        sel = slice(None) if not w_is_depth else np.flatnonzero(bad)
        local = face[sel] - t.face0
        vd = t.face_depth
        bs = b[:, sel]
        d = bs[0] * vd[0][local] + bs[1] * vd[1][local] + bs[2] * vd[2][local]
        if w_is_depth:
            depth[sel] = d
        else:
            depth = d
    return face, depth, b
