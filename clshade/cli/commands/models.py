"""`clshade models`: presets and lobes with formula, parameters and source."""
from __future__ import annotations

import argparse
import math
import sys

from clshade.cli.common import progress_bar
from clshade.errors import ClshadeError


def cmd_models(args: argparse.Namespace) -> int:
    import json
    from clshade.models.model import GROUPS, presets
    from clshade.verify.plausibility import physically_based
    lobes = args.registry.lobes
    try:  # measured on the device with a reduced sweep (`clshade check plausibility` for the full one)
        with progress_bar("measuring albedo", "preset") as progress:
            measured: dict[str, bool] = physically_based(progress=progress)
    except ClshadeError as exc:
        print(f"clshade: warning: physically_based not measured ({exc})", file=sys.stderr)
        measured = {}
    if args.json:
        data = {
            "presets": [{"id": m.id, "name": m.label, "diffuse": m.diffuse, "specular": m.specular,
                         "family": m.family, "workflow": m.workflow, "fresnel": m.fresnel if m.uses_fresnel else None,
                         "physically_based": measured.get(m.id)}
                        for m in presets()],
            "lobes": [{"id": l.id, "name": l.name, "kind": l.kind, "family": l.family, "formula": l.formula,
                       "source": l.source, "uses": sorted(l.uses), "notes": list(l.notes),
                       "origin": l.origin, "path": str(l.path) if l.is_users else None,
                       "deviations": list(l.deviations),
                       "params": [{"name": p.name, "min": p.low, "max": p.high, "default": p.default,
                                   "description": p.description} for p in l.params]}
                      for l in lobes.values()],
            "groups": {k: list(v) for k, v in GROUPS.items()},
        }
        try:        # JSON has no NaN or Infinity; the lobe readers refuse them, this says which if one passed
            text = json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False)
        except ValueError:
            bad = [f"{l.source}: param {p.name}" for l in lobes.values() for p in l.params
                   if not all(math.isfinite(x) for x in (p.low, p.high, p.default, *p.value))]
            where = bad[0] if bad else "clshade models --json"
            raise ClshadeError(f"{where}: a number that is not finite cannot be written as JSON") from None
        print(text)
        return 0
    print("Presets (the study's shaders):")
    for m in presets():
        pb = {True: "physically based", False: "not physically based", None: "unmeasured"}[measured.get(m.id)]
        print(f"  {m.id:32s} {m.label:26s} {m.family:10s} workflow={m.workflow:8s} {pb} (measured)")
    print("\nLobes (combine as diffuse+specular, e.g. oren_nayar+ggx_correlated; append @dielectric or "
          "@conductor for exact Fresnel):")
    for l in lobes.values():
        params = ", ".join(_param_text(p) for p in l.params) or "no parameters"
        print(f"  {l.id:24s} {l.kind:8s} {l.family:10s} {l.formula}")
        print(f"  {'':24s} params: {params}")
        print(f"  {'':24s} source: {l.source}")
        if l.is_users:
            print(f"  {'':24s} yours: {l.path} ({'BRDF Explorer file' if l.origin == 'brdf' else 'lobe file'})")
    return 0


def _param_text(p) -> str:
    """One parameter for `clshade models`: range and default, and the value compiled in where set."""
    if p.kind in ("float", "color") and not p.value and p.description.startswith("the material key"):
        return f"{p.name} = the material key (per pixel)"
    if p.kind == "color":
        return f"{p.name} (colour) = {','.join(f'{c:g}' for c in p.value)}"
    if p.kind == "bool":
        return f"{p.name} (bool) = {int(p.value[0])}"
    text = f"{p.name} [{p.low:g}, {p.high:g}] = {p.default:g}"
    return text + (f" (set to {p.value[0]:g})" if p.value and p.value[0] != p.default else "")
