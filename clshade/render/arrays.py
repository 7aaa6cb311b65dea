"""Row gathers and scatters of (N, C) arrays as whole records: NumPy's fancy indexing of
rows loops over the columns, a gather of opaque C-element records does not (several times
faster for the per-pixel lookups of the rasterizer and the G-buffer)."""
from __future__ import annotations

import numpy as np


def _records(a: np.ndarray) -> np.ndarray:
    """A C-contiguous (N, C) array as N opaque records of one row each."""
    return a.view(np.dtype((np.void, a.dtype.itemsize * a.shape[1])))[:, 0]


def take_rows(a: np.ndarray, index: np.ndarray) -> np.ndarray:
    """a[index] for an (N, C) array (made C-contiguous if needed)."""
    return _records(np.ascontiguousarray(a))[index].view(a.dtype).reshape(len(index), a.shape[1])


def put_rows(a: np.ndarray, index: np.ndarray, values: np.ndarray) -> None:
    """a[index] = values for a C-contiguous (N, C) array."""
    _records(a)[index] = _records(np.ascontiguousarray(values, a.dtype))
