"""The command line's rough edges (issue 14, point 8): every flag validated before work,
quiet broken pipes, file modes that follow the umask, sweep layout and labels, plain
numbers in messages, the README images' provenance."""
from __future__ import annotations

import os
import stat
import subprocess
import sys

import numpy as np
import pytest

from clshade.cli import main
from clshade.models.registry import Registry
from clshade.errors import ClshadeError
from clshade.render.image import read_image, write_image
from clshade.render.scene import parse_scene

from conftest import ROOT, SCENES

BUILT_IN = Registry()          # the built-in lobes

RED_BALL = str(SCENES / "red_ball.toml")


def _error(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("clshade: error: ")
    return err


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e6", "65"])
def test_exposure_flag_validated_like_the_scene_key(capsys, tmp_path, value):
    err = _error(capsys, ["render", RED_BALL, f"--exposure={value}", "-o", str(tmp_path / "x.png")])
    assert "--exposure" in err and "[-64, 64]" in err
    assert not (tmp_path / "x.png").exists()


def test_empty_model_refused(capsys, tmp_path):
    assert "no model given" in _error(capsys, ["render", RED_BALL, "-m", "", "-o", str(tmp_path / "x.png")])
    assert "no model given" in _error(capsys, ["sweep", "-m", "", "-o", str(tmp_path / "x.png")])


@pytest.mark.parametrize("argv", [["sweep", "--size", "0"], ["sweep", "--size", "-3"],
                                  ["compare", RED_BALL, "--tile", "0"], ["compare", RED_BALL, "--width", "0"]])
def test_sizes_refused(capsys, tmp_path, argv):
    assert "must be within [1, " in _error(capsys, [*argv, "-o", str(tmp_path / "x.png")])


def test_scene_without_lights_warns(capsys, tmp_path):
    scene = tmp_path / "dark.toml"
    scene.write_text('[camera]\nposition = [0, 0, 3]\nwidth = 8\nheight = 8\n'
                     '[[objects]]\nprimitive = "sphere"\nmaterial = { base_color = [0.5, 0.5, 0.5] }\n')
    assert main(["render", str(scene), "-o", str(tmp_path / "d.png")]) == 0
    err = capsys.readouterr().err
    assert "warning: dark.toml has no [[lights]], no ambient and no emission" in err
    scene.write_text(scene.read_text().replace("[camera]", "[render]\nambient = 0.5\n[camera]"))
    assert main(["render", str(scene), "-o", str(tmp_path / "d.png")]) == 0
    assert "surfaces get only the ambient term" in capsys.readouterr().err


def test_error_values_are_plain_numbers():
    text = '[camera]\nposition = [0.0, 0.0, 3.0]\ntarget = [0.0, 0.0, 3.0]\n'
    with pytest.raises(ClshadeError) as info:
        parse_scene(text)
    assert "camera.target = [0.0, 0.0, 3.0]" in str(info.value)
    assert "np." not in str(info.value)


def test_broken_pipe_in_process(monkeypatch, capsys):
    class Closed:
        def write(self, text):
            raise BrokenPipeError(32, "Broken pipe")

        def flush(self):
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(sys, "stdout", Closed())
    assert main(["devices"]) == 141
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


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o027, 0o640), (0o002, 0o664)])
def test_written_images_follow_the_umask(tmp_path, umask, mode):
    image = np.zeros((2, 2, 4), np.float32)
    old = os.umask(umask)
    try:
        for name in ("a.png", "a.exr"):
            write_image(tmp_path / name, image)
            assert stat.S_IMODE((tmp_path / name).stat().st_mode) == mode
    finally:
        os.umask(old)


def test_overwritten_image_keeps_its_mode(tmp_path):
    path = tmp_path / "a.png"
    path.write_bytes(b"")
    path.chmod(0o644)
    old = os.umask(0o077)
    try:
        write_image(path, np.zeros((2, 2, 4), np.float32))
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == 0o644


def test_sweep_one_row_per_model_and_labels(runtime):
    from clshade.compare import GAP, LABEL_HEIGHT, TITLE_HEIGHT, sweep_labels, sweep_sheet, model_title
    roughness = (0.05, 0.15, 0.3, 0.5, 0.7, 0.9)
    pair = [BUILT_IN.resolve("phong"), BUILT_IN.resolve("ggx_correlated@dielectric")]
    sheet = sweep_sheet(RED_BALL, pair, roughness, size=8, runtime=runtime)
    assert sheet.shape[1] == GAP + len(roughness) * (8 + GAP)                       # 6 columns, no wrap
    assert sheet.shape[0] == GAP + len(pair) * (TITLE_HEIGHT + 8 + LABEL_HEIGHT + GAP)   # one row each
    assert sweep_labels(BUILT_IN.resolve("phong"), 0.5, 30.0) == ("r = 0.5", "n = 30")
    assert sweep_labels(BUILT_IN.resolve("lambert"), 0.5, 30.0) == ("r = 0.5", "")
    assert sweep_labels(BUILT_IN.resolve("ggx_correlated"), 0.5, 30.0) == ("r = 0.5", "")
    assert model_title(BUILT_IN.resolve("ggx_correlated@conductor")) == "GGX height-correlated, Conductor Fresnel"
    assert model_title(BUILT_IN.resolve("lambert")) == "Lambert"


@pytest.mark.text
def test_readme_images_come_from_make_images():
    """Each README image's caption quotes the command benchmarks/docgen/make_images.py runs for it."""
    make_images = pytest.importorskip("benchmarks.docgen.make_images", reason="needs the source checkout")
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    for name in ("robot.png", "robot_sheet.png"):
        assert f"docs/images/{name}" in readme
        assert "clshade " + " ".join(make_images.COMMANDS[name]) + " -o" in readme, name


def test_readme_robot_image_shows_the_float64_truth(tmp_path):
    """`clshade render scenes/robot.toml` (the README's command) and the committed
    docs/images/robot.png both show what the float64 frame oracle says the scene looks like
    (every light kind, shadows, ambient; the scene's exposure and tone map, 8-bit sRGB): at
    most 1/255 apart on every pixel that faces the viewer, the worst named. Not a comparison
    with an image the same code wrote: a wrong spot cone, falloff or tone map fails it."""
    from clshade.bench.run import compared_pixels
    from clshade.models.registry import Registry
    from clshade.pipeline import prepare_frame
    from clshade.render.image import to_display
    from clshade.render.scene import load_scene
    from clshade.verify import reference
    resolve = Registry().resolve          # the built-in lobes

    out = tmp_path / "robot.png"
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        assert main(["render", "scenes/robot.toml", "-o", str(out)]) == 0
    finally:
        os.chdir(cwd)
    scene = load_scene(ROOT / "scenes" / "robot.toml")
    frame = prepare_frame(scene)
    truth = reference.radiance(frame.gbuffer, frame.scene, resolve(scene.model), camera=frame.camera,
                               shadows=frame.shadows)
    want = to_display(truth, scene.tonemap, scene.exposure).reshape(-1, 3).astype(np.int16)
    idx = compared_pixels(frame.gbuffer, frame.camera)
    width = frame.camera.width
    for name, path in (("clshade render", out), ("docs/images/robot.png", ROOT / "docs" / "images" / "robot.png")):
        got = np.round(read_image(path)[..., :3] * 255.0).reshape(-1, 3).astype(np.int16)
        assert got.shape == want.shape, name
        err = np.abs(got[idx] - want[idx]).max(axis=1)
        worst = int(np.argmax(err))
        assert err[worst] <= 1, (f"{name}: pixel (row {idx[worst] // width}, column {idx[worst] % width}) is "
                                 f"{got[idx[worst]]}, the oracle says {want[idx[worst]]}; "
                                 f"{int((err > 1).sum())} pixels over 1/255 (python -m benchmarks.docgen.make_images)")


def test_progress_only_on_a_terminal(monkeypatch):
    import io
    from clshade.cli.common import progress_bar

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    log = io.StringIO()
    monkeypatch.setattr(sys, "stderr", log)
    with progress_bar("work", "step") as progress:
        assert progress is None                 # not a terminal: no bar, no callback
    assert log.getvalue() == ""
    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    with progress_bar("work", "step") as progress:
        progress(1, 3)
        progress(3, 3)
    assert "work:" in term.getvalue() and "/3 " in term.getvalue()   # drawn (then cleared: leave=False)


def test_long_commands_report_progress(runtime):
    """The loops behind sweep, compare, check stability and models call progress(done, total)."""
    from clshade.compare import sweep_sheet
    from clshade.verify import stability
    calls = []
    sweep_sheet(RED_BALL, [BUILT_IN.resolve("lambert")], (0.2, 0.8), size=4, runtime=runtime,
                progress=lambda d, t: calls.append((d, t)))
    assert calls == [(1, 2), (2, 2)]
    calls.clear()
    stability.run([BUILT_IN.resolve("lambert")], runtime=runtime, fast_math=(False,), shading=False, extras=False,
                  progress=lambda d, t: calls.append((d, t)))
    assert calls == [(1, 1)]


@pytest.mark.parametrize("flag, value, message", [
    ("--json", "nodir/b.json", "does not exist"), ("--csv", "nodir/b.csv", "does not exist"),
    ("--plot", "b.txt", "unsupported format .txt"), ("--plot", "nodir/b.png", "does not exist"),
    ("--json", ".", "is a folder"),
])
def test_bench_outputs_checked_before_the_run(monkeypatch, capsys, tmp_path, flag, value, message):
    import clshade.bench.run as bench_run

    def never(*a, **k):
        raise AssertionError("the benchmark ran before its outputs were checked")

    monkeypatch.setattr(bench_run, "run_bench", never)
    monkeypatch.chdir(tmp_path)
    err = _error(capsys, ["bench", RED_BALL, "--frames", "1", flag, value])
    assert flag in err and message in err


def test_bench_plot_needs_matplotlib_before_the_run(monkeypatch, capsys, tmp_path):
    import clshade.bench.run as bench_run
    monkeypatch.setattr(bench_run, "run_bench", lambda *a, **k: (_ for _ in ()).throw(AssertionError("ran")))
    monkeypatch.setitem(sys.modules, "matplotlib", None)          # import matplotlib → ImportError
    err = _error(capsys, ["bench", RED_BALL, "--frames", "1", "--plot", str(tmp_path / "b.png")])
    assert "needs matplotlib" in err and "pip install matplotlib" in err


def _unwritable_folder() -> str:
    """A folder no one can create files in, also as root (os.access says yes to root everywhere)."""
    for folder in ("/proc", "/sys"):
        if os.path.isdir(folder):
            return folder
    pytest.skip("no /proc or /sys folder on this system")


@pytest.mark.parametrize("command", [["render", RED_BALL], ["bench", RED_BALL, "--frames", "1", "--json"]])
def test_unwritable_output_refused_in_one_line(capsys, command):
    """An output in a folder that cannot be written is refused before the work, not a traceback after it."""
    out = os.path.join(_unwritable_folder(), "clshade_out." + ("json" if command[-1] == "--json" else "png"))
    argv = command + [out] if command[-1] == "--json" else command + ["-o", out]
    assert "not writable" in _error(capsys, argv)


@pytest.mark.parametrize("command", ["render", "compare", "sweep"])
def test_image_output_that_is_a_folder_refused(capsys, tmp_path, command):
    folder = tmp_path / "out.png"
    folder.mkdir()
    argv = [command, RED_BALL, "-o", str(folder)] + (["-m", "lambert"] if command != "render" else [])
    assert "is a folder" in _error(capsys, argv)


@pytest.mark.extra
def test_low01_only_from_1000_frames(tmp_path):
    """Below 1000 frames the 0.1 % low is the slowest frame again: the table prints –, the plot has no bar."""
    from clshade.report.bench import LOW01_MIN_FRAMES, bench_table, plot_fps
    row = dict(label="m", mean_ms=1.0, avg_fps=1000.0, low1_fps=500.0, low01_fps=123.4, median_ms=1.0, p99_ms=2.0,
               host_overhead_ms=0.1, mpixel_per_s=1.0, bytes_per_pixel=48, mean_bytes_per_pixel=40.0,
               lambert_ratio=1.0, copy_ratio=1.0, numpy_ms=1.0, numpy_ratio=1.0, max_rel_error=0.0,
               mean_rel_error=0.0)
    assert "123.4" not in bench_table([dict(row, frames=LOW01_MIN_FRAMES - 1)])
    assert "123.4" in bench_table([dict(row, frames=LOW01_MIN_FRAMES)])
    import matplotlib.pyplot as plt
    bars = []
    real_bar = plt.Axes.bar
    def counting_bar(self, *a, **k):
        bars.append(k.get("label"))
        return real_bar(self, *a, **k)
    import unittest.mock
    with unittest.mock.patch.object(plt.Axes, "bar", counting_bar):
        plot_fps([dict(row, frames=60)], tmp_path / "a.png", "t")
        assert bars == ["average", "1 % low"]
        bars.clear()
        plot_fps([dict(row, frames=1000)], tmp_path / "b.png", "t")
        assert bars == ["average", "1 % low", "0.1 % low"]
