"""benchmarks/results/mutants.md from mutants.json (the mutation runner, benchmarks/mutation/):
the behavioural kills as the headline, every kill's class and failing tests."""
from __future__ import annotations

from clshade.report.tables import MISSING, markdown


def mutants_markdown(doc: dict) -> str:
    """The summary and one row per mutant."""
    rows = doc["mutants"]
    classes = doc.get("kill_classes") or {}
    behavioural = sum(m.get("kill_class") == "behavioural" for m in rows)
    unclassified = sum(m["status"] == "killed" and "kill_class" not in m for m in rows)
    others = ", ".join(f"{n} {c}" for c, n in classes.items() if n and c != "behavioural")
    commits = sorted({(m.get("commit") or doc.get("commit") or "")[:10] for m in rows if m["status"] != "not run"})
    extras = doc.get("extras") or {}
    mach = doc["machine"]
    out = ["# Mutation testing", "",
           f"Rendered by `python -m benchmarks.publish` from benchmarks/results/mutants.json (last update "
           f"{doc['created']} on {mach['cpu']} ({mach['cores']} cores) by `{doc['command']}`; the mutants' suites ran "
           f"{sum(m['seconds'] for m in rows):.0f} s in all, 2 at a time, on the shared machine; rows measured on "
           f"{len(commits)} commit(s): {', '.join(commits) or MISSING}).", "",
           f"**{behavioural} of {doc['total']} mutants killed by a behavioural test.** "
           f"Killed otherwise: {others or 'none'}; {doc['survived']} survived"
           f"{_timeouts(rows)}"
           f"{', ' + str(doc['not_run']) + ' not run' if doc.get('not_run') else ''}"
           f"{'; ' + str(unclassified) + ' killed in an older run that recorded neither every failing test nor the kill class (unclassified: not counted above)' if unclassified else ''}. "
           "Each mutant is one small semantic bug (catalogue in benchmarks/mutation/) applied to a copy of the "
           "repository; " + _selection_text(rows) + _stop_text(rows) + ". A kill is behavioural when "
           "some failing test checks behaviour; tests marked `snapshot` (output vs a committed file the same code "
           "wrote), `text` (a string searched in source, docs or binaries) or `extra` (needs an optional package) "
           "do not count, nor does a mutated kernel that fails to compile."
           + (f" Optional packages present in the run: {', '.join(k for k, v in extras.items() if v) or 'none'}"
              f"{'; absent: ' + ', '.join(k for k, v in extras.items() if not v) if not all(extras.values()) else ''}."
              if extras else ""), "",
           markdown(["mutant", "file", "bug", "kill", "failing tests", "test files selected", "commit"],
                    [_row(m, doc) for m in rows])]
    return "\n".join(out) + "\n"


def _row(m: dict, doc: dict) -> list[str]:
    kill = m.get("kill_class") or ("killed (unclassified)" if m["status"] == "killed" else m["status"])
    kill = "**survived**" if kill == "survived" else kill
    tests = m.get("failing_tests")
    if tests is None:
        shown = f"first: {m.get('killed_by') or MISSING}"
    elif tests:
        shown = f"{len(tests)}: " + "; ".join(f"{f['test']} ({f['kind']})" for f in tests[:3]) \
            + (f"; … {len(tests) - 3} more" if len(tests) > 3 else "")
    else:
        shown = MISSING
    commit = (m.get("commit") or doc.get("commit") or "")[:10]
    run = f"{m['test_files_run']} of {m['test_files_total']}" if "test_files_run" in m else "all"
    return [m["name"], m["file"], m["description"], kill, shown, run, commit]


def _stop_text(rows: list[dict]) -> str:
    """Which failing tests a row lists: every one, or those up to the first behavioural kill."""
    ran = [m for m in rows if m["status"] in ("killed", "survived", "timeout")]
    stopped = sum(m.get("every_failure") is False for m in ran)
    if not stopped:
        return ", and every failing test is listed"
    every = "" if stopped == len(ran) else f" ({len(ran) - stopped} rows of a run without the stop list every one)"
    return (", up to the first behavioural failure of a test passing on the unmutated tree (the kill class is then "
            f"known), and the tests failing up to there are listed{every}")


def _timeouts(rows: list[dict]) -> str:
    """', N timed out (name, …)': a suite that hung past the runner's limit is not counted as a kill."""
    hung = [m["name"] for m in rows if m["status"] == "timeout"]
    return f", {len(hung)} timed out ({', '.join(hung)}: not counted as killed)" if hung else ""


def _selection_text(rows: list[dict]) -> str:
    """How much of the suite ran per mutant: all of it, or the test files that reach the mutated code."""
    selected = [m for m in rows if "test_files_run" in m]
    if not selected:
        return "the whole suite runs there"
    share = sum(m["test_files_run"] for m in selected) / max(1, sum(m["test_files_total"] for m in selected))
    return (f"the test files that reach the mutated code run there ({share:.0%} of the files per mutant on average; "
            "the runner records, on the same snapshot, what each test file executes, imports and reads, "
            "its child processes included; a file that reaches none of the mutated code runs the same on the "
            "mutant)")
