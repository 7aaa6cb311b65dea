"""clshade/cachedir.py, the one implementation of the caches' files: atomic entries, use
marked on read, pruning to the most recently used, failures that leave the cache as it was."""
from __future__ import annotations

import os

import numpy as np

from clshade import cachedir
from clshade.device.runtime import Runtime


def test_user_cache_dir(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cachedir.user_cache_dir("x") == tmp_path / "clshade" / "x"
    monkeypatch.setenv("XDG_CACHE_HOME", "")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cachedir.user_cache_dir("x") == tmp_path / "home" / ".cache" / "clshade" / "x"


def test_round_trip_prune_and_use(tmp_path):
    paths = [tmp_path / f"{i}.e" for i in range(4)]
    for i, path in enumerate(paths[:3]):
        assert cachedir.write_entry(path, bytes([i]) * 10, keep=3)
        os.utime(path, ns=(i * 10**9, i * 10**9))
    assert cachedir.read_entry(paths[0]) == bytes([0]) * 10     # read: now the most recently used
    assert cachedir.write_entry(paths[3], b"new", keep=3)
    assert sorted(tmp_path.iterdir()) == sorted([paths[0], paths[2], paths[3]])
    assert cachedir.read_entry(paths[1]) is None
    (tmp_path / "other.txt").write_text("not an entry")             # other suffixes are not pruned
    cachedir.prune(tmp_path, ".e", 1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["3.e", "other.txt"]


def test_failed_write_leaves_nothing(tmp_path, monkeypatch):
    (tmp_path / "file").write_text("x")
    assert cachedir.write_entry(tmp_path / "file" / "a.e", b"data", keep=4) is False
    target = tmp_path / "dir" / "a.e"

    def refuse(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(cachedir.os, "replace", refuse)
    assert cachedir.write_entry(target, b"data", keep=4) is False
    assert list((tmp_path / "dir").iterdir()) == []               # no temporary file left behind


def test_program_cache_is_pruned(runtime, tmp_path, monkeypatch):
    """The program-binary cache keeps PROGRAM_CACHE_ENTRIES, the one just read among them."""
    monkeypatch.setenv(cachedir.ENV_CACHE_DIR, str(tmp_path))
    monkeypatch.delenv(cachedir.ENV_NO_BINARY_CACHE, raising=False)
    monkeypatch.setattr("clshade.device.runtime.PROGRAM_CACHE_ENTRIES", 2)
    sources = [f"__kernel void k(__global float *x) {{ x[0] = {i}.0f; }}" for i in range(3)]

    def run(source):
        rt = Runtime(runtime.info.spec)
        kernel = rt.kernel(source, "k")
        out = np.zeros(1, np.float32)
        buf = rt.empty(4)
        kernel.set_args(buf)
        rt.cl.enqueue_nd_range_kernel(rt.queue, kernel, (1,), (1,)).wait()
        rt.cl.enqueue_copy(rt.queue, out, buf)
        return float(out[0]), rt._binary_path(source, rt.options)

    first = run(sources[0])[1]
    os.utime(first, ns=(10**9, 10**9))
    second = run(sources[1])[1]
    os.utime(second, ns=(2 * 10**9, 2 * 10**9))
    assert run(sources[0]) == (0.0, first)                         # from the binary: marks it used
    value, third = run(sources[2])
    assert value == 2.0
    assert sorted(tmp_path.glob("*.bin")) == sorted([first, third])
