"""Coverage: the pixel boxes of a batch's triangles split into tiles, grouped by
power-of-two size class and tested against the pixel centres of dense grids by
broadcasting, each worker thread resolving its share into its own key array."""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from clshade.render.arrays import run_tasks, workers_for
from clshade.render.raster.resolve import Resolve
from clshade.render.raster.triangles import Tris

#: Fragments are kept when ``-1 - eps <= z_ndc <= 1 + eps``.  Vertices created
#: by near-plane clipping lie on ``z_ndc = -1`` only up to a few ulps, so the
#: depth range test must not reject them on round-off.
NDC_DEPTH_EPS: float = 1e-9

#: A tile of a large triangle is skipped when, for one edge, all its corner
#: pixel centres are farther than this (in pixels) outside that edge.  The
#: margin keeps the cull conservative against round-off in the corner values.
TILE_CULL_MARGIN_PX: float = 1e-6

#: Largest bounding-box side processed as one dense grid; larger boxes are
#: split into TILE x TILE tiles.  Must be a power of two.  8 rather than 32: of the
#: candidate pixels of the robot's 32 x 32 edge tiles (960x540) 65 % lay outside the
#: triangle; 8 x 8 tiles test fewer of them, find more of a large triangle in interior
#: tiles (no edge tests), and make 17 size classes (one grid call each) instead of 37.
TILE: int = 8
_TILE_LOG2: int = TILE.bit_length() - 1

#: The candidate grids of a batch are shared out to the worker threads from this many
#: candidate pixels: the grids are many short NumPy calls and np.minimum.at, which scale
#: poorly on threads, and each worker's key array must be merged. On 2 cores, up to the
#: ~2 M candidate pixels of many_lights at 1920x1080, one thread is as fast or faster
#: (benchmarks/experiments/raster_threads.py); beyond that it is untested, so the split is kept.
COVER_PARALLEL_MIN_CELLS: int = 1 << 22

#: Tiles generated at a time (bounds memory when many triangles are large).
MAX_TILES: int = 1 << 18


def _make_tiles(t: Tris, t0: int, t1: int) -> tuple[NDArray[np.int64], ...]:
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


def cover(state: Resolve, t: Tris) -> int:
    """Test every triangle of a batch against its pixel centres and resolve into the key
    arrays, in groups of triangles of at most ~MAX_TILES tiles (bounds the tile arrays'
    memory even when many triangles are large). Returns how many key arrays were written."""
    n_tiles = (((t.col1 - t.col0) >> _TILE_LOG2) + 1) * (((t.row1 - t.row0) >> _TILE_LOG2) + 1)
    cum = np.cumsum(n_tiles)
    unit = _box_depth_in_unit_range(t)
    used = 1
    t0 = 0
    while t0 < len(cum):
        base = int(cum[t0 - 1]) if t0 else 0
        t1 = max(t0 + 1, int(np.searchsorted(cum, base + MAX_TILES, side="right")))
        used = max(used, _raster_tiles(state, t, _make_tiles(t, t0, t1), unit, state.tri_bits, state.z_scale))
        t0 = t1
    return used


def _box_depth_in_unit_range(t: Tris) -> NDArray[np.bool_]:
    """(T,) whether the NDC depth of every pixel centre of each triangle's box, as the grids
    compute it (``z_a X + (z_b Y + z_c)``), lies in [-1, 1]: then no fragment of it needs the
    near/far test or the clamp. Each term is an affine function rounded, so monotone along its
    axis, and so is their rounded sum in each: the extremes over a box are at its corner
    centres, exactly as the grids compute them (False with a NaN: the checked path)."""
    x0, x1 = t.z_a * (t.col0 + 0.5), t.z_a * (t.col1 + 0.5)
    y0, y1 = t.z_b * (t.row0 + 0.5) + t.z_c, t.z_b * (t.row1 + 0.5) + t.z_c
    c00, c01, c10, c11 = x0 + y0, x1 + y0, x0 + y1, x1 + y1
    lo = np.minimum(np.minimum(c00, c01), np.minimum(c10, c11))
    hi = np.maximum(np.maximum(c00, c01), np.maximum(c10, c11))
    return (lo >= -1.0) & (hi <= 1.0)


#: A size class with fewer tiles than this is tested in the square grid of its longer side
#: (cells beyond a box fail the edge tests as in any grid): one grid call instead of several
#: for the rare shapes, at the price of a few empty cells.
MERGE_CLASS_BELOW: int = 128


def _raster_tiles(
    state: Resolve, t: Tris, tiles: tuple[NDArray[np.int64], ...], unit: NDArray[np.bool_], tri_bits: int,
    z_scale: float
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
    counts = np.bincount(cls, minlength=n_cls * n_cls + 1)
    rare = np.flatnonzero((counts[:-1] > 0) & (counts[:-1] < MERGE_CLASS_BELOW))
    if len(rare):
        side = np.maximum(rare // n_cls, rare % n_cls)
        remap = np.arange(n_cls * n_cls + 1)
        remap[rare] = side * (n_cls + 1)
        cls = remap[cls]
        counts = np.bincount(cls, minlength=n_cls * n_cls + 1)
    order = np.argsort(cls, kind="stable")
    starts = np.concatenate([[0], np.cumsum(counts)])
    work: list[tuple[int, int, NDArray[np.int64], bool]] = []  # (log2 grid width, height, tiles, interior)
    for c in np.flatnonzero(counts):
        lsy, lsx = divmod(int(c), n_cls) if c < n_cls * n_cls else (_TILE_LOG2, _TILE_LOG2)
        per_chunk = max(1, state.chunk_cells >> (lsx + lsy))
        sel_all = order[starts[c]: starts[c + 1]]
        work += [(lsx, lsy, sel_all[s: s + per_chunk], c == n_cls * n_cls)
                 for s in range(0, len(sel_all), per_chunk)]
    cells = [len(sel) << (lsx + lsy) for lsx, lsy, sel, _ in work]
    workers = min(workers_for(sum(cells), COVER_PARALLEL_MIN_CELLS), len(work))
    shares: list[list[int]] = [[] for _ in range(workers)]
    load = [0] * workers
    for i in sorted(range(len(work)), key=cells.__getitem__, reverse=True):
        w = load.index(min(load))
        shares[w].append(i)
        load[w] += cells[i]
    keys = state.key_arrays(workers)
    run_tasks([lambda share=share, k=k: [_test_grid(state, t, tiles, *work[i], k, unit, tri_bits, z_scale)
                                         for i in share] for share, k in zip(shares, keys)], workers)
    return workers


def _test_grid(
    state: Resolve, t: Tris, tiles: tuple[NDArray[np.int64], ...], lsx: int, lsy: int,
    sel: NDArray[np.int64], interior: bool, keys: NDArray[np.int64], unit: NDArray[np.bool_], tri_bits: int,
    z_scale: float
) -> None:
    """Test tiles ``sel`` (all of one size class, grids of 2**lsx x 2**lsy) and resolve into `keys`;
    ``interior`` tiles (full grids inside their triangle) skip the edge tests; the fragments of
    triangles whose box lies in the depth range (`unit`) skip the depth test."""
    tile_tri, tx0, ty0, tbw, tbh, _ = tiles
    width = state.width
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
    # NDC depth z = zx[column] + zy[row] (one rounding each, as everywhere it is computed).
    zx = t.z_a[ti] * xc  # (gx, n)
    zy = t.z_b[ti] * yc + t.z_c[ti]  # (gy, n)
    in_unit = bool(unit[ti].all())
    if interior:
        z = np.add(zx[None, :, :], zy[:, None, :])  # (gy, gx, n)
        pix = (yabs * width)[:, None, :] + xabs[None, :, :]
        _resolve_into(keys, pix, z, ti, tri_bits, z_scale, in_unit)
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
    z = zx.ravel()[ci] + zy.ravel()[ri]
    pix = (yabs * width).ravel()[ri] + xabs.ravel()[ci]
    _resolve_into(keys, pix, z, ti[tl], tri_bits, z_scale, in_unit)


def _resolve_into(keys: NDArray[np.int64], pix: NDArray[np.int64], z: NDArray[np.float64],
                  tri: NDArray[np.int64], tri_bits: int, z_scale: float, in_unit: bool) -> None:
    """Keep the fragments between the near and far planes (all of them when `in_unit`: every z is
    known to lie in [-1, 1]) and resolve their packed keys into `keys`. `z` (a temporary) is
    overwritten; `tri` broadcasts against it."""
    if not in_unit:
        good = (z >= -1.0 - NDC_DEPTH_EPS) & (z <= 1.0 + NDC_DEPTH_EPS)  # between the near and far planes
        if not good.all():
            pix, z, tri = pix[good], z[good], np.broadcast_to(tri, z.shape)[good]
        np.clip(z, -1.0, 1.0, out=z)
    z += 1.0
    z *= z_scale
    q = z.astype(np.int64)
    q <<= tri_bits
    q |= tri
    np.minimum.at(keys, pix.ravel(), q.ravel())
