"""The measured build choice of each device and the measured order of the devices, kept on disk.

clshade times the image kernels' build choices on each device once (clshade/device/tune.py) and keeps
the winner with its measurement as JSON in cachedir.tuning_cache_dir() (`tuning/` beside the program
binaries), keyed by everything that could change the answer: the runtime (platform name and version),
the device's name, OpenCL version and driver version, the CPU (model, and a hash of its family, model,
stepping and feature flags), clshade's kernel sources (a hash of kernels/), the compiler's environment
(POCL_*, ...: health.build_environment) and TUNER_VERSION. A new driver, CPU or kernel is a new key, so
it is measured again; an old entry is pruned once TUNE_CACHE_ENTRIES newer ones exist. The order of
the CPU devices (which one is the default) is kept the same way, keyed by the set of their keys.

A device's entry holds one choice per model family (`families`: the families of the built-in lobes,
clshade.models.lobe's `family` field: diffuse, empirical, microfacet) beside the device's general
choice (for kernels of no family of its own). An entry that lacks a family of today's registry (one
measured before that family existed) is measured again.

CLSHADE_TUNE says what happens:
    auto (default, or 1)  read the cache; where an entry is missing, measure once and keep it
    fixed (or 0)          today's fixed rule and RUNTIME_PREFERENCE order; no cache read, no measuring
                          (tests/conftest.py and .ci/run set it: tests and CI never wait on a measurement)
Without a cache folder (CLSHADE_NO_BINARY_CACHE=1) nothing could be kept, so nothing is measured either.

The measuring runs in a child process (`python -m clshade.device.tune`): it shades a frame, and the
shading pass sits above the runtime that asks for it; a fresh process also times no other thread of
the caller's. A measurement that fails is kept as failed (its one-line reason), so it is not retried
on every run; `clshade devices --tune` measures again.
"""
from __future__ import annotations

import hashlib
import json
import os
import platform
import subprocess
import sys
import time
from functools import lru_cache
from pathlib import Path

from clshade.cachedir import ENV_NO_BINARY_CACHE, read_entry, tuning_cache_dir, write_entry
from clshade.device import health
from clshade.errors import ClshadeError
from clshade.models.lobe import builtin_lobes
from clshade.resources import kernels_dir

ENV_TUNE = "CLSHADE_TUNE"
AUTO = "auto"
FIXED_MODE = "fixed"
_MODES = {"": AUTO, "auto": AUTO, "1": AUTO, "on": AUTO, "fixed": FIXED_MODE, "0": FIXED_MODE, "off": FIXED_MODE}

DEVICE = "device"          # entry kinds: one device's build choice, the order of the CPU devices
RANKING = "ranking"
MEASURED = "measured"      # entry status: measured, or the measurement failed (`reason`)
FAILED = "failed"
SCHEMA = "clshade-tune/1"
#: Part of every key: raised when what is measured changes (the candidates, the calibration frame, the
#: rule that picks), so that entries measured the old way are measured again.
TUNER_VERSION = 3
#: Entries kept (one small JSON file each; a machine has a few devices, each new driver or kernel adds one).
TUNE_CACHE_ENTRIES = 64
#: The child process is stopped past this: the budgets (tune.TUNE_BUDGET_S per device, the same for the
#: ranking) plus the first builds and the drivers' start-up are well under it on the machines we know.
TUNE_TIMEOUT_S = 180.0


def mode() -> str:
    """AUTO or FIXED_MODE, from CLSHADE_TUNE (see the module docstring)."""
    text = os.environ.get(ENV_TUNE, "").strip().lower()
    if text not in _MODES:
        raise ClshadeError(f"{ENV_TUNE}={text!r}: expected auto (measure once per device, the default) or fixed")
    return _MODES[text]


def _cpuinfo() -> dict[str, str]:
    """The first processor's fields of /proc/cpuinfo ({} where there is none)."""
    out: dict[str, str] = {}
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if not line.strip():
                    if out:
                        break
                    continue
                name, _, value = line.partition(":")
                out.setdefault(name.strip(), value.strip())
    except OSError:
        pass
    return out


@lru_cache(maxsize=1)
def cpu_identity() -> tuple[str, str]:
    """(model name, hash of vendor, family, model, stepping and feature flags) of the host CPU."""
    info = _cpuinfo()
    name = info.get("model name") or platform.processor() or platform.machine()
    ident = "|".join(info.get(k, "") for k in ("vendor_id", "cpu family", "model", "stepping", "flags"))
    ident = ident if ident.strip("|") else f"{name}|{platform.machine()}"
    return name, hashlib.sha256(ident.encode()).hexdigest()[:16]


@lru_cache(maxsize=1)
def kernels_hash() -> str:
    """A hash of every file under kernels/ (names and contents)."""
    h = hashlib.sha256()
    root = kernels_dir()
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


def device_key(info, device_version: str, driver_version: str) -> dict:
    """The key of a device's build choice: `info` a runtime.DeviceInfo, the versions the driver reports."""
    cpu, cpu_hash = cpu_identity()
    return {"tuner": TUNER_VERSION, "runtime": info.runtime, "platform": info.platform,
            "platform_version": info.platform_version, "device": info.device, "device_version": device_version,
            "driver_version": driver_version, "cpu": cpu, "cpu_hash": cpu_hash, "kernels": kernels_hash(),
            "environment": health.build_environment()}


def families() -> tuple[str, ...]:
    """The model families tuned apart, from the registry's metadata: every built-in lobe's `family`
    (a model without a specular lobe is in the diffuse family: Model.family)."""
    return tuple(sorted({lobe.family for lobe in builtin_lobes().values()}))


def has_families(doc: dict, wanted: tuple[str, ...]) -> bool:
    """Whether a measured device entry holds a readable choice for every family of `wanted`."""
    got = doc.get("families")
    return isinstance(got, dict) and all(isinstance(got.get(f), dict) and "choice" in got[f] for f in wanted)


def ranking_key(device_keys: list[dict]) -> dict:
    """The key of the CPU devices' order: the set of their keys."""
    return {"tuner": TUNER_VERSION, "devices": sorted(key_hash(k) for k in device_keys)}


def key_hash(key: dict) -> str:
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:32]


def entry_path(kind: str, key: dict) -> Path | None:
    """Where the entry of `key` lives; None without a cache folder."""
    folder = tuning_cache_dir()
    return folder / f"{kind}-{key_hash(key)}.json" if folder is not None else None


def read(kind: str, key: dict) -> dict | None:
    """The entry of `key`, or None: absent, unreadable, not JSON, not an entry of this kind and key, or
    a measured device entry missing a family (`families`): each is measured again and overwritten."""
    path = entry_path(kind, key)
    raw = read_entry(path) if path is not None else None
    if not raw:
        return None
    try:
        doc = json.loads(raw)
    except (ValueError, UnicodeDecodeError):
        return None
    if (not isinstance(doc, dict) or doc.get("schema") != SCHEMA or doc.get("kind") != kind
            or doc.get("key") != key or doc.get("status") not in (MEASURED, FAILED)):
        return None
    if kind == DEVICE and doc["status"] == MEASURED and not has_families(doc, families()):
        return None
    return doc


def write(kind: str, key: dict, doc: dict) -> dict:
    """Store `doc` (a MEASURED or FAILED entry; schema, kind, key and time added) as the entry of `key`;
    returns it. A cache that cannot be written is left as it was."""
    doc = {"schema": SCHEMA, "kind": kind, "key": key, "key_hash": key_hash(key),
           "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), **doc}
    path = entry_path(kind, key)
    if path is not None:
        write_entry(path, json.dumps(doc, indent=1, ensure_ascii=False).encode(), TUNE_CACHE_ENTRIES)
    _memo[key_hash(key)] = doc
    return doc


_memo: dict[str, dict] = {}


def forget() -> None:
    """Drop this process's memo of entries (after measuring again, and in tests)."""
    _memo.clear()


def lookup(kind: str, key: dict, args: list[str]) -> tuple[dict | None, str]:
    """The entry of `key`: from this process's memo, the cache, else measured by `run_tuner(args)` and
    read back (a failure is stored as a FAILED entry). (None, why) without a cache folder."""
    h = key_hash(key)
    if h in _memo:
        return _memo[h], ""
    if entry_path(kind, key) is None:
        return None, f"no cache folder to keep a measurement in ({ENV_NO_BINARY_CACHE}=1)"
    entry = read(kind, key)
    if entry is None:
        why = run_tuner(args)
        entry = read(kind, key)
        if entry is None:
            entry = write(kind, key, {"status": FAILED, "reason": why or "the tuner stored no result"})
    _memo[h] = entry
    return entry, ""


def run_tuner(args: list[str]) -> str | None:
    """Run `python -m clshade.device.tune ARGS` (the same clshade, its progress on this stderr);
    None when it succeeded, else the reason in one line."""
    env = dict(os.environ)
    env[ENV_TUNE] = FIXED_MODE          # the child measures what it is asked; nothing in it tunes by itself
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    try:
        proc = subprocess.run([sys.executable, "-m", "clshade.device.tune", *args], env=env,
                              stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, timeout=TUNE_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return f"the tuner ran past {TUNE_TIMEOUT_S:.0f} s and was stopped"
    except OSError as exc:
        return f"the tuner could not start ({exc})"
    return None if proc.returncode == 0 else f"the tuner exited with status {proc.returncode}"
