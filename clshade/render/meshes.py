"""Scene objects → one world-space triangle soup with per-vertex normals and
per-face material ids, ready for the rasterizer."""
from __future__ import annotations

import hashlib
import os
import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from clshade import budget
from clshade.cachedir import read_entry, user_cache_dir, write_entry
from clshade.errors import ClshadeError, located
from clshade.render import primitives
from clshade.render.scene import Material, Scene, SceneObject
from clshade.render.textures import TextureSet, load_texture_file, primitive_uvs, texture_from_image, vertex_tangents

MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")


@dataclass(frozen=True)
class Geometry:
    vertices: np.ndarray       # (V, 3) float64 world space
    normals: np.ndarray        # (V, 3) float32 world space, unit
    faces: np.ndarray          # (F, 3) int64
    face_material: np.ndarray  # (F,) int32 index into Scene.material_names
    face_object: np.ndarray    # (F,) int32 index into Scene.objects
    cull: np.ndarray           # (F,) bool: back faces culled (False for double-sided materials)
    # Texturing: present only when some material has textures (else None / empty).
    uvs: np.ndarray | None = None            # (V, 2) float32, V up (see textures.py)
    tangents: np.ndarray | None = None       # (V, 4) float32 world tangent + handedness
    face_texture: np.ndarray | None = None   # (F,) int32 index into texture_sets, −1 = untextured
    texture_sets: tuple[TextureSet, ...] = ()
    emission: bool = False                   # some material or glTF texture set emits (emissive > 0)

    @property
    def triangle_count(self) -> int:
        return len(self.faces)

    @property
    def has_textures(self) -> bool:
        """True when a texture image is mapped (factor-only glTF materials do not count)."""
        return any(t.has_images for t in self.texture_sets)

    @property
    def has_emission(self) -> bool:
        """True when some face emits light (a material's or glTF set's emissive factor > 0)."""
        return self.emission

    @property
    def has_occlusion(self) -> bool:
        """True when some face has an ambient occlusion texture."""
        return any(t.occlusion is not None for t in self.texture_sets)


# Faces meeting at a vertex at more than this angle keep separate normals, so
# box edges and cylinder caps shade flat while curved sides stay smooth.
SHARP_EDGE_DEGREES = 30.0


def split_sharp_edges(vertices: np.ndarray, faces: np.ndarray, degrees: float = SHARP_EDGE_DEGREES):
    """Per-corner normals: each corner averages the normals of the faces around its
    vertex that lie within `degrees` of its own face, weighted by each face's angle at
    the vertex (so a cube corner gets the diagonal however its faces are triangulated).
    Returns unshared vertices (3 per face), faces and normals. Vectorised over corner pairs."""
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(cross, axis=1, keepdims=True)
    unit = np.divide(cross, length, out=np.zeros_like(cross), where=length > 0)
    e1 = np.roll(tri, -1, axis=1) - tri                                   # corner → next corner
    e2 = np.roll(tri, -2, axis=1) - tri                                   # corner → previous corner
    l12 = np.linalg.norm(e1, axis=2) * np.linalg.norm(e2, axis=2)
    cosine = np.divide(np.einsum("fcd,fcd->fc", e1, e2), l12, out=np.ones_like(l12), where=l12 > 0)
    angle = np.arccos(np.clip(cosine, -1.0, 1.0)).reshape(-1)             # (3F,) corner angles
    vid = faces.reshape(-1)
    fid = np.repeat(np.arange(len(faces)), 3)
    order = np.argsort(vid, kind="stable")
    sorted_vid = vid[order]
    starts = np.flatnonzero(np.r_[True, sorted_vid[1:] != sorted_vid[:-1]])
    sizes = np.diff(np.r_[starts, len(vid)])
    # All (a, b) corner pairs sharing a vertex: group sizes are small (valence).
    group_of = np.repeat(np.arange(len(starts)), sizes)
    pair_counts = sizes[group_of]
    a = np.repeat(order, pair_counts)
    first = np.repeat(starts[group_of], pair_counts)
    within = np.arange(len(a)) - np.repeat(np.cumsum(pair_counts) - pair_counts, pair_counts)
    b = order[first + within]
    keep = np.einsum("ij,ij->i", unit[fid[a]], unit[fid[b]]) >= np.cos(np.radians(degrees))
    # Sum per corner with one weighted bincount per axis: the same additions in the same
    # order as np.add.at(normals, a[keep], ...), several times faster.
    ak, bk = a[keep], b[keep]
    weighted = unit[fid[bk]] * angle[bk, None]
    normals = np.stack([np.bincount(ak, weighted[:, d], minlength=len(vid)) for d in range(3)], axis=1)
    n = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, n, out=np.repeat(unit, 3, axis=0), where=n > 0)
    return vertices[vid], np.arange(len(vid)).reshape(-1, 3), normals


def _primitive(obj: SceneObject):
    """Vertices, faces and normals of a procedural primitive (clshade/render/primitives.py):
    the sphere has exact normals unless the object asks for flat shading or its own crease
    angle; other primitives are split at the object's crease angle (see crease_degrees).
    Objects with the same primitive, parameters and normal options share one tessellation
    (read-only arrays: a scene's repeated parts — two arms, two eyes — are built once)."""
    key = (obj.primitive, tuple(sorted(obj.params.items())), obj.smooth, obj.crease_angle)
    try:
        hash(key)
    except TypeError:               # an unhashable parameter value: build it uncached
        return _tessellate(obj)
    return _tessellated(key)


@lru_cache(maxsize=256)
def _tessellated(key: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tessellation of `key` (see _primitive): from this process's memory, else from the
    tessellation cache on disk, else built (and stored there)."""
    path = _cache_path(key)
    arrays = _load_tessellation(path) if path is not None else None
    if arrays is None:
        kind, params, smooth, crease_angle = key
        arrays = _tessellate(SceneObject(name="", material="", primitive=kind, params=dict(params), smooth=smooth,
                                         crease_angle=crease_angle))
        if path is not None:
            _store_tessellation(path, arrays)
    for a in arrays:
        a.flags.writeable = False
    return arrays


# ---------------------------------------------------------------- tessellation cache on disk
#
# Tessellating a scene's primitives (and splitting their normals at the crease angle) costs
# a fresh process many small NumPy calls; reading the stored arrays back is one file read
# per distinct primitive. One file per (primitive, parameters, smooth, crease_angle), named by a
# SHA-256 over that key, the source of the code that builds it (primitives.py, this file)
# and NumPy's version, so that a change to any of them misses instead of reusing a stale
# entry. Written atomically (clshade/cachedir.py): concurrent runs see a whole entry or
# none. Entries that do not read back as a valid tessellation are rebuilt.

ENV_NO_TESSELLATION_CACHE = "CLSHADE_NO_TESSELLATION_CACHE"
#: Entries kept (the least recently used beyond this are deleted when one is stored): a
#: sphere of 4 subdivisions (2562 vertices, 5120 faces) takes 246 kB, so the folder stays
#: within some tens of MB.
TESSELLATION_CACHE_ENTRIES = 256
_SUFFIX = ".tess"
#: An entry: this 16-byte magic, the vertex and face counts (uint64), then the raw arrays
#: vertices (V, 3) float64, faces (F, 3) int64, normals (V, 3) float64, all little-endian
#: (every array starts 8-byte aligned).
_MAGIC = b"clshade tess v1\n"
_F8, _I8, _U8 = np.dtype("<f8"), np.dtype("<i8"), np.dtype("<u8")


def tessellation_cache_dir() -> Path | None:
    """$XDG_CACHE_HOME/clshade/tessellations (~/.cache/clshade/tessellations); None when
    CLSHADE_NO_TESSELLATION_CACHE=1."""
    if os.environ.get(ENV_NO_TESSELLATION_CACHE, "").strip() not in ("", "0"):
        return None
    return user_cache_dir("tessellations")


@lru_cache(maxsize=1)
def _code_fingerprint() -> str | None:
    """SHA-256 of the tessellating code (primitives.py, this file) and NumPy's version;
    None (no caching) when the source cannot be read."""
    digest = hashlib.sha256(np.__version__.encode())
    try:
        for source in (primitives.__file__, __file__):
            digest.update(Path(source).read_bytes())
    except OSError:
        return None
    return digest.hexdigest()


def _cache_path(key: tuple) -> Path | None:
    folder = tessellation_cache_dir()
    code = _code_fingerprint()
    if folder is None or code is None:
        return None
    return folder / (hashlib.sha256(f"{key!r}\0{code}".encode()).hexdigest() + _SUFFIX)


def _load_tessellation(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(vertices, faces, normals) from a cache entry, or None when it is missing or is not a
    valid tessellation (other magic, truncated, face indices out of range)."""
    data = read_entry(path)
    header = len(_MAGIC) + 16
    if data is None or len(data) < header or not data.startswith(_MAGIC):
        return None
    nv, nf = (int(x) for x in np.frombuffer(data, _U8, 2, len(_MAGIC)))
    if len(data) != header + 8 * (6 * nv + 3 * nf):
        return None
    v = np.frombuffer(data, _F8, 3 * nv, header).reshape(nv, 3)
    faces = np.frombuffer(data, _I8, 3 * nf, header + 24 * nv).reshape(nf, 3)
    n = np.frombuffer(data, _F8, 3 * nv, header + 24 * (nv + nf)).reshape(nv, 3)
    if nf and (faces.min() < 0 or faces.max() >= nv):
        return None
    return v, faces, n


def _store_tessellation(path: Path, arrays: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    """Write an entry (clshade/cachedir.py: atomic, the folder pruned to
    TESSELLATION_CACHE_ENTRIES); a failure to write leaves the cache as it was."""
    v, faces, n = arrays
    data = b"".join([_MAGIC, np.array([len(v), len(faces)], _U8).tobytes(),
                     *(np.ascontiguousarray(a, t).tobytes() for a, t in ((v, _F8), (faces, _I8), (n, _F8)))])
    write_entry(path, data, TESSELLATION_CACHE_ENTRIES)


def _tessellate(obj: SceneObject):
    p = obj.params
    kind = obj.primitive
    if kind == "sphere":
        v, f = primitives.icosphere(p["subdivisions"], p["radius"])
        if obj.smooth is None and obj.crease_angle is None:
            return v, f, v / np.linalg.norm(v, axis=1, keepdims=True)
    elif kind == "plane":
        s = p["size"] / 2
        v = np.array([[-s, 0, -s], [s, 0, -s], [s, 0, s], [-s, 0, s]], float)
        f = np.array([[0, 2, 1], [0, 3, 2]])
        return v, f, np.tile([0.0, 1.0, 0.0], (4, 1))
    elif kind == "box":
        v, f = primitives.box(p["size"])
    elif kind in ("cylinder", "cone", "capsule"):
        v, f = getattr(primitives, kind)(p["radius"], p["height"], p["sections"])
    elif kind == "torus":
        v, f = primitives.torus(p["major_radius"], p["minor_radius"], p["sections"], max(p["sections"] // 2, 3))
    else:  # pragma: no cover - validated in scene.py
        raise ClshadeError(f"unknown primitive {kind!r}")
    return split_sharp_edges(v, f, crease_degrees(obj))


def crease_degrees(obj: SceneObject) -> float:
    """The object's crease angle: `smooth = false` → 0 (flat: every face its own normal),
    `smooth = true` → 180 (no crease), else `crease_angle` or SHARP_EDGE_DEGREES."""
    if obj.smooth is not None:
        return 180.0 if obj.smooth else 0.0
    return SHARP_EDGE_DEGREES if obj.crease_angle is None else obj.crease_angle


@dataclass(frozen=True)
class MeshPart:
    """One geometry instance of a mesh file, in the file's world frame (node transform applied)."""
    vertices: np.ndarray              # (V, 3) float64
    faces: np.ndarray                 # (F, 3) int64
    normals: np.ndarray | None        # (V, 3) the file's own vertex normals, None when it has none
    uvs: np.ndarray | None            # (V, 2) or None
    material: object = None           # the trimesh material (glTF: PBRMaterial)
    name: str = ""


def _file_normals(mesh) -> np.ndarray | None:
    """Vertex normals the file stored (OBJ vn, PLY nx/ny/nz, glTF NORMAL), or None.
    trimesh puts loaded normals in its cache and computes them on first access
    otherwise, so a cached entry right after loading means the file had them."""
    cache = getattr(getattr(mesh, "_cache", None), "cache", {})
    normals = cache.get("vertex_normals")
    if normals is None or len(normals) != len(mesh.vertices):
        return None
    return np.asarray(normals, float)


def load_parts(path: Path, scene_file: Path | None = None, key: str = "mesh") -> list[MeshPart]:
    """Every geometry instance of a mesh file (any supported format) as MeshParts, node
    transforms applied (normals by the inverse transpose, winding flipped by mirrors)."""
    loaded = _load_trimesh(path, scene_file, key, force="scene")
    parts = []
    for node in loaded.graph.nodes_geometry:
        transform, gname = loaded.graph[node]
        g = loaded.geometry[gname]
        if len(getattr(g, "faces", ())) == 0:
            continue
        m = np.asarray(transform, float)
        v = np.asarray(g.vertices, float) @ m[:3, :3].T + m[:3, 3]
        n = _file_normals(g)
        if n is not None:
            n = n @ np.linalg.inv(m[:3, :3])
        f = np.asarray(g.faces, np.int64)
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            bad = int(f.min()) if f.min() < 0 else int(f.max())
            raise located(f"face index {bad} is out of range: {gname!r} has {len(v)} vertices (0 to {len(v) - 1})",
                          scene_file, key, str(path), has_value=True)
        if np.linalg.det(m[:3, :3]) < 0:
            f = f[:, ::-1]
        uv = getattr(g.visual, "uv", None)
        uv = None if uv is None or len(uv) != len(v) else np.asarray(uv, float)
        parts.append(MeshPart(v, f, n, uv, getattr(g.visual, "material", None), str(gname)))
    if not parts:
        raise located("mesh has no triangles", scene_file, key, str(path), has_value=True)
    return parts


def weld(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge vertices at exactly the same position: (unique positions, faces into them).
    Files that repeat a vertex per face (STL, OBJ with per-corner UVs) then share edges."""
    unique, inverse = np.unique(vertices, axis=0, return_inverse=True)
    return unique, inverse.reshape(-1)[faces]


def shading_normals(part: MeshPart, obj: SceneObject | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(source vertex per output vertex, faces, normals) of a loaded mesh part. The file's
    own normals are kept unless the object sets `smooth` or `crease_angle`; otherwise
    vertices are welded by position and normals split at the crease angle (as primitives)."""
    explicit = obj is not None and (obj.smooth is not None or obj.crease_angle is not None)
    if part.normals is not None and not explicit:
        return np.arange(len(part.vertices)), part.faces, part.normals
    degrees = SHARP_EDGE_DEGREES if obj is None else crease_degrees(obj)
    unique, welded = weld(part.vertices, part.faces)
    _, faces, normals = split_sharp_edges(unique, welded, degrees)
    return part.faces.reshape(-1), faces, normals


def _load_trimesh(path: Path, scene_file: Path | None, key: str, force: str | None = None):
    import trimesh
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise located(f"unsupported mesh format {path.suffix or '(none)'}; use one of {', '.join(MESH_SUFFIXES)}",
                      scene_file, key, str(path), has_value=True)
    if path.suffix.lower() == ".obj":
        _check_obj_indices(path, scene_file, key)
    try:
        return trimesh.load(path, process=False, force=force, resolver=_regular_files_resolver(path))
    except Exception as exc:  # trimesh raises many kinds
        raise located(f"cannot load mesh ({type(exc).__name__}: {exc})", scene_file, key, str(path), has_value=True) from exc


def _regular_files_resolver(path: Path):
    """trimesh's resolver of the files a mesh names (OBJ mtllib and textures, glTF buffers and
    images) in the mesh's folder, refusing any that is not a regular file (a FIFO named as a
    material library would block the read for ever, a device would never end)."""
    from trimesh.resolvers import FilePathResolver

    class RegularFiles(FilePathResolver):
        def get(self, name: str):
            for candidate in (name.strip(), name.strip().lstrip("/"), os.path.split(name)[-1]):
                try:
                    found = self.absolute(candidate)
                except ValueError:
                    continue
                if found.exists():
                    budget.regular_file(found, f"file {name!r} named by the mesh")
                    break
            return super().get(name)

    return RegularFiles(path)


#: An OBJ face corner whose vertex, texture or normal index is 0 (OBJ counts from 1, negative
#: from the end; 0 names nothing): a `0` after "f " or after a space or slash on an f line.
_OBJ_ZERO_INDEX = re.compile(rb"^[ \t]*f[ \t](?:[^\n]*[ \t/])?-?0+(?=[/ \t\r\n]|$)", re.M)


def _check_obj_indices(path: Path, scene_file: Path | None, key: str) -> None:
    """Refuse an OBJ face with index 0 (trimesh would read it as the last vertex)."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise located(f"cannot read mesh ({exc.strerror or exc})", scene_file, key, str(path), has_value=True) from None
    match = _OBJ_ZERO_INDEX.search(data)
    if match:
        line = data.count(b"\n", 0, match.start()) + 1
        raise located(f"line {line}: face index 0 (OBJ indices start at 1)", scene_file, key, str(path),
                      has_value=True)


def _gltf_texture_set(material, name: str, with_images: bool = True) -> TextureSet:
    """A trimesh PBRMaterial → TextureSet: the factors always (glTF defaults when absent),
    the textures only `with_images` (a primitive without TEXCOORD_0 cannot sample them).
    Caveats of trimesh's loader: it stores baseColorFactor quantised to uint8 (so factors
    are exact to 1/255 only), drops normalTexture.scale and occlusionTexture.strength
    (taken as 1) and KHR_texture_transform (not applied)."""
    if material is not None and not hasattr(material, "baseColorTexture") and hasattr(material, "to_pbr"):
        material = material.to_pbr()
    if material is None:
        return TextureSet(name=name)
    factor = getattr(material, "baseColorFactor", None)
    base = (1.0, 1.0, 1.0) if factor is None else tuple(float(c) / 255.0 for c in np.asarray(factor)[:3])
    rough = getattr(material, "roughnessFactor", None)
    metal = getattr(material, "metallicFactor", None)
    emissive = getattr(material, "emissiveFactor", None)
    textures = {}
    for attr, srgb in (("baseColorTexture", True), ("metallicRoughnessTexture", False), ("normalTexture", False),
                       ("emissiveTexture", True), ("occlusionTexture", False)):
        image = getattr(material, attr, None) if with_images else None
        textures[attr] = None if image is None else texture_from_image(image, srgb, f"{name}.{attr}")
    return TextureSet(base_factor=base, roughness_factor=1.0 if rough is None else float(rough),
                      metallic_factor=1.0 if metal is None else float(metal),
                      base_color=textures["baseColorTexture"], metallic_roughness=textures["metallicRoughnessTexture"],
                      normal=textures["normalTexture"], name=name,
                      emissive_factor=(0.0, 0.0, 0.0) if emissive is None else tuple(float(c) for c in emissive[:3]),
                      emissive=textures["emissiveTexture"], occlusion=textures["occlusionTexture"])


def _material_texture_set(material: Material, scene_file: Path | None, where: str) -> TextureSet:
    """The texture files a scene material names, loaded, with its factors."""
    def load(key: str, srgb: bool):
        path = getattr(material, key)
        return None if path is None else load_texture_file(path, srgb, scene_file, f"{where}.{key}")
    return TextureSet(base_factor=tuple(material.base_color), roughness_factor=material.roughness,
                      metallic_factor=material.metallic, base_color=load("base_color_texture", True),
                      metallic_roughness=load("metallic_roughness_texture", False),
                      normal=load("normal_texture", False), normal_scale=material.normal_scale,
                      uv_scale=material.uv_scale, name=material.name, emissive_factor=tuple(material.emissive))


def _check_texture_coordinates(uv: np.ndarray, scene_file: Path | None, key: str, value: str) -> None:
    """Refuse texture coordinates that are not finite as float32 (Geometry.uvs): sampling a NaN or
    infinite coordinate indexes no texel."""
    uv = np.asarray(uv, np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        bad = ~np.isfinite(uv.astype(np.float32)).all(axis=1)
    if bad.any():
        first = int(np.argmax(bad))
        u, v = (float(x) for x in uv[first])
        raise located(f"{int(bad.sum())} texture coordinate(s) not finite as float32 (first: vertex {first}: "
                      f"({u:g}, {v:g}))", scene_file, key, value, has_value=True)


def build_geometry(scene: Scene) -> Geometry:
    """Transform every object into world space and concatenate. UVs, tangents and
    texture sets are carried only when a material has textures or an object uses
    its glTF materials."""
    names = scene.material_names
    textured = any(scene.materials[o.material].textures or o.mesh_material for o in scene.objects)
    verts, norms, faces, fmat, fobj, cull, uvs, ftex = [], [], [], [], [], [], [], []
    sets: list[TextureSet] = []
    set_index: dict[int, int] = {}                 # id(TextureSet) → index in sets
    material_sets: dict[str, TextureSet] = {}      # scene material → its loaded textures
    gltf_sets: dict[tuple[int, bool], TextureSet] = {}   # (id(glTF material), has UVs) → its TextureSet
    offset = 0
    for index, obj in enumerate(scene.objects):
        material = scene.materials[obj.material]
        key = f"objects[{index}].mesh"
        if obj.primitive:
            v, f, n = _primitive(obj)
            uv = None
            if material.textures:
                v, f, corner, uv = primitive_uvs(obj.primitive, v, f, obj.params.get("size", 1.0))
                n = np.asarray(n, float)[corner]
            parts = [(v, f, n, uv, None)]
        else:
            parts = []
            for part in load_parts(obj.mesh, scene.path, key):
                source, f, n = shading_normals(part, obj)
                uv = None if part.uvs is None else part.uvs[source]
                tset = None
                if obj.mesh_material:
                    cache_key = (id(part.material), uv is not None)
                    if cache_key not in gltf_sets:
                        label = f"{obj.mesh.name}:{getattr(part.material, 'name', None) or part.name}"
                        gltf_sets[cache_key] = _gltf_texture_set(part.material, label, with_images=uv is not None)
                    tset = gltf_sets[cache_key]
                parts.append((part.vertices[source], f, n, uv, tset))
        if material.textures and not obj.mesh_material:
            if any(uv is None for *_, uv, _ in parts):
                raise located("mesh has no texture coordinates, but its material has textures",
                              scene.path, key, str(obj.mesh), has_value=True)
            if obj.material not in material_sets:
                where = f"objects[{index}].material" if "#" in obj.material else f"materials.{obj.material}"
                material_sets[obj.material] = _material_texture_set(material, scene.path, where)
            parts = [(v, f, n, uv, material_sets[obj.material]) for v, f, n, uv, _ in parts]
        for *_, uv, tset in parts:
            if tset is not None and tset.has_images and uv is not None:
                _check_texture_coordinates(uv, scene.path, key, str(obj.mesh or obj.primitive))
        m = obj.matrix()
        for v, f, n, uv, tset in parts:
            v = np.asarray(v, float) @ m[:3, :3].T + m[:3, 3]
            # Normals transform by the inverse transpose.
            n = np.asarray(n, float) @ np.linalg.inv(m[:3, :3])
            length = np.linalg.norm(n, axis=1, keepdims=True)
            # A NaN normal stays NaN so that the G-buffer counts (and contains) its pixels.
            n = np.where(np.isfinite(length), np.divide(n, length, out=np.zeros_like(n), where=length > 0), np.nan)
            if np.linalg.det(m[:3, :3]) < 0:     # a mirroring transform flips the winding
                f = f[:, ::-1]
            if tset is not None and id(tset) not in set_index:
                sets.append(tset)
                set_index[id(tset)] = len(sets) - 1
            verts.append(v)
            norms.append(n)
            faces.append(np.asarray(f, np.int64) + offset)
            fmat.append(np.full(len(f), names.index(obj.material), np.int32))
            fobj.append(np.full(len(f), index, np.int32))
            cull.append(np.full(len(f), not material.double_sided))
            uvs.append(uv if uv is not None else np.zeros((len(v), 2)))
            ftex.append(np.full(len(f), set_index[id(tset)] if tset is not None else -1, np.int32))
            offset += len(v)
    emission = (any(any(c > 0 for c in scene.materials[o.material].emissive) for o in scene.objects)
                or any(t.has_emission for t in sets))
    if not verts:
        return Geometry(np.zeros((0, 3)), np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int64),
                        np.zeros(0, np.int32), np.zeros(0, np.int32), np.zeros(0, bool))
    geometry = Geometry(np.concatenate(verts), np.concatenate(norms).astype(np.float32), np.concatenate(faces),
                        np.concatenate(fmat), np.concatenate(fobj), np.concatenate(cull), emission=emission)
    if not textured:
        return geometry
    from dataclasses import replace
    uv_all = np.concatenate(uvs)
    return replace(geometry, uvs=uv_all.astype(np.float32),
                   tangents=vertex_tangents(geometry.vertices, geometry.faces, geometry.normals, uv_all),
                   face_texture=np.concatenate(ftex), texture_sets=tuple(sets))
