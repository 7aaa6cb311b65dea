"""Device health: a device is used only after it has built and run a probe program.

An OpenCL runtime can list a device that cannot compile for it: pip's PoCL 3.0 (LLVM 14)
names an AMD family-26 CPU `generic` and then rejects that name ("unknown target CPU
'generic'") for every program. The probe finds that once per device, driver and build
environment (the result is cached on disk like the program binaries), so that the
default selection skips such a device and an explicit choice of it fails in one line.

The probe is a small kernel built with the options every shading kernel gets and run on
one work-item; its output is checked, so a device that builds but computes wrong values
is broken too.
"""
from __future__ import annotations

import hashlib
import json
import os
import warnings
from dataclasses import dataclass

import numpy as np

from clshade.cachedir import binary_cache_dir, read_entry, user_cache_dir, write_entry
from clshade.errors import first_error

#: Kept results (one small JSON file per device × driver × environment).
HEALTH_CACHE_ENTRIES = 256
#: Environment variables that change what a runtime's compiler does: part of the cache key, so
#: that e.g. POCL_EXTRA_BUILD_FLAGS set to a rejected option is probed anew, not read as healthy.
BUILD_ENV_PREFIXES = ("POCL_", "CL_CONFIG_", "OCL_ICD_", "CLSHADE_FORCE_BROKEN")
#: Test hook: a device whose "platform version, device name" contains this text is treated as
#: one whose builds fail (its reason names the variable), without touching the driver.
ENV_FORCE_BROKEN = "CLSHADE_FORCE_BROKEN"

PROBE_SOURCE = """
__kernel void clshade_probe(__global const float* in, __global float* out) {
    const size_t i = get_global_id(0);
    const float4 v = vload4(i, in);
    const float3 n = normalize(v.xyz);
    out[i] = sqrt(v.w) * dot(n, n) + exp(-v.w) * (float)i;
}
"""
PROBE_INPUT = np.array([1.0, 2.0, 2.0, 4.0], np.float32)
PROBE_EXPECTED = 2.0                   # sqrt(4)·|n|² + e⁻⁴·0
PROBE_TOLERANCE = 1e-5                 # a few ulp of float32 on the sqrt and the dot


@dataclass(frozen=True)
class Health:
    """Whether a device built and ran the probe; `reason` is the compiler's first error line."""
    ok: bool
    reason: str = ""


def first_error_line(log: str) -> str:
    """The compiler's reason for a failed probe build (clshade.errors.first_error), never empty."""
    return first_error(log) or "unknown build failure"


def build_environment() -> dict[str, str]:
    """The variables of the environment that change what a compiler does (BUILD_ENV_PREFIXES)."""
    return {k: v for k, v in sorted(os.environ.items()) if k.startswith(BUILD_ENV_PREFIXES)}


def _cache_key(cl, info, device) -> str:
    ident = json.dumps([info.platform, info.platform_version, info.device, device.version, device.driver_version,
                        cl.VERSION_TEXT, PROBE_SOURCE, build_environment()])
    return hashlib.sha256(ident.encode()).hexdigest()


def run_probe(cl, info, device, options: tuple[str, ...] = ()) -> Health:
    """Build and run the probe on `device` now (no cache)."""
    forced = os.environ.get(ENV_FORCE_BROKEN, "").strip()
    if forced and forced.lower() in f"{info.platform_version}, {info.device}".lower():
        return Health(False, f"error: builds made to fail by {ENV_FORCE_BROKEN}={forced!r}")
    try:
        ctx = cl.Context([device])
        queue = cl.CommandQueue(ctx)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")        # pyopencl's CompilerWarning on a non-empty log
            program = cl.Program(ctx, PROBE_SOURCE).build(options=list(options))
        mf = cl.mem_flags
        src = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=PROBE_INPUT)
        out = np.zeros(1, np.float32)
        dst = cl.Buffer(ctx, mf.WRITE_ONLY, size=out.nbytes)
        kernel = cl.Kernel(program, "clshade_probe")
        kernel.set_args(src, dst)
        cl.enqueue_nd_range_kernel(queue, kernel, (1,), (1,)).wait()
        cl.enqueue_copy(queue, out, dst)
        queue.finish()
    except cl.Error as exc:
        return Health(False, first_error_line(str(exc)))
    if not abs(float(out[0]) - PROBE_EXPECTED) <= PROBE_TOLERANCE:
        return Health(False, f"the probe kernel computed {float(out[0])!r}, expected {PROBE_EXPECTED!r}")
    return Health(True)


_memo: dict[str, Health] = {}


def probe(cl, info, device) -> Health:
    """The device's health: from this process's memo, else the disk cache, else `run_probe`
    (stored). CLSHADE_NO_BINARY_CACHE=1 turns the disk cache off here too."""
    key = _cache_key(cl, info, device)
    if key in _memo:
        return _memo[key]
    folder = binary_cache_dir()
    use_disk = folder is not None
    path = (folder or user_cache_dir("programs")) / "health" / f"{key}.json"
    if use_disk:
        raw = read_entry(path)
        if raw:
            try:
                doc = json.loads(raw)
                health = Health(bool(doc["ok"]), str(doc.get("reason", "")))
                _memo[key] = health
                return health
            except (ValueError, KeyError, TypeError):
                pass                               # a damaged entry: probe again
    health = run_probe(cl, info, device)
    _memo[key] = health
    if use_disk:
        write_entry(path, json.dumps(dict(ok=health.ok, reason=health.reason, device=info.description)).encode(),
                    HEALTH_CACHE_ENTRIES)
    return health


def remedy(info) -> str:
    """What a user can do about a broken device."""
    if "PoCL" in info.platform_version:
        return ("this PoCL's compiler cannot build for this CPU (PoCL's LLVM may predate it); choose a healthy "
                "device from `clshade devices` (clshade installs Intel's CPU runtime, intel-opencl-rt, for this) "
                "or a newer PoCL")
    return "choose a healthy device from `clshade devices`, or update this device's OpenCL driver"
