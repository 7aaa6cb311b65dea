"""Build-log locations mapped back through the #line markers (clshade/device/buildlog.py): a compiler
that ignores them (NVIDIA: `<kernel>:N:C:`, N counted in the whole program) reads as one that honours
them (PoCL: `surface.h:154:13:`), whose logs pass unchanged."""
from __future__ import annotations

from clshade.device import variants
from clshade.device.buildlog import relocate, source_lines
from clshade.models.registry import Registry

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
