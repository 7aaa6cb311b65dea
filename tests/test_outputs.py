"""Output files (clshade/outputs.py): every command checks its outputs before any work (a missing or
unwritable folder, a folder or unsupported suffix in place of a file, a name longer than the file system
allows) and refuses in one line; no output is written over one of the command's inputs (the scene, its
meshes and textures) or onto another output; a write is atomic (an interrupted one leaves nothing) and the
new file's mode follows the umask."""
from __future__ import annotations

import os
import stat
import sys

import numpy as np
import pytest

from clshade.render.image import write_image

from conftest import SCENES, refused, run_cli, write_scene
from hostile_files import obj_triangle, write
from scene_toml import small_red_sphere

SIZE = ["--width", "24", "--height", "16"]   # tiny renders keep the suite fast
RED_BALL = str(SCENES / "red_ball.toml")


# ---------------------------------------------------------------- checked before the work

@pytest.mark.parametrize("output, needle", [
    ("missing_folder/out.png", "does not exist"),
    ("scene.toml/out.png", "does not exist"),     # parent is a file
    ("out.bmp", "unsupported output format .bmp"),
    ("out", "unsupported output format (none)"),
])
def test_bad_output_path(tmp_path, capsys, output, needle):
    scene = write_scene(tmp_path)
    before = set(os.listdir(tmp_path))
    refused(capsys, ["render", str(scene), "-o", str(tmp_path / output), *SIZE], needle, output.split("/")[-1])
    assert set(os.listdir(tmp_path)) == before


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
    err = refused(capsys, ["bench", RED_BALL, "--frames", "1", flag, value])
    assert flag in err and message in err


def test_bench_plot_needs_matplotlib_before_the_run(monkeypatch, capsys, tmp_path):
    import clshade.bench.run as bench_run
    monkeypatch.setattr(bench_run, "run_bench", lambda *a, **k: (_ for _ in ()).throw(AssertionError("ran")))
    monkeypatch.setitem(sys.modules, "matplotlib", None)          # import matplotlib → ImportError
    err = refused(capsys, ["bench", RED_BALL, "--frames", "1", "--plot", str(tmp_path / "b.png")])
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
    assert "not writable" in refused(capsys, argv)


@pytest.mark.parametrize("command", ["render", "compare", "sweep"])
def test_image_output_that_is_a_folder_refused(capsys, tmp_path, command):
    folder = tmp_path / "out.png"
    folder.mkdir()
    argv = [command, RED_BALL, "-o", str(folder)] + (["-m", "lambert"] if command != "render" else [])
    assert "is a folder" in refused(capsys, argv)


@pytest.mark.parametrize("command", ["render", "bench"])
def test_output_name_longer_than_the_file_system_allows(tmp_path, capsys, command):
    scene = write_scene(tmp_path)
    long = tmp_path / ("x" * 300 + (".png" if command == "render" else ".json"))
    args = ["render", str(scene), "-o", str(long)] if command == "render" else \
        ["bench", str(scene), "--json", str(long), "--frames", "1", *SIZE]
    refused(capsys, args, f"file name is {len(long.name)} bytes long", "limit of this file system is 255")


def test_longest_allowed_name_is_written(tmp_path, capsys):
    """255 bytes is accepted: the temporary file of the atomic write has a short name of its own."""
    out = tmp_path / ("x" * 251 + ".png")
    code, _, err = run_cli(capsys, ["render", str(write_scene(tmp_path)), "-o", str(out)])
    assert code == 0 and err == "" and out.is_file()


# ---------------------------------------------------------------- never over an input or another output

def test_output_may_not_overwrite_inputs(tmp_path, capsys):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    scene = write_scene(tmp_path, small_red_sphere(shape=dict(mesh="tri.obj")))
    for target in (scene, tmp_path / "tri.obj"):
        content = target.read_bytes()
        refused(capsys, ["render", str(scene), "-o", str(target), *SIZE], "refusing to overwrite an input",
                target.name)
        assert target.read_bytes() == content


@pytest.mark.parametrize("flag", ["--json", "--csv"])
def test_bench_output_over_the_scene_is_refused(tmp_path, capsys, flag):
    scene = write_scene(tmp_path)
    before = scene.read_bytes()
    refused(capsys, ["bench", str(scene), flag, str(scene), "--frames", "1", *SIZE],
            "refusing to overwrite an input", str(scene))
    assert scene.read_bytes() == before


def test_no_command_writes_over_a_mesh_or_texture(tmp_path, capsys):
    """bench --plot, compare -o, sweep -o and aa -o aimed at the scene's inputs: refused, inputs unchanged."""
    write(tmp_path / "tri.obj", obj_triangle((1, 2, 3)))
    texture = tmp_path / "albedo.png"
    texture.write_bytes((SCENES / "textures" / "checker_base.png").read_bytes())
    scene = write_scene(tmp_path, small_red_sphere(shape=dict(mesh="tri.obj"),
                                                   red=dict(base_color_texture="albedo.png")))
    json_scene = tmp_path / "inputs.json"      # aa -o inputs writes inputs.json: here the scene itself
    json_scene.write_text(scene.read_text())
    inputs = {p: p.read_bytes() for p in (scene, texture, tmp_path / "tri.obj", json_scene)}
    for args in (["bench", str(scene), "--plot", str(texture), "--frames", "1", *SIZE],
                 ["compare", str(scene), "-o", str(texture), "-m", "lambert"],
                 ["sweep", str(scene), "-o", str(texture), "-m", "lambert", "--roughness", "0.5"],
                 ["aa", str(json_scene), "-o", str(tmp_path / "inputs"), "--frames", "1"]):
        refused(capsys, args, "refusing to overwrite an input")
    assert {p: p.read_bytes() for p in inputs} == inputs


@pytest.mark.parametrize("flags", [("--json", "--csv"), ("--csv", "--plot"), ("--json", "--plot")])
def test_two_bench_outputs_on_one_path_are_refused(tmp_path, capsys, flags):
    scene = write_scene(tmp_path)
    out = tmp_path / "out.png"       # a name --plot also accepts
    before = set(os.listdir(tmp_path))
    refused(capsys, ["bench", str(scene), flags[0], str(out), flags[1], str(out), "--frames", "1", *SIZE],
            "the same file as", flags[0])
    assert set(os.listdir(tmp_path)) == before


# ---------------------------------------------------------------- the write itself

def test_interrupted_write_leaves_nothing(tmp_path, monkeypatch):
    import OpenImageIO as oiio

    real_create = oiio.ImageOutput.create

    class Exploding:
        def __init__(self, inner):
            self.inner = inner

        def open(self, *a):
            return self.inner.open(*a)

        def write_image(self, pixels):
            self.inner.write_scanline(0, 0, pixels[0])    # part of the file is on disk …
            raise KeyboardInterrupt                        # … when the write is interrupted

        def close(self):
            return self.inner.close()

        def geterror(self):
            return ""

    monkeypatch.setattr(oiio.ImageOutput, "create", lambda path: Exploding(real_create(path)))
    for name in ("out.png", "out.exr"):
        with pytest.raises(KeyboardInterrupt):
            write_image(tmp_path / name, np.ones((4, 5, 4), np.float32))
        assert os.listdir(tmp_path) == []


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
