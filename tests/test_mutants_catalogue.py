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


def test_a_resumed_run_names_its_commit_only_when_every_row_ran_there(mutants, tmp_path, monkeypatch):
    """--resume runs the rows not measured on this commit; the file names the commit only once all are."""
    import json
    cat = mutants.CATALOGUE[:3]
    def row(m, commit, status="killed"):
        return dict(name=m.name, file=m.file, description=m.description, status=status, kill_class="behavioural",
                    returncode=1, failing_tests=[], seconds=1.0, summary="", commit=commit)
    previous = dict(commit="old", provenance={"commit": "old"},
                    mutants=[row(cat[0], "new"), row(cat[1], "old"), row(cat[2], None, "not run")])
    todo = mutants.still_to_run(cat, previous, "new")
    assert [m.name for m in todo] == [cat[1].name, cat[2].name]
    assert mutants.still_to_run(cat, previous, None) == cat
    out = tmp_path / "m.json"
    monkeypatch.setattr(mutants, "CATALOGUE", cat)
    doc = mutants.write_results(out, [row(todo[0], "new")], todo, previous, "new", 1.0)
    assert doc["provenance"]["commit"] == "old" and doc["not_run"] == 1      # one row still missing
    previous = json.loads(out.read_text())
    assert [m.name for m in mutants.still_to_run(cat, previous, "new")] == [cat[2].name]
    doc = mutants.write_results(out, [row(cat[2], "new")], [cat[2]], previous, "new", 1.0)
    assert doc["provenance"]["commit"] == "new" and doc["not_run"] == 0
    assert [r["commit"] for r in doc["mutants"]] == ["new"] * 3


def test_results_name_the_last_commit_of_the_catalogue_s_code(mutants, tmp_path, scratch_repo):
    """A commit of results only after the code's last change: the run (and --resume) names the code's commit."""
    git = scratch_repo
    for path, text, message in (("clshade/a.py", "x = 1\n", "code"), ("tests/test_a.py", "y = 2\n", "tests"),
                                ("benchmarks/results/mutants.json", "{}\n", "results"),
                                ("README.md", "r\n", "docs")):
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text(text)
        git("add", path)
        git("commit", "-qm", message)
    tests_commit = git("log", "-1", "--format=%H", "--", "tests")
    assert git("rev-parse", "HEAD") != tests_commit
    assert mutants.code_commit(tmp_path) == tests_commit


def test_the_plugin_tells_a_failed_build_from_a_wrong_build_message(tmp_path):
    """A test that wanted a program and got a build failure is a compile-error kill; a test that
    checks a build error's message (its assertion quotes it) and finds it wrong is a behavioural one."""
    import json
    import subprocess
    import sys
    from pathlib import Path
    bench = Path(__file__).resolve().parents[1] / "benchmarks"
    sys.path.insert(0, str(bench))
    try:
        from mutant_plugin import BUILD_FAILED      # not spelled out here: this test's own report would quote it
    finally:
        sys.path.remove(str(bench))
    (tmp_path / "test_builds.py").write_text(
        f"MESSAGE = 'clshade: error: {BUILD_FAILED} for lambert: <kernel>:3: error'\n"
        "class BuildError(Exception):\n    pass\n"
        "def test_wanted_a_program():\n    raise BuildError(MESSAGE)\n"
        "def test_checks_the_message():\n    assert 'lambert.cl:3' in MESSAGE, MESSAGE\n"
        "def test_other():\n    assert 1 == 2\n")
    report = tmp_path / "report.json"
    env = {**__import__("os").environ, "CLSHADE_MUTANT_REPORT": str(report), "PYTHONPATH": str(bench)}
    subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "mutant_plugin",
                    str(tmp_path / "test_builds.py")], cwd=tmp_path, env=env, capture_output=True, timeout=120)
    got = {f["test"].split("::")[1]: f["build_failed"] for f in json.loads(report.read_text())}
    assert got == {"test_wanted_a_program": True, "test_checks_the_message": False, "test_other": False}
