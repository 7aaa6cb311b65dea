"""Issue 29's hostile inputs, one test each (items 1–19): every error one line on stderr naming
the file, key and value, exit status 2; nothing written over an input; no size from input
allocated before the budget (clshade/budget.py) allowed it; stderr silent on success.

Modules under test: clshade.budget, clshade.outputs, clshade.diagnostics, clshade.render.scene,
clshade.render.meshes, clshade.render.textures, clshade.render.transforms, clshade.models, clshade.cli,
and the oracle check of clshade.bench.run, clshade.bench.aa and clshade.verify.stability.

Frames are tiny (24×16) and the CLI runs in-process, except where what is checked is the
process's own stderr (C libraries, interpreter exit) or an unbounded read (run in a child
process under a timeout)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from clshade import budget, cli
from clshade.errors import ClshadeError
from hostile_files import exr_header, gltf_triangle, obj_triangle, ply_triangle, png_header, write

SIZE = ["--width", "24", "--height", "16"]

SCENE = """
[camera]
position = [0.0, 0.0, 4.0]
width = 24
height = 16
fov = 40.0

[render]
background = [0.1, 0.2, 0.3]
ambient = [0.02, 0.02, 0.02]

[[lights]]
type = "directional"
direction = [-0.4, -0.5, -1.0]

[materials.red]
base_color = [0.8, 0.1, 0.1]
roughness = 0.4

[[objects]]
primitive = "sphere"
subdivisions = 2
material = "red"
"""


def scene_file(folder: Path, text: str = SCENE, name: str = "scene.toml") -> Path:
    return write(folder / name, text)


def mesh_scene(folder: Path, mesh: str) -> Path:
    return scene_file(folder, SCENE.replace('primitive = "sphere"\nsubdivisions = 2', f'mesh = "{mesh}"'))


def texture_scene(folder: Path, texture: str, key: str = "base_color_texture") -> Path:
    return scene_file(folder, SCENE.replace("roughness = 0.4", f'roughness = 0.4\n{key} = "{texture}"'))


def run_cli(capsys, args: list[str]) -> tuple[int, str, str]:
    code = cli.main(args)
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code: int, err: str, *needles: str) -> None:
    assert code == 2, (code, err)
    assert err.startswith("clshade: error: ") and err.endswith("\n"), err
    assert err.count("\n") == 1, err
    for needle in needles:
        assert needle in err, (needle, err)


def refused(capsys, args: list[str], *needles: str) -> str:
    code, _, err = run_cli(capsys, args)
    assert_one_line_error(code, err, *needles)
    return err


def child(args: list[str], cwd: Path, timeout: float = 60) -> subprocess.CompletedProcess:
    """`python -m clshade ARGS` in a child process (its whole stderr, interpreter exit included)."""
    return subprocess.run([sys.executable, "-m", "clshade", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=timeout)


def render_image(capsys, scene: Path, out: Path) -> np.ndarray:
    from clshade.render.image import read_image
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(out)])
    assert code == 0 and err == "", err
    return read_image(out)


# ---------------------------------------------------------------- data lost (1, 2)


@pytest.mark.parametrize("flag", ["--json", "--csv"])
def test_1_bench_output_over_the_scene_is_refused(tmp_path, capsys, flag):
    scene = scene_file(tmp_path)
    before = scene.read_bytes()
    refused(capsys, ["bench", str(scene), flag, str(scene), "--frames", "1", *SIZE],
            "refusing to overwrite an input", str(scene))
    assert scene.read_bytes() == before


def test_1_no_command_writes_over_a_mesh_or_texture(tmp_path, capsys):
    """bench --plot, compare -o, sweep -o and aa -o aimed at the scene's inputs: refused, inputs unchanged."""
    write(tmp_path / "tri.obj", obj_triangle((1, 2, 3)))
    from clshade.resources import scenes_dir
    texture = tmp_path / "albedo.png"
    texture.write_bytes((scenes_dir() / "textures" / "checker_base.png").read_bytes())
    scene = scene_file(tmp_path, SCENE.replace('primitive = "sphere"\nsubdivisions = 2', 'mesh = "tri.obj"')
                       .replace("roughness = 0.4", 'roughness = 0.4\nbase_color_texture = "albedo.png"'))
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
def test_2_two_bench_outputs_on_one_path_are_refused(tmp_path, capsys, flags):
    scene = scene_file(tmp_path)
    out = tmp_path / "out.png"       # a name --plot also accepts
    before = set(os.listdir(tmp_path))
    refused(capsys, ["bench", str(scene), flags[0], str(out), flags[1], str(out), "--frames", "1", *SIZE],
            "the same file as", flags[0])
    assert set(os.listdir(tmp_path)) == before


# ---------------------------------------------------------------- unbounded memory or time (3–7)


@pytest.mark.parametrize("path", ["/dev/zero", "/dev/urandom", "fifo", "folder"])
def test_3_special_scene_paths_are_refused_at_once(tmp_path, path):
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "fifo")
    proc = child(["render", path, "-o", "out.png"], tmp_path, timeout=30)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert "not a regular file" in proc.stderr and path in proc.stderr


@pytest.mark.parametrize("key", ["mesh", "base_color_texture"])
@pytest.mark.parametrize("path", ["/dev/zero", "fifo", "folder"])
def test_3_special_mesh_and_texture_paths_are_refused(tmp_path, capsys, key, path):
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "fifo")
    scene = mesh_scene(tmp_path, path) if key == "mesh" else texture_scene(tmp_path, path)
    args = ["render", str(scene), "-o", str(tmp_path / "o.png")]
    if path == "fifo":      # an accepted FIFO blocks its reader: in a child, so that the test fails instead of hanging
        proc = child(args, tmp_path, timeout=30)
        code, err = proc.returncode, proc.stderr
    else:
        code, _, err = run_cli(capsys, args)
    assert_one_line_error(code, err, "not a regular file", key, "scene.toml")


@pytest.mark.parametrize("name, content, size", [
    ("bomb.png", png_header(20000, 20000, padding=1_100_000), "20000x20000"),    # 1.1 MB, decodes to 1.2 GB
    ("normal.exr", exr_header(8192, 8192), "8192x8192"),
])
def test_4_texture_size_is_refused_from_its_header(tmp_path, capsys, monkeypatch, name, content, size):
    """The header's size is checked before any pixel is decoded (decoding is made to fail the test)."""
    import OpenImageIO as oiio
    monkeypatch.setattr(oiio.ImageInput, "read_image", lambda *a, **k: pytest.fail("pixels decoded"))
    write(tmp_path / name, content)
    key = "normal_texture" if name.endswith(".exr") else "base_color_texture"
    scene = texture_scene(tmp_path, name, key)
    refused(capsys, ["render", str(scene), "-o", str(tmp_path / "o.png")],
            f"materials.red.{key}", name, size, f"limit of {budget.MAX_TEXTURE_PIXELS} pixels")


def test_4_texture_within_the_ceiling_is_refused_when_memory_is_short(monkeypatch):
    monkeypatch.setattr(budget, "available_memory", lambda: 64 << 20)
    with pytest.raises(budget.ClshadeError, match=r"2048x2048 texture needs about .* GiB of memory, 0.06 GiB"):
        budget.texture_pixels(2048, 2048, 4)
    assert budget.texture_pixels(1024, 1024, 4) <= 64 << 20


def _lights(count: int, kind: str) -> str:
    light = ('[[lights]]\ntype = "directional"\ndirection = [0.0, -1.0, -1.0]\n' if kind == "directional" else
             '[[lights]]\ntype = "spot"\nposition = [0.0, 3.0, 3.0]\ndirection = [0.0, -1.0, -1.0]\n')
    return "\n".join([light] * count)


@pytest.mark.parametrize("kind", ["directional", "spot"])
def test_5_shadow_map_total_is_bounded(tmp_path, capsys, kind):
    text = SCENE.replace("[[lights]]\ntype = \"directional\"\ndirection = [-0.4, -0.5, -1.0]\n", _lights(64, kind))
    text = text.replace("ambient = [0.02, 0.02, 0.02]", "ambient = [0.02, 0.02, 0.02]\nshadows = true\n"
                        "shadow_map_size = 8192")
    refused(capsys, ["render", str(scene_file(tmp_path, text)), "-o", str(tmp_path / "o.png")],
            "render.shadow_map_size = 8192", "64 shadow maps", f"limit of {budget.MAX_SHADOW_TEXELS}")
    from clshade.render.scene import parse_scene      # the same lights at the default size fit
    assert len(parse_scene(text.replace("shadow_map_size = 8192", "shadow_map_size = 1024")).shadow_lights) == 64


def test_5_shadow_budget_boundary(monkeypatch):
    """Exactly the ceiling fits, one map more does not, whatever the memory (decided before allocation)."""
    monkeypatch.setattr(budget, "available_memory", lambda: 1 << 40)
    assert budget.shadow_texels(1, 8192) == 8192 * 8192 * budget.SHADOW_BYTES_PER_TEXEL
    assert budget.shadow_texels(64, 1024) == budget.shadow_texels(1, 8192)
    for count, size in ((2, 8192), (65, 1024), (1025, 256)):
        with pytest.raises(ClshadeError, match=f"{count} shadow maps of {size}x{size}"):
            budget.shadow_texels(count, size)
    monkeypatch.setattr(budget, "available_memory", lambda: 64 << 20)
    with pytest.raises(ClshadeError, match=r"32 shadow maps of 1024x1024 needs about 0.1\d GiB"):
        budget.shadow_texels(32, 1024)


def test_6_sweep_columns_are_bounded(tmp_path, capsys):
    values = ",".join(f"{i / 4999:.4f}" for i in range(5000))
    refused(capsys, ["sweep", str(scene_file(tmp_path)), "-o", str(tmp_path / "s.png"), "--roughness", values],
            "--roughness", "5000 values", f"limit of {budget.MAX_SWEEP_COLUMNS}")
    refused(capsys, ["sweep", str(scene_file(tmp_path)), "-o", str(tmp_path / "s.png"), "--roughness", "0.5",
                     "--size", "4096", "-m", "all"], "sheet", f"limit of {budget.MAX_SHEET_PIXELS}")
    assert not (tmp_path / "s.png").exists()


def test_7_bench_lights_are_bounded(tmp_path, capsys):
    scene = scene_file(tmp_path)
    refused(capsys, ["bench", str(scene), "--lights", "1000000000", *SIZE], "--lights = 1000000000",
            f"[0, {budget.MAX_LIGHTS}]")
    many = SCENE.replace("[[lights]]\ntype = \"directional\"\ndirection = [-0.4, -0.5, -1.0]\n",
                         _lights(budget.MAX_LIGHTS + 1, "directional"))
    refused(capsys, ["render", str(scene_file(tmp_path, many)), "-o", str(tmp_path / "o.png")],
            "scene.toml: lights", f"limit of {budget.MAX_LIGHTS}")


# ---------------------------------------------------------------- tracebacks (8–10)


@pytest.mark.parametrize("name, content, index", [
    ("big.ply", ply_triangle((0, 1, 500)), "500"),
    ("edge.ply", ply_triangle((0, 1, 3)), "3"),           # one past the last vertex
    ("negative.ply", ply_triangle((0, 1, -1)), "-1"),
    ("accessor.gltf", gltf_triangle((0, 1, 500)), "500"),
])
def test_8_out_of_range_face_indices(tmp_path, capsys, name, content, index):
    write(tmp_path / name, content)
    refused(capsys, ["render", str(mesh_scene(tmp_path, name)), "-o", str(tmp_path / "o.png")],
            "objects[0].mesh", name, f"face index {index} is out of range", "3 vertices")


def test_8_in_range_faces_still_render(tmp_path, capsys):
    for name, content in (("ok.ply", ply_triangle((0, 1, 2))), ("ok.gltf", gltf_triangle((0, 1, 2)))):
        write(tmp_path / name, content)
        image = render_image(capsys, mesh_scene(tmp_path, name), tmp_path / f"{name}.exr")
        assert image[..., 3].sum() > 0


@pytest.mark.parametrize("command", ["render", "bench"])
def test_9_output_name_longer_than_the_file_system_allows(tmp_path, capsys, command):
    scene = scene_file(tmp_path)
    long = tmp_path / ("x" * 300 + (".png" if command == "render" else ".json"))
    args = ["render", str(scene), "-o", str(long)] if command == "render" else \
        ["bench", str(scene), "--json", str(long), "--frames", "1", *SIZE]
    refused(capsys, args, f"file name is {len(long.name)} bytes long", "limit of this file system is 255")


def test_9_longest_allowed_name_is_written(tmp_path, capsys):
    """255 bytes is accepted: the temporary file of the atomic write has a short name of its own."""
    out = tmp_path / ("x" * 251 + ".png")
    code, _, err = run_cli(capsys, ["render", str(scene_file(tmp_path)), "-o", str(out)])
    assert code == 0 and err == "" and out.is_file()


@pytest.mark.parametrize("flag, value", [("--frames", "100000000000000000000"), ("--frames", "0"),
                                         ("--warmup", "100000000000000000000"), ("--warmup", "-1")])
def test_10_bench_frame_counts_are_bounded(tmp_path, capsys, flag, value):
    refused(capsys, ["bench", str(scene_file(tmp_path)), flag, value, *SIZE], f"{flag} = {value}",
            str(budget.MAX_FRAMES))


# ---------------------------------------------------------------- one line on stderr (11–13)


@pytest.mark.parametrize("content", [b"", b"\x89PNG\r\n\x1a\n" + b"\0" * 40, b"GIF89a garbage", "passwd",
                                     "truncated", "zero"])
def test_11_texture_failures_print_one_line(tmp_path, content):
    """libpng's own messages and nanobind's leak report at exit: neither reaches stderr."""
    from clshade.resources import scenes_dir
    good = (scenes_dir() / "textures" / "checker_base.png").read_bytes()
    data = {"passwd": Path("/etc/passwd").read_bytes() if Path("/etc/passwd").is_file() else b"root:x:0:0\n",
            "truncated": good[:300], "zero": png_header(0, 0)}.get(content, content)
    write(tmp_path / "t.png", data)
    proc = child(["render", str(texture_scene(tmp_path, "t.png")), "-o", "o.png", *SIZE], tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and "base_color_texture" in proc.stderr, proc.stderr
    assert "cannot read texture" in proc.stderr and "nanobind" not in proc.stderr


def test_11_texture_library_messages_are_kept_for_debug(tmp_path, capsys):
    from clshade.resources import scenes_dir
    write(tmp_path / "t.png", (scenes_dir() / "textures" / "checker_base.png").read_bytes()[:300])
    scene = texture_scene(tmp_path, "t.png")
    with pytest.raises(ClshadeError):
        cli.main(["--debug", "render", str(scene), "-o", str(tmp_path / "o.png")])
    err = capsys.readouterr().err
    assert "clshade: debug: OpenImageIO reading t.png: libpng error" in err, err


def test_12_numpy_warnings_do_not_reach_stderr(tmp_path, capsys, monkeypatch):
    """A RuntimeWarning during a successful render: stderr stays empty; --debug shows it."""
    from clshade import pipeline
    real = pipeline.build_geometry

    def warning_geometry(scene):
        np.float64(1.0) / np.float64(0.0)      # RuntimeWarning: divide by zero
        return real(scene)
    monkeypatch.setattr(pipeline, "build_geometry", warning_geometry)
    scene = scene_file(tmp_path)
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(tmp_path / "o.png")])
    assert code == 0 and err == "", err
    code, _, err = run_cli(capsys, ["--debug", "render", str(scene), "-o", str(tmp_path / "o.png")])
    assert code == 0 and "clshade: debug: RuntimeWarning" in err and "divide by zero" in err, err


def test_12_the_reported_target_is_refused_in_one_line(tmp_path, capsys):
    text = SCENE.replace("fov = 40.0", "fov = 40.0\ntarget = [0, 1e308, 0]")
    refused(capsys, ["render", str(scene_file(tmp_path, text)), "-o", str(tmp_path / "o.png")],
            "camera.target = [0, 1e+308, 0]", f"[-{budget.MAX_COORDINATE:g}, {budget.MAX_COORDINATE:g}]")


# Item 13 (a failed kernel build prints its whole log): test_bad_input.py
# test_kernel_build_failure_is_one_line_and_the_log_under_debug.


# ---------------------------------------------------------------- silently wrong (14–19)


@pytest.mark.parametrize("up", ["[0, 1e200, 0]", "[0, 1e-300, 0]", "[0, 5e-324, 0]", "[0, 1.7e308, 0]"])
def test_14_camera_up_of_any_finite_length(tmp_path, capsys, up):
    plain = render_image(capsys, scene_file(tmp_path), tmp_path / "plain.exr")
    text = SCENE.replace("fov = 40.0", f"fov = 40.0\nup = {up}")
    image = render_image(capsys, scene_file(tmp_path, text, "up.toml"), tmp_path / "up.exr")
    assert image[..., 3].sum() > 0
    np.testing.assert_array_equal(image, plain)


@pytest.mark.parametrize("key, value", [("position", "[1e308, 0, 4]"), ("position", "[0, 0, 1e300]"),
                                        ("target", "[0, 0, -1e200]")])
def test_15_camera_coordinates_that_overflow_are_refused(tmp_path, capsys, key, value):
    text = SCENE.replace("position = [0.0, 0.0, 4.0]", f"{key} = {value}" if key == "position"
                         else f"position = [0.0, 0.0, 4.0]\n{key} = {value}")
    refused(capsys, ["render", str(scene_file(tmp_path, text)), "-o", str(tmp_path / "o.png")],
            f"camera.{key}", "scene.toml", "components must be within")


@pytest.mark.parametrize("tiny, unit", [("[1e-320, 0, 0]", "[1, 0, 0]"), ("[1e308, 1e308, 1e308]", "[1, 1, 1]"),
                                        ("[-1e-310, -2e-310, 0]", "[-1, -2, 0]")])
def test_16_light_direction_of_any_finite_length(tmp_path, capsys, tiny, unit):
    def image(direction: str, name: str) -> np.ndarray:
        text = SCENE.replace("direction = [-0.4, -0.5, -1.0]", f"direction = {direction}")
        return render_image(capsys, scene_file(tmp_path, text, f"{name}.toml"), tmp_path / f"{name}.exr")
    np.testing.assert_allclose(image(tiny, "scaled"), image(unit, "unit"), rtol=1e-6, atol=0)


def test_16_light_direction_contributes(tmp_path, capsys):
    """The subnormal direction lights the sphere: brighter than the same scene unlit."""
    text = SCENE.replace("direction = [-0.4, -0.5, -1.0]", "direction = [-1e-320, 0, -1e-320]")
    lit = render_image(capsys, scene_file(tmp_path, text, "lit.toml"), tmp_path / "lit.exr")
    dark_text = text.replace("direction = [-1e-320, 0, -1e-320]", "direction = [-1, 0, -1]\nirradiance = 0.0")
    dark = render_image(capsys, scene_file(tmp_path, dark_text, "dark.toml"), tmp_path / "dark.exr")
    covered = lit[..., 3] > 0
    assert covered.any() and lit[covered, :3].sum() > 2 * dark[covered, :3].sum()


@pytest.mark.parametrize("model, fault", [
    ("+", "empty lobe name"), ("lambert+", "empty lobe name"), ("+lambert", "empty lobe name"),
    ("lambert++phong", "empty lobe name"), ("lambert@conductor", "lambert has no Fresnel term"),
    ("oren_nayar@dielectric", "oren_nayar has no Fresnel term")])
def test_17_malformed_model_specs_are_refused(tmp_path, capsys, model, fault):
    """Refused with the spec and what is wrong with it, from the command line and from the scene."""
    scene = scene_file(tmp_path)
    refused(capsys, ["render", str(scene), "-m", model, "-o", str(tmp_path / "o.png")], repr(model), fault)
    text = SCENE.replace("ambient = [0.02, 0.02, 0.02]", f'ambient = [0.02, 0.02, 0.02]\nmodel = "{model}"')
    refused(capsys, ["render", str(scene_file(tmp_path, text)), "-o", str(tmp_path / "o.png")],
            f"render.model = {model!r}", "scene.toml", fault)
    assert not (tmp_path / "o.png").exists()


@pytest.mark.parametrize("args, needle", [
    (["--width", "0"], "--width = 0"), (["--height", "-3"], "--height = -3"),
    (["--numpy-frames", "-1"], "--numpy-frames = -1"), (["--peers", "bogus"], "--peers = 'bogus'"),
    (["--peers", ","], "--peers = ','"), (["--lights", "-1"], "--lights = -1"),
])
def test_18_bench_options_are_checked(tmp_path, capsys, args, needle):
    refused(capsys, ["bench", str(scene_file(tmp_path)), "--frames", "1", *args], needle)


@pytest.mark.parametrize("model", ["", " ", ","])
def test_18_stability_with_an_empty_model_is_refused(capsys, model):
    refused(capsys, ["check", "stability", "--model", model], "no model given")


@pytest.mark.parametrize("face", [(0, 1, 2), (1, 0, 2), (1, 2, 0), ("1/0", "2/1", "3/1"), ("1//0", "2//1", "3//1")])
def test_19_obj_face_index_zero_is_refused(tmp_path, capsys, face):
    text = "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf {} {} {}\n".format(*face)
    write(tmp_path / "zero.obj", text)
    refused(capsys, ["render", str(mesh_scene(tmp_path, "zero.obj")), "-o", str(tmp_path / "o.png")],
            "objects[0].mesh", "zero.obj", "line 6: face index 0")


def test_19_obj_indices_that_contain_zero_digits_are_accepted(tmp_path, capsys):
    text = "".join(f"v {i % 7} {i // 7} 0\n" for i in range(12)) + "f 10 11 12\nf -1 -2 -3\n"
    write(tmp_path / "ten.obj", text)
    image = render_image(capsys, mesh_scene(tmp_path, "ten.obj"), tmp_path / "ten.exr")
    assert np.isfinite(image).all()


def test_readme_states_the_budget_as_it_is(checkout):
    """README's Resource limits section names each ceiling with the value budget.py holds."""
    text = (checkout / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## Resource limits"):text.index("## What it measures")]
    for name, shown in (("MAX_SCENE_FILE_BYTES", f"{budget.MAX_SCENE_FILE_BYTES >> 20} MiB"),
                        ("MAX_TEXTURE_PIXELS", "4096 × 4096"), ("MAX_SHADOW_TEXELS", "8192²"),
                        ("MAX_LIGHTS", str(budget.MAX_LIGHTS)), ("MAX_FRAMES", f"{budget.MAX_FRAMES:,}".replace(",", " ")),
                        ("MAX_SWEEP_COLUMNS", str(budget.MAX_SWEEP_COLUMNS)), ("MAX_SHEET_PIXELS", "8192²"),
                        ("MAX_COORDINATE", f"±{budget.MAX_COORDINATE:.0e}".replace("e+", "e"))):
        assert re.search(rf"{re.escape(shown)}[^|\n]*`{name}`", section), (name, shown)
    assert budget.MAX_TEXTURE_PIXELS == 4096 * 4096 and budget.MAX_SHADOW_TEXELS == 8192 ** 2
    assert budget.MAX_SHEET_PIXELS == 8192 ** 2


def test_4_gltf_images_are_checked_before_decoding():
    """glTF textures arrive as PIL images, opened lazily: their size is checked before conversion."""
    import io

    from PIL import Image

    from clshade.render.textures import texture_from_image
    image = Image.open(io.BytesIO(png_header(8192, 8192, padding=1 << 16)))    # header read, nothing decoded
    with pytest.raises(ClshadeError, match=r"robot\.baseColorTexture: 8192x8192 texture exceeds the limit"):
        texture_from_image(image, True, "robot.baseColorTexture")
    small = Image.new("RGB", (4, 2), (255, 0, 0))
    assert texture_from_image(small, True, "small").size == (4, 2)


@pytest.mark.parametrize("command", [["bench", "--frames", "1", *SIZE], ["aa", "--frames", "1"],
                                     ["check", "stability"]])
def test_models_without_an_oracle_are_refused_before_the_run(tmp_path, capsys, command):
    """Found by the hostile-long profile: `bench -m phong/metallic` ended in a ValueError from the
    float64 oracle (empirical lobes have no metallic-workflow formula). Refused in one line before the
    run by every command that measures error against the oracle; `render` still shades it."""
    scene = scene_file(tmp_path)
    if command[0] == "check":
        args = [*command, "--model", "phong/metallic"]
    else:
        args = [command[0], str(scene), "-m", "phong/metallic", *command[1:]]
        args += ["-o", str(tmp_path / "aa")] if command[0] == "aa" else []
    refused(capsys, args, "'lambert+phong/metallic'", "float64 oracle has no formula", "needs workflow='kdks'")
    code, _, err = run_cli(capsys, ["render", str(scene), "-m", "phong/metallic", "-o", str(tmp_path / "p.png")])
    assert code == 0 and err == ""
