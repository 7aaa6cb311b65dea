"""benchmarks/results/raster.md from raster.json (benchmarks/measure/raster_bench.py)."""
from __future__ import annotations

from clshade.report.tables import markdown


def raster_markdown(data: dict) -> str:
    """The rasterizer against Embree per scene, and the memory of a large mesh."""
    m, v = data["machine"], data["versions"]
    rows = [[r["scene"], f"{r['triangles']:,}", f"{r['width']}x{r['height']}", f"{r['coverage']:.1%}",
             f"{r['gbuffer_full_median_s']:.3f}", f"{r['raster_median_s']:.3f}", f"{r['raster_cull_median_s']:.3f}",
             f"{r['embree_median_s']:.3f}", f"x{r['speedup_vs_embree']:.2f}", f"x{r['speedup_cull_vs_embree']:.2f}",
             f"{r['id_agreement_vs_embree']:.3%}"] for r in data["scenes"]]
    rows += [[s, "skipped", *[""] * 9] for s in data.get("skipped", [])]
    lines = [
        f"# Rasterizer benchmark (measured by `{data['command']}`, rendered by `python -m benchmarks.publish`)",
        "",
        f"Machine: {m['cpu']}, {m['cores']} CPUs, Python {m['python']}, NumPy {m['numpy']}, trimesh {v['trimesh']}, "
        f"embreex {v['embreex']}; {m['os']}.",
        f"Median of {data['repeats']} interleaved repeats; times in seconds.  `full G-buffer` = rasterize "
        "(back faces culled) + build_gbuffer (normals interpolated, material channels written), the stage "
        "`clshade render` runs; `raster` keeps back faces (same visibility as the ray caster), `raster (cull)` "
        "drops them.  Embree times exclude ray generation and the BVH build.",
        "",
        markdown(["scene", "triangles", "resolution", "coverage", "full G-buffer", "raster", "raster (cull)",
                  "embree first hit", "speedup", "speedup (cull)", "id agreement"], rows),
    ]
    mem = data.get("memory")
    if mem:
        lines += [
            "",
            f"Memory: {mem['triangles']:,} triangles at {mem['width']}x{mem['height']} rasterized in "
            f"{mem['time_s']:.3f} s; peak memory allocated during the call "
            f"**{mem['peak_alloc_during_call_MiB']:.0f} MiB** (tracemalloc; includes the "
            f"{mem['output_MiB']:.0f} MiB output, excludes the {mem['input_MiB']:.0f} MiB input); "
            f"process max RSS {mem['process_max_rss_MiB']:.0f} MiB.",
        ]
    return "\n".join(lines) + "\n"
