"""Published numbers come from the results JSON: README.md's and REPORT.md's tables (and every other text
`python -m benchmarks.publish` renders, as the results registry lists them) equal their rendering from the
JSON, so a number edited by hand fails here."""
from __future__ import annotations

import json
import re
import subprocess

import pytest

from clshade.report.bench import LOW01_MIN_FRAMES, readme_table, targets_table
from clshade.report.study import noise_band
from clshade.report.tables import MISSING

publish = pytest.importorskip("benchmarks.publish.render", reason="needs the source checkout's benchmarks/")
from benchmarks.publish import freshness  # noqa: E402
from benchmarks.publish.registry import Rendering, Result  # noqa: E402

BENCH_JSON = "benchmarks/results/bench_1080p.json"
REPORT_JSON = "benchmarks/report/report.json"


@pytest.mark.snapshot
def test_every_published_file_equals_its_rendering(checkout):
    stale = publish.stale(checkout)
    assert not stale, f"edited by hand or JSON changed without `python -m benchmarks.publish`: {stale}"


def _table_rows(text: str, start: str) -> list[list[str]]:
    block = text[text.index(start):].split("\n\n", 1)[0]
    rows = [line.strip("|").split("|") for line in block.splitlines() if line.startswith("|")]
    return [[c.strip() for c in r] for r in rows[2:]]


@pytest.mark.snapshot
def test_readme_table_numbers_equal_the_json(checkout):
    text = (checkout / "README.md").read_text(encoding="utf-8")
    region = text.split("<!-- publish:bench-table -->", 1)[1]
    rows = _table_rows(region, "| model ")
    bench = json.loads((checkout / BENCH_JSON).read_text(encoding="utf-8"))
    assert [r[0] for r in rows] == [m["label"] for m in bench["models"]]
    for cells, m in zip(rows, bench["models"]):
        assert int(cells[1]) == m["frames"]
        assert float(cells[2]) == pytest.approx(m["mean_ms"], abs=0.05)
        assert float(cells[3]) == pytest.approx(m["avg_fps"], abs=0.5)
        assert float(cells[4]) == pytest.approx(m["low1_fps"], abs=0.5)
        assert cells[5] == (MISSING if m["frames"] < 1000 else f"{m['low01_fps']:.0f}")
        assert float(cells[6]) == pytest.approx(m["copy_ratio"], abs=0.005)
        assert float(cells[8]) == pytest.approx(m["max_rel_error"], rel=0.006)


def test_report_prints_frames_and_no_low01_below_1000_frames(checkout):
    text = (checkout / "benchmarks" / "REPORT.md").read_text(encoding="utf-8")
    doc = json.loads((checkout / REPORT_JSON).read_text(encoding="utf-8"))
    rows = _table_rows(text, "| model ")
    assert len(rows) == len(doc["models"])
    for cells, m in zip(rows, doc["models"]):
        assert int(cells[1]) == m["frames"]
        assert float(cells[2]) == pytest.approx(m["mean_ms"], abs=0.005)
        assert (cells[5] == MISSING) == (m["frames"] < LOW01_MIN_FRAMES)
    assert ("Noise band:" in text) == (noise_band(doc) is not None)


@pytest.mark.parametrize("which", ["README.md", "benchmarks/REPORT.md"])
def test_a_number_edited_by_hand_is_caught(checkout, which):
    """Change one digit in a table row of the published file: its rendering no longer matches."""
    path = checkout / which
    render = publish.renderings(checkout)[path]
    text = path.read_text(encoding="utf-8")
    assert render(text) == text
    rows = [m for m in re.finditer(r"^\| [^|\n]+ \| +(\d+) +\| +(\d+\.\d+) +\|", text, re.M)]
    assert rows, f"no numeric table row in {which}"
    m = rows[len(rows) // 2]
    i = m.start(2)
    digit = text[i]
    edited = text[:i] + ("1" if digit != "1" else "2") + text[i + 1:]
    assert render(edited) != edited


def test_every_results_markdown_is_rendered_by_publish(checkout):
    """No results table outside publish: each benchmarks/results/*.md is one of its renderings
    (so test_every_published_file_equals_its_rendering covers it)."""
    rendered = {p.resolve() for p in publish.renderings(checkout)}
    tables = sorted((checkout / "benchmarks" / "results").glob("*.md"))
    assert tables and not [p.name for p in tables if p.resolve() not in rendered]


@pytest.mark.text
@pytest.mark.parametrize("notes", ["docs/bench-notes.md", "docs/effects-notes.md"])
def test_dated_notes_say_they_are_history(checkout, notes):
    """Notes with hand-written measured figures say, before any figure, that they are dated history
    no published table quotes: current numbers come only from the rendered tables."""
    text = (checkout / notes).read_text(encoding="utf-8")
    head = text.split("\n\n", 2)[1]
    assert head.startswith("> **Dated history — not a published result.**"), head[:120]


def test_a_suspect_numpy_column_is_marked(checkout):
    """The straw-man guard's verdict reaches the published tables: a suspect run marks the README's
    × NumPy header and leaves the NumPy target unjudged; a clean run does neither."""
    bench = json.loads((checkout / BENCH_JSON).read_text(encoding="utf-8"))
    for bad in (False, True):
        bench["numpy_guard"] = dict(baseline_lambert_ms=20.0 if bad else 12.0, minimal_lambert_ms=10.0,
                                    ratio=2.0 if bad else 1.2, limit=1.5, suspect=bad, frames=25)
        table, targets = readme_table(bench), targets_table(bench)
        assert ("× faster than NumPy (suspect)" in table) == bad
        assert ("not judged (NumPy column suspect)" in targets) == bad
        assert ("SUSPECT" in table) == bad and f"{bench['numpy_guard']['ratio']:.2f}×" in table


def test_one_registry_entry_drives_publish_freshness_and_the_command_list(tmp_path):
    """Adding a result is one entry: its JSON is rendered into its file and its region, its producers
    decide its freshness, and README's command list names its command."""
    root = tmp_path
    subprocess.run(["git", "init", "-q", str(root)], check=True)
    (root / "measure.py").write_text("x = 1\n")
    (root / "out").mkdir()
    (root / "out" / "r.json").write_text(json.dumps({"value": 1.5}))
    (root / "README.md").write_text("# R\n\n<!-- publish:value -->\nold\n<!-- /publish:value -->\n\n"
                                    "<!-- publish:results-commands -->\nold\n<!-- /publish:results-commands -->\n")
    subprocess.run(["git", "-C", str(root), "add", "-A"], check=True)
    subprocess.run(["git", "-C", str(root), "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "c"],
                   check=True)
    entry = Result("out/r.json", "python -m measure", ("measure.py",),
                   (Rendering("out/r.md", lambda doc: f"# value {doc['value']}\n"),
                    Rendering("README.md", lambda doc: f"value = {doc['value']:.2f}", "value")), "a value")
    assert sorted(p.relative_to(root).as_posix() for p in publish.stale(root, (entry,))) == ["README.md", "out/r.md"]
    for path, render in publish.renderings(root, (entry,)).items():
        path.write_text(render(path.read_text() if path.exists() else ""))
    assert publish.stale(root, (entry,)) == []
    assert (root / "out" / "r.md").read_text() == "# value 1.5\n"
    readme = (root / "README.md").read_text()
    assert "value = 1.50" in readme and "# out/r.json: a value\npython -m measure\n" in readme
    assert freshness.staleness(root, (entry,)) == {"out/r.json": []}
