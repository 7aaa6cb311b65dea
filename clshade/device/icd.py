"""Registering the OpenCL runtimes that pip installs, so that the ICD loader finds them.

The loader (ocl-icd, bundled in pyopencl's wheel) loads every vendor library named by a
`*.icd` file in /etc/OpenCL/vendors — or, when the environment variable OCL_ICD_VENDORS
names a folder, in that folder instead — plus pyopencl's own folder, where
pocl-binary-distribution puts pip's PoCL.

Intel's CPU runtime from the package index (`intel-opencl-rt`, a default dependency of
clshade on x86-64 Linux: pip's PoCL 3.0 cannot compile for CPUs newer than its LLVM 14,
such as AMD's family 26) ships an .icd file that names a placeholder path, so no loader
finds it. `register()` writes a folder of .icd files — the system's, plus one naming the
installed `libintelocl.so` — and points OCL_ICD_VENDORS at it, before the loader starts.
A user who sets OCL_ICD_VENDORS keeps their own choice. CLSHADE_NO_PIP_RUNTIMES=1 leaves
the pip runtimes unregistered (the loader then sees what it saw before clshade).
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

from clshade.cachedir import user_cache_dir

ENV_VENDORS = "OCL_ICD_VENDORS"
ENV_NO_PIP_RUNTIMES = "CLSHADE_NO_PIP_RUNTIMES"
SYSTEM_VENDORS = Path("/etc/OpenCL/vendors")


@dataclass(frozen=True)
class PipRuntime:
    """An OpenCL runtime installed by pip whose .icd the loader cannot use as shipped."""
    distribution: str      # the package on the index
    library: str           # the ICD library's file name inside it
    icd_name: str          # the .icd file written for it


#: The runtimes registered here. Intel's FPGA emulator (libintelocl_emu.so, in the same wheel)
#: is left out: it is no device to shade on.
PIP_RUNTIMES = (PipRuntime("intel-opencl-rt", "libintelocl.so", "clshade-intel-cpu.icd"),)

_registered: str | None = None


def _pip_runtimes_off() -> bool:
    """CLSHADE_NO_PIP_RUNTIMES set to anything but '' or '0'."""
    return os.environ.get(ENV_NO_PIP_RUNTIMES, "").strip() not in ("", "0")


def installed_library(runtime: PipRuntime) -> Path | None:
    """The absolute path of `runtime`'s ICD library as pip installed it, or None."""
    try:
        files = metadata.distribution(runtime.distribution).files or ()
    except metadata.PackageNotFoundError:
        return None
    for f in files:
        if Path(str(f)).name == runtime.library:
            path = Path(f.locate()).resolve()
            if path.is_file():
                return path
    return None


def vendor_files() -> dict[str, str]:
    """The .icd files the registration folder holds: name → content (a library path)."""
    out: dict[str, str] = {}
    try:
        system = sorted(SYSTEM_VENDORS.glob("*.icd"))
    except OSError:
        system = []
    for icd in system:
        try:
            out[icd.name] = icd.read_text(encoding="utf-8", errors="replace")
        except OSError:
            continue
    for rt in PIP_RUNTIMES:
        lib = installed_library(rt)
        if lib is not None:
            out[rt.icd_name] = f"{lib}\n"
    return out


def _write_folder(files: dict[str, str]) -> Path:
    """A folder holding `files`, named by their contents (written once, atomically)."""
    digest = hashlib.sha256(repr(sorted(files.items())).encode()).hexdigest()[:16]
    base = user_cache_dir("icd")
    folder = base / digest
    if folder.is_dir() and sorted(p.name for p in folder.glob("*.icd")) == sorted(files):
        return folder
    base.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".icd-", dir=base))
    for name, text in files.items():
        (tmp / name).write_text(text, encoding="utf-8")
    try:
        os.replace(tmp, folder)
    except OSError:                   # another process won the race: use its folder
        for p in tmp.iterdir():
            p.unlink()
        tmp.rmdir()
    return folder


def register() -> str | None:
    """Point OCL_ICD_VENDORS at a folder with the system's and pip's runtimes (in the cache, else a
    temporary folder); returns the folder, or None when nothing was changed (the user's
    OCL_ICD_VENDORS, CLSHADE_NO_PIP_RUNTIMES=1, no pip runtime installed, or no folder could be written). Call before the first OpenCL call:
    the loader reads the variable once per process."""
    global _registered
    if _registered is not None:
        return _registered
    if os.environ.get(ENV_VENDORS, "").strip() or _pip_runtimes_off():
        return None
    files = vendor_files()
    if not any(rt.icd_name in files for rt in PIP_RUNTIMES):
        return None
    try:
        folder = _write_folder(files)
    except OSError:                   # no writable cache: a folder for this process alone
        try:
            folder = Path(tempfile.mkdtemp(prefix="clshade-icd-"))
            for name, text in files.items():
                (folder / name).write_text(text, encoding="utf-8")
        except OSError:
            return None
    os.environ[ENV_VENDORS] = str(folder)
    _registered = str(folder)
    return _registered


def unregistered_hint() -> str:
    """Where a pip runtime is installed but the loader cannot see it (the user's own OCL_ICD_VENDORS
    names a folder without it, or CLSHADE_NO_PIP_RUNTIMES is set): one sentence saying which and how
    to let the loader find it; '' otherwise."""
    if _registered is not None:
        return ""
    folder = os.environ.get(ENV_VENDORS, "").strip()
    off = _pip_runtimes_off()
    hints = []
    for rt in PIP_RUNTIMES:
        lib = installed_library(rt)
        if lib is None:
            continue
        if off:
            hints.append(f"{rt.distribution} is installed ({lib}) but {ENV_NO_PIP_RUNTIMES} leaves it unregistered")
            continue
        try:
            named = folder and any(str(lib) in p.read_text(encoding="utf-8", errors="replace")
                                   for p in Path(folder).glob("*.icd"))
        except OSError:
            named = False
        if folder and not named:
            hints.append(f"{rt.distribution} is installed ({lib}) but {ENV_VENDORS}={folder} names no .icd file "
                         f"with it: unset {ENV_VENDORS}, or add a .icd file holding that path")
    return "; ".join(hints)
