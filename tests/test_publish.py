"""Published numbers come from the results JSON: README.md's and REPORT.md's tables (and every other file
benchmarks/publish.py renders) equal their rendering from the JSON, so a number edited by hand fails here."""
from __future__ import annotations

import json
import re

import pytest


@pytest.fixture(scope="module")
def publish(bench_script):
    return bench_script("publish")


@pytest.mark.snapshot
def test_every_published_file_equals_its_rendering(publish):
    stale = publish.stale()
    assert not stale, f"edited by hand or JSON changed without `python benchmarks/publish.py`: {stale}"


def _table_rows(text: str, start: str) -> list[list[str]]:
    block = text[text.index(start):].split("\n\n", 1)[0]
    rows = [line.strip("|").split("|") for line in block.splitlines() if line.startswith("|")]
    return [[c.strip() for c in r] for r in rows[2:]]


@pytest.mark.snapshot
def test_readme_table_numbers_equal_the_json(publish, checkout):
    text = (checkout / "README.md").read_text(encoding="utf-8")
    region = text.split("<!-- publish:bench-table -->", 1)[1]
    rows = _table_rows(region, "| model |")
    bench = json.loads(publish.BENCH_JSON.read_text(encoding="utf-8"))
    assert [r[0] for r in rows] == [m["label"] for m in bench["models"]]
    for cells, m in zip(rows, bench["models"]):
        assert int(cells[1]) == m["frames"]
        assert float(cells[2]) == pytest.approx(m["mean_ms"], abs=0.05)
        assert float(cells[3]) == pytest.approx(m["avg_fps"], abs=0.5)
        assert float(cells[4]) == pytest.approx(m["low1_fps"], abs=0.5)
        assert cells[5] == ("–" if m["frames"] < 1000 else f"{m['low01_fps']:.0f}")
        assert float(cells[6]) == pytest.approx(m["copy_ratio"], abs=0.005)
        assert float(cells[8]) == pytest.approx(m["max_rel_error"], rel=0.006)


def test_report_prints_frames_and_no_low01_below_1000_frames(publish, checkout):
    text = (checkout / "benchmarks" / "REPORT.md").read_text(encoding="utf-8")
    doc = json.loads(publish.REPORT_JSON.read_text(encoding="utf-8"))
    rows = _table_rows(text, "| model | frames |")
    assert len(rows) == len(doc["models"])
    for cells, m in zip(rows, doc["models"]):
        assert int(cells[1]) == m["frames"]
        assert float(cells[2]) == pytest.approx(m["mean_ms"], abs=0.005)
        assert (cells[5] == "–") == (m["frames"] < publish.LOW01_MIN_FRAMES)
    assert ("Noise band:" in text) == (publish.noise_band(doc) is not None)


@pytest.mark.parametrize("which", ["README.md", "benchmarks/REPORT.md"])
def test_a_number_edited_by_hand_is_caught(publish, checkout, which):
    """Change one digit in a table row of the published file: its rendering no longer matches."""
    path = checkout / which
    render = publish.renderings()[path]
    text = path.read_text(encoding="utf-8")
    assert render(text) == text
    rows = [m for m in re.finditer(r"^\| [^|\n]+ \| (\d+) \| (\d+\.\d+) \|", text, re.M)]
    assert rows, f"no numeric table row in {which}"
    m = rows[len(rows) // 2]
    i = m.start(2)
    digit = text[i]
    edited = text[:i] + ("1" if digit != "1" else "2") + text[i + 1:]
    assert render(edited) != edited


def test_every_results_markdown_is_rendered_by_publish(publish, checkout):
    """No results table outside publish: each benchmarks/results/*.md is one of its renderings
    (so test_every_published_file_equals_its_rendering covers it)."""
    rendered = {p.resolve() for p in publish.renderings()}
    tables = sorted((checkout / "benchmarks" / "results").glob("*.md"))
    assert tables and not [p.name for p in tables if p.resolve() not in rendered]


@pytest.mark.text
@pytest.mark.parametrize("notes", ["docs/bench-notes.md", "docs/effects-notes.md"])
def test_dated_notes_say_they_are_history(checkout, notes):
    """Notes with hand-written measured figures say, before any figure, that they are dated history
    no published table quotes (issue 25): current numbers come only from the rendered tables."""
    text = (checkout / notes).read_text(encoding="utf-8")
    head = text.split("\n\n", 2)[1]
    assert head.startswith("> **Dated history — not a published result.**"), head[:120]


def test_a_suspect_numpy_column_is_marked(publish):
    """The straw-man guard's verdict reaches the published tables: a suspect run marks the README's
    × NumPy header and leaves the NumPy target unjudged; a clean run does neither."""
    bench = json.loads(publish.BENCH_JSON.read_text(encoding="utf-8"))
    for bad in (False, True):
        bench["numpy_guard"] = dict(baseline_lambert_ms=20.0 if bad else 12.0, minimal_lambert_ms=10.0,
                                    ratio=2.0 if bad else 1.2, limit=1.5, suspect=bad, frames=25)
        table, targets = publish.readme_bench_table(bench), "\n".join(publish.target_rows(bench))
        assert ("× faster than NumPy (suspect)" in table) == bad
        assert ("not judged (NumPy column suspect)" in targets) == bad
        assert ("SUSPECT" in table) == bad and f"{bench['numpy_guard']['ratio']:.2f}×" in table
