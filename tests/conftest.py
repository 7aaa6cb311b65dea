"""Shared fixtures: the OpenCL runtime (PoCL CPU by default), the bundled data as installed, the checkout and
the third-party assets folder.

The tests run against whatever `import clshade` finds. CI (.ci/run) installs the package non-editable and runs
pytest from tests/, so `clshade` and its data (kernels, scenes, textures) come from site-packages and a file
missing from the wheel fails a test. With CLSHADE_EXPECT_INSTALLED=1 the session refuses a clshade imported
from the checkout.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

import clshade
from clshade.resources import scenes_dir

ROOT = Path(__file__).resolve().parents[1]
ASSETS = ROOT.parent / "shared" / "assets"
SCENES = scenes_dir()  # the scenes the imported clshade ships (site-packages when installed)
PACKAGE = Path(clshade.__file__).resolve().parent
CHECKOUT = ROOT if (ROOT / "pyproject.toml").is_file() else None

# The checkout's `benchmarks` package importable by tests (`import benchmarks.publish.render`): the root is
# appended, after site-packages, so that `import clshade` still finds the installed package first.
if CHECKOUT is not None and str(CHECKOUT) not in sys.path:
    sys.path.append(str(CHECKOUT))


def pytest_report_header(config) -> str:
    devices = ", ".join(f"{i.spec} {i.runtime} ({i.kind})" for i in healthy_devices())
    return f"clshade imported from {PACKAGE}; scenes from {SCENES}\nhealthy OpenCL devices: {devices}"


def pytest_sessionstart(session) -> None:
    if os.environ.get("CLSHADE_EXPECT_INSTALLED") == "1" and PACKAGE == ROOT / "clshade":
        raise pytest.UsageError(f"CLSHADE_EXPECT_INSTALLED=1 but clshade was imported from the checkout "
                                f"({PACKAGE}), not from the installed package")
    want = int(os.environ.get("CLSHADE_EXPECT_RUNTIMES", "0") or 0)
    if want:
        have = healthy_devices()
        runtimes = sorted({i.runtime for i in have})
        if len(runtimes) < want:
            raise pytest.UsageError(f"CLSHADE_EXPECT_RUNTIMES={want} but the healthy runtimes are {runtimes}")


@pytest.fixture(scope="session")
def runtime():
    from clshade.device.runtime import get_runtime
    return get_runtime()


_HEALTHY: list | None = None


def healthy_devices() -> list:
    """Every healthy OpenCL device present (CPU and GPU), in the default's order: the oracle,
    stability and AA tests run on each (issue 24). With fewer than two, CI is not testing what
    it promises, so CLSHADE_EXPECT_RUNTIMES=N makes the session fail below N."""
    global _HEALTHY
    if _HEALTHY is None:
        from clshade.device.runtime import healthy_devices as found
        _HEALTHY = [info for info, _ in found(kind=None)]
    return _HEALTHY


#: The mutation runner's suites set this too: Hypothesis draws no constants from the source of the modules loaded so
#: far (its "local constants"), so that what a derandomized property test tries depends neither on which test files
#: ran before it in the process nor on literals elsewhere in clshade (benchmarks/mutation/impact.py relies on that).
ENV_NO_LOCAL_CONSTANTS = "CLSHADE_TEST_NO_LOCAL_CONSTANTS"
if os.environ.get(ENV_NO_LOCAL_CONSTANTS) == "1":
    from hypothesis.internal.conjecture import providers as _providers
    from hypothesis.internal.constants_ast import Constants as _Constants
    _providers._get_local_constants = _Constants

#: The mutation runner's suites (benchmarks/mutation/run.py) set this: `device_runtime` tests run on the default device
#: only. A mutated kernel or host line acts the same on every runtime, and each runtime would compile every mutated
#: variant again.
ENV_ONE_RUNTIME = "CLSHADE_TEST_ONE_RUNTIME"


def pytest_generate_tests(metafunc) -> None:
    """`device_runtime`: the test runs once per healthy device (the first only under CLSHADE_TEST_ONE_RUNTIME=1),
    with that device's Runtime."""
    if "device_runtime" in metafunc.fixturenames:
        infos = healthy_devices()
        if os.environ.get(ENV_ONE_RUNTIME) == "1":
            infos = infos[:1]
        metafunc.parametrize("device_runtime", [i.spec for i in infos], indirect=True,
                             ids=[f"{i.runtime}-{i.kind}".replace(" ", "_") for i in infos])


@pytest.fixture(scope="session")
def device_runtime(request):
    from clshade.device.runtime import get_runtime
    return get_runtime(request.param)


@pytest.fixture(scope="session")
def checkout() -> Path:
    """The source checkout (docs/, benchmarks/, importable as above); tests reading it skip when the tests run
    without it."""
    if CHECKOUT is None:
        pytest.skip(f"no source checkout at {ROOT} (tests copied without the repository)")
    return CHECKOUT


@pytest.fixture(scope="session")
def assets() -> Path:
    """../shared/assets beside the checkout; tests using it skip when it is absent."""
    if not ASSETS.is_dir():
        pytest.skip(f"third-party assets not found at {ASSETS} (only present beside the developers' checkout)")
    return ASSETS


@pytest.fixture
def nvidia_compiler(monkeypatch):
    """`fail(needle, message)`: from then on pyopencl builds a program whose source contains `needle`
    the way NVIDIA's OpenCL compiler fails it (OpenCL 3.0 CUDA 13.0.98, H100, 2026-11-26): `#line`
    ignored, the error located at `<kernel>:LINE:COL`, LINE counted in the whole assembled program.
    Other programs build as usual."""
    import pyopencl as cl
    real = cl.Program

    def fail(needle: str, message: str) -> None:
        def program(context, *args):
            source = args[0] if len(args) == 1 and isinstance(args[0], str) else None
            if source is None or needle not in source:
                return real(context, *args)
            lines = source.split("\n")
            row = next(i for i, text in enumerate(lines) if needle in text)
            col = lines[row].index(needle) + 1
            log = ("clBuildProgram failed: BUILD_PROGRAM_FAILURE - clBuildProgram failed: BUILD_PROGRAM_FAILURE\n\n"
                   "Build on <pyopencl.Device 'NVIDIA H100 80GB HBM3' on 'NVIDIA CUDA' at 0x5571>:\n\n"
                   f"<kernel>:{row + 1}:{col}: error: {message}\n{lines[row]}\n{' ' * (col - 1)}^\n\n(options: )")

            class Failing:
                def build(self, options=()):
                    raise cl.RuntimeError(log)
            return Failing()
        monkeypatch.setattr(cl, "Program", program)
    return fail


@pytest.fixture
def scratch_repo(tmp_path):
    """A new git repository at tmp_path; returns git(*args) run there (its stdout, stripped)."""
    import subprocess

    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True,
                              text=True).stdout.strip()
    git("init", "-q")
    git("config", "user.email", "t@example.org")
    git("config", "user.name", "t")
    return git
