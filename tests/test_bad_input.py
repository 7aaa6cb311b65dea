"""Bad input through the real CLI: one-line error naming file, key and value,
exit status 2, no traceback (unless --debug), and no output or temp file left."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from clshade import cli
from clshade.errors import ClshadeError

SIZE = ["--width", "24", "--height", "16"]   # tiny renders keep the suite fast

SCENE = """
[camera]
position = [0.0, 1.0, 4.0]
target = [0.0, 0.0, 0.0]
width = 24
height = 16

[render]
background = [0.1, 0.2, 0.3]

[[lights]]
type = "directional"
direction = [0.0, -1.0, -1.0]

[materials.red]
base_color = [0.8, 0.1, 0.1]
roughness = 0.4

[[objects]]
primitive = "sphere"
subdivisions = 1
material = "red"
"""


def write(tmp: Path, text: str, name: str = "scene.toml") -> Path:
    path = tmp / name
    path.write_text(text)
    return path


def run_cli(capsys, args: list[str]) -> tuple[int, str, str]:
    code = cli.main(args)
    out, err = capsys.readouterr()
    return code, out, err


def assert_clean_error(code: int, err: str, *needles: str) -> None:
    assert code == 2
    assert err.startswith("clshade: error: ")
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    for needle in needles:
        assert needle in err, (needle, err)


def assert_no_output(folder: Path, before: set[str]) -> None:
    assert set(os.listdir(folder)) == before, set(os.listdir(folder)) ^ before


def render_error(tmp: Path, capsys, scene_text: str, *needles: str, extra: list[str] | None = None) -> str:
    """Render a bad scene; the error must name the scene file (unless the bad value is an option)."""
    scene = write(tmp, scene_text)
    before = set(os.listdir(tmp))
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(tmp / "out.png"), *(extra or [])])
    assert_clean_error(code, err, *needles, *([] if extra else [str(scene.name)]))
    assert_no_output(tmp, before)
    return err


def test_malformed_toml_names_line_and_column(tmp_path, capsys):
    err = render_error(tmp_path, capsys, SCENE + "\nbroken = [1,\n")
    assert "malformed TOML" in err and "line" in err and "column" in err


def test_unknown_key_suggests_nearest(tmp_path, capsys):
    err = render_error(tmp_path, capsys, SCENE.replace("roughness = 0.4", "rougness = 0.4"), "rougness")
    assert "did you mean 'roughness'" in err


@pytest.mark.parametrize("old, new, key, value", [
    ("roughness = 0.4", 'roughness = "rough"', "materials.red.roughness", "'rough'"),
    ("width = 24", "width = 24.5", "camera.width", "24.5"),
    ("subdivisions = 1", "subdivisions = true", "objects[0].subdivisions", "True"),
])
def test_wrong_types(tmp_path, capsys, old, new, key, value):
    err = render_error(tmp_path, capsys, SCENE.replace(old, new), key, value)
    assert "must be" in err


@pytest.mark.parametrize("old, new, key, value", [
    ("roughness = 0.4", "roughness = 2", "materials.red.roughness", "2"),
    ("base_color = [0.8, 0.1, 0.1]", "base_color = [0.8, -0.1, 0.1]", "materials.red.base_color", "-0.1"),
    ("width = 24", "width = 0", "camera.width", "0"),
])
def test_out_of_range(tmp_path, capsys, old, new, key, value):
    err = render_error(tmp_path, capsys, SCENE.replace(old, new), key, value)
    assert "within" in err


def test_zero_width_option(tmp_path, capsys):
    render_error(tmp_path, capsys, SCENE, "--width = 0", extra=["--width", "0"])


def _mesh_scene(mesh: str) -> str:
    return SCENE.replace('primitive = "sphere"\nsubdivisions = 1', f'mesh = "{mesh}"')


def test_missing_mesh(tmp_path, capsys):
    render_error(tmp_path, capsys, _mesh_scene("nowhere.obj"), "objects[0].mesh", "nowhere.obj", "not found")


def test_unreadable_mesh(tmp_path, capsys):
    (tmp_path / "garbage.ply").write_bytes(b"\x00\xff not a ply file \x01" * 10)
    render_error(tmp_path, capsys, _mesh_scene("garbage.ply"), "objects[0].mesh", "garbage.ply")


def test_unsupported_mesh_format(tmp_path, capsys):
    (tmp_path / "thing.xyz").write_text("0 0 0\n")
    render_error(tmp_path, capsys, _mesh_scene("thing.xyz"), "objects[0].mesh", "unsupported mesh format .xyz")


def test_empty_mesh(tmp_path, capsys):
    (tmp_path / "empty.obj").write_text("")
    render_error(tmp_path, capsys, _mesh_scene("empty.obj"), "objects[0].mesh", "empty.obj")


def test_no_opencl_platform(tmp_path, capsys, monkeypatch):
    import pyopencl as cl
    scene = write(tmp_path, SCENE)
    before = set(os.listdir(tmp_path))
    for fake in (lambda: [], lambda: (_ for _ in ()).throw(cl.LogicError("clGetPlatformIDs", -1001, "no ICD"))):
        monkeypatch.setattr(cl, "get_platforms", fake)
        # A device spec nobody else uses, so the cached runtime is not reused.
        code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(tmp_path / "o.png"),
                                        "--device", "no-such-device-for-test"])
        assert_clean_error(code, err, "pocl")
        assert "install" in err
    assert_no_output(tmp_path, before)


def test_kernel_build_failure_is_one_line_and_the_log_under_debug(tmp_path, capsys, monkeypatch):
    import shutil

    from clshade.device import variants
    from clshade.resources import kernels_dir
    broken = tmp_path / "kernels"
    shutil.copytree(kernels_dir(), broken)
    text = (broken / "surface.h").read_text()
    (broken / "surface.h").write_text(text.replace("return g;", "return g  /* missing ; */ oops", 1))
    monkeypatch.setattr(variants, "kernels_dir", lambda: broken)
    scene = write(tmp_path, SCENE)
    before = set(os.listdir(tmp_path))
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(tmp_path / "o.png"), *SIZE])
    assert code == 2 and err.startswith("clshade: error: kernel build failed") and "Traceback" not in err
    assert err.count("\n") == 1, err            # issue 29, item 13: one line, the log's first error in it
    assert "surface.h:" in err and "error" in err.lower() and "clshade --debug" in err   # located by #line
    assert_no_output(tmp_path, before)
    with pytest.raises(ClshadeError):            # --debug: the whole log after the traceback's error
        cli.main(["--debug", "render", str(scene), "-o", str(tmp_path / "o.png"), *SIZE])
    debug = capsys.readouterr().err
    assert "clshade: debug: detail of the error:" in debug and debug.count("\n") > 2


def test_kernel_build_failure_names_the_file_where_the_compiler_ignores_line_markers(tmp_path, capsys, monkeypatch,
                                                                                     nvidia_compiler):
    """NVIDIA's compiler ignores #line and names `<kernel>:1050:13` (a line of the assembled program);
    the one-line error names surface.h and its line instead (clshade/device/buildlog.py)."""
    import shutil

    from clshade.device import variants
    from clshade.resources import kernels_dir
    broken = tmp_path / "kernels"
    shutil.copytree(kernels_dir(), broken)
    lines = (broken / "surface.h").read_text().split("\n")
    row = next(i for i, text in enumerate(lines) if "return g;" in text)
    lines[row] = lines[row].replace("return g;", "return g oops;")
    (broken / "surface.h").write_text("\n".join(lines))
    monkeypatch.setattr(variants, "kernels_dir", lambda: broken)
    nvidia_compiler("oops;", "expected ';' after return statement")
    code, _, err = run_cli(capsys, ["render", str(write(tmp_path, SCENE)), "-o", str(tmp_path / "o.png"), *SIZE])
    assert code == 2 and err.startswith("clshade: error: kernel build failed") and err.count("\n") == 1, err
    where = f"surface.h:{row + 1}:{lines[row].index('oops;') + 1}: error: expected ';' after return statement"
    assert where in err and "<kernel>" not in err, err


@pytest.mark.parametrize("output, needle", [
    ("missing_folder/out.png", "does not exist"),
    ("scene.toml/out.png", "does not exist"),     # parent is a file
    ("out.bmp", "unsupported output format .bmp"),
    ("out", "unsupported output format (none)"),
])
def test_bad_output_path(tmp_path, capsys, output, needle):
    scene = write(tmp_path, SCENE)
    before = set(os.listdir(tmp_path))
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(tmp_path / output), *SIZE])
    assert_clean_error(code, err, needle, output.split("/")[-1])
    assert_no_output(tmp_path, before)


def test_output_may_not_overwrite_inputs(tmp_path, capsys):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    scene = write(tmp_path, _mesh_scene("tri.obj"))
    for target in (scene, tmp_path / "tri.obj"):
        content = target.read_bytes()
        code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(target), *SIZE])
        assert_clean_error(code, err, "refusing to overwrite an input", target.name)
        assert target.read_bytes() == content


def test_debug_shows_traceback(tmp_path):
    scene = write(tmp_path, SCENE.replace("roughness = 0.4", "roughness = 2"))
    with pytest.raises(ClshadeError, match="roughness"):
        cli.main(["--debug", "render", str(scene), "-o", str(tmp_path / "o.png")])


def test_subprocess_exit_status_and_one_line(tmp_path):
    scene = write(tmp_path, SCENE.replace("roughness = 0.4", "roughnes = 0.4"))
    proc = subprocess.run([sys.executable, "-m", "clshade", "render", str(scene), "-o", str(tmp_path / "o.png")],
                          capture_output=True, text=True, cwd=tmp_path, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("clshade: error: ")
    assert "Traceback" not in proc.stderr and "did you mean 'roughness'" in proc.stderr
    assert not (tmp_path / "o.png").exists()


def test_empty_scene_renders_background(tmp_path, capsys):
    from clshade.render.image import read_image
    text = SCENE[:SCENE.index("[[objects]]")]
    scene = write(tmp_path, text)
    out = tmp_path / "empty.exr"
    code, stdout, err = run_cli(capsys, ["render", str(scene), "-o", str(out)])
    assert code == 0, err
    image = read_image(out)
    assert image.shape == (16, 24, 4)
    np.testing.assert_allclose(image[..., :3], np.broadcast_to([0.1, 0.2, 0.3], (16, 24, 3)), rtol=1e-6)


def test_nonfinite_mesh_renders_finite(tmp_path, capsys):
    """A NaN vertex and a NaN vertex normal in a mesh file: the render completes, is finite
    (the rasterizer drops the NaN face) and the CLI warns about the NaN-normal pixels."""
    from clshade.render.image import read_image
    (tmp_path / "nan.obj").write_text(
        "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nv 2 1 0\nv 1 1 0\nv 0 0 nan\n"
        "vn 0 0 1\nvn 0 0 1\nvn 0 0 1\nvn nan nan nan\nvn 0 0 1\n"
        "f 1//1 2//2 3//3\nf 2//2 4//4 5//5\nf 1//1 2//2 6//1\n")
    scene = write(tmp_path, _mesh_scene("nan.obj"))
    out = tmp_path / "nan.exr"
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(out)])
    assert code == 0, err
    image = read_image(out)
    assert np.isfinite(image).all() and image[..., 3].any()
    assert "pixels had non-finite G-buffer inputs" in err, err


def test_nonfinite_gbuffer_inputs_are_counted_and_contained(tmp_path, capsys, monkeypatch):
    """NaN reaching the G-buffer (here: a NaN normal injected after build_geometry) is
    counted, its pixels shade as background, no other pixel changes, and the CLI warns."""
    from clshade import pipeline
    from clshade.render.image import read_image
    scene = write(tmp_path, SCENE)
    clean = tmp_path / "clean.exr"
    assert run_cli(capsys, ["render", str(scene), "-o", str(clean)])[0] == 0
    real = pipeline.build_geometry

    def poisoned(sc):
        g = real(sc)
        g.normals[::2] = np.nan
        return g
    monkeypatch.setattr(pipeline, "build_geometry", poisoned)
    out = tmp_path / "poisoned.exr"
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(out)])
    assert code == 0, err
    a, b = read_image(clean), read_image(out)
    assert np.isfinite(b).all()
    changed = np.any(a != b, axis=-1)
    count = int(err.split("warning: ")[1].split()[0])
    assert 0 < count == int(changed.sum())
    np.testing.assert_allclose(b[changed][:, :3], np.broadcast_to([0.1, 0.2, 0.3], (count, 3)), rtol=1e-6)


def test_interrupted_write_leaves_nothing(tmp_path, monkeypatch):
    import OpenImageIO as oiio

    from clshade.render.image import write_image

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


def test_unknown_model_in_the_scene_names_file_and_key(tmp_path, capsys):
    scene = SCENE.replace('background = [0.1, 0.2, 0.3]', 'background = [0.1, 0.2, 0.3]\nmodel = "ggx_corelated"')
    render_error(tmp_path, capsys, scene, "render.model = 'ggx_corelated'", "unknown model")


def test_missing_scene_points_to_the_bundled_one(tmp_path, capsys, monkeypatch):
    """Outside the checkout `clshade render scenes/robot.toml` names where the installed scenes are."""
    from clshade.resources import scenes_dir
    monkeypatch.chdir(tmp_path)
    code, _, err = run_cli(capsys, ["render", "scenes/robot.toml"])
    assert_clean_error(code, err, "scenes/robot.toml: scene file not found", str(scenes_dir() / "robot.toml"))
    code, _, err = run_cli(capsys, ["render", "nowhere.toml"])
    assert_clean_error(code, err, "nowhere.toml: scene file not found")
    assert "bundled" not in err


@pytest.mark.parametrize("argv", [["render", "x.toml", "--tonemap", "filmic"], ["render", "x.toml", "--width", "abc"],
                                  ["check", "nonsense"], ["frobnicate"], ["render"]])
def test_usage_errors_are_one_line(capsys, argv):
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert len(err.strip().splitlines()) == 1 and ": error: " in err and "--help" in err, err
