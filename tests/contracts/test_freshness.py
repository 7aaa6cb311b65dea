"""Published results are measured on the code that produces them now (benchmarks/publish/freshness.py,
reading the producers of the results registry): a result older than the last change to its kernels or
measuring module fails here. The checker itself is tested on a synthetic repository: fresh, then stale
after a change to its code, and still fresh after a change elsewhere."""
from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from clshade.provenance import machine, provenance, stamp

freshness = pytest.importorskip("benchmarks.publish.freshness", reason="needs the source checkout's benchmarks/")
from benchmarks.publish.registry import RESULTS, Result  # noqa: E402


def _git(root: Path, *args: str) -> str:
    return subprocess.run(["git", "-C", str(root), *args], check=True, capture_output=True, text=True).stdout.strip()


def _commit(root: Path, message: str) -> str:
    _git(root, "add", "-A")
    _git(root, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-q", "-m", message)
    return _git(root, "rev-parse", "HEAD")


def test_checker_on_a_synthetic_repository(tmp_path: Path) -> None:
    root = tmp_path
    _git(root, "init", "-q")
    (root / "kernels").mkdir()
    (root / "kernels" / "brdf.h").write_text("#define MIN_ALPHA 1e-4f\n")
    (root / "measure.py").write_text("x = 1\n")
    (root / "other.txt").write_text("a\n")
    measured = _commit(root, "code")
    (root / "results").mkdir()
    (root / "results" / "r.json").write_text(json.dumps({"provenance": {"commit": measured}, "value": 1}))
    (root / "results" / "old.json").write_text(json.dumps({"value": 2}))        # no provenance: its own commit
    _commit(root, "results")
    results = (Result("results/r.json", "python measure.py", ("kernels", "measure.py")),
               Result("results/old.json", "python old.py", ("kernels",)),
               Result("results/absent.json", "python absent.py", ("kernels",)))   # never measured: not listed
    assert freshness.staleness(root, results) == {"results/r.json": [], "results/old.json": []}
    (root / "other.txt").write_text("b\n")
    _commit(root, "unrelated")
    assert freshness.staleness(root, results) == {"results/r.json": [], "results/old.json": []}
    (root / "kernels" / "brdf.h").write_text("#define MIN_ALPHA 1e-3f\n")
    change = _commit(root, "kernel change")
    assert freshness.staleness(root, results) == {"results/r.json": [change], "results/old.json": [change]}
    (root / "measure.py").write_text("x = 2\n")
    later = _commit(root, "measuring module change")
    (root / "results" / "old.json").write_text(json.dumps({"provenance": {"commit": later}, "value": 3}))
    _commit(root, "old.json measured again")
    assert freshness.staleness(root, results) == {"results/r.json": [later, change], "results/old.json": []}
    # a commit the history does not hold (a shallow clone): unknown, not fresh
    (root / "results" / "r.json").write_text(json.dumps({"provenance": {"commit": "0" * 40}}))
    assert freshness.staleness(root, results)["results/r.json"] is None


def test_every_results_json_has_a_registry_entry(checkout) -> None:
    found = {str(p.relative_to(checkout)) for folder in ("results", "report")
             for p in (checkout / "benchmarks" / folder).glob("*.json")}
    listed = {r.json for r in RESULTS}
    assert found <= listed, f"results without an entry in benchmarks/publish/registry.py: {sorted(found - listed)}"
    assert len(listed) == len(RESULTS), "two registry entries name the same JSON"


def test_every_producer_exists(checkout) -> None:
    """A producer path that no longer exists (a moved file) would leave its result fresh for ever."""
    missing = [(r.name, p) for r in RESULTS for p in r.producers if not (checkout / p).exists()]
    assert not missing, f"registry producers that do not exist: {missing}"


def test_the_known_stale_list_is_no_result_s_code() -> None:
    """Taking a result off KNOWN_STALE must not change that result's code (else it is stale again at once)."""
    here = "benchmarks/publish/freshness.py"
    for r in RESULTS:
        covering = [c for c in r.producers if here == c or here.startswith(c.rstrip("/") + "/")]
        assert not covering, f"{r.name}'s producers {covering} include {here}, which holds KNOWN_STALE"
    assert set(freshness.KNOWN_STALE) <= {r.json for r in RESULTS}


def test_provenance_names_commit_device_and_time() -> None:
    p = provenance("some device")
    assert p["device"] == "some device" and p["measured_at"].endswith("Z") and "dirty" in p
    assert stamp({"a": 1, "provenance": None}, "d")["provenance"]["device"] == "d"


def test_stamp_writes_the_one_machine_record() -> None:
    """Every stamped document carries the machine record with its one set of keys, replacing a machine
    description of the writer's own."""
    doc = stamp({"a": 1, "machine": "vm x86_64"})
    assert list(doc)[:2] == ["provenance", "machine"] and doc["a"] == 1
    assert set(doc["machine"]) == {"cpu", "cores", "memory_bytes", "arch", "os", "python", "numpy"}
    assert doc["machine"] == machine() and doc["machine"]["cores"] >= 1 and doc["machine"]["cpu"]


def test_a_checkout_is_dirty_for_code_not_for_results_or_rendered_documents(tmp_path, scratch_repo) -> None:
    from clshade.provenance import checkout_commit
    git = scratch_repo
    files = ("clshade/a.py", "kernels/k.cl", "README.md", "docs/d.md", "benchmarks/results/r.json")
    for path in files:
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text("0\n")
    git("add", *files)
    git("commit", "-qm", "all")
    assert checkout_commit(tmp_path)[1] is False
    for path in ("README.md", "docs/d.md", "benchmarks/results/r.json"):      # what publish and benchmarks write
        (tmp_path / path).write_text("1\n")
    commit, dirty = checkout_commit(tmp_path)
    assert dirty is False and len(commit) == 40
    for path in ("clshade/a.py", "kernels/k.cl"):
        (tmp_path / path).write_text("1\n")
        assert checkout_commit(tmp_path)[1] is True, path
        git("checkout", "--", path)


def _results() -> list:
    return [pytest.param(r.json, marks=[pytest.mark.xfail(reason=f"stale, not yet regenerated: "
                                                                 f"{freshness.KNOWN_STALE[r.json]}", strict=True)]
                         if r.json in freshness.KNOWN_STALE else []) for r in RESULTS]


@pytest.mark.parametrize("name", _results())
def test_published_result_is_not_older_than_its_code(checkout, name: str) -> None:
    result = next(r for r in RESULTS if r.json == name)
    if not (checkout / name).exists():
        pytest.skip(f"no {name}")
    if freshness.git(checkout, "rev-parse", "HEAD") is None:
        pytest.skip("not a git checkout")
    since = freshness.staleness(checkout, (result,))[name]
    if since is None:
        pytest.skip(f"{name}: its commit is not in this checkout's history (shallow clone?)")
    assert not since, (f"{name} is older than its code: {len(since)} later commit(s) changed "
                       f"{', '.join(result.producers)} (newest {since[0][:10]}); measure it again with "
                       f"`{result.command}`")
