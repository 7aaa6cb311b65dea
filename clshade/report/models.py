"""docs/models.md's tables (benchmarks/docgen/models_doc.py): the presets, each lobe's card and
parameters, and the named clamps of the kernel headers."""
from __future__ import annotations

from clshade.report.tables import MISSING, markdown


def presets_table(presets: list) -> str:
    """One row per preset (clshade.models.Model)."""
    return markdown(["preset", "name", "diffuse", "specular", "family", "workflow"],
                    [[m.id, m.label, m.diffuse, m.specular, m.family, m.workflow] for m in presets])


def lobe_card(lobe) -> str:
    """A lobe's formula, source, inputs and file (a two-column table without a header)."""
    return markdown(["", ""], [["formula", lobe.formula], ["source", lobe.source],
                               ["inputs", ", ".join(sorted(lobe.uses)) or MISSING],
                               ["file", f"kernels/models/{lobe.path.name}"]])


def parameters_table(params: list) -> str:
    """A lobe's parameters: range, default and meaning."""
    return markdown(["parameter", "min", "max", "default", "meaning"],
                    [[p.name, f"{p.low:g}", f"{p.high:g}", f"{p.default:g}", p.description] for p in params])


def clamps_table(constants: list) -> str:
    """The named floors (clshade.resources.kernel_constants) with the reason their header gives."""
    return markdown(["constant", "value", "file", "why (from the header)"],
                    [[c.name, f"{c.value:g}", f"kernels/{c.file}", c.comment] for c in constants])
