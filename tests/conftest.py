"""Shared fixtures and helpers: the OpenCL runtime (PoCL CPU by default), the bundled data as installed, the
checkout and the third-party assets folder; the command line run in-process or in a child process, the one-line
error it must print on bad input, and a frame compared with the float64 frame oracle.

The test folders mirror the packages (render/, device/, models/, verify/, bench/, report/, view/, cli/), tests of
clshade's top-level modules sit here, and contracts/ holds the promises checked across the tree. Basenames are
unique across the folders, which are not packages: pytest's default import mode puts each test's folder and this
one on sys.path, so `from conftest import ...`, `from scene_toml import ...` and `from hostile_files import ...`
work from every folder.

The tests run against whatever `import clshade` finds. CI (.ci/run) installs the package non-editable and runs
pytest from tests/, so `clshade` and its data (kernels, scenes, textures) come from site-packages and a file
missing from the wheel fails a test. With CLSHADE_EXPECT_INSTALLED=1 the session refuses a clshade imported
from the checkout.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import clshade
from clshade import cli
from clshade.resources import scenes_dir
from scene_toml import small_red_sphere

ROOT = Path(__file__).resolve().parents[1]
ASSETS = ROOT.parent / "shared" / "assets"
SCENES = scenes_dir()  # the scenes the imported clshade ships (site-packages when installed)
PACKAGE = Path(clshade.__file__).resolve().parent
CHECKOUT = ROOT if (ROOT / "pyproject.toml").is_file() else None

# Tests never wait on the tuner's measurement (clshade/device/tuned.py) and never depend on this machine's: every
# runtime builds today's fixed rule and the default device is the first in RUNTIME_PREFERENCE (.ci/run sets it too).
os.environ["CLSHADE_TUNE"] = "fixed"

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
    stability and AA tests run on each. With fewer than two, CI is not testing what it promises,
    so CLSHADE_EXPECT_RUNTIMES=N makes the session fail below N."""
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
    the way NVIDIA's OpenCL compiler fails it (OpenCL 3.0 CUDA 13.0.98 on an H100): `#line`
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
    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True,
                              text=True).stdout.strip()
    git("init", "-q")
    git("config", "user.email", "t@example.org")
    git("config", "user.name", "t")
    return git


# ---------------------------------------------------------------- the command line


def run_cli(capsys, args: list[str]) -> tuple[int, str, str]:
    """`clshade ARGS` in-process: (exit status, stdout, stderr)."""
    code = cli.main(args)
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code: int, err: str, *needles: str) -> None:
    """Bad input's answer: exit status 2 and exactly one line on stderr, `clshade: error: ...` (no traceback),
    holding every needle."""
    assert code == 2, (code, err)
    assert err.startswith("clshade: error: ") and err.endswith("\n"), err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for needle in needles:
        assert needle in err, (needle, err)


def refused(capsys, args: list[str], *needles: str) -> str:
    """`clshade ARGS` in-process must refuse in one line holding every needle; returns that line."""
    code, _, err = run_cli(capsys, args)
    assert_one_line_error(code, err, *needles)
    return err


def write_scene(folder: Path, text: str | None = None, name: str = "scene.toml") -> Path:
    """`text` (default: scene_toml.small_red_sphere()) written to folder/name."""
    path = folder / name
    path.write_text(small_red_sphere() if text is None else text)
    return path


def render_refused(folder: Path, capsys, text: str, *needles: str, extra: list[str] | None = None) -> str:
    """`clshade render` of the scene `text` (written to folder/scene.toml) must refuse in one line holding
    every needle and the scene file's name (unless `extra` options hold the bad value), and leave nothing new
    in the folder; returns the line."""
    scene = write_scene(folder, text)
    before = set(os.listdir(folder))
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(folder / "out.png"), *(extra or [])])
    assert_one_line_error(code, err, *needles, *([] if extra else [scene.name]))
    assert set(os.listdir(folder)) == before, set(os.listdir(folder)) ^ before
    return err


def cli_image(capsys, scene: Path, out: Path) -> np.ndarray:
    """`clshade render SCENE -o OUT` in-process must succeed with nothing on stderr; returns the image read
    back."""
    from clshade.render.image import read_image
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(out)])
    assert code == 0 and err == "", err
    return read_image(out)


def run_cli_process(args: list[str], cwd: Path, timeout: float = 60) -> subprocess.CompletedProcess:
    """`python -m clshade ARGS` in a child process: its whole stderr, what C libraries and the interpreter's
    exit print included, and a timeout for a read that would not end."""
    return subprocess.run([sys.executable, "-m", "clshade", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=timeout)


# ---------------------------------------------------------------- the float64 frame oracle

#: The kernels' bound against the float64 frame oracle (README), relative, on the compared pixels.
ORACLE_BOUND = 1e-4
#: A relative error below ORACLE_DARK · the frame's peak radiance counts as absolute.
ORACLE_DARK = 1e-3
#: The compared pixels: every light's n·l and n·v at least this far from 0 (at grazing light or view the
#: kernels' documented floors act; the error there is clshade.verify.bias's subject).
ORACLE_MIN_COS = 1e-3
#: The frame size oracle_errors renders at.
ORACLE_WIDTH, ORACLE_HEIGHT = 96, 72


def unblock_fifo(fifo: Path) -> None:
    """Let a reader stuck opening `fifo` go on (it reads an empty file)."""
    try:
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
    except OSError:         # no reader waiting: nothing to unblock
        pass


def call_beside_fifo(fifo: Path, call, seconds: float = 20.0) -> tuple[object, bool]:
    """`call()` on a thread, let go on by opening `fifo`'s other end if it is still stuck after `seconds`
    (a reader that opened the FIFO), so that a test fails instead of hanging: (what it returned or the
    exception it raised, whether it was stuck)."""
    import threading
    out: list = []

    def run() -> None:
        try:
            out.append(call())
        except Exception as exc:     # noqa: BLE001 — handed to the test
            out.append(exc)
    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    worker.join(timeout=seconds)
    stuck = worker.is_alive()
    while worker.is_alive():
        unblock_fifo(fifo)
        worker.join(timeout=1)
    return out[0], stuck


def oracle_errors(scene_path, model_spec: str, runtime=None) -> dict[str, float]:
    """Render `scene_path` with the kernel (on `runtime`, default the default device) and evaluate the float64
    frame oracle on the same G-buffer: the compared and covered pixel counts, the largest relative error on the
    compared pixels, the largest absolute difference on the background, and how many compared pixels a shadow
    darkens."""
    from clshade.models.registry import Registry
    from clshade.pipeline import render
    from clshade.verify import reference
    model = Registry().resolve(model_spec)
    r = render(scene_path, model, width=ORACLE_WIDTH, height=ORACLE_HEIGHT, runtime=runtime)
    frame = r.frame
    vis = reference.visibility(frame.gbuffer, frame.scene, frame.shadows, frame.camera)
    want = reference.radiance(frame.gbuffer, frame.scene, model, visibility=vis, camera=frame.camera)
    px = reference.pixels(frame.gbuffer, frame.camera)
    keep = np.sum(px.n * px.v, axis=1) >= ORACLE_MIN_COS
    for _, l, _ in reference.light_rays(frame.scene, px):
        keep &= np.abs(np.sum(px.n * l, axis=1)) >= ORACLE_MIN_COS
    if vis is not None:   # pixels whose PCF taps sit on a texel edge may round either way
        for dx, dy in ((1e-3, 1e-3), (-1e-3, -1e-3)):
            other = reference.visibility(frame.gbuffer, frame.scene, frame.shadows, frame.camera, offset=(dx, dy))
            keep &= (other == vis).reshape(len(vis), -1)[:, px.index].all(axis=0)
    idx = px.index[keep]
    got = r.image[..., :3].reshape(-1, 3)[idx].astype(np.float64)
    ref = want.reshape(-1, 3)[idx]
    peak = float(np.abs(ref).max())
    err = np.abs(got - ref) / np.maximum(np.abs(ref), ORACLE_DARK * peak)
    empty = ~frame.gbuffer.coverage.reshape(-1)
    bg = np.abs(r.image[..., :3].reshape(-1, 3)[empty] - want.reshape(-1, 3)[empty])
    return dict(pixels=len(idx), covered=len(px.index), max=float(err.max()), background=float(bg.max(initial=0)),
                shadowed=int((vis < 1).reshape(len(vis), -1)[:, idx].any(axis=0).sum()) if vis is not None else 0)
