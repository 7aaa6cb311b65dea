"""The performance bench's measuring parts: STREAM accounting, the
orbiting camera of whole frames, and the peers' output against clshade's."""
from __future__ import annotations

import dataclasses
import importlib.util

import numpy as np
import pytest

from clshade.bench import bandwidth, frame as whole, peers
from clshade.device.shade import Shader, scene_features
from clshade.models.registry import Registry
from clshade.pipeline import prepare_frame
from clshade.render.scene import load_scene, parse_scene

from conftest import ROOT, SCENES

resolve = Registry().resolve          # the built-in lobes


def test_stream_counts_bytes_as_stream_does(monkeypatch):
    """Copy moves 2 × 4 B per element, triad 3 × 4 B: with every timing 1 s, the
    rates are exactly those bytes (a wrong byte count or unit fails)."""
    ticks = iter(np.arange(0.0, 1000.0, 1.0))
    monkeypatch.setattr(bandwidth.time, "perf_counter", lambda: float(next(ticks)))
    out = bandwidth.stream(repeats=2, mib=1, method="numpy")
    n = 2 ** 20 // 4
    assert out["copy_best_gbs"] == pytest.approx(8 * n / 1e9)
    assert out["triad_best_gbs"] == pytest.approx(12 * n / 1e9)
    assert out["anchor_gbs"] == max(out["copy_best_gbs"], out["triad_best_gbs"])


def test_stream_kernels_compute_copy_and_triad():
    copy, triad, _ = bandwidth._numpy_kernels(2)
    a, b, c = np.arange(10, dtype=np.float32), np.full(10, 2.0, np.float32), np.zeros(10, np.float32)
    copy(a, c)
    np.testing.assert_array_equal(c, a)
    triad(a, b, c, np.float32(3.0))
    np.testing.assert_array_equal(a, 2.0 + 3.0 * np.arange(10, dtype=np.float32))


def record_kernel_times(runtime, monkeypatch) -> list[float]:
    """A list that receives the profiled time (s) of every kernel `runtime` enqueues from now on."""
    real = runtime.cl.enqueue_nd_range_kernel
    times: list[float] = []

    def timed(*a, **k):
        ev = real(*a, **k)
        ev.wait()
        times.append((ev.profile.end - ev.profile.start) * 1e-9)
        return type("E", (), {"wait": lambda self: None, "profile": ev.profile})()
    monkeypatch.setattr(runtime.cl, "enqueue_nd_range_kernel", timed)
    return times


def test_opencl_stream_counts_stream_bytes_and_checks_its_values(runtime, monkeypatch):
    """The OpenCL STREAM kernels run with plain and with streaming stores (and verify c = b,
    a = b + s·c after each kind); rates are the bytes STREAM counts (copy 2 × 4 B, triad 3 × 4 B per
    element) over the best profiled kernel time of each loop and store kind."""
    out = bandwidth.opencl_stream(runtime, repeats=2, mib=1)
    keys = [loop + suffix for suffix in bandwidth.STORE_KINDS.values() for loop in ("copy", "triad")]
    assert all(out[f"{k}_best_gbs"] > 0 for k in keys)
    assert out["best_gbs"] == max(out[f"{k}_best_gbs"] for k in keys)
    times = record_kernel_times(runtime, monkeypatch)
    out = bandwidth.opencl_stream(runtime, repeats=2, mib=1)
    n = 2 ** 20 // 4
    timed_runs = times[4:]            # after one warm-up run of each loop and store kind
    for j, suffix in enumerate(bandwidth.STORE_KINDS.values()):
        kind = timed_runs[4 * j:4 * j + 4]
        assert out[f"copy{suffix}_best_gbs"] == pytest.approx(8 * n / min(kind[0::2]) / 1e9)
        assert out[f"triad{suffix}_best_gbs"] == pytest.approx(12 * n / min(kind[1::2]) / 1e9)


def test_opencl_stream_check_catches_a_wrong_streaming_kernel(runtime, monkeypatch):
    """A streaming-store loop that writes the wrong value is refused, not timed."""
    monkeypatch.setattr(bandwidth, "OPENCL_STREAM_SOURCE",
                        bandwidth.OPENCL_STREAM_SOURCE.replace("STREAMING_STORE(b[i] + s * c[i], a + i)",
                                                               "STREAMING_STORE(b[i] - s * c[i], a + i)"))
    with pytest.raises(RuntimeError, match="wrong values"):
        bandwidth.opencl_stream(runtime, repeats=1, mib=1)


def test_opencl_fill_times_zeros_and_ones_and_checks_them(runtime, monkeypatch):
    """The fill rows time a streaming fill with each of FILL_VALUES (4 B per element over the best
    profiled time), interleaved after one warm-up round, and refuse a fill that wrote another value."""
    times = record_kernel_times(runtime, monkeypatch)
    out = bandwidth.opencl_fill(runtime, repeats=3, mib=1)
    n = 2 ** 20 // 4
    kept = times[2:]
    assert out["zeros_best_gbs"] == pytest.approx(4 * n / min(kept[0::2]) / 1e9)
    assert out["ones_best_gbs"] == pytest.approx(4 * n / min(kept[1::2]) / 1e9)
    assert out["zeros_over_ones"] == pytest.approx(out["zeros_median_gbs"] / out["ones_median_gbs"])
    monkeypatch.setattr(bandwidth, "FILL_VALUES", {"zeros": 0.0, "ones": 1.0, "twos": 2.0})
    monkeypatch.setattr(bandwidth, "OPENCL_STREAM_SOURCE", bandwidth.OPENCL_STREAM_SOURCE.replace(
        "STREAMING_STORE((float16)(v), c + i)", "STREAMING_STORE((float16)(fmin(v, 1.0f)), c + i)"))
    with pytest.raises(RuntimeError, match="fill of 2.0 wrote other values"):
        bandwidth.opencl_fill(runtime, repeats=1, mib=1)


@pytest.mark.snapshot
def test_committed_perf_tables_are_rendered_from_their_json():
    """benchmarks/results/perf_1080p.md is clshade.report.perf.perf_markdown() of the committed JSON, so no figure in it
    was typed by hand, and its fill line quotes each runtime's fill medians."""
    import json
    from clshade.report.perf import perf_markdown
    results = ROOT / "benchmarks" / "results"
    if not (results / "perf_1080p.json").exists():
        pytest.skip("no committed perf results (benchmarks/results/perf_1080p.json) in this checkout")
    doc = json.loads((results / "perf_1080p.json").read_text(encoding="utf-8"))
    md = (results / "perf_1080p.md").read_text(encoding="utf-8")
    assert md == perf_markdown(doc)
    for v in doc["stream"]["fill"].values():
        assert f"{v['zeros_median_gbs']:.1f} vs {v['ones_median_gbs']:.1f} GB/s ({v['zeros_over_ones']:.2f}×)" in md


def test_fill_line_quotes_each_fill_where_it_says():
    """The fill line names the fill of zeros first, then the fill of 1.0, then their ratio: fed fills
    that differ, each figure lands in its place."""
    import copy
    import json
    from clshade.report.perf import perf_markdown
    path = ROOT / "benchmarks" / "results" / "perf_1080p.json"
    if not path.exists():
        pytest.skip("no committed perf results (benchmarks/results/perf_1080p.json) in this checkout")
    doc = copy.deepcopy(json.loads(path.read_text(encoding="utf-8")))
    fills = doc["stream"]["fill"]
    for k, v in enumerate(fills.values()):
        v.update(zeros_median_gbs=11.0 + k, ones_median_gbs=33.0 + k, zeros_over_ones=(11.0 + k) / (33.0 + k))
    line = next(x for x in perf_markdown(doc).splitlines() if x.startswith("**Lines of zeros.**"))
    for k in range(len(fills)):
        assert f"{11.0 + k:.1f} vs {33.0 + k:.1f} GB/s ({(11.0 + k) / (33.0 + k):.2f}×)" in line, line


def test_each_item_is_timed_right_after_itself():
    """perf times the second of two back-to-back runs of an item, so the item before the timed run is
    the item itself, whatever the round's random order put before it."""
    from clshade.bench import perf
    calls = []

    def item() -> float:
        calls.append(len(calls))
        return float(len(calls))
    assert perf.timed_after_itself(item) == 2.0 and calls == [0, 1]


def test_cache_band_is_the_most_covered_window():
    from clshade.bench import perf
    coverage = np.zeros(64 * 40, bool)
    coverage[64 * 25 + 3:64 * 31] = True           # covered pixels 1603..1983
    active = perf.active_items(coverage, 8)
    assert len(active) == 320 and active.sum() == (1983 - 1600) // 8 + 1
    assert perf.cache_band(active, 16, 64) == (192, 64)   # work-items 192..255 hold all 48 covered ones (200..247)
    assert perf.cache_band(active, 16, 10_000) == (0, 320)


def test_miss_causes_come_from_the_measured_rows():
    """The cause text quotes the row's own numbers: in-cache arithmetic vs the excess over the copy kernel."""
    from clshade.bench import perf
    row = dict(median_ms=6.0, copy_ms=3.0, cache_frame_ms=4.5, copy_cache_frame_ms=1.5, cache_band_pixels=61440,
               copy_stream_ratio=1.4, copy_gbs=20.0, copy_ratio=2.0, bytes=60e6)
    text = perf.copy_miss_cause(row)
    assert "3.00 ms of arithmetic are 100% of its 3.00 ms over the copy kernel" in text and "75%" in text
    text = perf.stream_miss_cause(row, 28.0, 25.0)
    assert "1.40× the STREAM bound (20.0 vs 28.0 GB/s)" in text and "reaches 25.0 GB/s" in text and "at 80% of" in text
    assert "Lambert adds 3.00 ms (2.00× copy)" in text


def test_orbit_keeps_the_distance_and_moves_the_camera():
    cam = load_scene(SCENES / "sphere_grid.toml").camera
    moved = whole.orbit(cam, 10.0)
    d0 = np.linalg.norm(cam.position - cam.target)
    assert np.linalg.norm(moved.position - moved.target) == pytest.approx(d0)
    assert np.linalg.norm(moved.position - cam.position) == pytest.approx(2 * d0 * np.sin(np.radians(5.0)), rel=1e-6)


def test_whole_frames_time_every_stage(runtime):
    scene = load_scene(SCENES / "sphere_grid.toml")
    out = whole.whole_frames(scene, resolve("lambert"), runtime, 64, 36, frames=2)
    med = out["median_s"]
    assert set(whole.STAGES) <= set(med) and all(med[s] > 0 for s in whole.STAGES)
    assert med["frame"] >= max(med[s] for s in whole.STAGES)
    assert len(out["frames_s"]) == 2


def test_whole_frames_interleave_runtimes_and_judge_each(runtime):
    """One result per runtime (each naming its device, each with every frame), one whole-frame
    target per runtime, and the Markdown table has a column pair per runtime."""
    from clshade.bench import perf
    scene = load_scene(SCENES / "sphere_grid.toml")
    out = whole.whole_frames_on(scene, resolve("lambert"), [runtime, runtime], 64, 36, frames=2)
    assert [len(r["frames_s"]) for r in out] == [2, 2]
    merged = whole.merge_blocks([out, out])
    assert [(r["frames"], r["blocks"]) for r in merged] == [(4, 2), (4, 2)]
    assert merged[0]["median_s"] == out[0]["median_s"]           # the same frames twice: the same medians
    late = [dict(r, frames_s=[dict(f, frame=1.0) for f in r["frames_s"]]) for r in out]
    assert whole.merge_blocks([out, late])[0]["median_s"]["frame"] > out[0]["median_s"]["frame"]
    assert merged[0]["block_frame_s"] == [out[0]["median_s"]["frame"]] * 2
    assert all(r["device"] == runtime.info.description for r in out)
    # The verdicts are judged on stated frame times, not on this machine's (timings are no test's business).
    fast = dict(out[0], median_s=dict(out[0]["median_s"], frame=0.030), low1_fps=25.0)
    slow = dict(out[1], device="slow device", median_s=dict(out[1]["median_s"], frame=0.034), low1_fps=23.0)
    doc = dict(runtimes=[], peers=[], stream=dict(anchor_gbs=1.0), whole_frames=[fast, slow])
    frame_targets = [t for t in perf.targets(doc) if "whole frame" in t["target"]]
    assert [(t["runtime"], t["met"]) for t in frame_targets] == [(runtime.info.description, True)] * 2 + [
        ("slow device", False)] * 2
    assert "34 ms" not in frame_targets[2]["cause"] and "G-buffer" in frame_targets[2]["cause"]
    assert "43 ms" in frame_targets[3]["cause"], frame_targets[3]["cause"]      # 1000 / 23 FPS
    from clshade.report.perf import perf_whole_frame_markdown
    table = next(block for block in perf_whole_frame_markdown(doc["whole_frames"]) if block.startswith("| stage "))
    header = table.splitlines()[0]
    assert header.count("median ms") == 2 and "slow device" in header
    low = next(line for line in table.splitlines() if line.startswith("| whole frames' 1 % low"))
    assert [c.strip() for c in low.strip("|").split("|")][1:] == ["25.0", "", "23.0", ""]


@pytest.mark.extra
@pytest.mark.parametrize("uniform", [False, True])
@pytest.mark.parametrize("name", ["numba", "drjit"])
@pytest.mark.parametrize("model", ["lambert", "ggx_correlated", "phong"])
def test_peer_equals_clshade(runtime, name, model, uniform):
    """Each peer shades sphere_grid (10 materials, roughness 0 → 1, ambient) like the
    kernel: ≤ 1e-4 relative on covered, well-conditioned pixels. With `uniform`, every
    ball's metallic is 0.5 and both sides compile it in (Features.uniform; the peers
    take it as a constant) and trust the G-buffer's unit normals; without, the normals
    have length 2.5 and both sides normalise them."""
    module = {"numba": "numba", "drjit": "drjit"}[name]
    if importlib.util.find_spec(module) is None:
        pytest.skip(f"{module} not installed (pip install 'clshade[peers]')")
    text = (SCENES / "sphere_grid.toml").read_text(encoding="utf-8")
    if uniform:
        text = text.replace("metallic = 0.0", "metallic = 0.5")
    frame = prepare_frame(parse_scene(text), 160, 72)
    gb = frame.gbuffer
    if not uniform:   # normals of length 2.5: a G-buffer that does not promise unit ones
        scaled = np.asarray(gb.channels["normal"], np.float32) * np.float32(2.5)
        gb = dataclasses.replace(gb, channels={**gb.channels, "normal": scaled}, unit_normals=False)
    features = scene_features(frame.scene, geometry=frame.geometry)
    assert dict(features.uniform) == ({"metallic": 0.5} if uniform else {"metallic": 0.0})
    m = resolve(model)
    try:
        peer = peers.PEERS[name](m, gb, frame.scene, frame.camera,
                                 uniform=dict(features.uniform) if uniform else None)
    except RuntimeError as exc:
        pytest.skip(str(exc))
    image = Shader(runtime, gb, frame.scene, frame.camera).render(m, features)
    covered = np.flatnonzero(gb.channels["depth"] > 0)
    good = peers.well_conditioned(m, gb, covered)
    assert good.sum() > 0.5 * len(covered)
    assert peers.verify(peer.run(), image, covered[good]) <= peers.VERIFY_RTOL
    empty = np.flatnonzero(gb.channels["depth"] <= 0)
    np.testing.assert_allclose(peer.run().reshape(-1, 4)[empty], image.reshape(-1, 4)[empty], rtol=1e-6)


def test_peers_leave_out_only_the_ill_conditioned_pixels():
    """well_conditioned: a microfacet lobe's pixels with α below WELL_CONDITIONED_ALPHA (the
    roughness-0 ball of sphere_grid) are left out of the ≤ 1e-4 check, every other pixel
    stays in; a diffuse model keeps them all; the bound is 4·2⁻²³/1e-4."""
    frame = prepare_frame(load_scene(SCENES / "sphere_grid.toml"), 192, 108)
    gb = frame.gbuffer
    covered = np.flatnonzero(gb.channels["depth"] > 0)
    roughness = gb.channels["roughness"]
    # Some pixels at roughness 0.05 (α = 2.5e-3, below the bound, though r is above it).
    roughness[covered[roughness[covered] > 0.5][:50]] = 0.05
    r = roughness[covered]
    assert (r == np.float32(0.05)).sum() == 50
    alpha = np.maximum(r.astype(float) ** 2, peers.MIN_ALPHA)
    assert peers.WELL_CONDITIONED_ALPHA == pytest.approx(4.77e-3, rel=1e-3)
    good = peers.well_conditioned(resolve("ggx_correlated"), gb, covered)
    assert (r == 0).any() and not good[r == 0].any() and not good[r == np.float32(0.05)].any()
    np.testing.assert_array_equal(good, alpha >= peers.WELL_CONDITIONED_ALPHA)
    assert good[r >= 0.07].all() and good.sum() > 0.5 * len(covered)
    assert peers.well_conditioned(resolve("lambert"), gb, covered).all()
    assert "α <" in peers.ill_conditioned_note(resolve("ggx_correlated"))
    assert "exponent" in peers.ill_conditioned_note(resolve("phong"))
    assert peers.ill_conditioned_note(resolve("lambert")) == ""


def test_peer_refuses_models_it_does_not_implement():
    frame = prepare_frame(load_scene(SCENES / "sphere_grid.toml"), 16, 8)
    with pytest.raises(RuntimeError, match="implements"):
        peers._check_supported(resolve("cook_torrance"), frame.scene, "Numba")


def test_runtime_labels_name_what_the_device_string_says():
    """A runtime that is not PoCL keeps its own platform version (Intel's CPU runtime was 'PoCL ?, LLVM ?')."""
    from clshade.report.perf import short_device
    assert short_device("AMD EPYC [OpenCL 3.1 LINUX]") == "AMD EPYC (OpenCL 3.1 LINUX)"
    assert short_device("pthread-AMD EPYC [OpenCL 3.0 PoCL 3.0-rc2  Linux, Release, RELOC, LLVM 14.0.6, SLEEF]") == \
        "pthread-AMD EPYC (PoCL 3.0-rc2, LLVM 14.0.6)"
