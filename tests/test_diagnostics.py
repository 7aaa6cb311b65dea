"""What reaches stderr (clshade/diagnostics.py): the messages of C libraries (libpng through OpenImageIO,
nanobind's leak report at exit) and Python warnings are captured, so a failure prints one line and a
success prints nothing; --debug shows what was captured."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from clshade import cli
from clshade.errors import ClshadeError

from conftest import SCENES, run_cli, run_cli_process, write_scene
from hostile_files import png_header, write
from scene_toml import small_red_sphere

SIZE = ["--width", "24", "--height", "16"]


def _texture_scene(folder: Path, texture: str) -> Path:
    return write_scene(folder, small_red_sphere(red=dict(base_color_texture=texture)))


@pytest.mark.parametrize("content", [b"", b"\x89PNG\r\n\x1a\n" + b"\0" * 40, b"GIF89a garbage", "passwd",
                                     "truncated", "zero"])
def test_texture_failures_print_one_line(tmp_path, content):
    """libpng's own messages and nanobind's leak report at exit: neither reaches stderr."""
    good = (SCENES / "textures" / "checker_base.png").read_bytes()
    data = {"passwd": Path("/etc/passwd").read_bytes() if Path("/etc/passwd").is_file() else b"root:x:0:0\n",
            "truncated": good[:300], "zero": png_header(0, 0)}.get(content, content)
    write(tmp_path / "t.png", data)
    proc = run_cli_process(["render", str(_texture_scene(tmp_path, "t.png")), "-o", "o.png", *SIZE], tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and "base_color_texture" in proc.stderr, proc.stderr
    assert "cannot read texture" in proc.stderr and "nanobind" not in proc.stderr


def test_texture_library_messages_are_kept_for_debug(tmp_path, capsys):
    write(tmp_path / "t.png", (SCENES / "textures" / "checker_base.png").read_bytes()[:300])
    scene = _texture_scene(tmp_path, "t.png")
    with pytest.raises(ClshadeError):
        cli.main(["--debug", "render", str(scene), "-o", str(tmp_path / "o.png")])
    err = capsys.readouterr().err
    assert "clshade: debug: OpenImageIO reading t.png: libpng error" in err, err


def test_numpy_warnings_do_not_reach_stderr(tmp_path, capsys, monkeypatch):
    """A RuntimeWarning during a successful render: stderr stays empty; --debug shows it."""
    from clshade import pipeline
    real = pipeline.build_geometry

    def warning_geometry(scene):
        np.float64(1.0) / np.float64(0.0)      # RuntimeWarning: divide by zero
        return real(scene)
    monkeypatch.setattr(pipeline, "build_geometry", warning_geometry)
    scene = write_scene(tmp_path)
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(tmp_path / "o.png")])
    assert code == 0 and err == "", err
    code, _, err = run_cli(capsys, ["--debug", "render", str(scene), "-o", str(tmp_path / "o.png")])
    assert code == 0 and "clshade: debug: RuntimeWarning" in err and "divide by zero" in err, err
