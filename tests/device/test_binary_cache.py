"""The program-binary cache (clshade.device.runtime): a warm build loads the binary the
first build stored, renders the same pixels, and a damaged entry falls back to source."""
from __future__ import annotations

import numpy as np
import pytest

from clshade import cachedir
from clshade.device.runtime import Runtime
from clshade.device.shade import Shader, scene_features
from clshade.models.registry import Registry
from clshade.pipeline import prepare_frame

from conftest import SCENES

resolve = Registry().resolve          # the built-in lobes


@pytest.fixture(scope="module")
def frame():
    return prepare_frame(SCENES / "robot.toml", 48, 40)


def _shade(frame, device_spec: str) -> tuple[np.ndarray, Runtime]:
    rt = Runtime(device_spec)            # a fresh context: nothing built in this process yet
    shader = Shader(rt, frame.gbuffer, frame.scene, frame.camera, frame.shadows)
    features = scene_features(frame.scene, False, False, frame.geometry, False)
    return shader.render(resolve(frame.scene.model), features), rt


def test_binary_cache_round_trip(frame, runtime, tmp_path, monkeypatch):
    spec = runtime.info.spec
    monkeypatch.setenv(cachedir.ENV_NO_BINARY_CACHE, "1")
    reference, _ = _shade(frame, spec)
    monkeypatch.delenv(cachedir.ENV_NO_BINARY_CACHE)
    monkeypatch.setenv(cachedir.ENV_CACHE_DIR, str(tmp_path))
    cold, _ = _shade(frame, spec)
    entries = sorted(tmp_path.glob("*.bin"))
    assert len(entries) == 1 and entries[0].stat().st_size > 0

    built_from: list[str] = []
    cached = Runtime._cached_program

    def spy(self, source, options):
        program = cached(self, source, options)
        built_from.append("binary" if program is not None else "source")
        return program

    monkeypatch.setattr(Runtime, "_cached_program", spy)
    warm, _ = _shade(frame, spec)
    assert built_from == ["binary"]
    np.testing.assert_array_equal(cold, reference)
    np.testing.assert_array_equal(warm, reference)

    entries[0].write_bytes(b"not a program binary")       # damaged: source build, entry rewritten
    built_from.clear()
    again, _ = _shade(frame, spec)
    assert built_from == ["source"]
    np.testing.assert_array_equal(again, reference)
    assert entries[0].read_bytes() != b"not a program binary"


def test_binary_cache_off(monkeypatch, tmp_path):
    monkeypatch.setenv(cachedir.ENV_CACHE_DIR, str(tmp_path))
    assert cachedir.binary_cache_dir() == tmp_path
    monkeypatch.setenv(cachedir.ENV_NO_BINARY_CACHE, "1")
    assert cachedir.binary_cache_dir() is None


def test_binary_cache_key_covers_source_and_options(runtime, tmp_path, monkeypatch):
    """A fast-math build must never load the precise build's binary: the entry's name changes
    with the build options and with the source."""
    monkeypatch.setenv(cachedir.ENV_CACHE_DIR, str(tmp_path))
    src = "__kernel void k(__global float *x) { x[0] = 1.0f; }"
    paths = {runtime._binary_path(src, ()), runtime._binary_path(src, ("-cl-fast-relaxed-math",)),
             runtime._binary_path(src, ("-DA=1",)), runtime._binary_path(src + " ", ())}
    assert len(paths) == 4 and all(p.parent == tmp_path for p in paths)
