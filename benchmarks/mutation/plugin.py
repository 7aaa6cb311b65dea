"""pytest plugin of the mutation runner (benchmarks/mutation/run.py loads it as `-p benchmarks.mutation.plugin`):
records every failing test of a mutant's suite run (and every collection error) with its markers, as JSON at
$CLSHADE_MUTANT_REPORT. With $CLSHADE_MUTANT_STOP set, the run stops at the first behavioural failure of a test
not listed in $CLSHADE_MUTANT_BASELINE (a JSON list of the tests failing on the unmutated tree): the mutant's kill
class is then known, and the rest of its suite could only add failures."""
from __future__ import annotations

import json
import os

_FAILURES: list[dict] = []
# The tests' own kill classes (pyproject.toml registers the markers): a test so marked does
# not check behaviour, so a mutant killed only by such tests is not a behavioural kill.
CLASS_MARKERS = ("snapshot", "text", "extra")
BUILD_FAILED = "kernel build failed"      # clshade.device.runtime's message for a program that does not compile


def _text(report) -> str:
    return str(report.longrepr) if report.longrepr is not None else ""


def _crash(report) -> str:
    """The exception that ended the test ("AssertionError: …", "ClshadeError: …")."""
    crash = getattr(report.longrepr, "reprcrash", None)
    return crash.message if crash is not None else _text(report)


#: What a failure's test checked (kill_kind), in the order the runner ranks a mutant's kill by (run.classify).
KILL_CLASSES = ("behavioural", "compile error", "collection error", "snapshot", "text", "needs extra")
_STOP: dict = {}                          # the session and the baseline's tests, when the run stops at a kill


def kill_kind(failure: dict) -> str:
    """The kind of one recorded failure: a collection error, a kernel that failed to build, a test marked as not
    checking behaviour (its marker's class), else behavioural."""
    if failure["when"] == "collect":
        return "collection error"
    if failure["build_failed"]:
        return "compile error"
    for marker, kind in (("snapshot", "snapshot"), ("text", "text"), ("extra", "needs extra")):
        if marker in failure["markers"]:
            return kind
    return "behavioural"


def pytest_sessionstart(session) -> None:
    if os.environ.get("CLSHADE_MUTANT_STOP"):
        _STOP.update(session=session, baseline=frozenset(json.loads(os.environ.get("CLSHADE_MUTANT_BASELINE", "[]"))))


def pytest_runtest_logreport(report) -> None:
    if report.failed:
        text = _text(report)
        # A build that failed where the test wanted a program; not a test that checks a build error's
        # message and found it wrong (its assertion quotes the message).
        build_failed = BUILD_FAILED in text and not _crash(report).startswith("AssertionError")
        failure = dict(test=report.nodeid, when=report.when, markers=[m for m in CLASS_MARKERS if m in report.keywords],
                       build_failed=build_failed, message=text.strip().splitlines()[-1][:300] if text.strip() else "")
        _FAILURES.append(failure)
        if _STOP and kill_kind(failure) == "behavioural" and report.nodeid not in _STOP["baseline"]:
            _STOP["session"].shouldfail = f"first behavioural kill: {report.nodeid}"


def pytest_collectreport(report) -> None:
    if report.failed:
        _FAILURES.append(dict(test=report.nodeid, when="collect", markers=[], build_failed=False,
                              message=_text(report).strip().splitlines()[-1][:300] if _text(report).strip() else ""))


def pytest_sessionfinish(session) -> None:
    path = os.environ.get("CLSHADE_MUTANT_REPORT")
    if path:
        with open(path, "w", encoding="utf-8") as f:
            json.dump(_FAILURES, f)
