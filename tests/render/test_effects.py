"""The scene-driven effects: textures (sampling, mipmaps, sRGB, normal maps, glTF
materials), shadow maps (directional and spot, bias, PCF) and their scene keys; a texture
or a set of shadow maps over the budget (clshade/budget.py) refused before it is allocated."""
from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from clshade import budget
from clshade.errors import ClshadeError
from clshade.models.registry import Registry
from clshade.render.meshes import build_geometry
from clshade.pipeline import prepare_frame, render
from clshade.render.raster import rasterize
from clshade.render.scene import parse_scene
from clshade.render.transforms import orthographic
from clshade.render.textures import Texture, srgb_decode

from conftest import ASSETS, SCENES, refused, write_scene
from hostile_files import exr_header, png_header, write
from scene_toml import camera, light, material, obj, scene, small_red_sphere, table

BUILT_IN = Registry()          # the built-in lobes

GGX = BUILT_IN.resolve("ggx_correlated")
LAMBERT = BUILT_IN.resolve("lambert")


def _facing_plane(w: int, h: int, **surface) -> str:
    """A plane facing the camera (+Z), lit head-on; UVs run u → +X, v → +Y over it. `surface` adds material
    keys to the white, rough material `m`."""
    return scene(camera(position=[0.0, 0.0, 3.0], fov=40.0, width=w, height=h),
                 light("directional", direction=[0.0, 0.0, -1.0], irradiance=3.0),
                 material("m", base_color=[1.0, 1.0, 1.0], roughness=1.0, **surface),
                 obj(primitive="plane", size=2.0, rotate=[90.0, 0.0, 0.0], material="m"))


def _write_texture(path: Path, pixels: np.ndarray) -> Path:
    """Write float pixels as a float EXR (exact values) or 8-bit PNG, via OpenImageIO."""
    import OpenImageIO as oiio
    pixels = np.ascontiguousarray(pixels)
    fmt = oiio.FLOAT if pixels.dtype == np.float32 else oiio.UINT8
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], fmt))
    assert out.write_image(pixels)
    out.close()
    return path


# ---------------------------------------------------------------- texture sampling


def test_srgb_decode_and_8bit_base_colour(tmp_path):
    assert srgb_decode(np.array([0.0, 1.0]))[1] == pytest.approx(1.0)
    assert srgb_decode(np.array([188 / 255]))[0] == pytest.approx(0.5029, abs=1e-3)
    tex = _write_texture(tmp_path / "grey.png", np.full((4, 4, 3), 188, np.uint8))
    scene = parse_scene(_facing_plane(8, 8, base_color_texture=str(tex)), tmp_path / "s.toml")
    base = prepare_frame(scene).gbuffer.channels["base"].reshape(-1, 3)
    np.testing.assert_allclose(base, srgb_decode(np.array(188 / 255)), rtol=1e-5)   # decoded, not raw 0.737


def test_mip_level_from_footprint_and_trilinear_average():
    tex = Texture.from_pixels(np.indices((64, 64)).sum(0)[..., None] % 2 * 1.0)   # 1-texel checker
    assert len(tex.levels) == 7 and tex.levels[-1].shape == (1, 1, 1)
    one, four = np.array([[1 / 64, 0.0]]), np.array([[4 / 64, 0.0]])
    assert tex.lod(one, one * 0)[0] == pytest.approx(0.0) and tex.lod(four, four * 0)[0] == pytest.approx(2.0)
    uv = np.random.default_rng(1).random((100, 2))
    np.testing.assert_allclose(tex.sample(uv, np.full(100, 1.0)), 0.5, atol=1e-6)   # level 1 is uniform grey
    assert np.ptp(tex.sample(uv, np.zeros(100))) > 0.5                               # level 0 is not


def test_minified_checker_is_filtered_not_aliased(tmp_path):
    """A 128-cell checker squeezed into 32 pixels: mipmapping gives the mean (18 % grey
    in linear sRGB terms) instead of aliasing noise."""
    pixels = (np.indices((256, 256)).sum(0) // 2 % 2 * 255).astype(np.uint8)[..., None].repeat(3, 2)
    tex = _write_texture(tmp_path / "checker.png", pixels)
    scene = parse_scene(_facing_plane(32, 32, base_color_texture=str(tex)), tmp_path / "s.toml")
    frame = prepare_frame(scene)
    base = frame.gbuffer.channels["base"].reshape(32, 32, 3)[frame.gbuffer.coverage]
    assert base.std() < 0.02 and base.mean() == pytest.approx(0.5, abs=0.03)


def test_neutral_textures_equal_untextured(tmp_path):
    """White base colour, metallic-roughness (1, 1, 1) and a flat normal map (float EXR,
    exact (0.5, 0.5, 1)) render exactly like the untextured material."""
    white = _write_texture(tmp_path / "white.exr", np.ones((8, 8, 3), np.float32))
    flat = _write_texture(tmp_path / "flat.exr", np.tile(np.float32([0.5, 0.5, 1.0]), (8, 8, 1)))
    keys = dict(base_color_texture=str(white), metallic_roughness_texture=str(white), normal_texture=str(flat))
    plain = parse_scene(_facing_plane(24, 16, metallic=1.0), tmp_path / "a.toml")
    textured = parse_scene(_facing_plane(24, 16, metallic=1.0, **keys), tmp_path / "b.toml")
    a, b = render(plain, GGX), render(textured, GGX)
    assert not a.features.textures and b.features.textures
    np.testing.assert_allclose(b.image, a.image, rtol=1e-5, atol=1e-7)


def test_normal_map_green_is_plus_v(tmp_path):
    """glTF convention: a map texel leaning to +Y (green > 0.5) tilts the normal
    towards +V, here world +Y; red > 0.5 towards +U = world +X."""
    lean = _write_texture(tmp_path / "lean.exr", np.tile(np.float32([0.5 + 0.3, 0.5 + 0.2, 0.9]), (4, 4, 1)))
    scene = parse_scene(_facing_plane(8, 8, normal_texture=str(lean)), tmp_path / "s.toml")
    n = prepare_frame(scene).gbuffer.channels["normal"].reshape(-1, 3)
    expected = np.array([0.6, 0.4, 0.8]) / np.linalg.norm([0.6, 0.4, 0.8])
    np.testing.assert_allclose(n, np.broadcast_to(expected, n.shape), atol=1e-5)


def test_texture_errors_name_file_key_value(tmp_path):
    with pytest.raises(ClshadeError, match=r"s\.toml: materials\.m\.normal_texture = 'missing\.png': texture file not found"):
        parse_scene(_facing_plane(8, 8, normal_texture="missing.png"), tmp_path / "s.toml")
    (tmp_path / "bad.png").write_bytes(b"not a png")
    scene = parse_scene(_facing_plane(8, 8, base_color_texture="bad.png"), tmp_path / "s.toml")
    with pytest.raises(ClshadeError, match=r"materials\.m\.base_color_texture = '.*bad\.png': cannot read texture"):
        build_geometry(scene)


def test_textured_scene_renders(tmp_path):
    result = render(SCENES / "textured.toml", GGX, width=160, height=100)
    assert result.features.textures and result.features.shadows
    assert result.frame.geometry.uvs is not None and np.isfinite(result.image).all()
    untextured = build_geometry(parse_scene((SCENES / "shadows.toml").read_text(), SCENES / "shadows.toml"))
    assert untextured.uvs is None and untextured.face_texture is None      # no texture data without textures


# ---------------------------------------------------------------- glTF samples

GLTF = ASSETS / "gltf"


def _gltf_scene(path: Path, position: list[float], target: list[float], w: int, h: int,
                mesh_material: bool = True) -> str:
    """The glTF file `path` with its own materials (or the scene's `gltf` with mesh_material=False), seen
    from `position`."""
    return scene(camera(position=position, target=target, fov=40.0, near=0.01, width=w, height=h),
                 table("render", background=[0.2, 0.22, 0.25], ambient=[0.25, 0.25, 0.28]),
                 light("directional", direction=[-0.6, -0.5, -0.7], irradiance=3.0),
                 material("gltf", roughness=1.0),
                 obj(mesh=str(path), mesh_material=mesh_material, material="gltf"))


def test_waterbottle_textures_and_normal_map(assets):
    path = GLTF / "WaterBottle" / "WaterBottle.gltf"
    if not path.is_file():
        pytest.skip(f"{path} not present")
    scene = parse_scene(_gltf_scene(path, [0.12, 0.06, 0.42], [0.0, 0.0, 0.0], 120, 160))
    result = render(scene, GGX)
    geo = result.frame.geometry
    (tset,) = geo.texture_sets
    assert tset.base_color and tset.metallic_roughness and tset.normal and result.features.textures
    cov = result.frame.gbuffer.coverage.reshape(-1)
    base = result.frame.gbuffer.channels["base"].reshape(-1, 3)[cov]
    metal = result.frame.gbuffer.channels["metallic"][cov]
    assert cov.sum() > 4000 and np.isfinite(result.image).all()
    assert base[:, 0].mean() > 1.5 * base[:, 2].mean()              # the pale yellow body and red cap
    assert metal.max() > 0.9 and metal.min() < 0.1                  # metal body, rubber grip
    # The normal map perturbs the interpolated normals.
    plain = parse_scene(_gltf_scene(path, [0.12, 0.06, 0.42], [0.0, 0.0, 0.0], 120, 160, mesh_material=False))
    n_plain = prepare_frame(plain).gbuffer.channels["normal"].reshape(-1, 3)[cov]
    n_mapped = result.frame.gbuffer.channels["normal"].reshape(-1, 3)[cov]
    assert np.median(np.einsum("ij,ij->i", n_plain, n_mapped)) < 0.99999


def test_avocado(assets):
    path = GLTF / "Avocado" / "Avocado.gltf"
    if not path.is_file():
        pytest.skip(f"{path} not present")
    scene = parse_scene(_gltf_scene(path, [0.05, 0.09, 0.12], [0.0, 0.03, 0.0], 80, 80))
    result = render(scene, GGX)
    cov = result.frame.gbuffer.coverage
    rgb = result.image[cov][:, :3]
    assert cov.sum() > 800 and np.isfinite(rgb).all()
    assert rgb[:, 1].mean() > rgb[:, 2].mean()                      # green skin, yellow flesh, brown seed


# ---------------------------------------------------------------- shadows

#: The plane and the slab above it that the shadow tests light.
PLANE = obj(primitive="plane", size=6.0, material="m")
SLAB = obj(primitive="box", size=[1.0, 0.2, 1.0], translate=[0.0, 1.0, 0.0], material="m")


def _shadow_scene(shadows: bool, lights: str, objects: tuple[str, ...] = (PLANE, SLAB), pcf: int = 3) -> str:
    """Grey objects seen from straight above, with shadows on or off (256² maps, `pcf` × `pcf` taps)."""
    return scene(camera(position=[0.0, 6.0, 0.01], target=[0.0, 0.0, 0.0], fov=50.0, width=64, height=64),
                 table("render", shadows=shadows, shadow_map_size=256, shadow_pcf=pcf),
                 lights,
                 material("m", base_color=[0.5, 0.5, 0.5]),
                 objects)


@pytest.mark.parametrize("kind, extra", [
    ("directional", "direction = [1.0, -1.0, 0.0]\nirradiance = 2.0"),
    ("spot", "position = [-3.0, 4.0, 0.0]\ndirection = [0.75, -1.0, 0.0]\nintensity = 20.0\n"
             "outer_angle = 40.0\ninner_angle = 39.0")])
def test_shadow_under_occluder_and_no_acne(kind, extra):
    """A slanted light, a slab above a plane: where the slab's shadow falls (worked out
    by hand: x in [0.5, 1.5] for the sun, [0.45, 1.5] for the spot) the plane gets no
    light; far from it the shadowed image equals the unshadowed one exactly (no acne)."""
    sun = light(kind, **tomllib.loads(extra))
    on = render(parse_scene(_shadow_scene(True, sun)), LAMBERT)
    off = render(parse_scene(_shadow_scene(False, sun)), LAMBERT)
    assert on.features.shadows and not off.features.shadows
    frags, geo = on.frame.fragments, on.frame.geometry
    tri = frags.tri_id
    on_plane = (tri >= 0) & (geo.face_object[np.maximum(tri, 0)] == 0)
    world = np.einsum("hwc,hwcd->hwd", frags.bary, geo.vertices[geo.faces[np.maximum(tri, 0)]])
    x, z = world[..., 0], world[..., 2]
    under = on_plane & (x > 0.65) & (x < 1.3) & (np.abs(z) < 0.35)
    clear = on_plane & ((x < -1.0) | (np.abs(z) > 1.0))
    assert under.sum() > 20 and clear.sum() > 200
    assert on.image[under][:, :3].max() == 0.0                      # fully shadowed (no ambient)
    assert off.image[under][:, :3].min() > 0.0
    np.testing.assert_array_equal(on.image[clear], off.image[clear])  # lit plane: factor exactly 1
    assert np.array_equal(on.image[tri < 0], off.image[tri < 0])


def test_orthographic_raster_depth_and_near_clip():
    """The rasterizer with an orthographic matrix (clip w = 1): depth is −z_view, and
    a triangle crossing the near plane is clipped at it, not dropped."""
    view = np.eye(4)
    proj = orthographic(-1, 1, -1, 1, 1.0, 5.0)
    tri = np.array([[-0.9, -0.9, -3.0], [0.9, -0.9, -3.0], [0.0, 0.9, -3.0]])
    f = rasterize(tri, [[0, 1, 2]], view, proj, 16, 16)
    assert f.coverage.sum() > 50 and np.allclose(f.depth[f.coverage], 3.0)
    slanted = np.array([[-0.9, -0.9, 0.0], [0.9, -0.9, 0.0], [0.0, 0.9, -4.0]])    # z from 0 (behind near) to −4
    g = rasterize(slanted, [[0, 1, 2]], view, proj, 16, 16)
    assert g.coverage.any() and g.depth[g.coverage].min() >= 1.0 - 1e-9


def test_shadow_keys_are_validated(tmp_path):
    sun = light("directional", direction=[0.0, -1.0, 0.0])
    with pytest.raises(ClshadeError, match=r"render\.shadow_pcf = 4: must be one of 1, 3, 5, 7"):
        parse_scene(_shadow_scene(True, sun, pcf=4))
    with pytest.raises(ClshadeError, match=r"lights\[0\]\.shadows = True: point lights cannot cast shadows"):
        parse_scene(_shadow_scene(True, light("point", position=[0, 3, 0])))
    assert not parse_scene(_shadow_scene(True, light("point", shadows=False, position=[0, 3, 0]))).lights[0].shadows
    plane_of_mesh_material = obj(primitive="plane", mesh_material=True, size=6.0, material="m")
    with pytest.raises(ClshadeError, match=r"objects\[0\]\.mesh_material = True: applies to mesh files only"):
        parse_scene(_shadow_scene(True, sun, objects=(plane_of_mesh_material, SLAB)))


def test_gltf_material_factors_map_to_the_texture_set(tmp_path):
    """glTF pbrMetallicRoughness factors (written by trimesh, no third-party assets needed): baseColorFactor
    (stored as uint8 by trimesh) → base factor in [0, 1], roughnessFactor and metallicFactor kept apart."""
    import trimesh
    from trimesh.visual import TextureVisuals
    from trimesh.visual.material import PBRMaterial
    from clshade.render.meshes import _gltf_texture_set, load_parts
    box = trimesh.creation.box()
    box.visual = TextureVisuals(uv=np.zeros((len(box.vertices), 2)),
                                material=PBRMaterial(baseColorFactor=[255, 51, 102, 255], roughnessFactor=0.25,
                                                     metallicFactor=0.75))
    path = tmp_path / "box.glb"
    box.export(path)
    part, = load_parts(path)
    textures = _gltf_texture_set(part.material, "box")
    assert textures.base_factor == pytest.approx((1.0, 0.2, 0.4))
    assert (textures.roughness_factor, textures.metallic_factor) == pytest.approx((0.25, 0.75))


def test_metallic_roughness_texture_channels_and_factors():
    """glTF layout: G = roughness (× roughnessFactor), B = metallic (× metallicFactor), R ignored."""
    from clshade.render.gbuffer import _apply_texture_set
    from clshade.render.textures import Texture, TextureSet
    mr = Texture.from_pixels(np.tile(np.array([0.7, 0.2, 0.9], np.float32), (4, 4, 1)), "mr")
    t = TextureSet(roughness_factor=0.5, metallic_factor=0.4, metallic_roughness=mr)
    k = 3
    uv = np.full((k, 2), 0.5)
    zero = np.zeros((k, 2))
    normal = np.tile([0.0, 0.0, 1.0], (k, 1))
    tangent = np.tile([1.0, 0.0, 0.0, 1.0], (k, 1))
    base, rough, metal = _apply_texture_set(t, uv, zero, zero, normal, tangent)[:3]
    np.testing.assert_allclose(rough, 0.5 * 0.2, rtol=1e-6)
    np.testing.assert_allclose(metal, 0.4 * 0.9, rtol=1e-6)
    np.testing.assert_allclose(base, 1.0)


@pytest.mark.parametrize("direction", ["[1.0, -0.1, 0.0]"])
def test_no_self_shadowing_at_grazing_light(direction):
    """shadow.h's promise: the normal offset keeps lit planes free of acne at every angle, grazing included —
    a plane with nothing above it renders identically with shadows on and off."""
    sun = light("directional", direction=json.loads(direction), irradiance=2.0)
    on = render(parse_scene(_shadow_scene(True, sun, objects=(PLANE,))), LAMBERT)
    off = render(parse_scene(_shadow_scene(False, sun, objects=(PLANE,))), LAMBERT)
    assert on.features.shadows
    assert (on.image[..., 3] > 0).sum() > 1000
    np.testing.assert_array_equal(on.image, off.image)


def test_texture_v_axis_points_up():
    """UV origin at the bottom left, V up (OpenGL; row 0 of the image is the top): v = 7/8 samples the top row."""
    from clshade.render.textures import Texture
    column = np.array([[1.0], [0.6], [0.3], [0.0]], np.float32)[:, None, :].repeat(3, axis=2)   # (4, 1, 3)
    tex = Texture.from_pixels(np.repeat(column, 2, axis=1))
    got = tex.sample(np.array([[0.5, 0.875], [0.5, 0.125]]), np.zeros(2))[:, 0]
    np.testing.assert_allclose(got, [1.0, 0.0], atol=1e-6)


@pytest.mark.parametrize("direction", ["[0.3, -1.0, 0.2]", "[1.0, -0.5, 0.3]"])
def test_no_self_shadowing_on_the_lit_side_of_a_sphere(direction):
    """shadow.h's normal offset: a convex receiver cannot shadow its own lit side, and the plane
    below cannot reach it, so every sphere pixel facing the light (n·l ≥ 0.2) renders identically
    with shadows on and off. Without the normal offset the curved surface self-shadows (acne)
    where its slope to the light exceeds the constant depth bias."""
    ball = obj(primitive="sphere", radius=1.0, translate=[0.0, 1.0, 0.0], material="m")
    sun = light("directional", direction=json.loads(direction), irradiance=2.0)
    on = render(parse_scene(_shadow_scene(True, sun, objects=(PLANE, ball))), LAMBERT)
    off = render(parse_scene(_shadow_scene(False, sun, objects=(PLANE, ball))), LAMBERT)
    n = on.frame.gbuffer.channel("normal").reshape(-1, 3)
    l = -np.array(json.loads(direction), float)
    l /= np.linalg.norm(l)
    covered = on.frame.gbuffer.channel("depth").reshape(-1) > 0
    sphere_lit = covered & (np.abs(n[:, 1]) < 0.999) & (n @ l >= 0.2)
    assert sphere_lit.sum() > 100
    a, b = on.image.reshape(-1, 4)[sphere_lit], off.image.reshape(-1, 4)[sphere_lit]
    np.testing.assert_array_equal(a, b)


# ---------------------------------------------------------------- textures and shadow maps over the budget

@pytest.mark.parametrize("name, content, size", [
    ("bomb.png", png_header(20000, 20000, padding=1_100_000), "20000x20000"),    # 1.1 MB, decodes to 1.2 GB
    ("normal.exr", exr_header(8192, 8192), "8192x8192"),
])
def test_texture_size_is_refused_from_its_header(tmp_path, capsys, monkeypatch, name, content, size):
    """The header's size is checked before any pixel is decoded (decoding is made to fail the test)."""
    import OpenImageIO as oiio
    monkeypatch.setattr(oiio.ImageInput, "read_image", lambda *a, **k: pytest.fail("pixels decoded"))
    write(tmp_path / name, content)
    key = "normal_texture" if name.endswith(".exr") else "base_color_texture"
    scene = write_scene(tmp_path, small_red_sphere(red={key: name}))
    refused(capsys, ["render", str(scene), "-o", str(tmp_path / "o.png")],
            f"materials.red.{key}", name, size, f"limit of {budget.MAX_TEXTURE_PIXELS} pixels")


def test_gltf_images_are_checked_before_decoding():
    """glTF textures arrive as PIL images, opened lazily: their size is checked before conversion."""
    import io

    from PIL import Image

    from clshade.render.textures import texture_from_image
    image = Image.open(io.BytesIO(png_header(8192, 8192, padding=1 << 16)))    # header read, nothing decoded
    with pytest.raises(ClshadeError, match=r"robot\.baseColorTexture: 8192x8192 texture exceeds the limit"):
        texture_from_image(image, True, "robot.baseColorTexture")
    small = Image.new("RGB", (4, 2), (255, 0, 0))
    assert texture_from_image(small, True, "small").size == (4, 2)


@pytest.mark.parametrize("kind", ["directional", "spot"])
def test_shadow_map_total_is_bounded(tmp_path, capsys, kind):
    one = (light("directional", direction=[0.0, -1.0, -1.0]) if kind == "directional" else
           light("spot", position=[0.0, 3.0, 3.0], direction=[0.0, -1.0, -1.0]))
    text = small_red_sphere(lights=[one] * 64, render_keys=dict(shadows=True, shadow_map_size=8192))
    refused(capsys, ["render", str(write_scene(tmp_path, text)), "-o", str(tmp_path / "o.png")],
            "render.shadow_map_size = 8192", "64 shadow maps", f"limit of {budget.MAX_SHADOW_TEXELS}")
    fits = small_red_sphere(lights=[one] * 64, render_keys=dict(shadows=True, shadow_map_size=1024))
    assert len(parse_scene(fits).shadow_lights) == 64      # the same lights at the default size fit
