"""Staging (clshade/device/buffers.py): the buffers a stream of frames reuses for its per-frame
inputs hold what was last uploaded to their slot, grow when an input outgrows them, and never
share memory between slots; on every healthy device (host-memory slots on CPU devices, queue
copies elsewhere)."""
from __future__ import annotations

import numpy as np
import pytest

from clshade.device.buffers import Staging


def _read(runtime, buffer, count: int, dtype) -> np.ndarray:
    out = np.empty(buffer.size // np.dtype(dtype).itemsize, dtype)
    runtime.cl.enqueue_copy(runtime.queue, out, buffer)
    return out[:count]


@pytest.fixture
def staging(device_runtime):
    return Staging(device_runtime), device_runtime


def test_a_slot_holds_its_last_upload(staging):
    stage, rt = staging
    first = stage.upload("a", np.arange(10, dtype=np.int32))
    again = stage.upload("a", np.arange(10, 20, dtype=np.int32))
    assert again is first                       # reused, not a new buffer
    np.testing.assert_array_equal(_read(rt, again, 10, np.int32), np.arange(10, 20))


def test_a_slot_grows_for_a_larger_input(staging):
    stage, rt = staging
    small = stage.upload("a", np.ones(4, np.float64))
    large = np.linspace(0.0, 1.0, 1000)
    grown = stage.upload("a", large)
    assert grown.size >= large.nbytes > small.size
    np.testing.assert_array_equal(_read(rt, grown, 1000, np.float64), large)
    shorter = stage.upload("a", np.full(3, 7.0))      # a smaller input keeps the larger buffer
    assert shorter is grown
    np.testing.assert_array_equal(_read(rt, shorter, 3, np.float64), [7.0, 7.0, 7.0])


def test_slots_do_not_share_memory(staging):
    stage, rt = staging
    a = stage.upload(("batch", 0), np.full(64, 1, np.uint32))
    b = stage.upload(("batch", 1), np.full(64, 2, np.uint32))
    assert a is not b
    np.testing.assert_array_equal(_read(rt, a, 64, np.uint32), np.full(64, 1))
    np.testing.assert_array_equal(_read(rt, b, 64, np.uint32), np.full(64, 2))


def test_a_non_contiguous_input_is_uploaded_in_order(staging):
    stage, rt = staging
    grid = np.arange(24, dtype=np.float32).reshape(4, 6)
    buffer = stage.upload("t", grid.T)                # Fortran order: uploaded as its C-ordered copy
    np.testing.assert_array_equal(_read(rt, buffer, 24, np.float32), grid.T.reshape(-1))


def test_a_slot_grows_only_within_the_memory_available(staging, monkeypatch):
    """On a CPU device (a slot is host memory) growth is refused with the slot named when the memory
    available is smaller than the new buffer; a slot that already holds the input needs nothing more."""
    from clshade import budget
    from clshade.errors import ClshadeError
    stage, rt = staging
    if "cpu" not in rt.info.kind:
        pytest.skip(f"{rt.info.description}: its slots are device buffers, which its runtime bounds")
    held = stage.upload("setup", np.zeros(100, np.float32))
    monkeypatch.setattr(budget, "available_memory", lambda: 256)
    assert stage.upload("setup", np.ones(64, np.float32)) is held         # fits: no new buffer, no check
    with pytest.raises(ClshadeError, match=r"staging buffer for 'setup'.*needs about"):
        stage.upload("setup", np.zeros(1000, np.float32))
