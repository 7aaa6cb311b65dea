"""The mutation runner's test selection (benchmarks/mutation/impact.py): a test file is left out of a mutant's run only
when its recording shows it cannot reach the mutated code. A selection that drops a file which reaches the code would
turn kills into survivors silently, so each rule is checked on a small project recorded for real."""
from __future__ import annotations

import os
import sys
import textwrap

import pytest

pytest.importorskip("coverage", reason="the impact recorder needs coverage (pip install '.[test]')")


@pytest.fixture(scope="module")
def impact(checkout):
    from benchmarks.mutation import impact
    return impact


def _lines(impact, text: str, snippet: str) -> range:
    """The lines a mutant of `snippet` (once in `text`) covers."""
    start = text.index(snippet)
    return impact.mutated_lines(text, start, start + len(snippet))


MODULE = textwrap.dedent('''\
    import os
    SCALE = 2.0


    def double(x, offset=0.0):
        total = (x *
                 SCALE)
        return total + offset


    def negate(x):
        return -x


    def kernel_text():
        with open(os.path.join(os.path.dirname(__file__), "..", "kernels", "k.h"), encoding="utf-8") as f:
            return f.read()


    class Box:
        size = 3
        pick = staticmethod(lambda v: v + 1)

        def area(self):
            return self.size * self.size


    def label():
        return ("dou"
                "ble")
    ''')

TESTS = {
    # in-process calls
    "tests/test_double.py": ("from pkg.mod import double, label\n\ndef test_double():\n    assert double(2.0) == 4.0\n"
                             "    assert label() == 'double'\n"),
    # the call happens in a child Python process only
    "tests/test_child.py": textwrap.dedent('''\
        import subprocess, sys

        def test_negate_in_a_child():
            out = subprocess.run([sys.executable, "-c", "import pkg.mod; print(pkg.mod.negate(3))"],
                                 capture_output=True, text=True, check=True)
            assert out.stdout.strip() == "-3"
        '''),
    # reads a non-Python file through the package
    "tests/test_kernel.py": "from pkg.mod import kernel_text\n\ndef test_kernel():\n    assert 'k' in kernel_text()\n",
    # reaches nothing of pkg
    "tests/test_other.py": "def test_other():\n    assert 1 + 1 == 2\n",
}


@pytest.fixture(scope="module")
def recorded(impact, tmp_path_factory):
    root = tmp_path_factory.mktemp("project")
    (root / "pkg").mkdir()
    (root / "pkg" / "__init__.py").write_text("")
    (root / "pkg" / "mod.py").write_text(MODULE)
    (root / "kernels").mkdir()
    (root / "kernels" / "k.h").write_text("float k(float x) { return x; }\n")
    (root / "tests").mkdir()
    for name, text in TESTS.items():
        (root / name).write_text(text)
    env = dict(os.environ, PYTHONPATH=str(root), PYTHONDONTWRITEBYTECODE="1")
    return root, impact.record(root, sys.executable, env)


def _select(impact, recorded, file: str, original: str) -> set[str]:
    root, got = recorded
    text = (root / file).read_text()
    return set(impact.select(got, file, text, _lines(impact, text, original)))


def test_the_recording_sees_lines_children_and_reads(recorded):
    _, got = recorded
    assert all(r.returncode == 0 for r in got.values()), {k: v.returncode for k, v in got.items()}
    assert 6 in got["tests/test_double.py"].lines["pkg/mod.py"]            # `total = (x *`
    assert 12 in got["tests/test_child.py"].lines["pkg/mod.py"]            # negate's body, run in the child
    assert 12 not in got["tests/test_double.py"].lines["pkg/mod.py"]
    assert "kernels/k.h" in got["tests/test_kernel.py"].read
    assert "pkg/mod.py" in got["tests/test_double.py"].imported
    assert "pkg/mod.py" not in got["tests/test_double.py"].read            # an import is not a read


def test_a_function_body_mutant_runs_only_the_files_that_call_it(impact, recorded):
    assert _select(impact, recorded, "pkg/mod.py", "SCALE)") == {"tests/test_double.py"}     # 2nd line of a statement
    # a line without code of its own (folded into the statement's first line: no line event)
    assert _select(impact, recorded, "pkg/mod.py", '"ble")') == {"tests/test_double.py"}
    assert _select(impact, recorded, "pkg/mod.py", "return -x") == {"tests/test_child.py"}
    assert _select(impact, recorded, "pkg/mod.py", "return self.size * self.size") == set()    # never called


def test_an_import_time_mutant_runs_every_importer(impact, recorded):
    importers = {"tests/test_double.py", "tests/test_child.py", "tests/test_kernel.py"}
    assert _select(impact, recorded, "pkg/mod.py", "SCALE = 2.0") == importers
    assert _select(impact, recorded, "pkg/mod.py", "offset=0.0") == importers    # a default value
    assert _select(impact, recorded, "pkg/mod.py", "size = 3") == importers      # a class attribute


def test_a_lambda_body_counts_as_a_function_body_and_its_line_as_run_at_import(impact, recorded):
    lines = impact.statement_lines(MODULE, _lines(impact, MODULE, "lambda v: v + 1"))
    assert lines == {22}
    # the line also builds the class attribute at import, so coverage sees every importer run it
    assert _select(impact, recorded, "pkg/mod.py", "lambda v: v + 1") == {
        "tests/test_double.py", "tests/test_child.py", "tests/test_kernel.py"}


def test_a_non_python_file_runs_its_readers(impact, recorded):
    assert _select(impact, recorded, "kernels/k.h", "return x;") == {"tests/test_kernel.py"}


def test_a_file_whose_recording_failed_is_always_run(impact, recorded):
    root, got = recorded
    broken = dict(got)
    broken["tests/test_other.py"] = impact.FileImpact(lines={"tests/test_other.py": {1}}, returncode=2)
    text = (root / "pkg/mod.py").read_text()
    chosen = impact.select(broken, "pkg/mod.py", text, _lines(impact, text, "return -x"))
    assert set(chosen) == {"tests/test_child.py", "tests/test_other.py"}


def test_a_process_that_did_not_save_counts_whole(impact, recorded):
    root, got = recorded
    killed = dict(got)
    killed["tests/test_other.py"] = impact.FileImpact(lines={"tests/test_other.py": {1}}, whole={"pkg/mod.py"},
                                                     returncode=0)
    text = (root / "pkg/mod.py").read_text()
    chosen = impact.select(killed, "pkg/mod.py", text, _lines(impact, text, "return self.size * self.size"))
    assert chosen == ["tests/test_other.py"]


def test_the_map_survives_json(impact, recorded):
    _, got = recorded
    import json
    again = impact.from_json(json.loads(json.dumps(impact.to_json(got))))
    assert again.keys() == got.keys()
    assert all(again[k].lines == got[k].lines and again[k].read == got[k].read for k in got)
