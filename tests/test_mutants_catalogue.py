"""The mutation-testing catalogue (benchmarks/mutants.py) tracks the code: every mutant's original snippet occurs
exactly once in its file, so a refactor that moves a snippet fails here until the catalogue follows."""
from __future__ import annotations

import os

import pytest


@pytest.fixture(scope="module")
def mutants(bench_script):
    return bench_script("mutants")


def test_every_snippet_found_once(mutants, checkout):
    if os.environ.get("CLSHADE_MUTANT"):
        pytest.skip("running inside a mutant's copy (its snippet is replaced there by design)")
    assert len(mutants.CATALOGUE) >= 40
    mutants.check_catalogue(checkout)


def test_a_missing_snippet_is_an_error(mutants, tmp_path):
    (tmp_path / "kernels").mkdir()
    (tmp_path / "kernels" / "brdf.h").write_text("nothing to mutate here\n")
    with pytest.raises(SystemExit, match="found 0 times"):
        mutants.apply(tmp_path, mutants.Mutant("x", "kernels/brdf.h", "return a2;", "return 0;", "test"))


def test_results_file_is_the_catalogue(mutants):
    """The committed results name exactly the catalogue's mutants (rerun after changing the catalogue)."""
    import json
    if not mutants.OUT.exists():
        pytest.skip("no committed results yet")
    doc = json.loads(mutants.OUT.read_text(encoding="utf-8"))
    assert [m["name"] for m in doc["mutants"]] == [m.name for m in mutants.CATALOGUE]
    timeouts = sum(m["status"] == "timeout" for m in doc["mutants"])     # hung past the runner's limit
    assert doc["killed"] + doc["survived"] + timeouts + doc.get("not_run", 0) == doc["total"] == len(doc["mutants"])


def test_kill_classes(mutants):
    """A kill is behavioural only when some failing test checks behaviour; tests marked snapshot,
    text or extra, kernels that do not build and collection errors are counted apart."""
    def f(markers=(), when="call", build_failed=False):
        return dict(test="t", when=when, markers=list(markers), build_failed=build_failed, message="")
    assert mutants.classify([], 0) == "survived" and mutants.classify([], -1) == "timeout"
    assert mutants.classify([f(["snapshot"]), f()], 1) == "behavioural"
    assert mutants.classify([f(["snapshot"]), f(["text"])], 1) == "snapshot"
    assert mutants.classify([f(["text"])], 1) == "text"
    assert mutants.classify([f(["extra"])], 1) == "needs extra"
    assert mutants.classify([f(build_failed=True), f(["text"])], 1) == "compile error"
    assert mutants.classify([f(when="collect")], 2) == "collection error"
    assert mutants.classify([], 2) == "collection error"      # pytest failed before any test ran
