"""Build-log locations mapped back through the #line markers (clshade/device/buildlog.py): a compiler
that ignores them (NVIDIA: `<kernel>:N:C:`, N counted in the whole program) reads as one that honours
them (PoCL: `surface.h:154:13:`), whose logs pass unchanged; a failed kernel build through the command
line is one line naming the header and its line, with the whole log under --debug."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from clshade import cli
from clshade.device import variants
from clshade.device.buildlog import relocate, source_lines
from clshade.errors import ClshadeError
from clshade.models.registry import Registry
from clshade.resources import kernels_dir

from conftest import run_cli, write_scene

resolve = Registry().resolve          # the built-in lobes

SOURCE = '#define A 1\n#line 1 "a.h"\nint a;\nint b;\n#line 1 "/u/lobe.cl"\nx\n#line 40 "/u/lobe.cl"\ny\n#line 7\nz'


def test_each_physical_line_is_its_file_and_line() -> None:
    assert source_lines(SOURCE) == [None, None, ("a.h", 1), ("a.h", 2), None, ("/u/lobe.cl", 1), None,
                                    ("/u/lobe.cl", 40), None, ("/u/lobe.cl", 7)]


def test_nvidia_locations_name_the_file_and_line() -> None:
    log = ("Build on <pyopencl.Device 'NVIDIA H100 80GB HBM3' on 'NVIDIA CUDA' at 0x1>:\n\n"
           "<kernel>:4:13: error: expected ';'\n<kernel>:8:2: note: here\n<kernel>:10:1: warning: w")
    assert relocate(log, SOURCE) == ("Build on <pyopencl.Device 'NVIDIA H100 80GB HBM3' on 'NVIDIA CUDA' at 0x1>:\n\n"
                                     "a.h:2:13: error: expected ';'\n/u/lobe.cl:40:2: note: here\n"
                                     "/u/lobe.cl:7:1: warning: w")


def test_locations_without_a_file_are_left_alone() -> None:
    """The defines before the first marker, a marker line, and a line past the end have no file."""
    log = "<kernel>:1:9: error: a\n<kernel>:5:1: error: b\n<kernel>:11:1: error: c"
    assert relocate(log, SOURCE) == log
    assert relocate("<kernel>:3:1: error: a", "int a;\nint b;\nint c;") == "<kernel>:3:1: error: a"


def test_a_log_of_a_compiler_that_honours_the_markers_is_unchanged() -> None:
    for log in ("error: /u/lobe.cl:6:3: use of undeclared identifier 'q'\n<kernel>:4:1: note: x",
                "a.h:3:13: error: expected ';'"):      # lines 6 and 3 of the program are marked lines too
        assert relocate(log, SOURCE) == log


def test_the_assembled_shading_program_maps_to_surface_h() -> None:
    """The real program: the physical line of surface.h's `return g;` reads as that line of surface.h."""
    model = resolve("lambert+ggx_correlated")
    source = variants.assemble(model, {"SIMD": "1"}, "shade.cl", ("gbuffer.h", "shadow.h"))
    physical = next(i for i, text in enumerate(source.split("\n"), 1) if "return g;" in text)
    from clshade.resources import kernels_dir
    line = next(i for i, text in enumerate((kernels_dir() / "surface.h").read_text().split("\n"), 1)
                if "return g;" in text)
    assert physical > line + 100          # the program holds simd.h, brdf.h and count.h before surface.h
    assert relocate(f"<kernel>:{physical}:5: error: e", source) == f"surface.h:{line}:5: error: e"


# ---------------------------------------------------------------- a failed build through the command line

def _broken_kernels(tmp_path: Path, monkeypatch, replace: str) -> tuple[Path, list[str]]:
    """A copy of kernels/ whose surface.h has `return g;` replaced by `replace` at its first place, used by
    every build from then on; returns the copy's folder and surface.h's lines."""
    broken = tmp_path / "kernels"
    shutil.copytree(kernels_dir(), broken)
    lines = (broken / "surface.h").read_text().split("\n")
    row = next(i for i, text in enumerate(lines) if "return g;" in text)
    lines[row] = lines[row].replace("return g;", replace)
    (broken / "surface.h").write_text("\n".join(lines))
    monkeypatch.setattr(variants, "kernels_dir", lambda: broken)
    return broken, lines


def test_kernel_build_failure_is_one_line_and_the_log_under_debug(tmp_path, capsys, monkeypatch):
    _broken_kernels(tmp_path, monkeypatch, "return g  /* missing ; */ oops")
    scene = write_scene(tmp_path)
    before = set(os.listdir(tmp_path))
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(tmp_path / "o.png")])
    assert code == 2 and err.startswith("clshade: error: kernel build failed") and "Traceback" not in err
    assert err.count("\n") == 1, err            # one line, the log's first error in it
    assert "surface.h:" in err and "error" in err.lower() and "clshade --debug" in err   # located by #line
    assert set(os.listdir(tmp_path)) == before
    with pytest.raises(ClshadeError):            # --debug: the whole log after the traceback's error
        cli.main(["--debug", "render", str(scene), "-o", str(tmp_path / "o.png")])
    debug = capsys.readouterr().err
    assert "clshade: debug: detail of the error:" in debug and debug.count("\n") > 2


def test_kernel_build_failure_names_the_file_where_the_compiler_ignores_line_markers(tmp_path, capsys, monkeypatch,
                                                                                     nvidia_compiler):
    """NVIDIA's compiler ignores #line and names `<kernel>:1050:13` (a line of the assembled program);
    the one-line error names surface.h and its line instead."""
    _, lines = _broken_kernels(tmp_path, monkeypatch, "return g oops;")
    row = next(i for i, text in enumerate(lines) if "return g oops;" in text)
    nvidia_compiler("oops;", "expected ';' after return statement")
    code, _, err = run_cli(capsys, ["render", str(write_scene(tmp_path)), "-o", str(tmp_path / "o.png")])
    assert code == 2 and err.startswith("clshade: error: kernel build failed") and err.count("\n") == 1, err
    where = f"surface.h:{row + 1}:{lines[row].index('oops;') + 1}: error: expected ';' after return statement"
    assert where in err and "<kernel>" not in err, err
