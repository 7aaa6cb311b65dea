"""`clshade check plausibility` and `clshade check stability`: the measurements behind the
claims clshade makes about its models."""
from __future__ import annotations

import argparse

from clshade.cli.common import progress_bar
from clshade.errors import ClshadeError


def cmd_plausibility(args: argparse.Namespace) -> int:
    import json
    from dataclasses import asdict
    from clshade.report.plausibility import plausibility_table
    from clshade.verify import plausibility as P
    sweep = P.QUICK if args.quick else P.Sweep()
    chosen = args.registry.resolve_many(args.model) if args.model else None
    with progress_bar("plausibility", "preset") as progress:
        verdicts = P.evaluate_presets(sweep, args.device, models=chosen, progress=progress, registry=args.registry)
    if args.json:
        print(json.dumps({"energy_tol": P.ENERGY_TOL, "reciprocity_tol": P.RECIPROCITY_TOL,
                          "sweep": asdict(sweep), "presets": [v.as_dict() for v in verdicts]},
                         indent=2, ensure_ascii=False))
    else:
        for line in [plausibility_table(verdicts), ""] + P.describe_method(sweep):
            print(line)
    return 0 if all(v.non_negative and v.reciprocal for v in verdicts) else 1


def cmd_stability(args: argparse.Namespace) -> int:
    import json
    from clshade.report.stability import stability_text
    from clshade.verify import stability
    models = None
    if args.model is not None:
        if not args.model.replace(",", "").strip():
            raise ClshadeError(f"--model = {args.model!r}: no model given; `clshade models` lists them")
        models = [v for m in args.registry.resolve_many(args.model) for v in stability.variants_of(m)]
    with progress_bar("stability", "step") as progress:
        rep = stability.run(models, device=args.device, progress=progress, registry=args.registry,
                            environment=not args.no_environment)
    if args.json:
        print(json.dumps(rep.as_dict(), indent=2, ensure_ascii=False, default=str))
    else:
        print(stability_text(rep))
    return 0 if rep.ok else 1
