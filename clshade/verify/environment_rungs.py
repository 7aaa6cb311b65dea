"""The rungs of the environment ladder as the benchmark (clshade.bench.environment) and the stability check
(clshade.verify.environment_stability) enumerate them: every diffuse × specular rung of
clshade.render.environment (a rung added there is enumerated with no change here), a sampling one once per N."""
from __future__ import annotations

from dataclasses import dataclass

from clshade.errors import ClshadeError
from clshade.models.model import Model
from clshade.render import environment as E

#: The specular rungs that prefilter the sky for a built-in lobe family (clshade.device.variants.split_family):
#: a user's lobe has none, so the ladder leaves them out for it (the sampled rung serves every lobe).
PREFILTERED = ("split_sum", "split_sum_ms")

#: The sample ladder of the sampled rungs by default: N from 1 to the top the issue asks for (×4 a step:
#: the Monte Carlo error halves per step, so each step is visible on a log plot).
SAMPLE_LADDER = (1, 4, 16, 64, 256, 1024)


@dataclass(frozen=True)
class Rung:
    """One configuration of the ladder: a diffuse and a specular rung, and N when one of them samples."""
    diffuse: str
    specular: str
    samples: int | None = None

    @property
    def label(self) -> str:
        n = f" N={self.samples}" if self.samples is not None else ""
        return f"{self.diffuse}/{self.specular}{n}"


def ladder_rungs(samples: tuple[int, ...] = SAMPLE_LADDER) -> list[Rung]:
    """Every diffuse × specular rung of clshade.render.environment, a sampling one once per N of `samples`."""
    samples = tuple(dict.fromkeys(samples))
    for n in samples:
        if E.check_rungs(E.DEFAULT_DIFFUSE, "none", n):
            raise ClshadeError(f"sample ladder: N = {n}: {E.check_rungs(E.DEFAULT_DIFFUSE, 'none', n)}")
    if not samples:
        raise ClshadeError("sample ladder: no N given")
    out = []
    for d in E.DIFFUSE_RUNGS:
        for s in E.SPECULAR_RUNGS:
            if "sampled" in (d, s):
                out += [Rung(d, s, n) for n in samples]
            else:
                out.append(Rung(d, s))
    return out




def model_rungs(model: Model, rungs: list[Rung]) -> list[Rung]:
    """The rungs of `rungs` that shade `model` differently: a model without a specular lobe runs only specular
    "none" (every specular rung shades it alike), and one whose lobe has no prefilter family (a user's lobe:
    clshade/render/environment.py's LOBE_SAMPLING) skips the PREFILTERED rungs."""
    if model.specular == "none":
        return [r for r in rungs if r.specular == "none"]
    lobe = model.specular_lobe
    if lobe is None or lobe.is_users or lobe.id not in E.LOBE_SAMPLING:
        return [r for r in rungs if r.specular not in PREFILTERED]
    return list(rungs)
