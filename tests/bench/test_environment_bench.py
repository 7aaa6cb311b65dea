"""The environment ladder of `clshade bench` (clshade/bench/environment.py): every rung enumerated from the
render module's tuples, each with its error against the float64 truth beside its frame time, the precompute's
bytes, the CLI's refusals, and the Markdown and plot of clshade/report/environment.py."""
from __future__ import annotations

import json

import numpy as np
import pytest

from clshade.bench import environment as B
from clshade.models.registry import Registry
from clshade.render import environment as E
from clshade.report.environment import environment_markdown, environment_plot, environment_results_markdown
from clshade.resources import scenes_dir

from conftest import refused, run_cli

SCENE = scenes_dir() / "environment.toml"
GGX = Registry().resolve("ggx_correlated")
LAMBERT = Registry().resolve("lambert")


def test_the_ladder_is_every_diffuse_by_specular_pair_and_each_n_of_a_sampling_one():
    got = [(r.diffuse, r.specular, r.samples) for r in B.ladder_rungs((1, 4))]
    want = []
    for d in E.DIFFUSE_RUNGS:
        for s in E.SPECULAR_RUNGS:
            want += [(d, s, n) for n in (1, 4)] if "sampled" in (d, s) else [(d, s, None)]
    assert got == want
    assert {(d, s) for d, s, _ in got} == {(d, s) for d in E.DIFFUSE_RUNGS for s in E.SPECULAR_RUNGS}


def test_a_rung_added_to_the_render_module_is_measured(monkeypatch):
    """split_sum joins SPECULAR_RUNGS (the next milestone): the ladder has it with no change here."""
    monkeypatch.setattr(E, "SPECULAR_RUNGS", E.SPECULAR_RUNGS + ("split_sum",))
    got = [(r.diffuse, r.specular, r.samples) for r in B.ladder_rungs((8,))]
    assert ("sh9", "split_sum", None) in got and ("sampled", "split_sum", 8) in got


@pytest.mark.parametrize("text, needle", [("0", "N = 0"), ("4,2048", "N = 2048"), ("a,b", "comma-separated"),
                                          (",", "no N")])
def test_bad_sample_ladders_are_refused(text, needle):
    with pytest.raises(Exception) as exc:
        B.parse_samples(text)
    assert needle in str(exc.value) and "--environment-ladder" in str(exc.value)


@pytest.fixture(scope="module")
def doc():
    return B.run_environment_bench(SCENE, [LAMBERT, GGX], 3, 1, width=40, height=40, samples=(1, 64),
                                   oracle_pixels=48)


def _row(doc, model, d, s, n=None):
    (row,) = [r for r in doc["rows"] if r["model"] == model.id and (r["diffuse"], r["specular"], r["samples"]) == (d, s, n)]
    return row


def test_every_model_and_rung_has_a_row_a_model_without_specular_only_specular_none(doc):
    ggx = {(r["diffuse"], r["specular"], r["samples"]) for r in doc["rows"] if r["model"] == GGX.id}
    lam = {(r["diffuse"], r["specular"], r["samples"]) for r in doc["rows"] if r["model"] == LAMBERT.id}
    assert ggx == {(r.diffuse, r.specular, r.samples) for r in B.ladder_rungs((1, 64))}
    assert lam == {k for k in ggx if k[1] == "none"}
    for r in doc["rows"]:
        assert r["frames"] == 3 and 0 < r["low01_fps"] <= r["low1_fps"] <= r["avg_fps"] * (1 + 1e-9)
        assert r["oracle_pixels"] == 48 and sum(b["pixels"] for b in r["by_nv"]) <= 48


def test_the_error_is_against_the_truth_each_approximation_in_its_place(doc):
    """SH9 beats the constant for Lambert; N = 64 beats N = 1; a GGX robot without its specular is far off."""
    assert _row(doc, LAMBERT, "sh9", "none")["rel_rmse"] < 0.5 * _row(doc, LAMBERT, "constant", "none")["rel_rmse"]
    assert _row(doc, GGX, "sampled", "sampled", 64)["rel_rmse"] < 0.5 * _row(doc, GGX, "sampled", "sampled", 1)["rel_rmse"]
    assert _row(doc, GGX, "sh9", "none")["rel_rmse"] > _row(doc, GGX, "sh9", "sampled", 64)["rel_rmse"]
    # Cost is linear in N: 64 samples take far longer than one (noise cannot make that ratio small).
    assert _row(doc, GGX, "sampled", "sampled", 64)["mean_ms"] > 5 * _row(doc, GGX, "sampled", "sampled", 1)["mean_ms"]


def test_the_precompute_counts_every_array_it_keeps(doc):
    pre = doc["precompute"]
    w, h = pre["size"]
    assert pre["bytes"]["sh9"] == 9 * 3 * 8 and pre["bytes"]["conditional"] == h * (w + 1) * 4
    assert pre["bytes"]["radiance"] == h * w * 3 * 4 and pre["total_bytes"] == sum(pre["bytes"].values())
    assert pre["ms"] > 0 and pre["device_bytes"] == (11 * 4 + h * w * 4 + (h + 1) + h * (w + 1)) * 4


def test_markdown_and_plot(doc, tmp_path):
    text = environment_markdown(doc)
    table = text[text.index("## The ladder"):text.index("## Error by n·v")]
    assert sum(1 for line in table.splitlines() if line.startswith("| lambert")) == len(doc["rows"])
    assert "What each approximation buys" in text and "× Lambert's time" in text
    both = environment_results_markdown(dict(command="x", runs=[doc, doc], skipped=[dict(map="m.exr", reason="absent")]))
    assert both.count("### The ladder") == 2 and "skipped m.exr: absent" in both
    environment_plot([doc], tmp_path / "p.png")
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"


def test_cli_bench_on_a_sky_writes_the_ladder(capsys, tmp_path):
    out = tmp_path / "env.json"
    code, text, _ = run_cli(capsys, ["bench", str(SCENE), "-m", "lambert", "--width", "24", "--height", "24",
                                     "--frames", "2", "--warmup", "0", "--environment-ladder", "2",
                                     "--oracle-pixels", "16", "--json", str(out), "--no-progress"])
    assert code == 0 and "## The ladder" in text
    doc = json.loads(out.read_text())
    assert doc["schema"] == B.SCHEMA and doc["sample_ladder"] == [2]
    assert {r["rung"] for r in doc["rows"]} == {"constant/none", "sh9/none", "sampled/none N=2"}


@pytest.mark.parametrize("extra, needle", [(["--environment-ladder", "0"], "N = 0"), (["--csv", "x.csv"], "--csv"),
                                           (["--oracle-pixels", "0"], "--oracle-pixels")])
def test_cli_refusals_on_a_sky(capsys, extra, needle):
    refused(capsys, ["bench", str(SCENE), "-m", "lambert", *extra], needle)


def test_cli_ladder_flags_need_a_sky(capsys):
    refused(capsys, ["bench", str(scenes_dir() / "red_ball.toml"), "--environment-ladder", "4"],
            "--environment-ladder", "no [environment]")
