"""Loaded meshes: every format without stderr noise, shading normals (file normals kept,
crease splitting otherwise, `smooth` / `crease_angle`), glTF metallic-roughness factors
without UVs, emission and occlusion, the primitives; a bad mesh file (missing, unreadable,
empty, a face index out of range) refused in one line, NaN in a mesh file rendered finite.
The mesh files are written at test time by scenes/make_meshes.py."""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from clshade.errors import ClshadeError
from clshade.pipeline import prepare_frame
from clshade.render.meshes import build_geometry
from clshade.render.scene import parse_scene

from conftest import (ORACLE_BOUND, ROOT, SCENES, cli_image, oracle_errors, refused, render_refused, run_cli,
                      write_scene)
from hostile_files import gltf_triangle, ply_triangle, write
from scene_toml import camera, light, material, obj, render, scene, small_red_sphere

_spec = importlib.util.spec_from_file_location("make_meshes", SCENES / "make_meshes.py")
make_meshes = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(make_meshes)


@pytest.fixture(scope="module")
def meshes(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("meshes")
    make_meshes.write_all(folder)
    return folder


def _scene(*objects: str, width: int = 64, height: int = 64, position: list | None = None) -> str:
    """The objects (scene_toml.obj tables) in a frame seen from above the front, lit from above, with a
    grey material `m`."""
    return scene(camera(position=position or [0.0, 1.5, 4.0], target=[0.0, 0.0, 0.0], width=width, height=height),
                 light("directional", direction=[0.0, -1.0, -1.0]),
                 material("m", base_color=[0.8, 0.8, 0.8]),
                 objects)


def _geometry(folder: Path, **keys):
    """The geometry of one object of these keys, of material `m`."""
    return build_geometry(parse_scene(_scene(obj(**keys, material="m")), folder / "scene.toml"))


def test_every_format_renders_with_empty_stderr(meshes, tmp_path):
    """OBJ (Latin-1 comment), STL, PLY and glTF in one scene: the CLI writes nothing to stderr,
    also without scipy (not a run-time dependency: the README install has none; the test
    extra brings it, so the child process blocks its import)."""
    scene = (SCENES / "mesh_formats.toml").read_text(encoding="utf-8").replace("meshes/", f"{meshes}/")
    path = tmp_path / "formats.toml"
    path.write_text(scene.replace("width = 640", "width = 96").replace("height = 400", "height = 64"),
                    encoding="utf-8")
    env = {**os.environ, "PYTHONWARNINGS": "default"}
    child = ("import sys; sys.modules['scipy'] = None; from clshade.cli import main; "
             f"sys.exit(main(['render', {str(path)!r}, '-o', {str(tmp_path / 'f.png')!r}]))")
    done = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, env=env, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    assert (tmp_path / "f.png").is_file()


def test_ply_cube_has_sharp_edges(meshes):
    """An 8-vertex cube (shared vertices, no normals) shades flat per face: every corner
    normal is an axis, not the diagonal an averaged normal would be."""
    g = _geometry(meshes, mesh=f"{meshes}/cube.ply")
    assert len(g.faces) == 12
    assert np.allclose(np.abs(g.normals).max(axis=1), 1.0, atol=1e-6)
    # each corner's normal is its own face's normal
    tri = g.vertices[g.faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    face_n /= np.linalg.norm(face_n, axis=1, keepdims=True)
    assert np.allclose(g.normals[g.faces], face_n[:, None, :], atol=1e-6)


def test_stl_soup_is_smooth_not_faceted(meshes):
    """A binary STL repeats every vertex per triangle (process=False keeps it that way):
    the side of the tube still gets radial (smooth) normals, the caps flat ones."""
    g = _geometry(meshes, mesh=f"{meshes}/tube.stl")
    v, n = g.vertices, g.normals.astype(float)
    side = np.abs(n[:, 1]) < 0.5
    radial = v[side] * [1, 0, 1]
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    assert side.sum() > 0
    assert np.allclose(n[side], radial, atol=1e-6)
    cap = ~side
    assert np.allclose(np.abs(n[cap, 1]), 1.0, atol=1e-6)


def test_smooth_and_crease_angle_keys(meshes):
    cube = f"{meshes}/cube.ply"
    smooth = _geometry(meshes, mesh=cube, smooth=True)
    # one normal per position: the corner diagonals
    assert np.allclose(np.abs(smooth.normals), 1 / np.sqrt(3), atol=1e-6)
    wide = _geometry(meshes, mesh=cube, crease_angle=100)
    assert np.allclose(np.abs(wide.normals), 1 / np.sqrt(3), atol=1e-6)
    flat_sphere = _geometry(meshes, primitive="sphere", subdivisions=1, smooth=False)
    tri = flat_sphere.vertices[flat_sphere.faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    face_n /= np.linalg.norm(face_n, axis=1, keepdims=True)
    assert np.allclose(flat_sphere.normals[flat_sphere.faces], face_n[:, None, :], atol=1e-5)
    with pytest.raises(ClshadeError, match="smooth or crease_angle"):
        _geometry(meshes, mesh=cube, smooth=True, crease_angle=10)
    with pytest.raises(ClshadeError, match="crease_angle"):
        _geometry(meshes, mesh=cube, crease_angle=200)


def test_file_normals_are_kept(tmp_path):
    """OBJ `vn` normals are used as they are (here deliberately tilted), unless the object sets a crease angle."""
    v, f = make_meshes.box_mesh()
    tilted = np.array([0.0, 0.6, 0.8])
    lines = [f"v {x} {y} {z}" for x, y, z in v] + [f"vn {tilted[0]} {tilted[1]} {tilted[2]}"]
    lines += [f"f {a + 1}//1 {b + 1}//1 {c + 1}//1" for a, b, c in f]
    (tmp_path / "box.obj").write_text("\n".join(lines) + "\n")
    kept = _geometry(tmp_path, mesh=f"{tmp_path}/box.obj")
    assert np.allclose(kept.normals, tilted, atol=1e-6)
    recomputed = _geometry(tmp_path, mesh=f"{tmp_path}/box.obj", crease_angle=30)
    assert np.allclose(np.abs(recomputed.normals).max(axis=1), 1.0, atol=1e-6)


def test_gltf_normals_are_kept(meshes):
    """glTF NORMAL is used: the uv-sphere's exact normals, not face-averaged ones."""
    g = _geometry(meshes, mesh=f"{meshes}/spheres.gltf")
    offset = g.vertices - np.c_[np.round(g.vertices[:, 0]), np.zeros((len(g.vertices), 2))]
    exact = offset / np.linalg.norm(offset, axis=1, keepdims=True)
    assert np.allclose(g.normals, exact, atol=1e-5)


def test_gltf_factors_without_uvs(meshes):
    """MetalRoughSpheres-like: five primitives, each its own baseColor/metallic/roughness
    factors and no UVs. Every sphere's G-buffer pixels carry its own factors (baseColor
    to trimesh's 1/255 quantisation); the scene material's values must not leak in."""
    spheres = obj(mesh=f"{meshes}/spheres.gltf", mesh_material=True,
                  material=dict(base_color=[0.5, 0.5, 0.5], roughness=0.55, metallic=0.45))
    text = _scene(spheres, width=200, height=60, position=[0.0, 0.0, 4.0])
    frame = prepare_frame(parse_scene(text, meshes / "scene.toml"))
    g, gb = frame.geometry, frame.gbuffer
    tri = frame.fragments.tri_id.reshape(-1)
    cov = tri >= 0
    names = [t.name for t in g.texture_sets]
    base = gb.channels["base"].reshape(-1, 3)
    for i, (factor, metal, rough, _) in enumerate(make_meshes.SPHERE_MATERIALS):
        index = next(k for k, n in enumerate(names) if n.endswith(f"sphere{i}"))
        pix = np.flatnonzero(cov)[g.face_texture[tri[cov]] == index]
        assert len(pix) > 50, f"sphere {i} not visible"
        assert np.allclose(base[pix], factor[:3], atol=0.5 / 255 + 1e-6), f"sphere {i} baseColorFactor"
        assert np.allclose(gb.channels["roughness"][pix], rough, atol=1e-6), f"sphere {i} roughnessFactor"
        assert np.allclose(gb.channels["metallic"][pix], metal, atol=1e-6), f"sphere {i} metallicFactor"


def test_gltf_factor_defaults(tmp_path):
    """glTF defaults when a material omits factors: baseColor 1, metallic 1, roughness 1."""
    path = make_meshes.write_gltf(tmp_path / "one.gltf", materials=(((1.0, 1.0, 1.0, 1.0), 1.0, 1.0, (0, 0, 0)),))
    doc = json.loads(path.read_text())
    doc["materials"][0]["pbrMetallicRoughness"] = {}
    path.write_text(json.dumps(doc))
    one = obj(mesh=str(path), mesh_material=True, material=dict(roughness=0.3))
    frame = prepare_frame(parse_scene(_scene(one), tmp_path / "scene.toml"))
    cov = frame.gbuffer.coverage.reshape(-1)
    assert cov.sum() > 50
    assert np.allclose(frame.gbuffer.channels["base"].reshape(-1, 3)[cov], 1.0)
    assert np.allclose(frame.gbuffer.channels["roughness"][cov], 1.0)
    assert np.allclose(frame.gbuffer.channels["metallic"][cov], 1.0)


# ---------------------------------------------------------------- emission and ambient occlusion

def _emissive_ball(emissive) -> str:
    """A grey sphere of this `emissive` radiance, no lights and no ambient."""
    return scene(camera(position=[0.0, 0.0, 3.0], width=48, height=48), render(ambient=0),
                 material("glow", base_color=[0.5, 0.5, 0.5], emissive=emissive),
                 obj(primitive="sphere", subdivisions=2, material="glow"))


def test_emission_is_a_variant_feature(runtime):
    """A material's `emissive` radiance is added unlit (no lights: the image is exactly it);
    a scene without emission compiles no emissive channel."""
    from clshade.models.registry import Registry
    from clshade.pipeline import render
    glow = parse_scene(_emissive_ball([0.5, 0.25, 0.125]))
    out = render(glow, Registry().resolve("ggx_correlated"), runtime=runtime)
    assert out.features.emissive and "emissive" in out.shader.variant(out.model, out.features).channels
    cov = out.image[..., 3] > 0
    assert cov.sum() > 100
    assert np.allclose(out.image[cov][:, :3], [0.5, 0.25, 0.125], rtol=1e-6)
    dark = render(parse_scene(_emissive_ball(0)), Registry().resolve("ggx_correlated"),
                  runtime=runtime)
    assert not dark.features.emissive
    variant = dark.shader.variant(dark.model, dark.features)
    assert "emissive" not in variant.channels and variant.defines()["HAS_EMISSIVE"] == "0"
    assert np.all(dark.image[..., :3] == 0)


def test_gltf_emissive_factor(meshes):
    """The glTF emissiveFactor reaches the emissive channel of its own primitive only."""
    spheres = obj(mesh=f"{meshes}/spheres.gltf", mesh_material=True, material="m")
    text = _scene(spheres, width=200, height=60, position=[0.0, 0.0, 4.0])
    frame = prepare_frame(parse_scene(text, meshes / "scene.toml"))
    g, gb = frame.geometry, frame.gbuffer
    assert g.has_emission
    tri = frame.fragments.tri_id.reshape(-1)
    cov = tri >= 0
    emissive = gb.channels["emissive"].reshape(-1, 3)
    names = [t.name for t in g.texture_sets]
    for i, (*_, factor) in enumerate(make_meshes.SPHERE_MATERIALS):
        index = next(k for k, n in enumerate(names) if n.endswith(f"sphere{i}"))
        pix = np.flatnonzero(cov)[g.face_texture[tri[cov]] == index]
        assert np.allclose(emissive[pix], factor), f"sphere {i} emissiveFactor"


def _occlusion_quad(path: Path, occlusion: tuple[int, int]) -> Path:
    """A 2×2 quad facing +Z with UVs and a 4×1 occlusion texture: two texels `occlusion[0]`, two `occlusion[1]`
    (between the centres of equal texels bilinear filtering returns the texel value exactly)."""
    import base64
    import io
    from PIL import Image
    png = io.BytesIO()
    Image.fromarray(np.array([[[occlusion[0]] * 3] * 2 + [[occlusion[1]] * 3] * 2], np.uint8)).save(png, "PNG")
    v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], "<f4")
    n = np.tile(np.array([0, 0, 1], "<f4"), (4, 1))
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], "<f4")
    f = np.array([0, 1, 2, 0, 2, 3], "<u4")
    blob = v.tobytes() + n.tobytes() + uv.tobytes() + f.tobytes()
    sizes = [v.nbytes, n.nbytes, uv.nbytes, f.nbytes]
    offsets = np.cumsum([0] + sizes[:-1]).tolist()
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3,
                                       "material": 0}]}],
           "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0,
                                                   "roughnessFactor": 1.0},
                          "occlusionTexture": {"index": 0}}],
           "textures": [{"source": 0, "sampler": 0}],
           "samplers": [{"magFilter": 9728, "minFilter": 9728}],
           "images": [{"uri": "data:image/png;base64," + base64.b64encode(png.getvalue()).decode()}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                          "min": [-1, -1, 0], "max": [1, 1, 0]},
                         {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
                         {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
                         {"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}],
           "bufferViews": [{"buffer": 0, "byteOffset": o, "byteLength": s} for o, s in zip(offsets, sizes)],
           "buffers": [{"byteLength": len(blob),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}]}
    path.write_text(json.dumps(doc))
    return path


def _quad_scene(quad: Path, ambient: float, lights: list[str]) -> str:
    """The occlusion quad filling a 64×32 frame, under this ambient and these lights."""
    return scene(camera(position=[0.0, 0.0, 2.0], fov=40.0, width=64, height=32), render(ambient=ambient),
                 material("m", roughness=1.0), obj(mesh=str(quad), mesh_material=True, material="m"), lights)


def test_occlusion_texture_scales_ambient_only(runtime, tmp_path):
    """glTF occlusionTexture multiplies the ambient term: with ambient light only, the left half
    (occlusion 0.25) is a quarter of the right half (1.0); without ambient no channel exists."""
    from clshade.models.registry import Registry
    from clshade.pipeline import render
    quad = _occlusion_quad(tmp_path / "quad.gltf", (64, 255))
    out = render(parse_scene(_quad_scene(quad, 1.0, []), tmp_path / "s.toml"), Registry().resolve("lambert"),
                 runtime=runtime)
    assert out.features.occlusion
    rgb = out.image[..., :3]
    left, right = rgb[12:20, 17:25], rgb[12:20, 39:47]   # u in (0.125, 0.375) and (0.625, 0.875)
    assert right.min() > 0
    assert np.allclose(left, right * (64 / 255), rtol=1e-3)      # linear: no sRGB decode
    lit = parse_scene(_quad_scene(quad, 0, [light("directional", direction=[0, 0, -1])]), tmp_path / "s.toml")
    out = render(lit, Registry().resolve("lambert"), runtime=runtime)
    assert not out.features.occlusion
    rgb = out.image[..., :3]
    assert rgb[12:20, 17:25].min() > 0
    assert np.allclose(rgb[12:20, 17:25], rgb[12:20, 39:47], rtol=1e-4)


@pytest.mark.parametrize("model", ["ggx_correlated", "phong"])
def test_emission_and_occlusion_match_the_oracle(tmp_path, model):
    """Kernel vs the float64 frame oracle (reference.radiance) on a scene with lights, ambient,
    an occlusion-textured glTF quad and an emissive sphere: both terms are in both."""
    quad = _occlusion_quad(tmp_path / "quad.gltf", (64, 255))
    path = tmp_path / "glow.toml"
    path.write_text(scene(camera(position=[0.0, 0.0, 3.0], fov=50.0), render(ambient=[0.6, 0.5, 0.4]),
                          light("point", position=[1.0, 1.5, 2.0], intensity=4.0),
                          material("m", roughness=0.6),
                          obj(mesh=str(quad), mesh_material=True, material="m"),
                          obj(primitive="sphere", radius=0.3, translate=[0.4, 0.0, 0.5],
                              material=dict(base_color=[0.2, 0.3, 0.4], emissive=[0.7, 0.2, 0.1]))))
    res = oracle_errors(path, model)
    assert res["pixels"] > 0.5 * res["covered"], res
    assert res["max"] <= ORACLE_BOUND, res


@pytest.mark.parametrize("kind, args, volume, lo, hi", [
    ("icosphere", (3, 2.0), 4 / 3 * np.pi * 8, [-2, -2, -2], [2, 2, 2]),
    ("box", ((1.0, 2.0, 3.0),), 6.0, [-0.5, -1, -1.5], [0.5, 1, 1.5]),
    ("cylinder", (0.5, 2.0, 64), np.pi * 0.25 * 2, [-0.5, -0.5, -1], [0.5, 0.5, 1]),
    ("cone", (0.5, 3.0, 64), np.pi * 0.25 * 3 / 3, [-0.5, -0.5, 0], [0.5, 0.5, 3]),
    ("capsule", (0.5, 1.0, 64), np.pi * 0.25 + 4 / 3 * np.pi * 0.125, [-0.5, -0.5, -1], [0.5, 0.5, 1]),
    ("torus", (1.0, 0.25, 96, 48), 2 * np.pi ** 2 * 0.0625, [-1.25, -1.25, -0.25], [1.25, 1.25, 0.25]),
])
def test_primitives_are_closed_and_outward(kind, args, volume, lo, hi):
    """Signed volume (divergence theorem) ≈ the solid's: every face outward, none missing;
    every edge shared by exactly two faces (watertight); bounds as the scene format says."""
    from clshade.render import primitives
    v, f = getattr(primitives, kind)(*args)
    tri = v[f]
    signed = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6
    assert signed == pytest.approx(volume, rel=0.02)
    edges = np.sort(f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)
    assert np.allclose(v.min(0), lo, atol=1e-9) and np.allclose(v.max(0), hi, atol=1e-9)


def test_gbuffer_normals_unit_and_nonfinite_pixels_uncovered(meshes):
    """Interpolated normals are written normalised; pixels whose normal is NaN are counted,
    zeroed and leave the coverage (the CLI's covered-pixel count)."""
    from clshade.render.gbuffer import build_gbuffer
    from clshade.render.raster import rasterize
    scene = parse_scene(_scene(obj(primitive="sphere", subdivisions=1, material="m", smooth=True)),
                        meshes / "scene.toml")
    g = build_geometry(scene)
    cam = scene.camera
    frags = rasterize(g.vertices, g.faces, cam.view_matrix(), cam.projection_matrix(), cam.width, cam.height,
                      cull_backfaces=g.cull)
    gb = build_gbuffer(scene, g, frags, cam)
    cov = gb.coverage.reshape(-1)
    n = gb.channels["normal"].reshape(-1, 3)[cov]
    assert cov.sum() > 100 and np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-6)
    g.normals[g.faces[0]] = np.nan                          # poison the corners of face 0
    bad = build_gbuffer(scene, g, frags, cam)
    hit = (frags.tri_id.reshape(-1) >= 0) & np.isin(frags.tri_id.reshape(-1), np.flatnonzero(
        np.isin(g.faces, g.faces[0]).any(axis=1)))
    assert 0 < bad.nonfinite_pixels <= hit.sum()
    assert bad.coverage.sum() == gb.coverage.sum() - bad.nonfinite_pixels
    assert np.isfinite(bad.channels["normal"]).all()


def test_water_bottle_brings_emission_and_occlusion(assets, tmp_path):
    """Khronos' WaterBottle (emissive and occlusion-roughness-metallic textures): with its glTF
    materials the G-buffer gets emissive and occlusion channels from the textures."""
    path = tmp_path / "bottle.toml"
    path.write_text(scene(camera(position=[0.0, 0.05, 0.45], width=64, height=80), render(ambient=0.4),
                          light("directional", direction=[-0.5, -0.3, -1.0]),
                          material("m", roughness=0.5),
                          obj(mesh=str(assets / "gltf" / "WaterBottle" / "WaterBottle.gltf"), mesh_material=True,
                              material="m")))
    from clshade.device.shade import scene_features
    frame = prepare_frame(parse_scene(path.read_text(), path))
    features = scene_features(frame.scene, geometry=frame.geometry)
    assert features.emissive and features.occlusion and features.textures
    cov = frame.gbuffer.coverage.reshape(-1)
    occlusion = frame.gbuffer.channels["occlusion"][cov]
    emissive = frame.gbuffer.channels["emissive"].reshape(-1, 3)[cov]
    assert cov.sum() > 500
    assert occlusion.min() < 0.9 and occlusion.max() <= 1.0       # the texture, not the constant 1
    assert 0 < (emissive.max(axis=1) > 0).sum() < cov.sum()         # the emissive label, not the whole bottle


# ---------------------------------------------------------------- bad mesh files, refused in one line

def _mesh_scene(mesh: str) -> str:
    return small_red_sphere(shape=dict(mesh=mesh))


def test_missing_mesh(tmp_path, capsys):
    render_refused(tmp_path, capsys, _mesh_scene("nowhere.obj"), "objects[0].mesh", "nowhere.obj", "not found")


def test_unreadable_mesh(tmp_path, capsys):
    (tmp_path / "garbage.ply").write_bytes(b"\x00\xff not a ply file \x01" * 10)
    render_refused(tmp_path, capsys, _mesh_scene("garbage.ply"), "objects[0].mesh", "garbage.ply")


def test_unsupported_mesh_format(tmp_path, capsys):
    (tmp_path / "thing.xyz").write_text("0 0 0\n")
    render_refused(tmp_path, capsys, _mesh_scene("thing.xyz"), "objects[0].mesh", "unsupported mesh format .xyz")


def test_empty_mesh(tmp_path, capsys):
    (tmp_path / "empty.obj").write_text("")
    render_refused(tmp_path, capsys, _mesh_scene("empty.obj"), "objects[0].mesh", "empty.obj")


@pytest.mark.parametrize("name, content, index", [
    ("big.ply", ply_triangle((0, 1, 500)), "500"),
    ("edge.ply", ply_triangle((0, 1, 3)), "3"),           # one past the last vertex
    ("negative.ply", ply_triangle((0, 1, -1)), "-1"),
    ("accessor.gltf", gltf_triangle((0, 1, 500)), "500"),
])
def test_out_of_range_face_indices(tmp_path, capsys, name, content, index):
    write(tmp_path / name, content)
    refused(capsys, ["render", str(write_scene(tmp_path, _mesh_scene(name))), "-o", str(tmp_path / "o.png")],
            "objects[0].mesh", name, f"face index {index} is out of range", "3 vertices")


def test_in_range_faces_still_render(tmp_path, capsys):
    for name, content in (("ok.ply", ply_triangle((0, 1, 2))), ("ok.gltf", gltf_triangle((0, 1, 2)))):
        write(tmp_path / name, content)
        image = cli_image(capsys, write_scene(tmp_path, _mesh_scene(name)), tmp_path / f"{name}.exr")
        assert image[..., 3].sum() > 0


@pytest.mark.parametrize("face", [(0, 1, 2), (1, 0, 2), (1, 2, 0), ("1/0", "2/1", "3/1"), ("1//0", "2//1", "3//1")])
def test_obj_face_index_zero_is_refused(tmp_path, capsys, face):
    text = "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf {} {} {}\n".format(*face)
    write(tmp_path / "zero.obj", text)
    refused(capsys, ["render", str(write_scene(tmp_path, _mesh_scene("zero.obj"))), "-o", str(tmp_path / "o.png")],
            "objects[0].mesh", "zero.obj", "line 6: face index 0")


def test_obj_indices_that_contain_zero_digits_are_accepted(tmp_path, capsys):
    text = "".join(f"v {i % 7} {i // 7} 0\n" for i in range(12)) + "f 10 11 12\nf -1 -2 -3\n"
    write(tmp_path / "ten.obj", text)
    image = cli_image(capsys, write_scene(tmp_path, _mesh_scene("ten.obj")), tmp_path / "ten.exr")
    assert np.isfinite(image).all()


def test_nonfinite_mesh_renders_finite(tmp_path, capsys):
    """A NaN vertex and a NaN vertex normal in a mesh file: the render completes, is finite
    (the rasterizer drops the NaN face) and the CLI warns about the NaN-normal pixels."""
    from clshade.render.image import read_image
    (tmp_path / "nan.obj").write_text(
        "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nv 2 1 0\nv 1 1 0\nv 0 0 nan\n"
        "vn 0 0 1\nvn 0 0 1\nvn 0 0 1\nvn nan nan nan\nvn 0 0 1\n"
        "f 1//1 2//2 3//3\nf 2//2 4//4 5//5\nf 1//1 2//2 6//1\n")
    scene = write_scene(tmp_path, _mesh_scene("nan.obj"))
    out = tmp_path / "nan.exr"
    code, _, err = run_cli(capsys, ["render", str(scene), "-o", str(out)])
    assert code == 0, err
    image = read_image(out)
    assert np.isfinite(image).all() and image[..., 3].any()
    assert "pixels had non-finite G-buffer inputs" in err, err


@pytest.mark.parametrize("bad", ["nan", "inf", "1e39"])
def test_nonfinite_texture_coordinates_are_refused(tmp_path, capsys, bad):
    """A textured mesh whose texture coordinate is NaN, infinite, or infinite once stored as float32:
    one line naming the scene, the object's mesh key and file, and the first bad vertex (sampling it
    would index no texel). The same coordinates on an untextured material render."""
    (tmp_path / "uv.obj").write_text(f"v -1 -1 0\nv 1 -1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt {bad} 1\nvn 0 0 1\n"
                                     "f 1/1/1 2/2/1 3/3/1\n")
    texture = str(SCENES / "textures" / "checker_base.png")
    text = scene(camera(position=[0.0, 0.0, 3.0], target=[0.0, 0.0, 0.0], width=32, height=32), render(),
                 light("directional", direction=[0.0, 0.0, -1.0]),
                 material("tex", base_color=[1.0, 1.0, 1.0], base_color_texture=texture),
                 obj(mesh="uv.obj", material="tex"))
    render_refused(tmp_path, capsys, text, "objects[0].mesh", "uv.obj", "texture coordinate", "not finite")
    plain = text.replace(f'base_color_texture = "{texture}"\n', "")
    assert plain != text
    image = cli_image(capsys, write_scene(tmp_path, plain), tmp_path / "plain.exr")
    assert np.isfinite(image).all() and image[..., 3].any()
