"""OpenCL runtime: device selection, one context and profiling queue, and a
cache of built programs and kernels keyed by (source, build options).

Device choice, in order: the `device` argument (CLI `--device`), the
environment variable CLSHADE_DEVICE, then the default — a CPU device, PoCL
preferred and the highest PoCL version first. A device spec is `P:D`
(platform and device index from `clshade devices`), `cpu`/`gpu`, or a
case-insensitive substring of "platform name, platform version, device name"
(e.g. `PoCL 3.1`). Two PoCL installs are both named "Portable Computing
Language", so select by version or device, never by name alone.
"""
from __future__ import annotations

import hashlib
import os
import re
import tempfile
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from clshade.errors import ClshadeError

ENV_DEVICE = "CLSHADE_DEVICE"
INSTALL_HINT = ("install an OpenCL CPU runtime without root: "
                "`pip install pocl-binary-distribution` (or Debian's pocl-opencl-icd)")


def _cl():
    try:
        import pyopencl as cl
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ClshadeError(f"pyopencl is not installed ({exc}); `pip install pyopencl`") from exc
    return cl


@dataclass(frozen=True)
class DeviceInfo:
    platform_index: int
    device_index: int
    platform: str
    platform_version: str
    device: str
    kind: str

    @property
    def spec(self) -> str:
        return f"{self.platform_index}:{self.device_index}"

    @property
    def description(self) -> str:
        return f"{self.device} [{self.platform_version}]"


def list_devices() -> list[tuple[DeviceInfo, object]]:
    """Every OpenCL device on every platform, with its description."""
    cl = _cl()
    try:
        platforms = cl.get_platforms()
    except (cl.LogicError, cl.RuntimeError) as exc:
        raise ClshadeError(f"no OpenCL platform found ({exc}); {INSTALL_HINT}") from exc
    out = []
    for pi, platform in enumerate(platforms):
        try:
            devices = platform.get_devices()
        except (cl.LogicError, cl.RuntimeError):
            continue
        for di, device in enumerate(devices):
            kind = cl.device_type.to_string(device.type).lower()
            out.append((DeviceInfo(pi, di, platform.name.strip(), platform.version.strip(),
                                   device.name.strip(), kind), device))
    if not out:
        raise ClshadeError(f"no OpenCL device found; {INSTALL_HINT}")
    return out


def _pocl_version(version: str) -> tuple[int, ...]:
    match = re.search(r"PoCL (\d+)\.(\d+)", version)
    return tuple(int(x) for x in match.groups()) if match else (-1,)


def select_device(spec: str | None = None):
    """Pick an OpenCL device by spec (see module docstring); returns (DeviceInfo, cl.Device)."""
    spec = spec or os.environ.get(ENV_DEVICE) or None
    devices = list_devices()
    if spec is None:
        def rank(item):
            info = item[0]
            return ("cpu" not in info.kind, "PoCL" not in info.platform_version,
                    tuple(-x for x in _pocl_version(info.platform_version)))
        return sorted(devices, key=rank)[0]
    text = spec.strip()
    if re.fullmatch(r"\d+:\d+", text):
        for info, device in devices:
            if info.spec == text:
                return info, device
    elif text.lower() in ("cpu", "gpu", "accelerator"):
        for info, device in devices:
            if text.lower() in info.kind:
                return info, device
    else:
        for info, device in devices:
            haystack = f"{info.platform}, {info.platform_version}, {info.device}".lower()
            if text.lower() in haystack:
                return info, device
    known = "; ".join(f"{i.spec} {i.description}" for i, _ in devices)
    raise ClshadeError(f"device {spec!r} matches no OpenCL device (have: {known})")


ENV_NO_BINARY_CACHE = "CLSHADE_NO_BINARY_CACHE"
ENV_CACHE_DIR = "CLSHADE_CACHE_DIR"


def binary_cache_dir() -> Path | None:
    """The folder of cached program binaries: $CLSHADE_CACHE_DIR, else
    $XDG_CACHE_HOME/clshade/programs (~/.cache/clshade/programs); None when
    CLSHADE_NO_BINARY_CACHE=1. A warm build from source still costs the driver
    ~30 ms of CPU (PoCL hashes and links it again); from the binary ~5 ms."""
    if os.environ.get(ENV_NO_BINARY_CACHE, "").strip() not in ("", "0"):
        return None
    folder = os.environ.get(ENV_CACHE_DIR, "").strip()
    if folder:
        return Path(folder)
    base = os.environ.get("XDG_CACHE_HOME", "").strip() or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "clshade" / "programs"


# Lanes per work-item the kernels support (kernels/simd.h); buffers are padded to the largest.
SIMD_WIDTHS = ("1", "4", "8")
SIMD_PAD = 8


def padded(count: int) -> int:
    """`count` rounded up to a multiple of SIMD_PAD (device buffers of per-pixel data)."""
    return (count + SIMD_PAD - 1) // SIMD_PAD * SIMD_PAD


class Runtime:
    """One OpenCL context and in-order profiling queue on the chosen device."""

    def __init__(self, device: str | None = None) -> None:
        cl = _cl()
        self.cl = cl
        self.info, self.device = select_device(device)
        self.context = cl.Context([self.device])
        self.queue = cl.CommandQueue(self.context, properties=cl.command_queue_properties.PROFILING_ENABLE)
        self._programs: dict[str, object] = {}
        self._kernels: dict[tuple[str, str], object] = {}

    def kernel(self, source: str, name: str, options: tuple[str, ...] = (), label: str = "") -> object:
        """Build (once) and return kernel `name` from `source` with build `options`."""
        key = hashlib.sha1(("\0".join(options) + "\0" + source).encode()).hexdigest()
        if (key, name) in self._kernels:
            return self._kernels[(key, name)]
        program = self._programs.get(key)
        if program is None:
            program = self._cached_program(source, options)
        if program is None:
            program = self.cl.Program(self.context, source)
            try:
                program.build(options=list(options))
            except self.cl.RuntimeError as exc:
                files = ", ".join(sorted(set(re.findall(r'#line 1 "([^"]+)"', source))))
                log = str(exc).strip()
                raise ClshadeError(f"kernel build failed for {label or name} (files: {files}; "
                                   f"options: {' '.join(options) or 'none'}) on {self.info.description}:\n{log}") from exc
            self._store_program(source, options, program)
        self._programs[key] = program
        kernel = self.cl.Kernel(program, name)
        self._kernels[(key, name)] = kernel
        return kernel

    def _binary_path(self, source: str, options: tuple[str, ...]) -> Path | None:
        """Where the program binary of (device, driver, source, options) is cached; None when
        caching is off (CLSHADE_NO_BINARY_CACHE=1) or there is no cache folder."""
        folder = binary_cache_dir()
        if folder is None:
            return None
        device = self.device
        ident = "\0".join((self.info.platform, self.info.platform_version, self.info.device,
                            device.version, device.driver_version, self.cl.VERSION_TEXT,
                            *options, source))
        return folder / (hashlib.sha256(ident.encode()).hexdigest() + ".bin")

    def _cached_program(self, source: str, options: tuple[str, ...]):
        """The program built from its cached binary, or None (no entry, unreadable, or the
        driver refuses it: the caller then builds from source and stores a new entry)."""
        path = self._binary_path(source, options)
        if path is None or not path.is_file():
            return None
        try:
            program = self.cl.Program(self.context, [self.device], [path.read_bytes()])
            return program.build(options=list(options))
        except (OSError, self.cl.Error):
            return None

    def _store_program(self, source: str, options: tuple[str, ...], program) -> None:
        """Cache the built program's binary (atomically: a temporary file, then a rename);
        a failure to write leaves the cache as it was."""
        path = self._binary_path(source, options)
        if path is None:
            return
        try:
            binary = program.get_info(self.cl.program_info.BINARIES)[0]
            if not binary:
                return
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=".", suffix=".bin", dir=path.parent)
            with os.fdopen(fd, "wb") as f:
                f.write(binary)
            os.replace(tmp, path)
        except (OSError, self.cl.Error):
            pass

    def to_device(self, array: np.ndarray):
        """Upload a contiguous array into a read-only device buffer."""
        mf = self.cl.mem_flags
        array = np.ascontiguousarray(array)
        return self.cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=array)

    def empty(self, nbytes: int):
        return self.cl.Buffer(self.context, self.cl.mem_flags.READ_WRITE, size=max(int(nbytes), 1))

    @property
    def simd(self) -> int:
        """Pixels per work-item of the shading kernels (kernels/simd.h): 8 (float8,
        one AVX2 register) on CPU devices, where PoCL does not vectorise across
        work-items for us; 1 on GPUs, whose hardware does. CLSHADE_SIMD overrides."""
        text = os.environ.get("CLSHADE_SIMD", "").strip()
        if text:
            if text not in SIMD_WIDTHS:
                raise ClshadeError(f"CLSHADE_SIMD={text!r}: expected one of {', '.join(SIMD_WIDTHS)}")
            return int(text)
        return 8 if "cpu" in self.info.kind else 1

    @property
    def local_size(self) -> int:
        """Work-group size used for every dispatch (one size: PoCL compiles per local size)."""
        return int(min(64, self.device.max_work_group_size))

    def global_size(self, count: int) -> int:
        """`count` padded up to a multiple of the local size (kernels guard the tail)."""
        local = self.local_size
        return max(local, (count + local - 1) // local * local)


@lru_cache(maxsize=4)
def get_runtime(device: str | None = None) -> Runtime:
    """A shared runtime per device spec (contexts are expensive)."""
    return Runtime(device)
