"""The tuner's measurements as Markdown: one device's race of build choices and the race of the devices
(clshade/device/tune.py's cache entries: `clshade devices --tune`), and the tuning results document
(benchmarks/measure/tuning.py: every choice on a full frame per runtime, default against the best)."""
from __future__ import annotations

from clshade.device.buildchoice import BuildChoice
from clshade.report.tables import MISSING, cell, markdown

yes_no = {True: "yes", False: "no", None: MISSING}


def _ms(row: dict, model: str) -> str:
    return cell((row.get("median_ms") or {}).get(model), ".2f")


def _ratio(x: float | None) -> str:
    return cell(x, ".3f")


def choice_name(row: dict) -> str:
    """A candidate by what it changes from today's rule (buildchoice.BuildChoice.label)."""
    return BuildChoice.from_dict(row["choice"]).label()


def device_tuning_markdown(entry: dict) -> str:
    """One device's cache entry: the general choice, then per model family its decision and every
    candidate's calibration times; the key."""
    head = f"**{entry['key']['runtime']}** ({entry.get('device', entry['key']['device'])})"
    if entry["status"] != "measured":
        return f"{head}: not measured: {entry.get('reason', '')} (today's rule is used)"
    cal, noise = entry["calibration"], entry["noise"]
    L = [f"{head}: per model family "
         + ", ".join(f"{f} **{body['label']}**" for f, body in entry["families"].items())
         + f"; general choice (other families, kernels of no model) **{entry['label']}** — {entry['decision']}.", "",
         f"Calibration: {cal['scene']} {cal['width']}×{cal['height']}; {entry['seconds']:.1f} s of a "
         f"{entry['budget_s']:.0f} s budget{', spent' if entry['budget_spent'] else ''} ({entry['budget_split']}); "
         f"noise band: {noise['z']:g} standard errors of the paired ratio, at least {noise['floor']:.0%}, from "
         f"{noise['min_rounds']} rounds on. Key `{entry['key_hash']}`: {key_line(entry['key'])}."]
    for family, body in entry["families"].items():
        models = body["models"]
        rows = []
        for r in body["candidates"]:
            stage = " (combined, against the first pick)" if r.get("stage") == 2 else ""
            ratio = r.get("vs_first_pick") if r.get("stage") == 2 else r.get("vs_default")
            rows.append([choice_name(r) + stage, cell(r.get("simd")), cell(r.get("local_size")),
                         yes_no[r.get("inline_math")], yes_no[r.get("streaming_stores")], yes_no[r.get("prefetch")],
                         *(_ms(r, m) for m in models), _ratio(ratio), cell(r.get("band"), ".1%"),
                         cell(r.get("rounds")), r["status"] + (f": {r['reason']}" if r.get("reason") else "")])
        L += ["", f"*{family}* ({', '.join(models)}): **{body['label']}** — {body['decision']}; rounds "
              f"{' + '.join(map(str, body['rounds']))} in {body['seconds']:.1f} s of its "
              f"{body['budget_s']:.1f} s{', spent' if body['budget_spent'] else ''}.", "",
              markdown(["choice", "lanes", "work-group", "inline math", "streaming stores", "prefetch",
                        *(f"{m} ms" for m in models), "× today's rule", "band", "rounds", "status"], rows)]
    return "\n".join(L)


def key_line(key: dict) -> str:
    """The parts of a device key a reader checks: runtime, driver, device, CPU, kernels."""
    return (f"{key['runtime']}, driver {key['driver_version']}, {key['device']}, CPU {key['cpu']} "
            f"(flags {key['cpu_hash']}), kernels {key['kernels']}"
            + (f", environment {', '.join(f'{k}={v}' for k, v in key['environment'].items())}"
               if key.get("environment") else ""))


def ranking_markdown(entry: dict) -> str:
    """The race of the CPU devices: the default and each device's calibration times."""
    if entry["status"] != "measured":
        return f"Device order not measured: {entry.get('reason', '')} (RUNTIME_PREFERENCE order is used)"
    cal = entry["calibration"]
    models = cal["models"]
    position = {h: i + 1 for i, h in enumerate(entry["order"])}
    rows = [[cell(position.get(r["key_hash"])), r["spec"], r["runtime"], r["label"],
             *(_ms(r, m) for m in models), _ratio(r.get("vs_default")), cell(r.get("band"), ".1%"),
             r["status"] + (f": {r['reason']}" if r.get("reason") else "")] for r in entry["devices"]]
    return "\n".join([f"Default device: **{entry['decision']}**; measured in {entry['seconds']:.1f} s "
                      f"(budget {entry['budget_s']:.0f} s{', spent' if entry['budget_spent'] else ''}), "
                      f"{cal['scene']} {cal['width']}×{cal['height']}.", "",
                      markdown(["rank", "spec", "runtime", "build choice", *(f"{m} ms" for m in models),
                                "× the first in RUNTIME_PREFERENCE", "band", "status"], rows)])


def tuning_markdown(doc: dict) -> str:
    """benchmarks/results/tuning.json: per runtime, every build choice's time per model on a full frame
    beside today's rule and the tuned choice, each model's ratio to its copy kernel, and the cached key."""
    prov, mach = doc["provenance"], doc["machine"]
    target = doc["target"]
    L = ["# Build choices measured on the device", "",
         f"{doc['scene']} at {doc['width']}×{doc['height']}, {doc['rounds']} interleaved rounds (every choice × "
         f"model × shading and copy kernel, each the second of two back-to-back dispatches, process idle before "
         f"each), medians; measured {doc['created']} on {mach['cpu']} ({mach['cores']} cores), commit "
         f"`{(prov['commit'] or 'unknown')[:10]}`{' (uncommitted changes)' if prov['dirty'] else ''}, with "
         f"`{doc['command']}`. The tuner's own race (the calibration frame) ran first on each runtime and its "
         f"pick per model family (the general choice for a model of no measured family) is the `tuned` mark "
         f"and column; the target: the tuned default within {target:.0%} of the fastest choice "
         f"for every model. The fastest of seven noisy medians is biased low (the winner's curse): the target "
         f"is judged on the held-out ratio, the fastest picked by median on the even rounds and timed against "
         f"the tuned build on the odd ones, and the other way round (geometric mean of the two; "
         f"clshade.bench.tuning.held_out_ratio); the plain ratio of medians is beside it.", ""]
    if doc.get("ranking"):
        L += [ranking_markdown(doc["ranking"]), ""]
    for rt in doc["runtimes"]:
        L += [f"## {rt['runtime']}: {rt['device']}", ""]
        if "error" in rt:
            L += [f"Not measured: {rt['error']}", ""]
            continue
        models = doc["models"]
        header = ["choice", "lanes", "work-group", *(h for m in models for h in (f"{m} ms", "× copy"))]
        rows = []
        for c in rt["choices"]:
            mark = f" (**tuned: {', '.join(c['tuned_for'])}**)" if c["tuned_for"] else ""
            rows.append([choice_name(c) + mark, cell(c.get("simd")),
                         cell(c.get("local_size")),
                         *(v for m in models for v in (cell(c["models"][m]["median_ms"], ".2f"),
                                                      cell(c["models"][m]["copy_ratio"], ".2f")))])
        L += [markdown(header, rows), ""]
        summary = [[m, s["family"], s["tuned"], f"{s['rule_ms']:.2f}", f"{s['tuned_ms']:.2f}", f"{s['best_ms']:.2f} ({s['best']})",
                    f"{s['rule_vs_best']:.3f}", f"{s['tuned_vs_best']:.3f}", _ratio(s.get("rule_vs_best_held_out")),
                    _ratio(s.get("tuned_vs_best_held_out")),
                    "met" if s["tuned_within_target"] else "**missed**", f"{s['tuned_copy_ratio']:.2f}"]
                   for m, s in rt["summary"].items()]
        L += [markdown(["model", "family", "tuned choice", "today's rule ms", "tuned ms", "fastest ms (choice)", "rule ÷ fastest",
                        "tuned ÷ fastest", "rule ÷ fastest, held out", "tuned ÷ fastest, held out",
                        f"tuned within {target:.0%} (held out)", "tuned × copy"], summary), ""]
        L += ["The tuner's race on the calibration frame:", "", device_tuning_markdown(rt["tuning"]), ""]
    return "\n".join(L)
