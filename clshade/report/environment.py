"""The environment ladder (clshade.bench.environment's document) as Markdown tables, a short answer to the
study's question under environment light, and an error-vs-time plot."""
from __future__ import annotations

from pathlib import Path

from clshade.report.tables import cell, markdown

HEADER = ("model", "rung (diffuse/specular)", "N", "rel RMSE", "max rel err", "ms/frame", "FPS avg", "1 % low",
          "0.1 % low")


def _pct(x: float | None) -> str:
    return cell(None if x is None else 100.0 * x, ".2f") + ("" if x is None else " %")


def ladder_table(doc: dict) -> str:
    """One row per model × rung × N: the error against the truth beside the frame time."""
    rows = [[r["model"], f"{r['diffuse']}/{r['specular']}", cell(r["samples"]), _pct(r["rel_rmse"]),
             _pct(r["max_rel"]), cell(r["mean_ms"], ".3f"), cell(r["avg_fps"], ".0f"), cell(r["low1_fps"], ".0f"),
             cell(r["low01_fps"], ".0f")] for r in doc["rows"]]
    return markdown(HEADER, rows)


def nv_table(doc: dict) -> str:
    """The relative RMSE of every row split by n·v (grazing views first)."""
    bins = [f"n·v ∈ ({lo:g}, {hi:g}]" for lo, hi in zip(doc["nv_bins"][:-1], doc["nv_bins"][1:])]
    rows = [[r["model"], f"{r['diffuse']}/{r['specular']}", cell(r["samples"])]
            + [_pct(b["rel_rmse"]) + (f" ({b['pixels']} px)" if b["pixels"] else "") for b in r["by_nv"]]
            for r in doc["rows"]]
    return markdown(("model", "rung", "N", *bins), rows)


def precompute_table(doc: dict) -> str:
    """The sky's precompute: time and the bytes of every array it keeps."""
    pre = doc["precompute"]
    parts = ", ".join(f"{k} {v / 1e6:.3f}" for k, v in pre["bytes"].items())
    return markdown(("map", "size", "precompute ms", "host MB", "device MB", "arrays (MB)"),
                    [[Path(doc["environment"]["map"]).name if doc["environment"]["map"] else "uniform", "×".join(map(str, pre["size"])), cell(pre["ms"], ".2f"),
                      cell(pre["total_bytes"] / 1e6, ".3f"), cell(pre["device_bytes"] / 1e6, ".3f"), parts]])


def answer(doc: dict) -> list[str]:
    """The study's question under this sky, from the rows: each model's time over Lambert's at the same rung
    and N (median and range over the rungs both ran), and what its rungs buy: the cheapest rung's error and
    the most accurate rung's, with its time over the cheapest."""
    by_model: dict[str, list[dict]] = {}
    for r in doc["rows"]:
        by_model.setdefault(r["model"], []).append(r)
    lambert = {(r["diffuse"], r["specular"], r["samples"]): r["mean_ms"] for r in by_model.get("lambert", [])}
    lines = []
    for model, rs in by_model.items():
        base = min(rs, key=lambda r: r["mean_ms"])
        best = min((r for r in rs if r["rel_rmse"] is not None), key=lambda r: r["rel_rmse"], default=None)
        text = f"- **{model}**: cheapest rung {base['rung']} ({base['mean_ms']:.3f} ms, {_pct(base['rel_rmse'])} RMSE)"
        if best is not None:
            text += (f"; most accurate {best['rung']} ({_pct(best['rel_rmse'])} RMSE) for "
                     f"{best['mean_ms'] / base['mean_ms']:.1f}× the cheapest rung's time")
        ratios = sorted(r["mean_ms"] / lambert[k] for r in rs
                        if (k := (r["diffuse"], r["specular"], r["samples"])) in lambert)
        if model != "lambert" and ratios:
            text += (f"; {ratios[len(ratios) // 2]:.2f}× Lambert's time at the same rung (median of "
                     f"{len(ratios)}, {ratios[0]:.2f}–{ratios[-1]:.2f}×)")
        lines.append(text + ".")
    return lines


def environment_markdown(doc: dict, level: int = 1) -> str:
    """The whole document as Markdown (headings from `level`): what was measured, the answer, the ladder,
    the n·v split, the precompute."""
    env = doc["environment"]
    sky = env["map"] or f"uniform {env['uniform']}"
    h, hh = "#" * level, "#" * (level + 1)
    head = [f"{h} Environment ladder: {Path(doc['scene']).name if doc.get('scene') else 'scene'} under {Path(sky).name}",
            "",
            f"{doc['width']}×{doc['height']}, {doc['frames']} timed frames per case after {doc['warmup']} warm-up, "
            f"interleaved; {doc['device']['name']} ({doc['device']['platform']}). Error against the float64 "
            f"truth on {doc['oracle_pixels']} pixels ({doc['error_definition']}). Created {doc['created']}.",
            "", f"{hh} What each approximation buys", "", *answer(doc), "", f"{hh} The ladder", "", ladder_table(doc),
            "", f"{hh} Error by n·v", "", nv_table(doc), "", f"{hh} Precompute", "", precompute_table(doc), ""]
    return "\n".join(head)


def environment_results_markdown(doc: dict) -> str:
    """benchmarks/results/environment.json (one ladder document per sky under `runs`, skipped skies with
    their reason) as Markdown."""
    out = ["# Environment ladder: every sky", "", f"`{doc.get('command', '')}`", ""]
    for skip in doc.get("skipped", []):
        out.append(f"- skipped {skip['map']}: {skip['reason']}")
    if doc.get("skipped"):
        out.append("")
    for run in doc["runs"]:
        out.append(environment_markdown(run, level=2))
        out.append("")
    return "\n".join(out)


#: One marker per rung pair (diffuse/specular) in environment_plot, in a fixed order so that a pair looks
#: the same in every panel and every run.
RUNG_MARKERS = "os^vDPX*<>hpd8H"


def environment_plot(docs: list[dict], path: Path) -> None:
    """Error (relative RMSE) against ms per frame, log–log, a panel per sky: a colour per model, a marker per
    rung pair; a line through the N ladder of each sampled pair, a lone marker for each fixed one."""
    import math

    from clshade.report.plots import pyplot, write_figure
    plt = pyplot()
    models, pairs = [], []
    for doc in docs:
        for r in doc["rows"]:
            if r["rel_rmse"] is None:
                continue
            if r["model"] not in models:
                models.append(r["model"])
            if (r["diffuse"], r["specular"]) not in pairs:
                pairs.append((r["diffuse"], r["specular"]))
    colours = {m: f"C{k % 10}" for k, m in enumerate(models)}
    markers = {p: RUNG_MARKERS[k % len(RUNG_MARKERS)] for k, p in enumerate(pairs)}
    cols = min(3, max(1, len(docs)))
    rows = math.ceil(max(1, len(docs)) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols + 2.4, 3.6 * rows), squeeze=False, sharex=True,
                             sharey=True)
    for ax, doc in zip(axes.flat, docs):
        series: dict[tuple, list[dict]] = {}
        for r in doc["rows"]:
            if r["rel_rmse"] is not None:
                series.setdefault((r["model"], r["diffuse"], r["specular"]), []).append(r)
        for (model, d, s), rs in series.items():
            rs = sorted(rs, key=lambda r: r["samples"] or 0)
            x, y = [r["mean_ms"] for r in rs], [max(r["rel_rmse"], 1e-6) for r in rs]
            ax.plot(x, y, color=colours[model], marker=markers[(d, s)], ms=4, lw=0.8 if len(rs) > 1 else 0,
                    mfc="none" if len(rs) > 1 else colours[model])
        ax.set_title(Path(doc["environment"]["map"] or "uniform").stem, fontsize=9)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="both", lw=0.3)
    for ax in axes.flat[len(docs):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("device ms per frame")
    for ax in axes[:, 0]:
        ax.set_ylabel("relative RMSE vs the float64 truth")
    handles = [plt.Line2D([], [], color=colours[m], lw=2, label=m) for m in models]
    handles += [plt.Line2D([], [], color="0.3", marker=markers[p], lw=0, label=f"{p[0]}/{p[1]}") for p in pairs]
    fig.legend(handles=handles, loc="center right", fontsize=7, frameon=False,
               title="model (colour), diffuse/specular rung (marker)", title_fontsize=7)
    fig.suptitle("Environment ladder: error against time (sampled rungs: a line through N = 1 … 1024, hollow)",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0, 1 - 2.4 / (4.2 * cols + 2.4), 0.97))
    write_figure(plt, fig, path)


def environment_answer_markdown(doc: dict) -> str:
    """benchmarks/REPORT.md's environment section (benchmarks/results/environment.json): per sky, what each
    model's rungs buy and its time over Lambert's, with the link to the ladder tables and the plot."""
    out = [f"From benchmarks/results/environment.json (`{doc.get('command', '')}`): the tables, the error split by "
           "n·v and the precompute are in [results/environment.md](results/environment.md); error against time: "
           "[results/environment.png](results/environment.png)."]
    for run in doc["runs"]:
        env = run["environment"]
        sky = Path(env["map"]).name if env["map"] else f"uniform {env['uniform']}"
        out += ["", f"**{sky}** ({run['width']}×{run['height']}, {run['device']['name']}):", "", *answer(run)]
    return "\n".join(out)


def environment_cost_markdown(doc: dict) -> str:
    """benchmarks/results/environment_cost.md: each rung's device time at full size against one directional
    light, the sampled rung's line in N, and the precompute per map (benchmarks/measure/environment_cost.py)."""
    from clshade.report.tables import markdown
    sh = doc["shading"]
    out = ["# What light from the sky costs", "",
           f"Rendered by `python -m benchmarks.publish` from {doc['results_file']}; how it is "
           f"measured: the docstring of benchmarks/measure/environment_cost.py. {doc['scene']} at "
           f"{sh['width']}×{sh['height']} ({sh['covered_pixels']} covered pixels) on {sh['device']['name']} "
           f"({sh['device']['platform']}), median device ms of {sh['rounds']} interleaved rounds.", ""]
    rows = []
    for m in sh["models"]:
        for r in m["rows"]:
            rows.append([m["model"], r["rung"], f"{r['median_ms']:.3f}", f"{r['over_directional']:.2f}×",
                         f"{r['spread_ms'][0]:.3f}–{r['spread_ms'][1]:.3f}"])
    out += [markdown(["model", "lighting", "median ms", "× one directional light", "min–max ms"], rows), ""]
    fits = [[m["model"], f"{m['sampled_fit']['ms_per_sample']:.4f}", f"{m['sampled_fit']['intercept_ms']:.3f}",
             f"{m['sampled_fit']['max_rel_departure']:.1%}"] for m in sh["models"] if "sampled_fit" in m]
    out += ["The sampled rung's cost against N (a least-squares line through its N):", "",
            markdown(["model", "ms per sample", "ms at N = 0", "largest departure from the line"], fits), ""]
    split = [r for m in sh["models"] for r in m["rows"] if r["rung"].endswith("/split_sum")]
    if split:
        worst = max(r["over_directional"] for r in split)
        out += [f"Target (split sum ≤ 1.5× one directional light): worst model **{worst:.2f}×** — "
                f"{'met' if worst <= 1.5 else 'missed'}.", ""]
    pre = [[p["map"], f"{p['size'][0]}×{p['size'][1]}", f"{p['prepare_ms']:.0f}",
            ", ".join(f"{k} {c['cold_ms']:.0f}" for k, c in p["chains"].items()),
            ", ".join(f"{k} {t['cold_ms']:.0f}" for k, t in p["dfg"].items()),
            f"**{p['ggx_split_sum_ms']:.0f}**", f"{p['all_families_ms']:.0f}",
            f"{max(c['warm_ms'] for c in p['chains'].values()):.2f}",
            f"{sum(c['bytes'] for c in p['chains'].values()) / 1e6:.1f}"] for p in doc["precompute"]]
    out += ["The precompute on the host, cold (caches cleared), ms:", "",
            markdown(["map", "size", "SH9 + CDFs", "mip chain per family", "DFG table per lobe",
                      "GGX split sum in all (target < 1000)", "every family and lobe", "cached call (max)",
                      "chains MB"], pre), ""]
    if doc.get("skipped"):
        out += [f"Skipped: {doc['skipped']}.", ""]
    commit = (doc["provenance"].get("commit") or "unknown")[:10]
    out += [f"*Commit {commit}; machine {doc['machine'].get('cpu', '')}, {doc['machine'].get('cores')} cores; "
            f"measured {doc['created']} by `{doc['command']}`; load average {doc['load_average']}.*", ""]
    return "\n".join(out)
