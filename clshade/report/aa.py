"""`clshade aa` documents (the anti-aliasing ladder, clshade.bench.aa) as Markdown and the ladder plot."""
from __future__ import annotations

from pathlib import Path

from clshade.report.plots import label_points, pyplot, write_figure
from clshade.report.tables import cell, markdown

# (error key, panel name, Pareto mark of the rows: clshade.bench.aa marks each panel's front)
AA_ERRORS = (("frame_rel_error", "whole frame", "pareto"),
             ("silhouette_rel_error", "silhouette pixels", "pareto_silhouette"),
             ("highlight_rel_error", "highlight pixels", "pareto_highlight"))


def aa_markdown(doc: dict) -> str:
    """`clshade aa` results: the ladder, the convergence of the truth, temporal stability."""
    d = doc["definitions"]
    out = [f"# Anti-aliasing ladder — {doc['scene']} {doc['width']}x{doc['height']}", "",
           f"Generated {doc['date']} by `{doc.get('command', 'clshade aa')}`; device {doc['device']['name']} "
           f"[{doc['device']['platform_version']}] on {doc['machine']['cpu']} "
           f"({doc['machine']['cores']} CPUs, shared). Frame time: {d['frame_time']}. Error: {d['error']}. "
           f"Silhouette: {d['silhouette']}; highlight: {d['highlight']}. ● = on the Pareto front of its model "
           "(frame time vs whole-frame error).", "",
           markdown(["model", "rung", "samples/px", "mean ms", "raster ms", "frame err", "silhouette err",
                     "highlight err", "Pareto"],
                    [[r["group"], r["label"],
                      f"{r['samples'] ** 2} coverage, 1 shaded" if r.get("msaa") else r["samples"] ** 2,
                      cell(r["mean_ms"], ".3f"), cell(r["raster_ms"], ".0f"),
                      cell(r["frame_rel_error"], ".4f"), cell(r["silhouette_rel_error"], ".3f"),
                      cell(r["highlight_rel_error"], ".3f"), "●" if r.get("pareto") else ""] for r in doc["ladder"]])]
    if doc["convergence"]:
        out += ["", "## Is the truth converged?", "",
                "The same errors of the truth against a denser one (both float64, ordered grids):", "",
                markdown(["model", "truth", "against", "frame err", "silhouette err", "highlight err"],
                         [[c["group"], f"{c['truth_samples']}x{c['truth_samples']}",
                           f"{c['check_samples']}x{c['check_samples']}", cell(c["frame_rel_error"], ".5f"),
                           cell(c["silhouette_rel_error"], ".4f"), cell(c["highlight_rel_error"], ".4f")]
                          for c in doc["convergence"]])]
    if doc["temporal"]:
        spheres = doc["temporal"][0]["spheres"]
        out += ["", "## Temporal stability", "", d["temporal"] + ".", "",
                markdown(["model", "rung", *(f"r {s['roughness']:g}" for s in spheres), "mean"],
                         [[r["group"], r["label"], *(f"{s['energy_change']:.1e}" for s in r["spheres"]),
                           f"{r['mean_energy_change']:.1e}"] for r in doc["temporal"]])]
    truth = "; ".join(f"{t['model']} {t['samples']}x{t['samples']} in {t['seconds']:.0f} s" for t in doc["truth"])
    return "\n".join(out + ["", f"Truth frames: {truth}.", ""])


def plot_aa(doc: dict, path: Path) -> None:
    """Frame time (log) vs each error (log), one panel per pixel set; the Pareto front of
    each model in that panel's error ringed."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.3))
    rows = doc["ladder"]
    for ax, (key, name, mark) in zip(axes, AA_ERRORS):
        ax.set_title(name, fontsize=9)
        if all(r[key] is None for r in rows):
            ax.text(0.5, 0.5, f"no {name} in this frame", ha="center", transform=ax.transAxes)
            continue
        for group in dict.fromkeys(r["group"] for r in rows):
            pts = [r for r in rows if r["group"] == group and r[key] is not None]
            errs = [max(r[key], 1e-9) for r in pts]
            sc = ax.scatter([r["mean_ms"] for r in pts], errs, label=group)
            for r, e in zip(pts, errs):
                if r.get(mark):
                    ax.scatter([r["mean_ms"]], [e], s=160, facecolors="none", edgecolors=sc.get_facecolor()[0])
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(plt.NullFormatter())   # minor log labels overlap over one decade
        label_points(ax, [(r["mean_ms"], max(r[key], 1e-9), r["label"]) for r in rows if r[key] is not None])
        ax.set_xlabel("mean device frame time (ms)")
        ax.set_ylabel(f"mean relative error, {name}")
    axes[0].legend(fontsize=7)
    t = doc["truth"][0]["samples"] if doc["truth"] else "?"
    fig.suptitle(f"anti-aliasing ladder vs the pixel integral ({t}x{t} float64), {doc['scene']} "
                 f"{doc['width']}x{doc['height']}, {doc['device']['name']}", fontsize=10)
    fig.tight_layout()
    write_figure(plt, fig, path)
