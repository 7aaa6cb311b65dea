"""OpenCL runtime: device selection, one context and profiling queue, and a
cache of built programs and kernels keyed by (source, build options).

Device choice, in order: the `device` argument (CLI `--device`), the
environment variable CLSHADE_DEVICE, then the default — the fastest healthy CPU
device as measured once on this machine (clshade/device/tune.py, cached), or with
tuning off (CLSHADE_TUNE=fixed) the first healthy CPU device in RUNTIME_PREFERENCE.
The image kernels' build choices (BuildChoice) are the device's measured ones the
same way, else today's fixed rule (FIXED): one per model family (`Runtime.for_model`: the
family of the model's specular lobe, or diffuse), the device's general choice for a family
the tuner did not measure (a user lobe's own family) and for kernels of no model. A device spec is `P:D`
(platform and device index from `clshade devices`), `cpu`/`gpu`, or a
case-insensitive substring of "platform name, platform version, device name"
(e.g. `PoCL 3.1`). Two PoCL installs are both named "Portable Computing
Language", so select by version or device, never by name alone.
"""
from __future__ import annotations

import copy
import hashlib
import os
import re
import warnings
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from clshade.cachedir import binary_cache_dir, read_entry, write_entry
from clshade.device import health, tuned
from clshade.device.buffers import DeviceBuffers
from clshade.device.buildchoice import (ENV_SCALAR_GATHER, ENV_SIMD, FIXED, LIBRARY_MATH, LOCAL_SIZE, SCALAR_GATHER,
                                        SIMD_WIDTHS, BuildChoice, flag, forced)
from clshade.device.buildlog import relocate
from clshade.diagnostics import stderr_captured
from clshade.errors import ClshadeError, first_error
from clshade.resources import kernels_dir

ENV_DEVICE = "CLSHADE_DEVICE"
INSTALL_HINT = ("install an OpenCL CPU runtime without root: `pip install pocl-binary-distribution` or "
                "`pip install intel-opencl-rt` (or Debian's pocl-opencl-icd)")


def _cl():
    """pyopencl, with pip's OpenCL runtimes registered with the ICD loader first (clshade/device/icd.py)."""
    from clshade.device import icd
    icd.register()
    try:
        import pyopencl as cl
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ClshadeError(f"pyopencl is not installed ({exc}); `pip install pyopencl`") from exc
    return cl


# A compiler error naming a file by absolute path (a user's lobe), as PoCL's clang writes it
# ("error: /path:11:31: message") and as clang-based compilers write it ("/path:11:31: error: message");
# NVIDIA's `<kernel>:N:C: error: message` reaches here relocated (clshade/device/buildlog.py).
_BUILD_ERROR = re.compile(r"(?:error: (?P<file>/[^:\n]+):(?P<line>\d+):\d+[^:\n]*: (?P<message>[^\n]+))"
                          r"|(?:(?P<file2>/[^:\n]+):(?P<line2>\d+):\d+: error: (?P<message2>[^\n]+))")


def _user_file_error(log: str, source: str) -> str | None:
    """`file:line: message` of the first compiler error in a user's lobe file (named by its
    absolute path in the source's #line markers; clshade's own files are named relative), or None."""
    users = {f for f in re.findall(r'^#line \d+ "([^"]+)"', source, re.M) if os.path.isabs(f)}
    for m in _BUILD_ERROR.finditer(log):
        file, line, message = (m.group("file"), m.group("line"), m.group("message")) if m.group("file") \
            else (m.group("file2"), m.group("line2"), m.group("message2"))
        if file in users:
            return f"{file}:{line}: {message.strip()}"
    return None


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

    @property
    def runtime(self) -> str:
        """A short name of the OpenCL runtime: `PoCL 3.0`, `Intel OpenCL 3.1`, `NVIDIA CUDA 13.0`: the
        platform name and the runtime's own version where the platform version states one after
        "OpenCL X.Y" ("OpenCL 3.0 CUDA 13.0.98"), else the OpenCL version; else the platform name."""
        pocl = _pocl_version(self.platform_version)
        if pocl != (-1,):
            return "PoCL " + ".".join(map(str, pocl))
        version = re.search(r"OpenCL (\d+\.\d+)(?:\D*?(\d+\.\d+))?", self.platform_version)
        name = re.sub(r"\(R\)|\(TM\)", "", self.platform).strip()
        return f"{name} {version.group(2) or version.group(1)}" if version else name


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


#: The default device's runtime, in order of preference among healthy CPU devices: the order of the
#: runtimes' kernel times on the same frame in benchmarks/results/runtimes.json (fastest first;
#: tests/device/test_runtimes.py fails when the measured order there disagrees). A substring of
#: "platform, platform version"; runtimes matching none come after these.
RUNTIME_PREFERENCE = ("PoCL 3.1", "Intel(R) OpenCL", "PoCL 3.0")


def preference(info: DeviceInfo) -> tuple:
    """Sort key of the default selection: CPU devices first, then RUNTIME_PREFERENCE, then the
    newest PoCL, then the listing order."""
    text = f"{info.platform}, {info.platform_version}"
    rank = next((i for i, key in enumerate(RUNTIME_PREFERENCE) if key in text), len(RUNTIME_PREFERENCE))
    return ("cpu" not in info.kind, rank, tuple(-x for x in _pocl_version(info.platform_version)),
            info.platform_index, info.device_index)


def device_health(info: DeviceInfo, device) -> "health.Health":
    """Whether `device` builds and runs the probe program (clshade/device/health.py; cached)."""
    return health.probe(_cl(), info, device)


@dataclass(frozen=True)
class Selection:
    """The chosen device, and the better-ranked devices the default skipped with their reasons."""
    info: DeviceInfo
    device: object
    skipped: tuple[tuple[DeviceInfo, str], ...] = ()


def choose_device(spec: str | None = None) -> Selection:
    """Pick a healthy OpenCL device by spec (see module docstring). The default is the first
    healthy device in `default_order` (measured, else `preference`); an explicit spec naming a
    broken device fails in one line naming the device, the compiler's reason and the remedy."""
    spec = spec or os.environ.get(ENV_DEVICE) or None
    devices = list_devices()
    if spec is None:
        skipped = []
        for info, device in default_order(devices):
            state = device_health(info, device)
            if state.ok:
                return Selection(info, device, tuple(skipped))
            skipped.append((info, state.reason))
        detail = "; ".join(f"{i.spec} {i.description}: {reason}" for i, reason in skipped)
        from clshade.device import icd
        hidden = icd.unregistered_hint()
        raise ClshadeError(f"no OpenCL device can build programs ({detail}); {hidden or INSTALL_HINT}")
    info, device = _match(spec, devices)
    state = device_health(info, device)
    if not state.ok:
        raise ClshadeError(f"device {info.spec} {info.description} cannot build OpenCL programs: {state.reason}; "
                           f"{health.remedy(info)}")
    return Selection(info, device)


def default_order(devices: list[tuple[DeviceInfo, object]]) -> list[tuple[DeviceInfo, object]]:
    """The devices in the default's order: `preference` order, with the CPU devices in their measured
    order instead (`measured_ranking`) where tuning is on and the ranking could be measured."""
    ordered = sorted(devices, key=lambda item: preference(item[0]))
    ranking = measured_ranking(ordered)
    if ranking is None:
        return ordered
    position = {key: i for i, key in enumerate(ranking.get("order", []))}
    cpus = [item for item in ordered if "cpu" in item[0].kind]
    rest = [item for item in ordered if "cpu" not in item[0].kind]
    # Stable: a device the ranking does not list (broken when it was measured) keeps its place after those it lists.
    cpus.sort(key=lambda item: position.get(tuned.key_hash(device_key(*item)), len(position)))
    return cpus + rest


def device_key(info: DeviceInfo, device) -> dict:
    """What the tuned build choice of this device depends on (clshade/device/tuned.py)."""
    return tuned.device_key(info, str(device.version), str(device.driver_version))


def measured_ranking(ordered: list[tuple[DeviceInfo, object]]) -> dict | None:
    """The measured ranking of the CPU devices (clshade/device/tune.py, `rank`): from the cache, else
    measured now in a child process; None with tuning off, with fewer than two CPU devices, or when
    it could not be measured (the caller keeps `preference` order)."""
    if tuned.mode() != tuned.AUTO:
        return None
    cpus = [(info, device) for info, device in ordered if "cpu" in info.kind]
    if len(cpus) < 2:
        return None
    key = tuned.ranking_key([device_key(info, device) for info, device in cpus])
    entry, _ = tuned.lookup(tuned.RANKING, key, ["rank"])
    return entry if entry is not None and entry.get("status") == tuned.MEASURED else None


def _match(spec: str, devices: list[tuple[DeviceInfo, object]]) -> tuple[DeviceInfo, object]:
    text = spec.strip()
    if re.fullmatch(r"\d+:\d+", text):
        for info, device in devices:
            if info.spec == text:
                return info, device
    elif text.lower() in ("cpu", "gpu", "accelerator"):
        matches = [item for item in devices if text.lower() in item[0].kind]
        if matches:
            return min(matches, key=lambda item: preference(item[0]))
    else:
        for info, device in devices:
            haystack = f"{info.platform}, {info.platform_version}, {info.device}".lower()
            if text.lower() in haystack:
                return info, device
    known = "; ".join(f"{i.spec} {i.description}" for i, _ in devices)
    raise ClshadeError(f"device {spec!r} matches no OpenCL device (have: {known})")


def healthy_devices(kind: str | None = "cpu") -> list[tuple[DeviceInfo, object]]:
    """Every device (of `kind`, None for all) that passes the probe, in `preference` order."""
    out = []
    for info, device in sorted(list_devices(), key=lambda item: preference(item[0])):
        if (kind is None or kind in info.kind) and device_health(info, device).ok:
            out.append((info, device))
    return out


#: Program binaries kept (the least recently used beyond this are deleted when one is
#: stored; clshade/cachedir.py): every model × feature set × build option is an entry of
#: some 50–150 kB, and the test suite alone builds hundreds of them.
PROGRAM_CACHE_ENTRIES = 2048


def tuned_choice(info: DeviceInfo, device) -> tuple[BuildChoice, str]:
    """The device's measured build choice and where it comes from: the cache (clshade/device/tuned.py),
    else measured now in a child process (clshade/device/tune.py); FIXED where tuning is off or
    could not measure (the reason says which)."""
    if tuned.mode() != tuned.AUTO:
        return FIXED, f"tuning off: {tuned.ENV_TUNE}={os.environ.get(tuned.ENV_TUNE, '').strip()}"
    key = device_key(info, device)
    entry, why = tuned.lookup(tuned.DEVICE, key, ["device", info.spec, "--key", tuned.key_hash(key)])
    if entry is not None and entry.get("status") == tuned.MEASURED:
        try:
            return BuildChoice.from_dict(entry["choice"]), f"measured on this device, key {tuned.key_hash(key)[:12]}"
        except (KeyError, TypeError, ValueError):
            why = f"unreadable choice in {tuned.entry_path(tuned.DEVICE, key)}"
    elif entry is not None:
        why = str(entry.get("reason", "not measured"))
    return FIXED, f"not measured: {why}"


def tuned_family_choices(info: DeviceInfo, device) -> dict[str, BuildChoice]:
    """The device's measured choice per model family (clshade/device/tuned.py, `families`); {} where
    tuning is off or nothing was measured (every kernel then gets `tuned_choice`'s)."""
    if tuned.mode() != tuned.AUTO:
        return {}
    key = device_key(info, device)
    entry, _ = tuned.lookup(tuned.DEVICE, key, ["device", info.spec, "--key", tuned.key_hash(key)])
    if entry is None or entry.get("status") != tuned.MEASURED:
        return {}
    try:
        return {family: BuildChoice.from_dict(body["choice"]) for family, body in entry["families"].items()}
    except (KeyError, TypeError, ValueError, AttributeError):
        return {}


def host_has_avx512f() -> bool:
    """Whether the host CPU reports AVX-512F (/proc/cpuinfo; False where unreadable)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            return any(line.startswith("flags") and " avx512f" in line for line in fh)
    except OSError:
        return False


class Runtime(DeviceBuffers):
    """One OpenCL context and in-order profiling queue on the chosen device; its buffers:
    DeviceBuffers (clshade/device/buffers.py)."""

    def __init__(self, device: str | None = None, options: tuple[str, ...] = (),
                 choice: BuildChoice | None = None) -> None:
        """`options`: build options added to every program (e.g. LIBRARY_MATH, INLINE_MATH), after
        the build `choice` (default: the device's tuned one, `tuned_choice`); the environment's
        switches (`forced`) apply over either."""
        cl = _cl()
        self.cl = cl
        chosen = choose_device(device)
        self.info, self.device = chosen.info, chosen.device
        self.skipped = chosen.skipped          # better-ranked devices the default passed over, with reasons
        self.context = cl.Context([self.device])
        self.queue = cl.CommandQueue(self.context, properties=cl.command_queue_properties.PROFILING_ENABLE)
        self._programs: dict[str, object] = {}
        self._kernels: dict[tuple[str, str], object] = {}
        self._facts: dict[tuple[str, ...], dict[str, bool]] = {}
        self._base_options = (tuple(options) + (("-DCLSHADE_HOST_AVX512F",) if host_has_avx512f() else ())
                              + ((SCALAR_GATHER,) if flag(ENV_SCALAR_GATHER) else ()))
        self._honour_env = True
        self.family: str | None = None      # the model family this runtime builds for (None: the general choice)
        self.family_choices: dict[str, BuildChoice] = {}
        self._by_family: dict[str, Runtime] = {}
        if choice is None:
            choice, self.choice_source = tuned_choice(self.info, self.device)
            self.family_choices = {f: forced(c)[0] for f, c in tuned_family_choices(self.info, self.device).items()}
        else:
            self.choice_source = "given"
        self.choice, self.forced_by = forced(choice)
        self.options = self._options(self.choice)

    def _options(self, choice: BuildChoice) -> tuple[str, ...]:
        """The explicit options, the host's AVX-512 flag, then the choice's (the order they always had)."""
        return self._base_options + choice.options()

    def with_choice(self, choice: BuildChoice) -> "Runtime":
        """This runtime (its context, queue and built programs shared) building with `choice`
        exactly: the environment's switches (CLSHADE_INLINE_MATH, CLSHADE_SIMD, ...) do not apply.
        What the tuner times (clshade/device/tune.py)."""
        clone = copy.copy(self)
        clone.choice, clone.choice_source, clone.forced_by = choice, "given", ()
        clone._honour_env = False
        clone.family, clone.family_choices, clone._by_family = None, {}, {}
        clone.options = clone._options(choice)
        return clone

    def for_model(self, model) -> "Runtime":
        """The runtime that builds `model`'s image kernels (a models.model.Model): this one with the
        choice measured for the model's family (Model.family: its specular lobe's, or diffuse), the
        environment's switches over it; this one itself where that family has no measured choice
        (tuning off, or a user lobe of a family of its own: the general choice)."""
        family = model.family
        choice = self.family_choices.get(family)
        if choice is None:
            return self
        if family not in self._by_family:
            clone = copy.copy(self)
            clone.choice, clone.family, clone._by_family = choice, family, {}
            clone.choice_source = f"{self.choice_source}; the {family} family's choice"
            clone.options = clone._options(choice)
            self._by_family[family] = clone
        return self._by_family[family]

    def build_record(self) -> dict[str, object]:
        """What the image kernels built here get and why: the choice, where it comes from (measured,
        fixed rule, given), the switches that forced parts of it, and what the device then compiles
        (lanes, work-group size, and simd.h's x86 paths as probed). For results files and listings."""
        return dict(choice=self.choice.as_dict(), label=self.choice.label(), source=self.choice_source,
                    family=self.family, families={f: c.label() for f, c in sorted(self.family_choices.items())},
                    forced_by=list(self.forced_by) + ([ENV_SIMD] if self._env_simd() else []),
                    simd=self.simd, local_size=self.local_size, inline_math=self.inline_math,
                    streaming_stores=self.streaming_stores, prefetch=self.prefetches)

    def kernel(self, source: str, name: str, options: tuple[str, ...] = (), label: str = "") -> object:
        """Build (once) and return kernel `name` from `source` with build `options`
        (and the runtime's own options)."""
        options = tuple(options) + self.options
        key = hashlib.sha1(("\0".join(options) + "\0" + source).encode()).hexdigest()
        if (key, name) in self._kernels:
            return self._kernels[(key, name)]
        program = self._programs.get(key)
        if program is None:
            program = self._cached_program(source, options)
        if program is None:
            program = self.cl.Program(self.context, source)
            try:
                # The compiler's own stderr ("1 error generated.") is kept for --debug (diagnostics).
                with stderr_captured("OpenCL compiler"), warnings.catch_warnings():
                    warnings.simplefilter("ignore", self.cl.CompilerWarning)   # a non-empty log on success
                    program.build(options=list(options))
            except self.cl.RuntimeError as exc:
                log = relocate(str(exc).strip(), source)     # `<kernel>:N:` (NVIDIA) as file:line
                where = _user_file_error(log, source)
                if where is not None:       # the user's lobe: one line, the compiler's own words
                    raise ClshadeError(f"{where} (OpenCL C, building {label or name})", detail=log) from exc
                files = ", ".join(sorted(set(re.findall(r'#line 1 "([^"]+)"', source))))
                raise ClshadeError(f"kernel build failed for {label or name} (files: {files}; "
                                   f"options: {' '.join(options) or 'none'}) on {self.info.description}: "
                                   f"{first_error(log)} (the whole log: clshade --debug)", detail=log) from exc
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
        binary = read_entry(path) if path is not None else None
        if not binary:
            return None
        try:
            program = self.cl.Program(self.context, [self.device], [binary])
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", self.cl.CompilerWarning)
                return program.build(options=list(options))
        except self.cl.Error:
            return None

    def _store_program(self, source: str, options: tuple[str, ...], program) -> None:
        """Cache the built program's binary (clshade/cachedir.py: atomic, the folder pruned to
        PROGRAM_CACHE_ENTRIES); a failure to write leaves the cache as it was."""
        path = self._binary_path(source, options)
        if path is None:
            return
        try:
            binary = program.get_info(self.cl.program_info.BINARIES)[0]
        except self.cl.Error:
            return
        if binary:
            write_entry(path, bytes(binary), PROGRAM_CACHE_ENTRIES)

    @property
    def simd(self) -> int:
        """Pixels per work-item of the shading kernels (kernels/simd.h). On CPU
        devices, where PoCL does not vectorise across work-items for us, the
        device's native float vector width (CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT:
        16 with AVX-512, 8 with AVX2, 4 with SSE), capped at 8 when the runtime's
        compiler target has no AVX-512 (see `native_simd`); 1 on GPUs, whose
        hardware vectorises. The build choice's `lanes` (measured: clshade/device/tune.py)
        replace that rule where the device builds them; CLSHADE_SIMD overrides both."""
        text = self._env_simd()
        if text:
            if text not in SIMD_WIDTHS:
                raise ClshadeError(f"{ENV_SIMD}={text!r}: expected one of {', '.join(SIMD_WIDTHS)}")
            if int(text) == 16 and "cpu" in self.info.kind and self.native_simd < 16:
                raise ClshadeError(f"{ENV_SIMD}={text!r}: device {self.info.description} compiles without "
                                   f"AVX-512 (use 1, 4 or 8)")
            return int(text)
        lanes = self.choice.lanes
        if lanes is not None and not (lanes == 16 and "cpu" in self.info.kind and self.native_simd < 16):
            return lanes
        return self.native_simd if "cpu" in self.info.kind else 1

    def _env_simd(self) -> str:
        return os.environ.get(ENV_SIMD, "").strip() if self._honour_env else ""

    @property
    def native_simd(self) -> int:
        """The widest supported SIMD ≤ the device's native float vector width. On a
        `narrow_target` 16 lanes build only with kernels/simd.h's inline builtins, so such a
        device stays at 8 without an AVX-512 host or with LIBRARY_MATH (docs/bench-notes.md)."""
        width = int(getattr(self.device, "native_vector_width_float", 8) or 8)
        if self.narrow_target and (not host_has_avx512f() or LIBRARY_MATH in self.options):
            width = 8
        return max(int(w) for w in SIMD_WIDTHS if int(w) <= max(width, 1))

    @property
    def narrow_target(self) -> bool:
        """PoCL reporting AVX-512's vector widths (16 floats) while compiling for a CPU name
        without "avx512" (pip's PoCL 3.0 on an AVX-512 host): a 512-bit vector passed to its
        library's builtins there breaks the program (clCreateKernel: INVALID_KERNEL_NAME)."""
        width = int(getattr(self.device, "native_vector_width_float", 8) or 8)
        return width >= 16 and "PoCL" in self.info.platform_version and "avx512" not in self.info.device

    @property
    def double_lanes(self) -> int:
        """Doubles per vector in kernels that carry one pixel per lane of a double vector
        (kernels/visibility.cl): 8 (512 bits) where the device's native double width is 8 and
        its compiler targets it, else 4 (256 bits: AVX2, and what any device compiles)."""
        native = int(getattr(self.device, "native_vector_width_double", 0) or 0)
        return 8 if native >= 8 and not self.narrow_target else 4

    @property
    def inline_math(self) -> bool:
        """Whether kernels built here use kernels/simd.h's inline builtins (the header
        decides from the compiler target and CLSHADE_HOST_AVX512F; probed on the device)."""
        return self._simd_h_defines("CLSHADE_INLINE_MATH")

    @property
    def streaming_stores(self) -> bool:
        """Whether the image kernels built here write their rows with streaming stores
        (kernels/simd.h, STORE_ROW8: x86 with AVX, probed on the device; rows of 8 floats,
        so only at SIMD 8 and 16)."""
        return self.simd >= 8 and self._simd_h_defines("CLSHADE_STREAMING_STORES")

    @property
    def prefetches(self) -> bool:
        """Whether the image kernels built here prefetch the G-buffer ahead (kernels/simd.h PREFETCH:
        x86, probed on the device; CLSHADE_NO_PREFETCH=1 leaves it out)."""
        return self._simd_h_defines("CLSHADE_PREFETCH")

    #: The macros of kernels/simd.h that say which of its paths a build takes (one probe reads all).
    SIMD_H_MACROS = ("CLSHADE_INLINE_MATH", "CLSHADE_STREAMING_STORES", "CLSHADE_PREFETCH")

    def _simd_h_defines(self, macro: str) -> bool:
        """Whether kernels/simd.h defines `macro` when built on this device with these options
        (one probe program per set of options, every SIMD_H_MACROS at once)."""
        if self.options not in self._facts:
            body = "".join(f"#ifdef {m}\n out[{i}] = 1;\n#else\n out[{i}] = 0;\n#endif\n"
                           for i, m in enumerate(self.SIMD_H_MACROS))
            source = ((kernels_dir() / "simd.h").read_text(encoding="utf-8")
                      + "\n__kernel void probe(__global int* out) {\n" + body + "}\n")
            kernel = self.kernel(source, "probe", label="simd.h probe")
            out = np.zeros(len(self.SIMD_H_MACROS), np.int32)
            buf = self.empty(out.nbytes)
            kernel.set_args(buf)
            self.cl.enqueue_nd_range_kernel(self.queue, kernel, (1,), (1,)).wait()
            self.cl.enqueue_copy(self.queue, out, buf)
            self._facts[self.options] = dict(zip(self.SIMD_H_MACROS, (bool(x) for x in out)))
        return self._facts[self.options][macro]

    @property
    def local_size(self) -> int:
        """Work-group size used for every dispatch (one size: PoCL compiles per local size): the
        build choice's, else LOCAL_SIZE; at most the device's maximum."""
        return int(min(self.choice.local or LOCAL_SIZE, self.device.max_work_group_size))

    def global_size(self, count: int) -> int:
        """`count` padded up to a multiple of the local size (kernels guard the tail)."""
        local = self.local_size
        return max(local, (count + local - 1) // local * local)


@lru_cache(maxsize=4)
def get_runtime(device: str | None = None) -> Runtime:
    """A shared runtime per device spec (contexts are expensive)."""
    return Runtime(device)
