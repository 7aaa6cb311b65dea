"""The mutation-testing catalogue (benchmarks/mutation/catalogue.toml) tracks the code, and its runner
(benchmarks/mutation/run.py) classifies and records what each mutant did.

Each mutant is anchored to a file, a function in it and a text once inside that function. In this suite a catalogue
error (a malformed entry, a duplicate name, a text found twice inside its anchor) fails; a mutant whose anchor is
gone from the tree is reported, not failed: the catalogue test is an expected failure naming every such mutant
(pytest's -ra summary lists it), and the runner gives it the status "anchor gone" (`--check` lists it)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import pytest


@pytest.fixture(scope="module")
def run(checkout):
    from benchmarks.mutation import run
    return run


@pytest.fixture(scope="module")
def catalogue(checkout):
    from benchmarks.mutation import catalogue
    return catalogue


def test_every_mutant_resolves(catalogue, checkout):
    if os.environ.get("CLSHADE_MUTANT"):
        pytest.skip("running inside a mutant's copy (its text is replaced there by design)")
    mutants = catalogue.load()
    assert len(mutants) >= 40
    sites = catalogue.resolve_all(checkout, mutants)           # a catalogue error raises here
    moved = [f"{s.mutant.name} ({s.mutant.file} -> {s.file})" for s in sites if s.moved]
    if moved:
        warnings.warn(f"{len(moved)} mutants moved to another file (python -m benchmarks.mutation.run "
                      f"--fix-moved): {', '.join(moved)}", stacklevel=1)
    gone = [f"{s.mutant.name}: {s.gone}" for s in sites if s.gone]
    if gone:
        pytest.xfail(f"{len(gone)} mutants with their anchor gone: " + "; ".join(gone))


# ---- the loader and the anchors, on small files

PY = textwrap.dedent('''\
    LIMIT = 3


    def scale(x):
        return x * 2


    class Box:
        size = 4

        def area(self):
            return self.size * 2
    ''')

C = textwrap.dedent('''\
    #define SQ(x) ((x) * (x))
    #if WIDE
    #define LANES 8
    #else
    #define LANES 4
    #endif
    typedef struct { float a; float b; } pair;

    /* a { in a comment does not count, nor a "{" in a string */
    INLINE float
    D_term(float a2, float d)
    {
        return a2 / (3.14f * d * d);
    }

    OVL float clamp01(float x) { return fmin(fmax(x, 0.0f), 1.0f); }
    OVL float4 clamp01(float4 x) { return fmin(fmax(x, 0.0f), 1.0f) * 1.0f; }

    __kernel __attribute__((reqd_work_group_size(64, 1, 1))) void shade(__global float *out, PARAMS(a, b))
    {
        out[0] = D_term(1.0f, 2.0f) * 2.0f;
    }
    ''')


def _tree(tmp_path: Path, files: dict[str, str], entries: list[dict]) -> Path:
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text, encoding="utf-8")
    body = "".join("[[mutant]]\n" + "".join(f"{k} = {json.dumps(v)}\n" for k, v in e.items()) + "\n"
                   for e in entries)
    (tmp_path / "catalogue.toml").write_text(body, encoding="utf-8")
    return tmp_path / "catalogue.toml"


def _entry(name: str, file: str, anchor: str, original: str, replacement: str = "0") -> dict:
    return dict(name=name, file=file, anchor=anchor, original=original, replacement=replacement, description="d")


def _sites(catalogue, tmp_path, files, entries):
    return catalogue.resolve_all(tmp_path, catalogue.load(_tree(tmp_path, files, entries)))


def test_a_text_elsewhere_in_the_file_does_not_count(catalogue, tmp_path):
    """`* 2` occurs in scale and in Box.area: anchored, each mutant still finds exactly one."""
    sites = _sites(catalogue, tmp_path, {"m.py": PY}, [_entry("a", "m.py", "scale", "* 2"),
                                                        _entry("b", "m.py", "Box.area", "* 2"),
                                                        _entry("c", "m.py", "Box", "size = 4"),
                                                        _entry("d", "m.py", "LIMIT", "3")])
    assert all(not s.gone and not s.moved for s in sites)
    assert [PY[:s.start].count("\n") + 1 for s in sites] == [5, 12, 9, 1]


def test_a_function_moved_within_its_file_still_resolves(catalogue, tmp_path):
    entries = [_entry("py", "m.py", "Box.area", "self.size * 2", "self.size"),
               _entry("c", "k.h", "D_term", "d * d", "d")]
    moved_py = PY.replace("class Box:", "def first():\n    return 1\n\n\nclass Box:").replace(
        "LIMIT = 3\n", "") + "\n\ndef scale_again(x):\n    return x * 3\n"
    moved_c = C.replace("/* a { in a comment", "float other(float x) { return x * 2.0f; }\n/* a { in a comment")
    for py, c in ((PY, C), (moved_py, moved_c)):
        sites = _sites(catalogue, tmp_path, {"m.py": py, "k.h": c}, entries)
        for s in sites:
            catalogue.apply(tmp_path, s)
        assert not any(s.gone or s.moved for s in sites)
        assert (tmp_path / "m.py").read_text() == py.replace("self.size * 2", "self.size")
        assert (tmp_path / "k.h").read_text() == c.replace("d * d", "d")


def test_a_text_twice_in_its_function_is_an_error_naming_the_mutant(catalogue, tmp_path):
    twice = PY.replace("return x * 2", "y = x * 2\n    return y * 2")
    with pytest.raises(catalogue.CatalogueError, match=r"mutant doubled: text found 2 times in scale of m\.py"):
        _sites(catalogue, tmp_path, {"m.py": twice}, [_entry("fine", "m.py", "Box.area", "* 2"),
                                                      _entry("doubled", "m.py", "scale", "* 2")])


def test_a_gone_function_is_reported_not_raised(catalogue, run, tmp_path, capsys):
    entries = [_entry("kept", "m.py", "scale", "* 2"), _entry("renamed", "m.py", "area", "* 2"),
               _entry("edited", "k.h", "D_term", "d * d * d"), _entry("no_file", "gone.py", "vanished", "* 2")]
    sites = _sites(catalogue, tmp_path, {"m.py": PY, "k.h": C}, entries)
    assert [bool(s.gone) for s in sites] == [False, True, True, True]
    assert "no area in m.py" in sites[1].gone
    assert "D_term of k.h no longer holds the text" in sites[2].gone
    assert "gone.py not found" in sites[3].gone
    with pytest.raises(catalogue.CatalogueError, match="renamed: anchor gone"):
        catalogue.apply(tmp_path, sites[1])
    assert run.check(sites) == 1
    out = capsys.readouterr().out
    assert "anchor gone      renamed" in out and "4 mutants: 1 resolved (0 moved to another file), 3 anchor gone" in out
    row = run.gone_row(sites[1])
    assert row["status"] == row["kill_class"] == "anchor gone" and "no area in m.py" in row["summary"]


def test_a_function_moved_to_another_file_resolves_there_only_if_unambiguous(catalogue, tmp_path):
    rest = PY.replace("def scale(x):\n    return x * 2\n", "")
    entry = [_entry("scale", "a/m.py", "scale", "x * 2")]
    sites = _sites(catalogue, tmp_path, {"a/m.py": rest, "b/n.py": "def scale(x):\n    return x * 2\n"}, entry)
    assert sites[0].moved and sites[0].file == "b/n.py" and not sites[0].gone
    (tmp_path / "c.py").write_text("def scale(x):\n    return x * 2\n")
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "t.py").write_text("def scale(x):\n    return x * 2\n")      # tests are not searched
    sites = catalogue.resolve_all(tmp_path, catalogue.load(tmp_path / "catalogue.toml"))
    assert "in 2 files (b/n.py, c.py): ambiguous" in sites[0].gone


def test_a_kernel_function_moved_from_a_header_to_a_cl_file_resolves_there(catalogue, tmp_path):
    header = C[:C.index("INLINE float\nD_term")]
    sites = _sites(catalogue, tmp_path, {"kernels/k.h": header, "kernels/shade.cl": C},
                   [_entry("d", "kernels/k.h", "D_term", "d * d")])
    assert sites[0].file == "kernels/shade.cl" and C[sites[0].start:sites[0].end] == "d * d"


def test_fix_moved_rewrites_only_the_moved_files(catalogue, tmp_path):
    path = _tree(tmp_path, {}, [_entry("a", "old.py", "f", "x"), _entry("b", "old.py", "g", "y")])
    text = "# a comment\n" + path.read_text()
    path.write_text(text)
    catalogue.rewrite_files(path, {"b": "new/place.py"})
    assert path.read_text() == text.replace('file = "old.py"\nanchor = "g"', "file = 'new/place.py'\nanchor = \"g\"")
    assert [m.file for m in catalogue.load(path)] == ["old.py", "new/place.py"]


def test_c_anchors(catalogue):
    """Functions with the return type on a line of their own, overloads (one anchor), kernels with attributes,
    macros defined under #if alternatives (one anchor), typedefs, and the top level."""
    from benchmarks.mutation.anchors import TOP, regions
    found = regions("k.h", C)
    spans: dict[str, list[str]] = {}
    for r in found:
        spans.setdefault(r.name, []).append(C[r.start:r.end])
    assert spans["D_term"] == ["INLINE float\nD_term(float a2, float d)\n{\n    return a2 / (3.14f * d * d);\n}\n"]
    assert len(spans["clamp01"]) == 2 and spans["LANES"] == ["#define LANES 8\n", "#define LANES 4\n"]
    assert spans["shade"][0].startswith("__kernel") and spans["shade"][0].endswith("}\n")
    assert spans["pair"] == ["typedef struct { float a; float b; } pair;\n"]
    assert spans["SQ"] == ["#define SQ(x) ((x) * (x))\n"]
    assert "#if WIDE" in "".join(spans[TOP]) and "D_term(" not in "".join(spans[TOP])
    assert "PARAMS" not in spans and "fmin" not in spans and "__attribute__" not in spans


def test_javascript_anchors(catalogue):
    from benchmarks.mutation.anchors import regions
    js = "const s = `{${a}`;\nfunction draw() {\n  if (x) { go(\"}\"); }\n  function inner(y) { return y; }\n}\n"
    found = {r.name: js[r.start:r.end] for r in regions("v.js", js)}
    assert found["draw"] == js[js.index("function draw"):]
    assert found["inner"] == "  function inner(y) { return y; }\n"


def test_malformed_catalogues(catalogue, tmp_path):
    path = _tree(tmp_path, {}, [_entry("a", "m.py", "f", "x"), _entry("a", "n.py", "f", "x")])
    with pytest.raises(catalogue.CatalogueError, match="duplicate mutant names: a"):
        catalogue.load(path)
    path.write_text('[[mutant]]\nname = "b"\nfile = "m.py"\noriginal = "x"\n')
    with pytest.raises(catalogue.CatalogueError, match="mutant b: needs exactly the string fields"):
        catalogue.load(path)
    _tree(tmp_path, {}, [_entry("c", "notes.txt", "f", "x")])
    with pytest.raises(catalogue.CatalogueError, match="notes.txt is not a file with anchors"):
        catalogue.load(path)


# ---- the runner's results


def test_results_file_is_the_catalogue(run, catalogue):
    """The committed results name exactly the catalogue's mutants (rerun after changing the catalogue)."""
    if not run.OUT.exists():
        pytest.skip("no committed results yet")
    doc = json.loads(run.OUT.read_text(encoding="utf-8"))
    assert [m["name"] for m in doc["mutants"]] == [m.name for m in catalogue.load()]
    timeouts = sum(m["status"] == "timeout" for m in doc["mutants"])     # hung past the runner's limit
    assert doc["killed"] + doc["survived"] + timeouts + doc.get("not_run", 0) + doc.get("anchor_gone", 0) \
        == doc["total"] == len(doc["mutants"])


def test_kill_classes(run):
    """A kill is behavioural only when some failing test checks behaviour; tests marked snapshot,
    text or extra, kernels that do not build and collection errors are counted apart."""
    def f(markers=(), when="call", build_failed=False):
        return dict(test="t", when=when, markers=list(markers), build_failed=build_failed, message="")
    assert run.classify([], 0) == "survived" and run.classify([], -1) == "timeout"
    assert run.classify([f(["snapshot"]), f()], 1) == "behavioural"
    assert run.classify([f(["snapshot"]), f(["text"])], 1) == "snapshot"
    assert run.classify([f(["text"])], 1) == "text"
    assert run.classify([f(["extra"])], 1) == "needs extra"
    assert run.classify([f(build_failed=True), f(["text"])], 1) == "compile error"
    assert run.classify([f(when="collect")], 2) == "collection error"
    assert run.classify([], 2) == "collection error"      # pytest failed before any test ran


def test_a_resumed_run_names_its_commit_only_when_every_row_ran_there(run, catalogue, tmp_path):
    """--resume runs the rows not measured on this commit; the file names the commit only once all are."""
    cat = catalogue.load()[:3]
    def row(m, commit, status="killed"):
        return dict(name=m.name, file=m.file, description=m.description, status=status, kill_class="behavioural",
                    returncode=1, failing_tests=[], seconds=1.0, summary="", commit=commit)
    previous = dict(commit="old", provenance={"commit": "old"},
                    mutants=[row(cat[0], "new"), row(cat[1], "old"), row(cat[2], None, "not run")])
    todo = run.still_to_run(cat, previous, "new")
    assert [m.name for m in todo] == [cat[1].name, cat[2].name]
    assert run.still_to_run(cat, previous, None) == cat
    out = tmp_path / "m.json"
    doc = run.write_results(out, [row(todo[0], "new")], todo, cat, previous, "new", 1.0)
    assert doc["provenance"]["commit"] == "old" and doc["not_run"] == 1      # one row still missing
    previous = json.loads(out.read_text())
    assert [m.name for m in run.still_to_run(cat, previous, "new")] == [cat[2].name]
    gone = dict(row(cat[2], "new", "anchor gone"), kill_class="anchor gone")
    doc = run.write_results(out, [gone], [cat[2]], cat, previous, "new", 1.0)
    assert doc["provenance"]["commit"] == "new" and doc["not_run"] == 0 and doc["anchor_gone"] == 1
    assert [r["commit"] for r in doc["mutants"]] == ["new"] * 3
    assert run.still_to_run(cat, json.loads(out.read_text()), "new") == []     # gone on this commit: not rerun


def test_results_name_the_last_commit_of_the_catalogue_s_code(checkout, tmp_path, scratch_repo):
    """A commit of results only after the code's last change: the run (and --resume) names the code's commit."""
    from benchmarks.mutation.snapshot import code_commit
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
    assert code_commit(tmp_path) == tests_commit


def plugin_env(checkout, report) -> dict[str, str]:
    """The environment of a pytest run with the runner's plugin, writing to `report`: without the variables of a
    mutant run this test may itself be part of (its stop at the first kill would cut the run short)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("CLSHADE_MUTANT")}
    return dict(env, CLSHADE_MUTANT_REPORT=str(report), PYTHONPATH=str(checkout))


def test_the_plugin_tells_a_failed_build_from_a_wrong_build_message(checkout, tmp_path):
    """A test that wanted a program and got a build failure is a compile-error kill; a test that
    checks a build error's message (its assertion quotes it) and finds it wrong is a behavioural one."""
    from benchmarks.mutation.plugin import BUILD_FAILED     # not spelled out here: this test's report would quote it
    (tmp_path / "test_builds.py").write_text(
        f"MESSAGE = 'clshade: error: {BUILD_FAILED} for lambert: <kernel>:3: error'\n"
        "class BuildError(Exception):\n    pass\n"
        "def test_wanted_a_program():\n    raise BuildError(MESSAGE)\n"
        "def test_checks_the_message():\n    assert 'lambert.cl:3' in MESSAGE, MESSAGE\n"
        "def test_other():\n    assert 1 == 2\n")
    report = tmp_path / "report.json"
    env = plugin_env(checkout, report)
    subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "benchmarks.mutation.plugin",
                    str(tmp_path / "test_builds.py")], cwd=tmp_path, env=env, capture_output=True, timeout=120)
    got = {f["test"].split("::")[1]: f["build_failed"] for f in json.loads(report.read_text())}
    assert got == {"test_wanted_a_program": True, "test_checks_the_message": False, "test_other": False}


def test_the_plugin_stops_at_the_first_behavioural_kill_only(checkout, tmp_path):
    """With the stop on, a mutant's run ends at its first behavioural failure of a test that passes on the
    unmutated tree; a baseline failure, a snapshot-marked failure and a build failure do not stop it; off, every
    test runs."""
    from benchmarks.mutation.plugin import BUILD_FAILED
    (tmp_path / "test_order.py").write_text(
        "import pytest\n"
        "def test_a_baseline_failure():\n    assert 0\n"
        "@pytest.mark.snapshot\ndef test_b_snapshot():\n    assert 0\n"
        f"def test_c_build():\n    raise RuntimeError('{BUILD_FAILED} for lambert')\n"
        "def test_d_passes():\n    pass\n"
        "def test_e_behaviour():\n    assert 0\n"
        "def test_f_after():\n    assert 0\n")
    (tmp_path / "pytest.ini").write_text("[pytest]\nmarkers =\n    snapshot: x\n")
    def failing(stop: bool) -> tuple[list[str], int]:
        report = tmp_path / "report.json"
        env = plugin_env(checkout, report)
        if stop:
            env.update(CLSHADE_MUTANT_STOP="1",
                       CLSHADE_MUTANT_BASELINE=json.dumps(["test_order.py::test_a_baseline_failure"]))
        proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p",
                               "benchmarks.mutation.plugin", "test_order.py"], cwd=tmp_path, env=env,
                              capture_output=True, timeout=120)
        return [f["test"].split("::")[1] for f in json.loads(report.read_text())], proc.returncode
    assert failing(stop=True) == (["test_a_baseline_failure", "test_b_snapshot", "test_c_build", "test_e_behaviour"], 1)
    assert failing(stop=False) == (["test_a_baseline_failure", "test_b_snapshot", "test_c_build", "test_e_behaviour",
                                    "test_f_after"], 1)
