"""The live viewer's benchmark (benchmarks/measure/view_bench.py: view.json, view_pocl30.json) as
Markdown: the README's table and the results file."""
from __future__ import annotations

from clshade.report.tables import MISSING, cell, markdown

STEPS = ("reshade", "orbit", "drag")


def _ms(x: float | None) -> str:
    return cell(x, ".1f")


def _commit(doc: dict) -> str:
    prov = doc["provenance"]
    return f"{(prov['commit'] or 'unknown')[:10]}{' (uncommitted changes)' if prov['dirty'] else ''}"


def steps_table(doc: dict) -> str:
    """The viewer's rates and latencies, one row per kind of step, with the targets."""
    k, t = doc["kinds"], doc["targets"]
    names = {"reshade": "re-shade (roughness slider)", "orbit": "orbit (1° steps)",
             "drag": f"drag (orbit inputs at {doc['drag_hz']:.0f} Hz)"}
    target = {"reshade": t["reshade_per_s"], "orbit": t["orbit_fps"], "drag": None}
    rows = []
    for kind in STEPS:
        e = k[kind]
        met = target[kind] is not None and e["rate_per_s_median"] >= target[kind]
        goal = MISSING if target[kind] is None else f"≥ {target[kind]:.0f} " + ("met" if met else "**not met**")
        rows.append([names[kind], f"{e['rate_per_s_median']:.1f}", goal, _ms(e["latency_ms"]["median"]),
                     _ms(e["latency_ms"]["p95"]), _ms(e["server_ms_median"]), _ms(e["transfer_and_browser_ms_median"]),
                     _ms(e["draw_ms_median"]), e["frames"]])
    if "canvas_1080" in doc:        # the canvas following a window, at the default cap
        e, goal = doc["canvas_1080"], t.get("canvas_1080_orbit_fps")
        met = goal is not None and e["rate_per_s_median"] >= goal
        rows.append([f"orbit, {e['width']}x{e['height']} canvas (following the window)",
                     f"{e['rate_per_s_median']:.1f}",
                     MISSING if goal is None else f"≥ {goal:.0f} " + ("met" if met else "**not met**"),
                     _ms(e["latency_ms"]["median"]), _ms(e["latency_ms"]["p95"]), _ms(e["server_ms_median"]),
                     _ms(e["transfer_and_browser_ms_median"]), _ms(e["draw_ms_median"]), e["frames"]])
    return markdown(["step", f"frames/s (median of {doc['repeats']} blocks)", "target", "latency median ms",
                     "p95 ms", "server ms", "transfer + browser ms", "draw ms", "frames"], rows)


def view_table(doc: dict, name: str = "view.json") -> str:
    """README's table of a viewer result (benchmarks/results/`name`): steps_table and its footnote."""
    m = doc["machine"]
    return "\n".join([steps_table(doc), "", f"*From benchmarks/results/{name} (`{doc['command']}`, {doc['date']}, "
                                             f"commit {_commit(doc)}, {doc['scene']} at {doc['width']}x{doc['height']}, "
                                             f"headless Chromium, device `{doc['device'].split(' [')[0]}`, {m['cores']} "
                                             f"cores, load {doc['load_average']['start'][0]:.1f} at start).*"])


def view_markdown(doc: dict) -> str:
    """benchmarks/results/view.md from view.json (view_pocl30.md from view_pocl30.json)."""
    k, m = doc["kinds"], doc["machine"]
    stages = list(dict.fromkeys(s for x in ("orbit", "reshade", "drag") for s in k[x]["stage_ms_median"]))
    rows = [[s, *(_ms(k[x]["stage_ms_median"].get(s)) for x in STEPS)] for s in stages]
    encoding = doc.get("frame_encoding")         # absent: results measured when frames travelled raw
    rows.append([f"pack (header + {'encoded' if encoding else 'raw'} RGBA, "
                 f"{k['orbit']['bytes_per_frame'] / 1e6:.1f} MB)", *(_ms(k[x]["pack_ms_median"]) for x in STEPS)])
    if all("render_ms_median" in k[x] for x in STEPS):
        rows.append(["**render, whole** (render thread, stages above and the rest)",
                     *(_ms(k[x]["render_ms_median"]) for x in STEPS)])
    drag = k["drag"]
    lines = [
        "# Live viewer: frames per second and input-to-frame latency",
        "",
        f"Measured by `{doc['command']}` on {doc['date']}, commit {_commit(doc)}, device "
        f"`{doc['device']}`, {m['cpu']} ({m['cores']} cores, load {doc['load_average']['start'][0]:.1f} at start); "
        f"{doc['scene']} at {doc['width']}x{doc['height']} in headless Chromium; rendered by "
        "`python -m benchmarks.publish`.",
        "",
        steps_table(doc),
        "", f"Drag: {drag['inputs_sent']} inputs sent, {drag['frames']} frames drawn, "
            f"{drag['states_skipped']} stale states skipped by the server (latest state wins).",
        "", "Where the server's time goes (median ms per frame of each stage, over the frames that ran it):", "",
        markdown(["stage", "re-shade", "orbit", "drag"], rows)]
    if any("visibility + g-buffer (device)" in k[x]["stage_ms_median"] for x in STEPS):
        lines += ["", "Orbit frames of a scene without textures: `rasterize` is the host's triangle setup, and "
                      "`visibility + g-buffer (device)` the coverage tests, depth resolve, winners' barycentrics and "
                      "G-buffer interpolation on the device (kernels/visibility.cl), bit for bit the host's G-buffer."]
    lines += ["", "Latency: from the page's input (control state sent) to the frame drawn on its canvas "
                  "(putImageData returned; compositing to the screen not included). Server ms: from the state's "
                  "arrival to the frame sent (waiting, rendering, packing, sending). " + _frames_note(doc)]
    return "\n".join(lines) + "\n"


def _frames_note(doc: dict) -> str:
    """How the frames travelled and how many bytes they took, from the result's frame_encoding."""
    encoding = doc.get("frame_encoding")
    if not encoding:
        return ("Frames travel as raw RGBA (no encoding: the canvas must equal `clshade render`'s PNG, which "
                "lossy JPEG would not).")
    sizes = [("an orbit frame", doc["kinds"]["orbit"]["bytes_per_frame"], doc["width"], doc["height"])]
    if "canvas_1080" in doc:
        c = doc["canvas_1080"]
        sizes.append((f"a {c['width']}x{c['height']} canvas frame", c["bytes_per_frame"], c["width"], c["height"]))
    told = ", ".join(f"{what} {sent / 1e6:.1f} MB of {w * h * 4 / 1e6:.1f} MB of pixels" for what, sent, w, h in sizes)
    return (f"Frames travel losslessly as {encoding} (clshade/view/server.py, encode_view; the canvas equals "
            f"`clshade render`'s PNG): {told}.")
