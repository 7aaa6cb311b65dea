"""The runtimes document (clshade.bench.runtimes: `python -m benchmarks.measure.runtimes`) as Markdown."""
from __future__ import annotations

from clshade.report.tables import MISSING, markdown


def runtimes_markdown(doc: dict) -> str:
    """Every runtime's health and builds, then each model's time and error per healthy runtime."""
    yn = lambda v: MISSING if v is None else ("yes" if v else "no")  # noqa: E731
    prov, mach = doc["provenance"], doc["machine"]
    lines = ["# Every OpenCL runtime on one frame",
             "",
             f"{doc['scene']} at {doc['width']}×{doc['height']} ({doc['covered_pixels']} covered pixels), "
             f"{doc['rounds']} interleaved rounds after {doc['warmup']} warm-up ({doc['timed_run']}, process idle "
             f"before each); medians; measured {doc['created']} on {mach['cpu']} ({mach['cores']} cores), commit "
             f"`{(prov['commit'] or 'unknown')[:10]}`{' (uncommitted changes)' if prov['dirty'] else ''}, "
             f"with `{doc['command']}`.",
             f"Error: against the float64 frame oracle on the same G-buffer, as in `clshade bench`. "
             f"GPU: {doc['gpu']}.",
             "",
             markdown(["device", "runtime", "state", "SIMD", "inline math", "streaming stores", "prefetch", "fp64"],
                      [[f"{d['spec']} {d['device']}", d["runtime"],
                        "healthy" if d["healthy"] else f"broken: {d['reason']}", d.get("simd", MISSING),
                        yn(d.get("inline_math")), yn(d.get("streaming_stores")), yn(d.get("prefetch")), yn(d["fp64"])]
                       for d in doc["devices"]])]
    healthy = [d for d in doc["devices"] if d["healthy"]]
    def cells(r: dict) -> tuple[str, str]:
        return (f"{r['median_ms']:.2f} ({r['copy_ratio']:.2f})", f"{r['max_rel_error']:.1e} / {r['mean_rel_error']:.1e}")
    rows = [[m, *(c for d in healthy for c in cells(d["models"][m]))] for m in doc["models"]]
    rows.append(["geometric mean of the medians", *(c for d in healthy for c in (f"{d['geomean_median_ms']:.2f}", ""))])
    lines += ["", markdown(["model", *(h for d in healthy for h in (f"{d['runtime']} ms (× copy)",
                                                                     "max / mean rel. error"))], rows)]
    fastest = doc["fastest_cpu"]
    agree = fastest is not None and fastest["spec"] == doc["default"]["spec"]
    ranking = ", ".join(next(d["runtime"] for d in healthy if d["spec"] == s) for s in doc["ranking"])
    lines += ["", f"Ranking (fastest first): {ranking}. "
              f"The default selection picks {doc['default']['runtime']} ({doc['default']['spec']}); "
              + ("it is the fastest healthy CPU runtime measured here."
                 if agree else f"the fastest healthy CPU runtime measured here is {fastest and fastest['runtime']}.")
              + f" Preference order in the code: {', '.join(doc['runtime_preference'])}.", ""]
    return "\n".join(lines)
