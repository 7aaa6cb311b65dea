"""The tessellation cache on disk (clshade/render/meshes.py): an entry reads back as exactly
the tessellation it stores, any change of the key (a parameter, the normal options, the
code) misses instead of reusing it, a damaged entry is rebuilt, and the folder is pruned."""
from __future__ import annotations

import os

import numpy as np
import pytest

from clshade.render import meshes
from clshade.render.scene import SceneObject


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A private cache folder, the in-process memo cleared before and after."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv(meshes.ENV_NO_TESSELLATION_CACHE, raising=False)
    meshes._tessellated.cache_clear()
    yield tmp_path / "clshade" / "tessellations"
    meshes._tessellated.cache_clear()


@pytest.fixture
def built(monkeypatch):
    """The keys _tessellate actually built (a load from disk builds nothing)."""
    calls: list[tuple] = []
    real = meshes._tessellate

    def spy(obj):
        calls.append((obj.primitive, tuple(sorted(obj.params.items())), obj.smooth, obj.crease_angle))
        return real(obj)

    monkeypatch.setattr(meshes, "_tessellate", spy)
    return calls


def _obj(primitive: str, **params) -> SceneObject:
    crease = params.pop("crease_angle", None)
    return SceneObject(name="t", material="m", primitive=primitive, params=params, crease_angle=crease)


CAPSULE = dict(radius=0.12, height=0.8, sections=32)


def _fresh(obj: SceneObject):
    """Tessellate in this process, from nothing (no memo, no disk)."""
    meshes._tessellated.cache_clear()
    return meshes._primitive(obj)


def test_entry_reads_back_bit_exact(cache, built, monkeypatch):
    obj = _obj("capsule", **CAPSULE)
    monkeypatch.setenv(meshes.ENV_NO_TESSELLATION_CACHE, "1")
    reference = _fresh(obj)
    assert not cache.exists()                                    # switched off: nothing written
    monkeypatch.delenv(meshes.ENV_NO_TESSELLATION_CACHE)
    stored = _fresh(obj)
    assert len(list(cache.glob("*.tess"))) == 1
    built.clear()
    loaded = _fresh(obj)
    assert built == []                                           # from the disk, not rebuilt
    for a, b, c in zip(reference, stored, loaded):
        assert a.dtype == c.dtype and a.shape == c.shape
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, c)
        assert not c.flags.writeable


@pytest.mark.parametrize("other", [
    _obj("capsule", radius=0.12, height=0.8000001, sections=32),  # a parameter
    _obj("capsule", radius=0.12, height=0.8, sections=33),
    _obj("capsule", crease_angle=45.0, **CAPSULE),                 # the normal options
    _obj("cylinder", **CAPSULE),                                   # the primitive
])
def test_a_different_key_is_not_reused(cache, built, other):
    _fresh(_obj("capsule", **CAPSULE))
    built.clear()
    got = _fresh(other)
    assert len(built) == 1                                       # built, not read from the entry
    np.testing.assert_array_equal(got[1], meshes._tessellate(other)[1])
    assert len(list(cache.glob("*.tess"))) == 2


def test_changed_code_misses(cache, built, monkeypatch):
    """The key covers the tessellating code: an entry written by other code is not read."""
    obj = _obj("sphere", radius=0.5, subdivisions=2)
    _fresh(obj)
    monkeypatch.setattr(meshes, "_code_fingerprint", lambda: "other code")
    built.clear()
    _fresh(obj)
    assert len(built) == 1 and len(list(cache.glob("*.tess"))) == 2


@pytest.mark.parametrize("damage", ["truncate", "magic", "index"])
def test_damaged_entry_is_rebuilt(cache, built, damage):
    obj = _obj("capsule", **CAPSULE)
    reference = _fresh(obj)
    (entry,) = cache.glob("*.tess")
    data = bytearray(entry.read_bytes())
    if damage == "truncate":
        data = data[:-8]
    elif damage == "magic":
        data[0] ^= 1
    else:                                   # first face index → the vertex count (out of range)
        nv = int(np.frombuffer(bytes(data), "<u8", 1, len(meshes._MAGIC))[0])
        data[len(meshes._MAGIC) + 16 + 24 * nv:len(meshes._MAGIC) + 24 + 24 * nv] = np.array([nv], "<i8").tobytes()
    entry.write_bytes(bytes(data))
    built.clear()
    again = _fresh(obj)
    assert len(built) == 1
    for a, b in zip(reference, again):
        np.testing.assert_array_equal(a, b)
    assert meshes._load_tessellation(entry) is not None         # rewritten whole


def test_prune_keeps_the_most_recently_used(cache, monkeypatch):
    monkeypatch.setattr(meshes, "TESSELLATION_CACHE_ENTRIES", 3)
    objs = [_obj("box", size=(1.0, 1.0, 0.1 * (i + 1))) for i in range(5)]
    paths = []
    for i, obj in enumerate(objs):
        _fresh(obj)
        (path,) = set(cache.glob("*.tess")) - set(paths)
        os.utime(path, ns=(i * 10**9, i * 10**9))                # a clear order of use
        paths.append(path)
    assert sorted(cache.glob("*.tess")) == sorted(paths[-3:])
    _fresh(objs[2])                          # the oldest left is read: now the most recently used
    _fresh(_obj("box", size=(2.0, 1.0, 1.0)))
    assert paths[2].exists() and not paths[3].exists()


def test_unwritable_cache_still_renders(tmp_path, monkeypatch):
    """A cache folder that cannot be created (a file in its place): the tessellation is built
    and returned, nothing raised."""
    (tmp_path / "clshade").write_text("not a folder")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    meshes._tessellated.cache_clear()
    try:
        v, f, n = meshes._primitive(_obj("capsule", **CAPSULE))
        assert len(v) == len(n) and f.max() < len(v)
    finally:
        meshes._tessellated.cache_clear()


def test_read_only_cache_is_read(cache, built, monkeypatch):
    """An entry that can be read but not touched (a shared, read-only cache) is still used."""
    obj = _obj("capsule", **CAPSULE)
    reference = _fresh(obj)

    def refuse(*args, **kwargs):
        raise PermissionError("read-only file system")

    monkeypatch.setattr(meshes.os, "utime", refuse)
    built.clear()
    loaded = _fresh(obj)
    assert built == []
    np.testing.assert_array_equal(loaded[2], reference[2])
