"""Device health and OpenCL runtimes.

A device is used only after it has built and run a probe program. Where pip's PoCL cannot
compile (an AMD family-26 CPU, newer than its LLVM 14: "unknown target CPU 'generic'"), the
default selection must skip it and use another runtime — Intel's CPU runtime, a default
dependency on x86-64 Linux — and an explicit choice of it must fail in one line. Here the
failure is reproduced on any CPU: POCL_EXTRA_BUILD_FLAGS set to an option PoCL rejects makes
every PoCL build fail, and CLSHADE_FORCE_BROKEN fakes it for any other device.
"""
from __future__ import annotations

import json
import math
import os
import statistics
import subprocess
import sys
from pathlib import Path

import pytest

from clshade.device import health, icd, runtime
from clshade.errors import ClshadeError

from conftest import SCENES, assert_one_line_error, run_cli, write_scene

REJECTED = "--clshade-rejects-this"       # an option PoCL's compiler rejects: every PoCL build fails

# The log pyopencl raised on an AMD EPYC of family 26, as printed there.
ZEN5_LOG = """clBuildProgram failed: BUILD_PROGRAM_FAILURE - clBuildProgram failed: BUILD_PROGRAM_FAILURE

Build on <pyopencl.Device 'pthread-AMD EPYC' on 'Portable Computing Language' at 0x55d0c3a1e2b0>:

error: unknown target CPU 'generic'
note: valid target CPU values are: nocona, core2, penryn, bonnell, atom, silvermont, slm, goldmont
(options: -I /venv/lib/python3.11/site-packages/pyopencl/cl)
"""


def _pocl_devices() -> list:
    return [(i, d) for i, d in runtime.list_devices() if "PoCL" in i.platform_version]


def _other_healthy() -> list:
    return [i for i, d in runtime.healthy_devices(kind=None) if "PoCL" not in i.platform_version]


def _cli(args: list[str], tmp_path: Path, **env_extra: str) -> subprocess.CompletedProcess:
    """clshade in a new process (a new ICD loader), with fresh caches."""
    env = {k: v for k, v in os.environ.items() if k not in ("CLSHADE_DEVICE", "POCL_EXTRA_BUILD_FLAGS")}
    env.update(CLSHADE_CACHE_DIR=str(tmp_path / "cache"), XDG_CACHE_HOME=str(tmp_path / "xdg"), **env_extra)
    return subprocess.run([sys.executable, "-m", "clshade", *args], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=300)


def test_first_error_line_is_the_compilers_reason():
    assert health.first_error_line(ZEN5_LOG) == "error: unknown target CPU 'generic'"
    pocl_option = ("clBuildProgram failed: INVALID_BUILD_OPTIONS\n\nBuild on <pyopencl.Device 'x' on 'y' at 0x1>:\n\n"
                   "Invalid build option: --clshade-rejects-this\n\n(options: -I /x)")
    assert health.first_error_line(pocl_option) == "Invalid build option: --clshade-rejects-this"
    assert health.first_error_line("") == "unknown build failure"
    warned = ZEN5_LOG.replace("error: unknown", "<source>:3:9: warning: unused variable 'x'\nerror: unknown")
    assert health.first_error_line(warned) == "error: unknown target CPU 'generic'"


PROBE_EVERY_POCL = ("import json; from clshade.device import health, runtime; cl = runtime._cl(); "
                    "print(json.dumps([[i.description, *map(str, health.probe(cl, i, d).__dict__.values())] "
                    "for i, d in runtime.list_devices() if 'PoCL' in i.platform_version]))")


def _probe_in_new_process(tmp_path: Path, **env_extra: str) -> list[tuple[str, bool, str]]:
    """(device, ok, reason) of every PoCL device, probed in a new process: PoCL reads
    POCL_EXTRA_BUILD_FLAGS once per process."""
    env = {k: v for k, v in os.environ.items() if k != "POCL_EXTRA_BUILD_FLAGS"}
    env.update(CLSHADE_CACHE_DIR=str(tmp_path / "cache"), **env_extra)
    done = subprocess.run([sys.executable, "-c", PROBE_EVERY_POCL], capture_output=True, text=True, env=env,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    return [(d, ok == "True", reason) for d, ok, reason in json.loads(done.stdout)]


def test_probe_fails_where_pocl_rejects_its_builds_and_the_cache_knows(tmp_path):
    """The probe is a real build: PoCL with a rejected option is broken, without it healthy. The
    result is cached on disk per build environment: a healthy entry is not reused once
    POCL_EXTRA_BUILD_FLAGS changes what PoCL's compiler does, and is reused without it."""
    if not _pocl_devices():
        pytest.skip("no PoCL device present")
    entries = lambda: sorted((tmp_path / "cache" / "health").glob("*.json"))  # noqa: E731
    first = _probe_in_new_process(tmp_path)
    healthy = [device for device, ok, _ in first if ok]
    if not healthy:                           # pip's PoCL 3.0 on AMD family 26 (Zen 5) builds nothing
        pytest.skip(f"no PoCL device builds here: {first}")
    stored = entries()
    assert len(stored) == len(first)
    broken = _probe_in_new_process(tmp_path, POCL_EXTRA_BUILD_FLAGS=REJECTED)
    assert all(not ok and "\n" not in reason for _, ok, reason in broken), broken
    assert all(REJECTED in reason for device, _, reason in broken if device in healthy), broken
    assert len(entries()) == 2 * len(first)
    for path in stored:                       # the first entries, now read from disk: make them say so
        doc = json.loads(path.read_text(encoding="utf-8"))
        path.write_text(json.dumps({**doc, "reason": "read from the cache"}), encoding="utf-8")
    again = _probe_in_new_process(tmp_path)
    assert [ok for _, ok, _ in again] == [ok for _, ok, _ in first], (first, again)
    assert all(reason == "read from the cache" for device, _, reason in again if device in healthy), again


def _fake_health(monkeypatch, broken: set[str]):
    """Every device whose spec is in `broken` fails the probe; the others pass."""
    monkeypatch.setattr(runtime, "device_health", lambda info, device: health.Health(
        info.spec not in broken, f"error: fake failure of {info.spec}" if info.spec in broken else ""))


def test_the_default_skips_a_broken_device_and_records_it(monkeypatch):
    monkeypatch.delenv("CLSHADE_DEVICE", raising=False)
    ranked = sorted(runtime.list_devices(), key=lambda item: runtime.preference(item[0]))
    first = ranked[0][0]
    _fake_health(monkeypatch, set())
    assert runtime.choose_device(None).info == first
    _fake_health(monkeypatch, {first.spec})
    if len(ranked) == 1:
        with pytest.raises(ClshadeError, match="no OpenCL device can build programs") as err:
            runtime.choose_device(None)
        assert first.spec in str(err.value) and "\n" not in str(err.value)
        return
    chosen = runtime.choose_device(None)
    assert chosen.info != first and chosen.info == ranked[1][0]
    assert [(i.spec, reason) for i, reason in chosen.skipped] == [(first.spec, f"error: fake failure of {first.spec}")]


def test_no_healthy_device_fails_in_one_line(monkeypatch):
    monkeypatch.delenv("CLSHADE_DEVICE", raising=False)
    _fake_health(monkeypatch, {i.spec for i, _ in runtime.list_devices()})
    with pytest.raises(ClshadeError) as err:
        runtime.choose_device(None)
    text = str(err.value)
    assert "no OpenCL device can build programs" in text and "\n" not in text
    assert all(f"{i.spec} " in text for i, _ in runtime.list_devices())


def test_an_explicitly_chosen_broken_device_fails_in_one_line(monkeypatch):
    info, _ = runtime.list_devices()[0]
    _fake_health(monkeypatch, {info.spec})
    with pytest.raises(ClshadeError) as err:
        runtime.choose_device(info.spec)
    text = str(err.value)
    assert "\n" not in text and info.spec in text and info.description in text
    assert f"fake failure of {info.spec}" in text and "clshade devices" in text     # the reason and the remedy


def test_the_default_prefers_cpu_devices_then_the_measured_runtime_order():
    def info(platform, version, kind="cpu", p=0):
        return runtime.DeviceInfo(p, 0, platform, version, "dev", kind)
    pocl30 = info("Portable Computing Language", "OpenCL 3.0 PoCL 3.0-rc2 Linux", p=0)
    pocl31 = info("Portable Computing Language", "OpenCL 3.0 PoCL 3.1+debian Linux", p=1)
    intel = info("Intel(R) OpenCL", "OpenCL 3.1 LINUX", p=2)
    gpu = info("NVIDIA CUDA", "OpenCL 3.0 CUDA 12.4", kind="gpu", p=3)
    order = sorted([gpu, intel, pocl30, pocl31], key=runtime.preference)
    assert order[-1] == gpu
    want = []
    for key in runtime.RUNTIME_PREFERENCE:
        want += [d for d in (pocl30, pocl31, intel) if key in f"{d.platform}, {d.platform_version}" and d not in want]
    assert order[:3] == want
    assert [d.runtime for d in (pocl30, pocl31, intel)] == ["PoCL 3.0", "PoCL 3.1", "Intel OpenCL 3.1"]
    # NVIDIA's platform version "OpenCL 3.0 CUDA 13.0.98" (on an H100): the CUDA version, not OpenCL's
    assert info("NVIDIA CUDA", "OpenCL 3.0 CUDA 13.0.98", kind="gpu").runtime == "NVIDIA CUDA 13.0"


def test_devices_footnote_names_the_rule_that_chose_the_default() -> None:
    """The starred default is a GPU where no CPU device is healthy (the H100 machine): the footnote says so."""
    from clshade.cli.commands.devices import default_rule
    assert "CPU device" in default_rule(runtime.DeviceInfo(0, 0, "PoCL", "OpenCL 3.0 PoCL 3.1", "cpu0", "all | cpu"))
    gpu = default_rule(runtime.DeviceInfo(0, 0, "NVIDIA CUDA", "OpenCL 3.0 CUDA 13.0.98", "H100", "all | gpu"))
    assert "no CPU device is healthy" in gpu and "gpu" in gpu


def test_the_cli_works_with_every_pocl_build_failing(tmp_path):
    """The README's render where pip's PoCL cannot compile: the default skips every PoCL device
    and renders on another runtime (rc 0, nothing on stderr); `clshade devices` shows each PoCL
    device as broken with the compiler's reason; choosing one fails in one line."""
    if not _pocl_devices():
        pytest.skip("no PoCL device present")
    if not _other_healthy():
        pytest.skip("no healthy non-PoCL device (Intel's CPU runtime is a dependency on x86-64 Linux only)")
    out = tmp_path / "ball.png"
    done = _cli(["render", str(SCENES / "red_ball.toml"), "-o", str(out), "--width", "40", "--height", "30",
                 "--explain"], tmp_path, POCL_EXTRA_BUILD_FLAGS=REJECTED)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert out.is_file()
    device_line = next(l for l in done.stdout.splitlines() if l.startswith("device: "))
    assert "PoCL" not in device_line
    assert sum(l.startswith("skipped device: ") and REJECTED in l for l in done.stdout.splitlines()) >= 1
    listing = _cli(["devices"], tmp_path, POCL_EXTRA_BUILD_FLAGS=REJECTED)
    assert listing.returncode == 0, listing.stderr
    lines = listing.stdout.splitlines()
    for k, line in enumerate(lines):
        if "PoCL" in line and "|" in line:
            assert not line.startswith("*"), line
            assert "BROKEN" in lines[k + 1] and REJECTED in lines[k + 1], lines[k + 1]
    assert any(l.startswith("*") for l in lines)
    chosen = _cli(["render", str(SCENES / "red_ball.toml"), "-o", str(tmp_path / "x.png"), "--device", "PoCL",
                   "--width", "40", "--height", "30"], tmp_path, POCL_EXTRA_BUILD_FLAGS=REJECTED)
    assert chosen.returncode == 2 and len(chosen.stderr.strip().splitlines()) == 1, chosen.stderr
    assert "cannot build OpenCL programs" in chosen.stderr and REJECTED in chosen.stderr
    assert not (tmp_path / "x.png").exists()


def test_every_device_broken_fails_the_cli_in_one_line(tmp_path):
    names = {i.runtime for i, _ in runtime.list_devices() if "PoCL" not in i.platform_version}
    force = "|".join(sorted(names))
    if len(names) > 1:
        pytest.skip("CLSHADE_FORCE_BROKEN fakes one non-PoCL runtime; more are present")
    env = dict(POCL_EXTRA_BUILD_FLAGS=REJECTED)
    if names:
        env["CLSHADE_FORCE_BROKEN"] = next(i.device for i, _ in runtime.list_devices() if "PoCL" not in i.platform_version)
    done = _cli(["render", str(SCENES / "red_ball.toml"), "-o", str(tmp_path / "x.png"), "--width", "40",
                 "--height", "30"], tmp_path, **env)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, (force, done.stderr)
    assert "no OpenCL device can build programs" in done.stderr


def test_pip_runtimes_are_registered_beside_the_systems(tmp_path, monkeypatch):
    """icd.register writes the system's .icd files and one naming pip's libintelocl.so into a
    folder, and points OCL_ICD_VENDORS there; a user's own OCL_ICD_VENDORS is left alone."""
    if icd.installed_library(icd.PIP_RUNTIMES[0]) is None:
        pytest.skip("intel-opencl-rt is not installed (a dependency on x86-64 Linux only)")
    system = tmp_path / "vendors"
    system.mkdir()
    (system / "vendor-a.icd").write_text("/opt/a/libA.so\n", encoding="utf-8")
    monkeypatch.setattr(icd, "SYSTEM_VENDORS", system)
    monkeypatch.setattr(icd, "_registered", None)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.delenv("OCL_ICD_VENDORS", raising=False)
    monkeypatch.delenv("CLSHADE_NO_PIP_RUNTIMES", raising=False)
    folder = Path(icd.register())
    assert os.environ["OCL_ICD_VENDORS"] == str(folder)
    assert (folder / "vendor-a.icd").read_text(encoding="utf-8") == "/opt/a/libA.so\n"
    lib = Path((folder / icd.PIP_RUNTIMES[0].icd_name).read_text(encoding="utf-8").strip())
    assert lib.is_absolute() and lib.is_file() and lib.name == "libintelocl.so"
    monkeypatch.setattr(icd, "_registered", None)
    monkeypatch.setenv("OCL_ICD_VENDORS", "/the/users/choice")
    assert icd.register() is None and os.environ["OCL_ICD_VENDORS"] == "/the/users/choice"
    # The user's folder hides Intel's runtime: the "no device" error says so, and how to undo it.
    hint = icd.unregistered_hint()
    assert "intel-opencl-rt" in hint and str(lib) in hint and "OCL_ICD_VENDORS=/the/users/choice" in hint
    (system / "mine.icd").write_text(f"{lib}\n", encoding="utf-8")     # a folder of the user's that names it
    monkeypatch.setenv("OCL_ICD_VENDORS", str(system))
    assert icd.unregistered_hint() == ""
    monkeypatch.delenv("OCL_ICD_VENDORS")
    monkeypatch.setenv("CLSHADE_NO_PIP_RUNTIMES", "1")
    assert "CLSHADE_NO_PIP_RUNTIMES" in icd.unregistered_hint()


def test_a_new_process_finds_pips_intel_runtime(tmp_path):
    """What `pip install .` gives is usable with no variable set by hand: a fresh process lists
    Intel's CPU device (its shipped .icd names a placeholder path that no loader finds)."""
    if icd.installed_library(icd.PIP_RUNTIMES[0]) is None:
        pytest.skip("intel-opencl-rt is not installed (a dependency on x86-64 Linux only)")
    env = {k: v for k, v in os.environ.items() if k != "OCL_ICD_VENDORS"}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    code = ("import json; from clshade.device.runtime import list_devices; "
            "print(json.dumps([i.platform for i, _ in list_devices()]))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "Intel(R) OpenCL" in json.loads(done.stdout)
    without = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                             env={**env, "CLSHADE_NO_PIP_RUNTIMES": "1"})
    assert "Intel(R) OpenCL" not in json.loads(without.stdout or "[]")


def test_a_device_that_computes_wrong_values_is_broken(monkeypatch):
    """The probe's output is checked, not only its build: expecting another value marks a
    healthy device broken, naming what it computed."""
    cl = runtime._cl()
    info, device = runtime.healthy_devices(kind=None)[0]
    assert health.run_probe(cl, info, device).ok
    monkeypatch.setattr(health, "PROBE_EXPECTED", health.PROBE_EXPECTED + 1e-3)
    state = health.run_probe(cl, info, device)
    assert not state.ok and "computed 2.0" in state.reason


def test_the_default_order_is_the_measured_order(checkout):
    """The default device is the fastest healthy CPU runtime as measured: benchmarks/results/runtimes.json
    (each runtime with its tuned build) names its fastest as the default. RUNTIME_PREFERENCE, the order used
    with tuning off (CLSHADE_TUNE=fixed: today's rule on every runtime), ranks the runtimes as their
    today's-rule times in benchmarks/results/tuning.json do (geometric mean over the models)."""
    doc = json.loads((checkout / "benchmarks" / "results" / "runtimes.json").read_text(encoding="utf-8"))
    measured = [d for d in doc["devices"] if d["healthy"] and "cpu" in d["kind"]]
    assert len({d["runtime"] for d in measured}) >= 2, "runtimes.json compares fewer than two runtimes"
    by_speed = [d["runtime"] for d in sorted(measured, key=lambda d: d["geomean_median_ms"])]
    assert doc["runtime_preference"] == list(runtime.RUNTIME_PREFERENCE)
    assert doc["default"]["runtime"] == by_speed[0]
    for d in measured:     # every runtime's images were checked against the oracle in the same run
        assert all(r["max_rel_error"] is not None for r in d["models"].values()), d["runtime"]
    tuning = json.loads((checkout / "benchmarks" / "results" / "tuning.json").read_text(encoding="utf-8"))
    rule = {e["runtime"]: (e["key"], math.exp(statistics.fmean(math.log(s["rule_ms"]) for s in e["summary"].values())))
            for e in tuning["runtimes"] if e.get("summary")}
    assert len(rule) >= 2, "tuning.json times today's rule on fewer than two runtimes"
    by_rule = sorted(rule, key=lambda r: rule[r][1])
    by_preference = sorted(rule, key=lambda r: runtime.preference(runtime.DeviceInfo(
        0, 0, rule[r][0]["platform"], rule[r][0]["platform_version"], rule[r][0]["device"], "cpu")))
    assert by_preference == by_rule, (by_preference, {r: round(rule[r][1], 3) for r in by_rule})


def test_no_opencl_platform(tmp_path, capsys, monkeypatch):
    """No OpenCL platform, or an ICD loader that fails: one line naming what to install, nothing written."""
    import pyopencl as cl
    scene = write_scene(tmp_path)
    before = set(os.listdir(tmp_path))
    for fake in (lambda: [], lambda: (_ for _ in ()).throw(cl.LogicError("clGetPlatformIDs", -1001, "no ICD"))):
        monkeypatch.setattr(cl, "get_platforms", fake)
        # A device spec nobody else uses, so the cached runtime is not reused.
        code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(tmp_path / "o.png"),
                                        "--device", "no-such-device-for-test"])
        assert_one_line_error(code, err, "pocl")
        assert "install" in err
    assert set(os.listdir(tmp_path)) == before
