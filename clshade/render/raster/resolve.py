"""Depth resolve: packed (depth, triangle) keys per pixel, one key array per worker
thread (kept between calls), their merge, and the winners' face, view depth and
perspective-correct barycentrics."""
from __future__ import annotations

import threading

import numpy as np
from numpy.typing import NDArray

from clshade.render.arrays import chunks, run_tasks, workers_for
from clshade.render.raster.triangles import Tris

#: Key arrays of frames up to this many pixels are kept for the next call (they
#: are left all-empty): the frames of a moving camera reuse them instead of
#: allocating and filling 8 bytes a pixel per worker thread every frame.
KEEP_KEYS_MAX_PIXELS: int = 1 << 22

EMPTY_KEY = np.iinfo(np.int64).max
_spare_keys: list[NDArray[np.int64]] = []
_spare_lock = threading.Lock()
KEY_BITS = 62  # packed keys stay below 2**62: non-negative, no overflow


def key_layout(batch_faces: int) -> tuple[int, float]:
    """(tri_bits, z_scale) of the packed keys of batches of up to `batch_faces` faces:
    key = (int64((z_ndc + 1) · z_scale) << tri_bits) | triangle, the minimum the nearest."""
    # Bits of a packed key holding the triangle index: near-plane
    # clipping at most doubles a batch's `batch_faces` faces.
    tri_bits = max(1, (2 * batch_faces - 1).bit_length())
    # The quantisation is the same for every batch (depths are compared
    # across batches): tri_bits covers the largest possible batch.
    return tri_bits, float((1 << (KEY_BITS - tri_bits)) - 1) * 0.5


#: The bits of one key over all face batches (a visibility pass resolves a view at once, setup_view).
VIEW_KEY_BITS = 63


def view_max_triangles(batch_faces: int) -> int:
    """The most set-up triangles of one view that keys of VIEW_KEY_BITS resolve at once with the depth
    quantisation of key_layout(batch_faces) (so that depth ties break as across batches): one less than
    the indices the triangle bits hold, so that the largest key (the deepest depth, the last index) stays
    below EMPTY_KEY = 2⁶³ − 1, which would read as no fragment."""
    tri_bits, _ = key_layout(batch_faces)
    return (1 << (VIEW_KEY_BITS - (KEY_BITS - tri_bits))) - 1


def view_tri_bits(triangles: int, batch_faces: int) -> int:
    """The triangle bits of those keys for `triangles` (at most view_max_triangles) set-up triangles: at
    least key_layout's."""
    return max(key_layout(batch_faces)[0], (max(triangles, 1) - 1).bit_length())


class Resolve:
    """Depth-resolve state shared by all face batches."""

    def __init__(self, width: int, height: int, chunk_cells: int, w_is_depth: bool,
                 several_batches: bool, batch_faces: int) -> None:
        self.width = width
        self.height = height
        self.w_is_depth = w_is_depth
        self.chunk_cells = chunk_cells
        n_pix = width * height
        # Quantised depth of the current winner of each pixel (across batches;
        # not needed when there is one batch).
        self.best_q = np.full(n_pix, EMPTY_KEY, dtype=np.int64) if several_batches else None
        # Packed (depth, triangle) keys of the batch being rasterized, one
        # array per worker thread (each resolves its share of the candidate
        # grids with np.minimum.at; the arrays are merged by a minimum); reset
        # to empty (only the touched rows) after each batch.
        self.keys: list[NDArray[np.int64]] = []
        self.key_arrays(1)
        self.tri_bits, self.z_scale = key_layout(batch_faces)

    def key_arrays(self, count: int) -> list[NDArray[np.int64]]:
        """`count` key arrays (the first is the merge target): spare ones of an earlier call, else new."""
        n_pix = self.width * self.height
        while len(self.keys) < count:
            with _spare_lock:
                spare = next((i for i, a in enumerate(_spare_keys) if a.size == n_pix), None)
                keys = _spare_keys.pop(spare) if spare is not None else None
            self.keys.append(keys if keys is not None else np.full(n_pix, EMPTY_KEY, dtype=np.int64))
        return self.keys[:count]

    def release(self) -> None:
        """Keep the (all-empty again) key arrays for the next call when the frame is small enough."""
        if self.width * self.height <= KEEP_KEYS_MAX_PIXELS:
            with _spare_lock:
                _spare_keys[:] = [a for a in _spare_keys if a.size == self.keys[0].size] + self.keys
        self.keys = []


def resolved(state: Resolve, used: int, lo: int, hi: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
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
            other[r] = EMPTY_KEY
        masks[i] = keys[r] != EMPTY_KEY

    run_tasks([lambda i=i: merge(i) for i in range(len(ranges))])
    counts = [int(np.count_nonzero(m)) for m in masks]
    starts = np.concatenate([[0], np.cumsum(counts)]).tolist()
    hit = np.empty(starts[-1], np.int64)
    k = np.empty(starts[-1], np.int64)

    def extract(i: int) -> None:
        out, r, mask = slice(starts[i], starts[i + 1]), ranges[i], masks[i]
        hit[out] = np.flatnonzero(mask) + r.start
        # Through the mask, not the indices: a covered region's mask is coherent, and a masked
        # read or write of it several times faster than a gather or scatter.
        k[out] = keys[r][mask]
        keys[r][mask] = EMPTY_KEY

    run_tasks([lambda i=i: extract(i) for i in range(len(ranges))])
    return hit, k


def winners(
    t: Tris,
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
    py = pf / width
    np.floor(py, out=py)
    px = py * width
    np.subtract(pf, px, out=px)  # (pf - py * width) + 0.5
    px += 0.5
    py += 0.5
    # Evaluated in place, in the order of a X + (b Y + c) (the same roundings).
    b = np.empty((3, len(pix)))
    by = np.empty(len(pix))
    for j in range(3):
        e = b[j]
        np.multiply(np.take(t.persp_a[j], tri), px, out=e)
        np.multiply(np.take(t.persp_b[j], tri), py, out=by)
        by += np.take(t.persp_c[j], tri)
        e += by
        np.maximum(e, 0.0, out=e)
    s = b[0] + b[1]
    s += b[2]
    # s <= 0 or non-finite: only reachable by round-off/overflow on
    # near-degenerate slivers or absurd coordinates; fall back to the centroid.
    bad = ~((s > 0.0) & (s < np.inf))
    if bad.any():
        b[:, bad] = 1.0
        s[bad] = 3.0
    if w_is_depth:
        # w_clip = -z_view: the perspective-correct depth 1 / sum(lambda_i / w_i)
        # is sum(E_i) / sum(E_i / w_i), and sum(E_i) is twice the triangle area.
        depth = np.take(t.area2, tri)
        depth /= s
    b /= s
    face = np.take(t.face, tri)
    if not w_is_depth or bad.any():  # general projection: interpolate -z_view
        sel = slice(None) if not w_is_depth else np.flatnonzero(bad)
        local, vd, corners = face[sel] - t.batch.f0, t.vdepth, t.batch.corners
        bs = b[:, sel]
        d = bs[0] * vd[corners[0][local]] + bs[1] * vd[corners[1][local]] + bs[2] * vd[corners[2][local]]
        if w_is_depth:
            depth[sel] = d
        else:
            depth = d
    return face, depth, b
