"""`clshade devices`: OpenCL platforms and devices, their health and the default."""
from __future__ import annotations

import argparse


def default_rule(default) -> str:
    """How `clshade devices` explains its starred default (clshade.device.runtime.preference)."""
    if default is None:
        return "none, no device passes the health probe"
    if "cpu" in default.kind:
        return "the first healthy CPU device in clshade.device.runtime.RUNTIME_PREFERENCE"
    kind = default.kind.split("|")[-1].strip()        # "all | gpu" → "gpu"
    return f"no CPU device is healthy, so the first healthy device ({kind}) in clshade.device.runtime.preference order"


def cmd_devices(args: argparse.Namespace) -> int:
    from clshade.device.runtime import choose_device, device_health, list_devices
    from clshade.errors import ClshadeError
    try:
        default = choose_device(None).info
    except ClshadeError:
        default = None
    for info, device in list_devices():
        mark = "*" if info == default else " "
        state = device_health(info, device)
        status = "healthy" if state.ok else f"BROKEN: {state.reason}"
        print(f"{mark} {info.spec}  {info.kind:10s} {info.device}  |  {info.platform} | {info.platform_version}")
        print(f"        {info.runtime}: {status}")
    print(f"(* = default: {default_rule(default)}; choose with --device P:D or CLSHADE_DEVICE)")
    return 0
