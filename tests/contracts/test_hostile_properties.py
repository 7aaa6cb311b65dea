"""The hostile-input promise as properties (Hypothesis): for generated scene values, mesh files,
texture files and command-line flags, `clshade` either

  - exits 0, writes a finite image and prints nothing on stderr but clshade's own warnings, or
  - exits 2 with exactly one line on stderr (`clshade: error: ...`),

within a bounded time and memory, and never changes the scene or the files it reads.

The CLI runs in-process on 32×32 frames (a few ms per example once the kernels are built);
file descriptors 1 and 2 are captured as well as sys.stdout/sys.stderr, so what C libraries
print counts. Profiles (CLSHADE_HYPOTHESIS_PROFILE): `hostile-ci` (default, a few hundred
examples in all) and `hostile-long` (ten times as many, for a benchmark-style run:
`CLSHADE_HYPOTHESIS_PROFILE=hostile-long python -m pytest tests/contracts/test_hostile_properties.py`).
The examples each test ran are counted in EXAMPLES and printed at the end of the module.
"""
from __future__ import annotations

import contextlib
import hashlib
import io
import os
import re
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from clshade import cli
from hostile_files import exr_header, gltf_triangle, png_header
from scene_toml import red_sphere, value as value_text

settings.register_profile("hostile-ci", max_examples=60, deadline=None, derandomize=True, database=None,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
settings.register_profile("hostile-long", max_examples=600, deadline=None, derandomize=False, database=None,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
PROFILE = os.environ.get("CLSHADE_HYPOTHESIS_PROFILE", "hostile-ci")
if PROFILE not in ("hostile-ci", "hostile-long"):
    raise pytest.UsageError(f"CLSHADE_HYPOTHESIS_PROFILE={PROFILE!r}: use hostile-ci or hostile-long")
BASE = settings.get_profile(PROFILE)


def scaled(fraction: float) -> settings:
    """The profile with `fraction` of its examples (the tests differ in cost per example)."""
    return settings(BASE, max_examples=max(1, round(BASE.max_examples * fraction)))


#: Wall time of one example: the slowest accepted input here (a 1024² shadow map, 8×8 samples
#: of a 32×32 frame, a 4096² texture) takes a few seconds on 2 shared cores.
SECONDS_PER_EXAMPLE = 60.0
#: Peak resident memory of the test process: the budget's ceilings keep every accepted input
#: far below it (README: Resource limits), an unbounded allocation goes past it.
MAX_RSS_BYTES = 3 << 30
EXAMPLES: Counter = Counter()
#: 32×32 frames, shaded by the general kernel (one build per model for every feature set, where
#: the specialised kernels would build a variant for each generated combination of features).
FRAME = ["--width", "32", "--height", "32", "--general"]

SCENE = red_sphere()


# ---------------------------------------------------------------- running the CLI


@contextlib.contextmanager
def _captured_fd(fd: int):
    """Point file descriptor `fd` at a temporary file; yields a function returning its text."""
    saved = os.dup(fd)
    tmp = tempfile.TemporaryFile()
    os.dup2(tmp.fileno(), fd)
    text: list[str] = []
    try:
        yield lambda: "".join(text)
    finally:
        os.dup2(saved, fd)
        os.close(saved)
        tmp.seek(0)
        text.append(tmp.read().decode("utf-8", "replace"))
        tmp.close()


def run_clshade(args: list[str]) -> tuple[int, str, float]:
    """(exit status, everything written to stderr, seconds) of `clshade ARGS` run in-process."""
    out, err = io.StringIO(), io.StringIO()
    start = time.perf_counter()
    sys.stdout.flush()
    sys.stderr.flush()
    with _captured_fd(1), _captured_fd(2) as fd_err:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = cli.main(args)
            except SystemExit as exc:           # argparse: usage errors
                code = exc.code if isinstance(exc.code, int) else 2
    return code, err.getvalue() + fd_err(), time.perf_counter() - start


def reset_peak_memory() -> None:
    """Reset the process's peak resident set (Linux: 5 > /proc/self/clear_refs), so that the
    peak read after an example is that example's, not an earlier test's."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def peak_memory() -> int | None:
    """Peak resident bytes since the last reset (VmHWM); None where /proc is not there."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def digest(paths: list[Path]) -> dict[Path, str | None]:
    return {p: hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else None for p in paths}


def check_promise(args: list[str], inputs: list[Path], image: Path | None, kind: str) -> int:
    """Run clshade and check the promise; returns the exit status."""
    before = digest(inputs)
    reset_peak_memory()
    code, err, seconds = run_clshade(args)
    EXAMPLES[kind, code] += 1
    assert code in (0, 2), (code, args, err)
    if code == 0:      # nothing but clshade's own warnings (a scene without lights, NaN normals)
        assert all(line.startswith("clshade: warning: ") for line in err.splitlines()), (args, err)
        if image is not None:
            from clshade.render.image import read_image
            pixels = read_image(image)
            assert np.isfinite(pixels).all(), args
            image.unlink()
    else:      # `clshade: error: ...`, or a usage error `clshade render: error: ...` (argparse)
        assert re.match(r"clshade( [a-z]+)*: error: ", err) and err.count("\n") == 1 and err.endswith("\n"), \
            (args, err)
    assert seconds < SECONDS_PER_EXAMPLE, (seconds, args)
    peak = peak_memory()
    assert peak is None or peak < MAX_RSS_BYTES, (peak, args)
    assert digest(inputs) == before, args
    leftovers = [p for p in os.listdir(inputs[0].parent) if p.startswith(".clshade-")]
    assert not leftovers, leftovers
    return code


@pytest.fixture(scope="module")
def folder():
    with tempfile.TemporaryDirectory(prefix="clshade-hostile-") as name:
        yield Path(name)


@pytest.fixture(scope="module", autouse=True)
def report_examples():
    yield
    total = sum(EXAMPLES.values())
    lines = [f"{kind}: exit {code} × {n}" for (kind, code), n in sorted(EXAMPLES.items())]
    print(f"\nhostile-input properties ({PROFILE}): {total} examples; " + "; ".join(lines))


# ---------------------------------------------------------------- generated values

FLOATS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 5e-324, -5e-324, 1e-320, 1e-300, 1e-12, 1e12, 1e200, 1e308, 1.7976931348623157e308,
                     -1e308, 0.5, 1.0, 2.0, -1.0, 179.0, 180.0, 64.0, 65.0]),
    st.floats(-10.0, 10.0),
)
INTEGERS = st.one_of(st.integers(-(2 ** 70), 2 ** 70),
                     st.sampled_from([0, -1, 1, 2, 3, 7, 8, 9, 63, 64, 65, 255, 256, 257, 4096, 8192, 8193, 16384,
                                      16385, 2 ** 31, 2 ** 63, 10 ** 20]))
SCALARS = st.one_of(FLOATS, INTEGERS, st.booleans(), st.text(max_size=12))
VECTORS = st.one_of(st.lists(FLOATS, min_size=3, max_size=3), st.lists(SCALARS, max_size=5))
VALUES = st.one_of(SCALARS, VECTORS, st.just({}), st.just([]))

#: Keys of SCENE (table, key) that a mutation rewrites: every value kind the format has.
KEYS = [("camera", k) for k in ("position", "target", "up", "fov", "width", "height", "near", "far")] + \
       [("render", k) for k in ("background", "ambient", "exposure", "model", "tonemap", "samples", "shadows",
                                "shadow_map_size", "shadow_pcf", "specular_aa")] + \
       [("lights", k) for k in ("type", "direction", "irradiance", "position", "intensity", "outer_angle",
                                "inner_angle", "shadows")] + \
       [("materials.red", k) for k in ("base_color", "roughness", "metallic", "shininess", "ior", "eta", "k",
                                       "emissive", "ks", "kd", "f90", "uv_scale", "normal_scale")] + \
       [("objects", k) for k in ("translate", "rotate", "scale", "subdivisions", "radius", "primitive", "smooth",
                                 "crease_angle")]


def set_key(text: str, table: str, key: str, value) -> str:
    """SCENE with `key` of the first `table` set to `value` (inserted when absent)."""
    header = f"[[{table}]]" if table in ("lights", "objects") else f"[{table}]"
    start = text.index(header) + len(header)
    end = text.find("\n[", start)
    end = len(text) if end < 0 else end
    lines = text[start:end].split("\n")
    line = f"{key} = {value_text(value)}"
    for i, old in enumerate(lines):
        if old.split("=")[0].strip() == key:
            lines[i] = line
            break
    else:
        lines.insert(1, line)
    return text[:start] + "\n".join(lines) + text[end:]


# ---------------------------------------------------------------- the properties


@scaled(2.0)
@given(table_key=st.sampled_from(KEYS), value=VALUES)
def test_scene_values(folder, table_key, value):
    table, key = table_key
    scene = folder / "scene.toml"
    scene.write_text(set_key(SCENE, table, key, value))
    image = folder / "out.exr"
    check_promise(["render", str(scene), "-o", str(image), *FRAME], [scene], image, "scene value")


INDEX = st.one_of(st.integers(-6, 8), st.sampled_from([2 ** 31 - 1, -(2 ** 31), 500, 65535]))
COORD = st.one_of(st.floats(-2.0, 2.0), st.sampled_from(["nan", "inf", "-inf", "1e308", "1e-320", "0"]))


@st.composite
def mesh_files(draw) -> tuple[str, str | bytes]:
    """(suffix, content) of an OBJ, PLY or glTF with generated vertices and face indices, or garbage."""
    kind = draw(st.sampled_from(["obj", "ply", "gltf", "garbage"]))
    # "plain": well-formed (the accepted path is checked too); "edge": one face corner just past
    # either end of the vertex list; "wild": any coordinates and indices.
    defect = draw(st.sampled_from(["plain", "edge", "wild"]))
    plain = defect != "wild"
    vertices = draw(st.lists(st.tuples(*(st.floats(-2.0, 2.0) if plain else COORD,) * 3), min_size=3 if plain else 0,
                             max_size=5))
    index = st.integers(1 if kind == "obj" else 0, len(vertices) - (kind != "obj")) if plain else INDEX
    faces = draw(st.lists(st.tuples(index, index, index), min_size=1 if plain else 0, max_size=4))
    if defect == "edge":
        edge = draw(st.sampled_from([0, len(vertices) + 1] if kind == "obj" else [-1, len(vertices)]))
        faces[-1] = (faces[-1][0], faces[-1][1], edge)
    if kind == "obj":
        extra = draw(st.sampled_from(["", "vt 0 0\n", "vn 0 0 1\n", "f\n", "f 1\n", "f 1/2/3 x y\n", "o\n", "g \x00\n"]))
        text = "".join(f"v {x} {y} {z}\n" for x, y, z in vertices) + extra + \
            "".join(f"f {a} {b} {c}\n" for a, b, c in faces)
        return ".obj", text
    if kind == "ply":
        header = (f"ply\nformat ascii 1.0\nelement vertex {len(vertices)}\nproperty float x\nproperty float y\n"
                  f"property float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
        return ".ply", header + "".join(f"{x} {y} {z}\n" for x, y, z in vertices) + \
            "".join(f"3 {a} {b} {c}\n" for a, b, c in faces)
    if kind == "gltf":
        a, b, c = draw(st.tuples(*(st.integers(0, 2) if defect == "plain" else st.integers(0, 65535),) * 3))
        if defect == "edge":
            c = 3
        return ".gltf", gltf_triangle((a, b, c))
    return draw(st.sampled_from([".obj", ".ply", ".stl", ".glb", ".off"])), draw(st.binary(max_size=200))


@scaled(1.0)
@given(mesh=mesh_files())
def test_mesh_files(folder, mesh):
    suffix, content = mesh
    path = folder / f"mesh{suffix}"
    path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    scene = folder / "scene.toml"
    scene.write_text(red_sphere(mesh=path.name))
    image = folder / "out.exr"
    check_promise(["render", str(scene), "-o", str(image), *FRAME], [scene, path], image, "mesh file")


@st.composite
def texture_files(draw) -> tuple[str, bytes]:
    """(suffix, content) of an image whose header promises a generated size, a real small image,
    a truncated one, or garbage."""
    from clshade.resources import scenes_dir
    kind = draw(st.sampled_from(["png header", "exr header", "small", "truncated", "garbage"]))
    side = st.one_of(st.integers(0, 70000), st.sampled_from([0, 1, 4096, 4097, 8192, 20000, 65535]))
    if kind == "png header":
        return ".png", png_header(draw(side), draw(side), padding=draw(st.sampled_from([0, 1 << 20])))
    if kind == "exr header":
        return ".exr", exr_header(max(draw(side), 1), max(draw(st.integers(1, 5000)), 1))
    if kind == "small":
        from PIL import Image
        w, h = draw(st.integers(1, 48)), draw(st.integers(1, 48))
        mode = draw(st.sampled_from(["L", "LA", "RGB", "RGBA", "I;16", "F"]))
        buf = io.BytesIO()
        Image.new(mode, (w, h)).save(buf, format="TIFF" if mode == "F" else "PNG")
        return (".tif" if mode == "F" else ".png"), buf.getvalue()
    good = (scenes_dir() / "textures" / "checker_base.png").read_bytes()
    if kind == "truncated":
        return ".png", good[:draw(st.integers(0, len(good) - 1))]
    return draw(st.sampled_from([".png", ".exr", ".jpg", ".tif", ".hdr"])), draw(st.binary(max_size=300))


@scaled(1.0)
@given(texture=texture_files(), key=st.sampled_from(["base_color_texture", "metallic_roughness_texture",
                                                     "normal_texture"]))
def test_texture_files(folder, texture, key):
    suffix, content = texture
    path = folder / f"texture{suffix}"
    path.write_bytes(content)
    scene = folder / "scene.toml"
    scene.write_text(red_sphere(**{key: path.name}))
    image = folder / "out.exr"
    check_promise(["render", str(scene), "-o", str(image), *FRAME], [scene, path], image, "texture file")


def sizes(valid_high: int):
    """Integers for a size flag, half of them valid and small (the point is hostile values, not
    big work), half not."""
    return st.one_of(st.integers(1, valid_high), st.one_of(st.integers(max_value=0), st.integers(min_value=16385),
                                                           st.sampled_from([0, -1, 16384 + 1, 10 ** 20])))


MODEL_PARTS = st.sampled_from(["lambert", "ggx_correlated", "phong", "oren_nayar", "burley", "none", "all", "",
                               "+", "@", "/", ",", "conductor", "dielectric", "schlick", "kdks", "metallic", " ",
                               "diffuse", "LAMBERT", "ggx-correlated"])
MODEL_SPECS = st.one_of(st.sampled_from(["lambert", "ggx_correlated", "oren_nayar+phong", "burley@schlick",
                                         "lambert+ggx_correlated@conductor", "phong/metallic"]),
                        st.lists(MODEL_PARTS, min_size=0, max_size=4).map("".join))
NUMBER_TEXT = st.one_of(st.integers().map(str), FLOATS.map(repr), st.text(max_size=6))


@st.composite
def render_flags(draw, folder: Path) -> list[str]:
    args: list[str] = []
    if draw(st.booleans()):
        args.append(f"--model={draw(MODEL_SPECS)}")
    for flag, values in (("--width", sizes(48)), ("--height", sizes(48)), ("--samples", sizes(4)),
                         ("--exposure", NUMBER_TEXT), ("--tonemap", st.sampled_from(["none", "aces", "x", ""])),
                         ("--fresnel", st.sampled_from(["schlick", "conductor", "bogus"])),
                         ("--workflow", st.sampled_from(["metallic", "kdks", "x"]))):
        if draw(st.integers(0, 5)) == 0:
            args.append(f"{flag}={draw(values)}")     # one word: a value may start with a minus sign
    args += draw(st.sampled_from([[], ["--half"], ["--fast-math"], ["--general"], ["--specular-aa"]]))
    return args


def output_paths(folder: Path, scene: Path):
    """Output paths: fresh, the scene itself, a folder, a device, too long a name, missing folder."""
    return st.one_of(st.sampled_from([folder / "out.exr", folder / "out.png"]),
                     st.sampled_from([scene, folder, Path("/dev/null"), folder / ("y" * 300 + ".png"),
                                      folder / "missing" / "o.png", folder / "out.bmp"]))


@scaled(1.0)
@given(data=st.data())
def test_render_flags(folder, data):
    scene = folder / "scene.toml"
    scene.write_text(SCENE)
    out = data.draw(output_paths(folder, scene))
    args = ["render", str(scene), "-o", str(out), *data.draw(render_flags(folder))]
    for flag in ("--width", "--height"):
        if not any(a.startswith(flag) for a in args):
            args += [flag, "32"]
    code = check_promise(args, [scene], out if out.suffix in (".exr", ".png") else None, "render flags")
    if code == 0:
        assert out.suffix in (".exr", ".png") and out.parent == folder


@scaled(0.5)
@given(data=st.data())
def test_bench_flags(folder, data):
    scene = folder / "scene.toml"
    scene.write_text(SCENE)
    plain = data.draw(st.booleans())     # half the runs with a valid model and width
    model = "lambert" if plain else data.draw(MODEL_SPECS)
    args = ["bench", str(scene), f"--models={model}", "--no-progress", "--height=24",
            f"--width={24 if plain else data.draw(sizes(24))}"]
    for flag, values in (("--frames", sizes(3)), ("--warmup", sizes(2)), ("--numpy-frames", sizes(2)),
                         ("--lights", sizes(3)), ("--samples", sizes(2)),
                         ("--peers", st.sampled_from(["bogus", "", ",", "numba,bogus"]))):
        if data.draw(st.integers(0, 4)) == 0:
            args.append(f"{flag}={data.draw(values)}")
    if not any(a.startswith("--frames") for a in args):
        args += ["--frames", "2", "--warmup", "0", "--numpy-frames", "1"]
    outputs = {}
    for flag in ("--json", "--csv", "--plot"):
        if data.draw(st.integers(0, 2)) == 0:
            outputs[flag] = data.draw(st.one_of(
                st.just(folder / {"--json": "b.json", "--csv": "b.csv", "--plot": "b.png"}[flag]),
                st.sampled_from([folder / "b.json", folder / "b.csv", folder / "b.png", scene, folder,
                                 folder / ("z" * 300 + ".json")])))
            args.append(f"{flag}={outputs[flag]}")
    code = check_promise(args, [scene], None, "bench flags")
    if code == 0:
        paths = [p.resolve() for p in outputs.values()]
        assert len(set(paths)) == len(paths) and scene.resolve() not in paths
        for p in outputs.values():
            assert p.is_file()
            p.unlink()
