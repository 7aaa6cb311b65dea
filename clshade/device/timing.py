"""The time of one shading dispatch, as the benchmark, the live viewer and the tuner report it, and
the wait for an idle process that interleaved timings start each item with."""
from __future__ import annotations

import time

from clshade.device.shade import Dispatch, Shader

# settle(): the process counts as idle once a QUIET_S window passes in which its threads used less
# than IDLE_SHARE of one core; never waits longer than SETTLE_MAX_S.
SETTLE_QUIET_S = 0.002
SETTLE_IDLE_SHARE = 0.1
SETTLE_MAX_S = 0.1


def timed_dispatch(shader: Shader, dispatch: Dispatch) -> tuple[float, float]:
    """(device ms from the event profile, wall ms from enqueue to completion) of one frame."""
    t0 = time.perf_counter()
    event = shader.enqueue(dispatch)
    event.wait()
    host = (time.perf_counter() - t0) * 1e3
    return (event.profile.end - event.profile.start) * 1e-6, host


def settle(quiet_s: float = SETTLE_QUIET_S, max_s: float = SETTLE_MAX_S) -> float:
    """Wait until every thread of this process is idle (a `quiet_s` window with less than
    SETTLE_IDLE_SHARE of one core of CPU time, all threads counted); returns the wait in s.
    One runtime's (or peer's) worker threads still spinning after its work must not slow the next."""
    t0 = time.perf_counter()
    cpu = time.process_time()
    while time.perf_counter() - t0 < max_s:
        time.sleep(quiet_s)
        now = time.process_time()
        if now - cpu < SETTLE_IDLE_SHARE * quiet_s:
            break
        cpu = now
    return time.perf_counter() - t0
