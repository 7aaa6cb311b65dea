"""`clshade devices`: OpenCL platforms and devices, their health, their build choices and the default;
`--tune` measures every device's build choices and the devices' order again and shows the races."""
from __future__ import annotations

import argparse


def default_rule(default, measured: bool = False) -> str:
    """How `clshade devices` explains its starred default (clshade.device.runtime.default_order):
    `measured` when the CPU devices' order was measured on this machine."""
    if default is None:
        return "none, no device passes the health probe"
    if "cpu" in default.kind:
        if measured:
            return ("the fastest healthy CPU device, measured once on this machine (cached beside the program "
                    "binaries; `clshade devices --tune` measures again)")
        return "the first healthy CPU device in clshade.device.runtime.RUNTIME_PREFERENCE"
    kind = default.kind.split("|")[-1].strip()        # "all | gpu" → "gpu"
    return f"no CPU device is healthy, so the first healthy device ({kind}) in clshade.device.runtime.preference order"


def _ordinal(n: int) -> str:
    return f"{n}{'th' if 10 <= n % 100 <= 20 else {1: 'st', 2: 'nd', 3: 'rd'}.get(n % 10, 'th')}"


def cmd_devices(args: argparse.Namespace) -> int:
    from clshade.device import tuned
    from clshade.device.runtime import (choose_device, device_health, device_key, list_devices, measured_ranking,
                                        preference, tuned_choice, tuned_family_choices)
    from clshade.errors import ClshadeError
    if getattr(args, "tune", False):
        _tune()
    try:
        default = choose_device(None).info
    except ClshadeError:
        default = None
    devices = list_devices()
    ranking = measured_ranking(sorted(devices, key=lambda item: preference(item[0])))
    rows = {r["key_hash"]: r for r in (ranking or {}).get("devices", [])}
    position = {h: i + 1 for i, h in enumerate((ranking or {}).get("order", []))}
    for info, device in devices:
        mark = "*" if info == default else " "
        state = device_health(info, device)
        status = "healthy" if state.ok else f"BROKEN: {state.reason}"
        if state.ok:
            key = tuned.key_hash(device_key(info, device))
            if key in position:
                times = rows[key].get("median_ms") or {}
                status += (f"; measured {_ordinal(position[key])} of {len(position)}"
                           + (" (" + ", ".join(f"{m} {ms:.2f} ms" for m, ms in times.items()) + ")" if times else ""))
            choice, source = tuned_choice(info, device)
            status += f"; build: {choice.label()} ({source})"
            families = tuned_family_choices(info, device)
            if families:
                status += "; per model family (the above for other families): " + ", ".join(f"{f} {c.label()}" for f, c in families.items())
        print(f"{mark} {info.spec}  {info.kind:10s} {info.device}  |  {info.platform} | {info.platform_version}")
        print(f"        {info.runtime}: {status}")
    print(f"(* = default: {default_rule(default, ranking is not None)}; choose with --device P:D or CLSHADE_DEVICE)")
    return 0


def _tune() -> None:
    """Measure every healthy device's build choices and the CPU devices' order again; print the races."""
    from clshade.device import tune
    from clshade.report.tuning import device_tuning_markdown, ranking_markdown
    entries, ranking = tune.retune_all()
    for entry in entries:
        print(device_tuning_markdown(entry))
        print()
    if ranking is not None:
        print(ranking_markdown(ranking))
        print()
