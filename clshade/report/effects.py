"""benchmarks/results/effects.md from effects.json (benchmarks/measure/effects_bench.py)."""
from __future__ import annotations

from clshade.report.tables import markdown


def effects_markdown(r: dict) -> str:
    """What each effect adds per model, general against specialised kernels, and the host stages."""
    w, h = r["size"]
    keys = list(r["effects"][0]["general_over_specialised"])
    lines = [f"# Effect costs ({r['device']})", "",
             f"{w}×{h} pixels, device time per frame (median of {r['rounds']} interleaved rounds; ratios are "
             "paired per round, then the median); "
             f"shadow maps {r['shadow_map_size']}², PCF {r['shadow_pcf']}×{r['shadow_pcf']}. "
             f"Rendered by `python -m benchmarks.publish` from effects.json (measured by `{r['command']}`).", "",
             f"**Specialisation gain, {r['target']['case']}: {r['target']['specialised_gain']:.2f}× "
             f"(target ≥ {r['target']['required']}×: {'met' if r['target']['met'] else 'NOT met'})**", "",
             "## What each effect adds (specialised kernels; ratios to the same model's 1-light frame)", "",
             markdown(["model", "1 light ms", "4 lights", "16 lights", "ms / extra light",
                       "shadows ×(1 / 4 / 16 lights)", "textures (kernel)"],
                      [[e["model"], f"{e['base_ms']:.2f}", f"{e['lights_4_ratio']:.2f}×",
                        f"{e['lights_16_ratio']:.2f}×", f"{e['ms_per_extra_light']:.3f}",
                        " / ".join(f"{e['shadows_ratio'][n]:.2f}×" for n in ("1", "4", "16")),
                        f"{e['textures_kernel_ratio']:.2f}×"] for e in r["effects"]]),
             "", "## General kernel time ÷ specialised kernel time", "",
             markdown(["model", *keys], [[e["model"], *(f"{e['general_over_specialised'][k]:.2f}×" for k in keys)]
                                         for e in r["effects"]]),
             "", "## Host stages (ms): textures cost here (sampled into the G-buffer), shadows add the map "
                 "rasterisation", "",
             markdown(["configuration", "geometry", "rasterize", "g-buffer", "shadow maps"],
                      [[name, *(f"{st.get(k, 0):.1f}" for k in ("geometry", "rasterize", "g-buffer", "shadow maps"))]
                       for name, st in r["host_stages_ms"].items()]),
             "", "Why shadows cost more than the BRDF, and why the specialisation gain is what it is: "
                 "[docs/effects-notes.md](../../docs/effects-notes.md) (dated notes).",
             "", f"Kernel builds and frames: {r['build_s']} s; whole run {r['total_s']} s.", ""]
    return "\n".join(lines)
