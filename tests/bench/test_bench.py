"""`clshade bench` end to end on a tiny frame: the JSON has every documented key and
sane values (no timing assertions: the machine is shared and noisy)."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from clshade.bench.run import frame_stats, pareto
from clshade.cli import main
from clshade.render.gbuffer import GBuffer

from conftest import CHECKOUT, ORACLE_BOUND, SCENES


def documented_keys(section: str) -> set[str]:
    """Keys listed as `| `key` |` rows under the '## <section>' heading of the schema doc (in the checkout)."""
    if CHECKOUT is None:
        pytest.skip("docs/bench-schema.md is not installed; this check needs the source checkout")
    text = (CHECKOUT / "docs" / "bench-schema.md").read_text(encoding="utf-8")
    body = text.split(f"## {section}", 1)[1].split("\n## ", 1)[0]
    return set(re.findall(r"^\| `([a-z0-9_.]+)` \|", body, re.M))


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> dict:
    out = tmp_path_factory.mktemp("bench") / "bench.json"
    rc = main(["bench", str(SCENES / "sphere_grid.toml"), "-m", "lambert,ggx_correlated",
               "--frames", "20", "--warmup", "2", "--width", "64", "--height", "48", "--numpy-frames", "1",
               "--no-progress", "--json", str(out)])
    assert rc == 0
    return json.loads(out.read_text(encoding="utf-8"))


def test_top_level_keys(report):
    keys = documented_keys("Top level")
    assert keys, "schema doc lists no top-level keys"
    assert keys <= set(report)
    for section, sub in (("machine", "Machine"), ("device", "Device")):
        assert documented_keys(sub) <= set(report[section])
    assert report["width"] == 64 and report["height"] == 48 and report["frames"] == 20


def test_the_build_choices_are_recorded(report):
    """The JSON names the build the kernels ran with (the tuned choice, here today's rule: the suite runs
    with CLSHADE_TUNE=fixed) and what the device compiled; the printed line says the same."""
    from clshade.cli.commands.bench import build_line
    from clshade.device.buildchoice import FIXED
    from clshade.device.runtime import get_runtime
    build = report["device"]["build"]
    rt = get_runtime()
    assert build["choice"] == FIXED.as_dict() and build["source"] == "tuning off: CLSHADE_TUNE=fixed"
    assert (build["simd"], build["local_size"], build["inline_math"], build["streaming_stores"], build["prefetch"]) \
        == (rt.simd, rt.local_size, rt.inline_math, rt.streaming_stores, rt.prefetches)
    line = build_line(build)
    assert line.startswith("build choices: today's rule (tuning off") and f"{rt.simd} lanes" in line


def test_model_rows(report):
    keys = documented_keys("Per model")
    assert {"model", "mean_ms", "avg_fps", "low1_fps", "low01_fps", "median_ms", "p99_ms", "host_overhead_ms",
            "bytes_per_pixel", "copy_ratio", "numpy_ratio", "max_rel_error", "mean_rel_error"} <= keys
    assert [r["model"] for r in report["models"]] == ["lambert", "lambert+ggx_correlated"]
    for row in report["models"]:
        assert keys <= set(row)
        assert row["frames"] == 20
        assert 0 < row["low01_fps"] <= row["low1_fps"] <= row["avg_fps"] * (1 + 1e-9)
        assert row["copy_ratio"] > 0 and row["numpy_ratio"] > 0 and row["lambert_ratio"] > 0
        assert row["p99_ms"] >= row["median_ms"] > 0
        assert 16 < row["bytes_per_pixel"] <= 64
        assert 4 + 16 <= row["mean_bytes_per_pixel"] <= row["bytes_per_pixel"]
        # the error column meets the kernels' bound against the oracle, not a bound 1000× looser
        assert 0 <= row["mean_rel_error"] <= row["max_rel_error"] < ORACLE_BOUND, row


def test_frame_stats_lows():
    frames = np.r_[np.full(999, 10.0), 100.0]
    s = frame_stats(frames, frames + 0.05)
    assert s["low01_fps"] == pytest.approx(10.0)          # the one 100 ms frame
    assert s["low1_fps"] == pytest.approx(1e3 / 19.0)      # ten slowest: 9 × 10 ms + 100 ms
    assert s["host_overhead_ms"] == pytest.approx(0.05)


def test_mean_bytes_per_pixel_counts_the_sky_skip():
    """Work-items with no covered pixel read only depth: a 5×4 frame, SIMD 8 (3 work-items,
    the last padded), one covered pixel in the second work-item."""
    cov = np.zeros((4, 5), bool)
    cov[2, 0] = True                                          # pixel 10: work-item 1
    gb = GBuffer(5, 4, {}, np.zeros((0, 4, 4), np.float32), cov)
    names = ("depth", "normal", "base")                       # 4 + 12 + 12 B
    # work-item 1: 8 pixels × (28 + 16) B; work-items 0 and 2: 8 pixels × (4 + 16) B each
    assert gb.mean_bytes_per_pixel(names, False, 8, 16) == pytest.approx((8 * 44 + 16 * 20) / 20)
    assert gb.mean_bytes_per_pixel(names, True, 1, 16) == pytest.approx(4 + 16 + 12 / 20)


def test_pareto():
    assert pareto([(1, 1), (2, 0.5), (2, 2), (0.5, 3)]) == [True, True, False, True]


@pytest.mark.parametrize("spec", ["lambert", "oren_nayar", "burley", "blinn_phong_normalized", "cook_torrance",
                                  "ggx_correlated@conductor"])
def test_general_reference_f32_matches_kernel(spec):
    """The general reference in float32 (the frame oracle in single precision, timed as its own
    column) is the same shading as shade.cl (within float32 noise)."""
    from clshade.bench.run import Bench
    from clshade.models.registry import Registry
    from clshade.bench.numpy_baseline import shade_reference_f32
    resolve = Registry().resolve          # the built-in lobes
    bench = Bench.prepare(SCENES / "sphere_grid.toml", 64, 48)
    model = resolve(spec)
    case = bench.case(model)
    image = case.shader.render(model, case.features)
    mine = shade_reference_f32(model, bench.frame.gbuffer, bench.frame.scene, bench.frame.camera)
    cov = bench.frame.gbuffer.coverage
    peak = np.abs(mine[cov, :3]).max()
    assert np.abs(image[cov] - mine[cov]).max() <= 1e-4 * peak
    assert np.array_equal(image[~cov], mine[~cov])


def test_numpy_guard(report):
    """The straw-man guard ran in the same rounds: its documented keys, a ratio, a verdict."""
    guard = report["numpy_guard"]
    assert documented_keys("NumPy guard") <= set(guard)
    assert guard["frames"] > 0 and guard["ratio"] > 0 and guard["suspect"] == (guard["ratio"] > guard["limit"])
    for row in report["models"]:
        assert row["numpy_check"] <= 1e-4 and row["numpy_layout"] in ("covered", "all") and row["reference_ratio"] > 0
