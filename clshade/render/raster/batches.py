"""`rasterize`: the checks, the vertices' clip coordinates, and the faces in batches,
each through triangle setup (triangles), coverage (tiles) and depth resolve (resolve)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from clshade.render.arrays import run_chunked
from clshade.render.raster.fragments import Fragments, no_fragments
from clshade.render.raster.mesh import RasterMesh, camera_centre
from clshade.render.raster.resolve import Resolve, key_layout, resolved, view_max_triangles, view_tri_bits, winners
from clshade.render.raster.visibility import ViewSetup
from clshade.render.raster.tiles import cover
from clshade.render.raster.triangles import Tris, join_batches, setup_parallel

#: Maximum faces per batch: bounds the per-triangle working memory (a few
#: hundred bytes per face) independently of the mesh size.  Small enough for
#: the batch temporaries to be recycled by malloc instead of being returned to
#: the OS and page-faulted in again (a large cost on virtual machines).
FACE_BATCH: int = 1 << 16

#: Preferred number of candidate pixels per dense grid chunk (cache friendly);
#: the effective chunk is ``min(max_fragments, GRID_CHUNK_CELLS)`` (but at
#: least one grid of the size class being processed).
GRID_CHUNK_CELLS: int = 1 << 17

#: Winning fragments whose barycentrics are computed at a time (cache sized).
WINNER_CHUNK: int = 1 << 16


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

    Many views of one mesh: make its :class:`RasterMesh` once and call :func:`rasterize_mesh`
    (the checks and the faces' planes are then made once).
    """
    return rasterize_mesh(RasterMesh(vertices, faces, cull_backfaces, keep=False), view, proj, width, height,
                          max_fragments)


def rasterize_mesh(
    mesh: RasterMesh,
    view: ArrayLike,
    proj: ArrayLike,
    width: int,
    height: int,
    max_fragments: int = 8_000_000,
) -> Fragments:
    """:func:`rasterize` of a :class:`RasterMesh` (the same fragments, bit for bit)."""
    frame = _Frame.of(mesh, view, proj, width, height, max_fragments)
    if frame is None:
        return no_fragments(int(height), int(width))
    state, height, width = frame.resolve_state(max_fragments), frame.height, frame.width
    with np.errstate(all="ignore"):  # non-finite input is dropped, never warned about
        if frame.n_batches == 1:  # the batch's winners are the result
            result = _raster_batch(state, *frame.args, 0, len(mesh), None) or no_fragments(height, width)
        else:  # later batches overwrite nearer pixels: winners go to full-frame arrays
            planes = (np.full((height, width), -1, np.int32), np.zeros((height, width), np.float32),
                      np.zeros((3, height, width), np.float32))
            for f0, f1 in zip(frame.bounds[:-1].tolist(), frame.bounds[1:].tolist()):
                _raster_batch(state, *frame.args, f0, f1, planes)
            result = Fragments.from_frame(*planes)
    state.release()  # not reached on an exception: arrays left mid-batch are dropped
    return result


def setup_view(
    mesh: RasterMesh,
    view: ArrayLike,
    proj: ArrayLike,
    width: int,
    height: int,
) -> ViewSetup | None:
    """The triangle setup of :func:`rasterize_mesh` (steps 1–4), for a pass that does coverage,
    depth resolve and the winners' barycentrics on its own (clshade.device.visibility: the
    visibility buffer and G-buffer on the device, rasterize_mesh's result bit for bit). A mesh of
    several face batches is set up batch by batch, as rasterize_mesh does, and joined in batch order
    (join_batches): keys of the batches' depth quantisation with a triangle index over all of them
    pick the winners rasterize_mesh's merge picks. None when those keys cannot hold the view's
    triangles (past view_max_triangles: use rasterize_mesh)."""
    frame = _Frame.of(mesh, view, proj, width, height, 1)
    tri_bits, z_scale = key_layout(FACE_BATCH)
    mvp = np.asarray(proj, np.float64) @ np.asarray(view, np.float64)
    if frame is None:
        return ViewSetup(int(width), int(height), None, True, tri_bits, z_scale, mvp=mvp)
    clip_t, vdepth, vfinite, _, eye = frame.args
    limit, done, count = view_max_triangles(FACE_BATCH), [], 0
    for f0, f1 in zip(frame.bounds[:-1], frame.bounds[1:]):
        with np.errstate(all="ignore"):  # non-finite input is dropped, never warned about
            part = _setup_batch(clip_t, vdepth, vfinite, mesh, eye, int(f0), int(f1), frame.width, frame.height)
        if part is not None:
            count += len(part.face)
            if count > limit:
                return None              # the rest is not set up (memory stays a few batches')
            done.append(part)
    t = None if not done else done[0] if frame.n_batches == 1 else join_batches(done, mesh.batch(0, len(mesh)))
    bits = view_tri_bits(count, FACE_BATCH)
    return ViewSetup(frame.width, frame.height, t, frame.w_is_depth, bits, z_scale, mvp=mvp)


@dataclass
class _Frame:
    """What every batch of one view shares: the image size, the vertices' clip
    coordinates, view depths and finiteness, the camera centre, the face batches."""
    width: int
    height: int
    args: tuple                     # (clip_t, vdepth, vfinite, mesh, eye): _raster_batch's
    n_batches: int
    bounds: NDArray[np.int64]
    w_is_depth: bool

    def resolve_state(self, max_fragments: int) -> Resolve:
        """The depth-resolve state of the view's batches (its key arrays)."""
        return Resolve(self.width, self.height, min(int(max_fragments), GRID_CHUNK_CELLS), self.w_is_depth,
                       several_batches=self.n_batches > 1, batch_faces=FACE_BATCH)

    @classmethod
    def of(cls, mesh: RasterMesh, view: ArrayLike, proj: ArrayLike, width: int, height: int,
           max_fragments: int) -> _Frame | None:
        """The checks and the clip transform; None for a mesh without faces."""
        width, height = int(width), int(height)
        if width < 1 or height < 1:
            raise ValueError(f"image size must be positive, got {width}x{height}")
        if int(max_fragments) < 1:
            raise ValueError("max_fragments must be >= 1")
        view_m = np.asarray(view, dtype=np.float64)
        proj_m = np.asarray(proj, dtype=np.float64)
        if view_m.shape != (4, 4) or proj_m.shape != (4, 4):
            raise ValueError("view and proj must be 4x4 matrices")
        n_faces = len(mesh)
        if n_faces == 0:
            return None
        with np.errstate(all="ignore"):  # non-finite input is dropped, never warned about
            mvp = proj_m @ view_m
            vx, vy, vz = mesh.columns
            # Per-row products (not a BLAS matmul: no thread pool, no extra copy).
            clip_t = np.empty((4, len(vx)))  # (4, V) clip coordinates
            for k in range(4):
                clip_t[k] = vx * mvp[k, 0] + vy * mvp[k, 1] + vz * mvp[k, 2] + mvp[k, 3]
            vdepth = -(vx * view_m[2, 0] + vy * view_m[2, 1] + vz * view_m[2, 2] + view_m[2, 3])  # -z_view
            vfinite = np.isfinite(vdepth)
            for k in range(4):
                vfinite &= np.isfinite(clip_t[k])
            eye = camera_centre(mvp)
        w_is_depth = bool(np.array_equal(proj_m[3], [0.0, 0.0, -1.0, 0.0]))
        n_batches = -(-n_faces // FACE_BATCH)
        bounds = np.linspace(0, n_faces, n_batches + 1).round().astype(int)  # balanced batches
        return cls(width, height, (clip_t, vdepth, vfinite, mesh, eye), n_batches, bounds, w_is_depth)


def _setup_batch(clip_t: NDArray[np.float64], vdepth: NDArray[np.float64], vfinite: NDArray[np.bool_],
                 mesh: RasterMesh, eye: NDArray[np.float64], f0: int, f1: int, width: int, height: int) -> Tris | None:
    """The triangle setup of faces ``f0:f1``, the back faces pre-culled for the camera centre
    `eye` left out; None when no triangle is left."""
    face = mesh.candidates(eye, f0, f1)
    if len(face) == 0:
        return None
    return setup_parallel(clip_t, vfinite, vdepth, mesh, mesh.batch(f0, f1), face, width, height)


def _raster_batch(
    state: Resolve,
    clip_t: NDArray[np.float64],
    vdepth: NDArray[np.float64],
    vfinite: NDArray[np.bool_],
    mesh: RasterMesh,
    eye: NDArray[np.float64],
    f0: int,
    f1: int,
    frame: tuple[NDArray[np.int32], NDArray[np.float32], NDArray[np.float32]] | None,
) -> Fragments | None:
    """Rasterize faces ``f0:f1`` (the back faces pre-culled for the camera centre `eye` left
    out): their winners as Fragments (``frame`` None, the only batch) or merged into the
    full-frame arrays ``frame`` = (tri_id, depth, bary planes)."""
    width = state.width
    t = _setup_batch(clip_t, vdepth, vfinite, mesh, eye, f0, f1, width, state.height)
    if t is None:
        return None
    tri_bits = state.tri_bits
    used = cover(state, t)
    hit, k = resolved(state, used, int(t.row0.min()) * width, (int(t.row1.max()) + 1) * width)
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

    def write(part: slice) -> None:
        face[part], depth[part], bary[:, part] = winners(t, hit[part], k[part] & tri_mask, width, state.w_is_depth)
        if frame is not None:
            frame[0].reshape(-1)[hit[part]] = face[part]
            frame[1].reshape(-1)[hit[part]] = depth[part]
            for j in range(3):
                frame[2][j].reshape(-1)[hit[part]] = bary[j, part]

    run_chunked(len(hit), write, max_chunk=WINNER_CHUNK)
    return Fragments(state.height, width, hit, face, depth, bary) if frame is None else None
