"""Triangle setup of a batch of faces: trivial rejects, near-plane clipping
(Sutherland–Hodgman, the clipped vertices' barycentrics folded into the triangle's
coefficients), projection to pixels, edge functions with the top-left tie rule,
the NDC depth plane and the pixel bounding box; in parts on the worker threads."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from clshade.render.arrays import chunks, run_tasks, workers_for
from clshade.render.raster.mesh import FaceBatch, RasterMesh

#: A triangle is degenerate (dropped) when the sine of the screen-space angle
#: between its edges is below this: such a sliver is thinner than float64
#: round-off can resolve (its barycentrics would be noise) and in practice
#: covers no pixel centre.  Exactly zero-area triangles are always dropped.
DEGENERATE_SIN_EPS: float = 1e-10

#: Edge-function threshold of edges that do *not* own ties (top-left rule):
#: ``E >= TIE_EPS`` means ``E > 0`` for any value a pixel-scale edge function
#: can take, while ``E >= 0.0`` is used for the edges that own ties.  The
#: smallest *normal* double is used (not the smallest subnormal) so the rule
#: survives flush-to-zero/denormals-are-zero floating-point modes.
TIE_EPS: float = float(np.finfo(np.float64).tiny)

#: A batch's triangle setup is split over the worker threads from this many
#: faces. Its many short NumPy calls scale poorly on threads and the join costs a
#: copy of every field: on 2 cores, the robot's ~19k front faces and the sphere grid's
#: 51k faces set up no faster in two parts than in one (benchmarks/experiments/raster_threads.py),
#: so only batches larger than the largest FACE_BATCH are split (a larger batch setting).
SETUP_PARALLEL_MIN_FACES: int = 1 << 17


@dataclass
class Tris:
    """Screen-space setup of the (clipped) triangles of one batch.

    Per-vertex / per-edge arrays are ``(3, T)`` so that each row is a
    contiguous 1-D array (fast gathers).
    """

    face: NDArray[np.int64]  # (T,) original face index
    vdepth: NDArray[np.float64]  # (V,) view depth of the mesh's vertices
    batch: FaceBatch  # the batch's faces (their corners' vertex indices)
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
    mesh: RasterMesh,
    batch: FaceBatch,
    face: NDArray[np.int64],
    width: int,
    height: int,
) -> Tris | None:
    """Cull, clip, project and set up edge functions for the faces ``face`` (ascending) of `batch`."""
    cull = mesh.cull
    fv = np.take(batch.corners, face - batch.f0, axis=1)  # (3, n) vertex indices
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

    return Tris(
        face=face, vdepth=vdepth, batch=batch, n_unclipped=int(np.count_nonzero(slot < 0)),
        persp_a=persp[0], persp_b=persp[1], persp_c=persp[2],
        edge_a=ea, edge_b=eb, edge_c=ec, edge_thr=thr, area2=np.abs(area2),
        z_a=za, z_b=zb, z_c=zc,
        col0=c0.astype(np.int64), col1=c1.astype(np.int64),
        row0=r0.astype(np.int64), row1=r1.astype(np.int64),
    )


def setup_parallel(
    clip_t: NDArray[np.float64],
    vfinite: NDArray[np.bool_],
    vdepth: NDArray[np.float64],
    mesh: RasterMesh,
    batch: FaceBatch,
    face: NDArray[np.int64],
    width: int,
    height: int,
) -> Tris | None:
    """:func:`_setup` of the faces ``face`` in parts on the worker threads, joined in the order
    one call gives (whole faces by index, then the clipped triangles by face index), so that
    triangle indices (the depth ties' order) do not depend on the number of threads."""
    workers = workers_for(len(face), SETUP_PARALLEL_MIN_FACES)
    if workers == 1:
        return _setup(clip_t, vfinite, vdepth, mesh, batch, face, width, height)
    parts: list[Tris | None] = [None] * workers
    spans = chunks(len(face), workers)

    def setup(i: int) -> None:
        parts[i] = _setup(clip_t, vfinite, vdepth, mesh, batch, face[spans[i]], width, height)

    run_tasks([lambda i=i: setup(i) for i in range(len(spans))], workers)
    done = [p for p in parts if p is not None]
    if not done:
        return None
    offsets = np.cumsum([0] + [len(p.face) for p in done]).tolist()
    order = np.concatenate([np.arange(o, o + p.n_unclipped) for o, p in zip(offsets, done)]
                           + [np.arange(o + p.n_unclipped, o + len(p.face)) for o, p in zip(offsets, done)])
    joined = {f.name: np.take(np.concatenate([getattr(p, f.name) for p in done], axis=-1), order, axis=-1)
              for f in dataclasses.fields(Tris) if f.name not in ("vdepth", "batch", "n_unclipped")}
    return Tris(vdepth=vdepth, batch=batch, n_unclipped=sum(p.n_unclipped for p in done), **joined)


def join_batches(parts: list[Tris], batch: FaceBatch) -> Tris:
    """The setups of consecutive face batches as one, in batch order: a triangle's index in the join orders
    rasterize_mesh's depth ties across batches (the nearer wins; at equal depth the earlier batch, then the
    lower index in the batch) as one batch's index does within it. `batch`: the faces of all of them (a
    triangle's face is then its index into the mesh). Its whole faces and clipped triangles alternate by batch:
    n_unclipped is 0 (no leading run of whole faces is promised)."""
    joined = {f.name: np.concatenate([getattr(p, f.name) for p in parts], axis=-1)
              for f in dataclasses.fields(Tris) if f.name not in ("vdepth", "batch", "n_unclipped")}
    return Tris(vdepth=parts[0].vdepth, batch=batch, n_unclipped=0, **joined)
