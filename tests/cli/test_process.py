"""The process entry point and its settings (clshade.cli.run, clshade/cli/process.py): the garbage
collector paused only while the CLI starts up, frozen for a quick exit, the allocator tuned, BLAS
single-threaded unless the user says; a reader that leaves the pipe early ends the command quietly
(exit status 141, nothing on stderr); `main` (the in-process entry the tests use) leaves the
interpreter's state alone."""
from __future__ import annotations

import gc
import json
import subprocess
import sys

import pytest

from clshade import cli
from clshade.cli import process
from clshade.cli.commands import devices

from conftest import ROOT

PROBE = """
import gc, json, sys
import clshade.cli as cli
from clshade.cli.commands import devices
seen = {}
kept = []
def probe(args):
    seen.update(enabled=gc.isenabled(), frozen=gc.get_freeze_count(), young=len(gc.get_objects()))
    kept.extend([] for _ in range(5000))     # objects the command allocates and keeps
    print("command output")
    return 3
devices.cmd_devices = probe
sys.argv = ["clshade", "devices"]
status = cli.run()
young = len(gc.get_objects())     # what a final collection would still traverse
print(json.dumps({**seen, "status": status, "young_after": young}))
"""


def test_run_collects_during_the_command_and_freezes_for_exit():
    proc = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == "command output"           # the command's own output, flushed, in order
    seen = json.loads(lines[-1])
    assert seen["status"] == 3                    # the command's exit status comes through
    assert seen["enabled"] is True                # collection is on while the command runs
    assert seen["frozen"] > 10_000                # start-up's objects were frozen before it
    assert seen["young"] < seen["frozen"] // 10   # ... and are not traversed by collections
    assert seen["young_after"] < 100              # everything frozen once it returned: exit traverses nothing
    assert proc.stderr == ""


def test_main_leaves_the_collector_alone(monkeypatch):
    monkeypatch.setattr(devices, "cmd_devices", lambda args: 0)
    before = (gc.isenabled(), gc.get_freeze_count())
    assert cli.main(["devices"]) == 0
    assert (gc.isenabled(), gc.get_freeze_count()) == before


def test_tune_allocator_sets_both_thresholds(monkeypatch):
    import ctypes
    calls: list[tuple[int, int]] = []

    class FakeMallopt:
        argtypes = restype = None

        def __call__(self, param, value):
            calls.append((param, value))
            return 1

    class FakeLibc:
        mallopt = FakeMallopt()

    monkeypatch.setattr(ctypes, "CDLL", lambda name: FakeLibc())
    assert process.tune_allocator() is True
    # glibc's malloc.h: M_TRIM_THRESHOLD = -1, M_MMAP_THRESHOLD = -3; 32 MiB is its largest mmap threshold
    assert calls == [(-3, 32 << 20), (-1, process.TRIM_THRESHOLD)]
    assert process.TRIM_THRESHOLD >= process.MMAP_THRESHOLD


def test_tune_allocator_without_mallopt(monkeypatch):
    import ctypes
    monkeypatch.setattr(ctypes, "CDLL", lambda name: object())
    assert process.tune_allocator() is False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_tune_allocator_on_this_libc():
    """On glibc both values are accepted (mallopt returns 1); elsewhere nothing is changed."""
    import platform
    if platform.libc_ver()[0] != "glibc":
        pytest.skip("not glibc")
    code = "from clshade.cli import process; print(process.tune_allocator())"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "True", out.stderr


THREADS = """
import json, os, sys
import clshade.cli as cli
from clshade.cli.commands import devices
seen = {}
def probe(args):
    seen.update(threads=len(os.listdir("/proc/self/task")), env=os.environ.get("OPENBLAS_NUM_THREADS"))
    return 0
devices.cmd_devices = probe
sys.argv = ["clshade", "devices"]
cli.run()
print(json.dumps(seen))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="counts threads in /proc/self/task")
@pytest.mark.parametrize("user_setting", [None, "2"])
def test_numpy_blas_is_single_threaded_unless_the_user_says(user_setting, monkeypatch):
    """With NumPy loaded by run() the process has one thread when the command starts (no
    OpenBLAS workers) and OPENBLAS_NUM_THREADS is not left in the environment; a value the
    user set is kept and honoured."""
    import os
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if user_setting:
        env["OPENBLAS_NUM_THREADS"] = user_setting
    proc = subprocess.run([sys.executable, "-c", THREADS], capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr
    seen = json.loads(proc.stdout.splitlines()[-1])
    assert seen["env"] == user_setting
    assert seen["threads"] == (1 if user_setting is None else int(user_setting))


# ---------------------------------------------------------------- a reader that left: quiet

def test_broken_pipe_in_process(monkeypatch, capsys):
    class Closed:
        def write(self, text):
            raise BrokenPipeError(32, "Broken pipe")

        def flush(self):
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(sys, "stdout", Closed())
    assert cli.main(["devices"]) == 141
    assert capsys.readouterr().err == ""


def test_broken_pipe_real_pipe():
    """`clshade devices | <reader that already left>`: no traceback, no 'Exception ignored'."""
    proc = subprocess.Popen([sys.executable, "-m", "clshade", "devices"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, cwd=ROOT)
    proc.stdout.close()                      # the reader leaves before the first line
    err = proc.stderr.read().decode()
    proc.wait(timeout=120)
    assert err == ""
    assert proc.returncode == 141
