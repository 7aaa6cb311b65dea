"""Host-side measurements as Markdown: the host stages A/B against a git ref (host_ab.json),
peak memory by frame size (memory.json) and the warm start-up of `clshade render` (startup.json);
their generators are benchmarks/experiments/host_ab.py, benchmarks/measure/memory_bench.py and
startup_bench.py."""
from __future__ import annotations

from clshade.report.tables import markdown


def _load(doc: dict) -> str:
    return ", ".join(f"{x:.1f}" for x in doc["load_average"]["start"])


def host_ab_markdown(doc: dict) -> str:
    """Each host stage and the whole frame, base against this checkout."""
    m = doc["machine"]
    e2e = doc["render_robot_640_s"]
    stages = markdown(["stage", "base CPU ms", "new CPU ms", "CPU ratio", "base wall ms", "new wall ms"],
                      [[name, f"{v['base']['cpu_ms']:.1f}", f"{v['new']['cpu_ms']:.1f}",
                        f"{v['base']['cpu_ms'] / v['new']['cpu_ms']:.2f}×", f"{v['base']['wall_ms']:.1f}",
                        f"{v['new']['wall_ms']:.1f}"] for name, v in doc["stages"].items()])
    wf = doc["whole_frame_1080p"]
    frames = markdown(["stage", "base CPU ms", "new CPU ms", "base wall ms", "new wall ms"],
                      [[st, f"{wf['base'][st]['cpu_ms']:.1f}", f"{wf['new'][st]['cpu_ms']:.1f}",
                        f"{wf['base'][st]['wall_ms']:.1f}", f"{wf['new'][st]['wall_ms']:.1f}"] for st in wf["new"]])
    sizes = doc["png_bytes"]
    frame = wf["new"]["frame"]
    met = frame["wall_ms"] <= doc["frame_target_s"] * 1e3
    lines = [f"# Host stages: this checkout against `{doc['base_ref']}` ({doc['base_commit']})", "",
             f"Measured {doc['date']} on {m['cpu']} ({m['cores']} cores, shared; 1-minute load average "
             f"{doc['load_average']['start'][0]:.1f} at the start, {doc['load_average']['end'][0]:.1f} at the end) by "
             f"`python -m benchmarks.experiments.host_ab` ({doc['rounds']} interleaved rounds in one process, outputs "
             f"checked byte-equal first); device: {doc['provenance']['device']}.", "",
             "Warm `clshade render scenes/robot.toml` (640×640 PNG), fresh processes, interleaved, same decoded "
             f"pixels: median CPU {e2e['base']['cpu']:.3f} s → {e2e['new']['cpu']:.3f} s "
             f"({e2e['base']['cpu'] / e2e['new']['cpu']:.2f}×), median wall {e2e['base']['wall']:.3f} s → "
             f"{e2e['new']['wall']:.3f} s ({e2e['base']['wall'] / e2e['new']['wall']:.2f}×).", "",
             stages, "",
             "The geometry row is a repeated build in one process (identical primitives share one "
             "tessellation after the first build); a fresh process pays the first build. Ratios within "
             "about ±10 % of 1 are within the noise of a shared machine at this load.", "",
             f"PNG file of the 640×640 robot: {sizes['base']} bytes (base) → {sizes['new']} bytes (new); "
             "same pixels.", "",
             f"Whole frame, robot at 1920×1080, camera orbiting {doc['orbit_degrees']:g}° a frame (target "
             f"≤ {doc['frame_target_s'] * 1e3:.0f} ms), medians:", "",
             frames, "",
             f"Target ≤ {doc['frame_target_s'] * 1e3:.0f} ms per whole frame: "
             f"**{'met' if met else 'missed'}** (median {frame['wall_ms']:.0f} ms wall, {frame['cpu_ms']:.0f} ms CPU)."]
    return "\n".join(lines) + "\n"


def memory_markdown(doc: dict) -> str:
    """Peak resident memory per frame size, against the limit of the document."""
    m, limit = doc["machine"], doc["limit_bytes_per_pixel"]
    rows = []
    for r in doc["rows"]:
        above, within = r.get("bytes_per_pixel_above_base"), r.get("within_limit")
        rows.append([f"{r['size']}²", r["exit_status"], f"{r['peak_rss_bytes'] / 2**20:.0f}",
                     "" if above is None else f"{above:.1f}", f"{r['bytes_per_pixel_whole_process']:.1f}",
                     "" if within is None else ("yes" if within else "no"), f"{r['wall_s']:.1f}", r["stderr"]])
    lines = ["# Peak host memory of `clshade render scenes/robot.toml` (PNG)", "",
             f"Measured {doc['date']} on {m['cpu']} ({m['cores']} cores, {m['memory_bytes'] / 2**30:.0f} GiB; load "
             f"average at start {_load(doc)}) by `{doc['command']}`; device: "
             f"{doc['provenance']['device']}.", "",
             f"Limit: peak ≤ {limit} B/px × pixels + the fixed base "
             f"(the peak of the {doc['summary']['base_size']}² render).", "",
             markdown(["size", "exit", "peak RSS (MiB)", "B/px above base", "B/px whole process", "within limit",
                       "wall (s)", "note"], rows),
             "", "Stages per size (ms, from the command's own `stages:` line):", ""]
    lines += [f"- {r['size']}²: {r['stages'] or '(none: refused)'}" for r in doc["rows"]]
    return "\n".join(lines) + "\n"


def startup_markdown(doc: dict) -> str:
    """The interpreter, the CLI's start-up and the whole render, and the render's stages."""
    w, m = doc["wall_s"], doc["machine"]
    stages = doc["render_stages_ms"]
    staged = sum(stages.values()) / 1e3
    labels = (("interpreter", "`python -c pass`"), ("imports", "CLI imports + argument parser"),
              ("render", "`clshade render scenes/robot.toml -o robot.png`"))
    lines = ["# Warm `clshade render scenes/robot.toml` (640×640 PNG), end to end", "",
             f"Measured {doc['date']} on {m['cpu']} ({m['cores']} cores, shared; 1-minute load average "
             f"{doc['load_average_1min']['min']:.1f}–{doc['load_average_1min']['max']:.1f} during the run) by "
             f"`{doc['command']}` ({doc['repeats']} interleaved rounds after a warm-up); "
             f"device: {doc['provenance']['device']}.", "",
             f"Target: ≤ {doc['target_s']} s wall. Median render: **{w['render']['median']:.2f} s** "
             f"(minimum {w['render']['min']:.2f} s): "
             f"{'meets' if w['render']['median'] <= doc['target_s'] else 'misses'} the target at this load.", "",
             markdown(["process", "median wall (s)", "min wall (s)", "median CPU (s, user + system)"],
                      [[label, f"{w[name]['median']:.3f}", f"{w[name]['min']:.3f}",
                        f"{doc['cpu_s'][name]['median']:.3f}"] for name, label in labels]),
             "", "Render stages (median ms over the rounds, from the command's `stages:` line; "
             f"they sum to {staged:.2f} s, the rest is interpreter start, imports and exit):", "",
             markdown(["stage", "ms"], [[k, f"{v:.1f}"] for k, v in stages.items()])]
    return "\n".join(lines) + "\n"
