"""The time of one shading dispatch, as the benchmark and the live viewer both report it."""
from __future__ import annotations

import time

from clshade.device.shade import Dispatch, Shader


def timed_dispatch(shader: Shader, dispatch: Dispatch) -> tuple[float, float]:
    """(device ms from the event profile, wall ms from enqueue to completion) of one frame."""
    t0 = time.perf_counter()
    event = shader.enqueue(dispatch)
    event.wait()
    host = (time.perf_counter() - t0) * 1e3
    return (event.profile.end - event.profile.start) * 1e-6, host
