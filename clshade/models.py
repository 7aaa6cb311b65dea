"""The lighting-model registry: the one source of truth for model metadata.

Each lobe is one file in kernels/models/ whose header block (``/*! clshade-model``)
declares its id, name, kind, family, formula, source, parameters, the inputs
it uses and its deviations from the study. This module parses those headers;
nothing here repeats them. A lighting *model* is a diffuse lobe plus a
specular lobe, a Fresnel term and a workflow; presets carry the study's
shader names.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path

from clshade.errors import ClshadeError
from clshade.resources import kernels_dir

FRESNELS = ("schlick", "dielectric", "conductor")
WORKFLOWS = ("metallic", "kdks")
NONE = "none"


@dataclass(frozen=True)
class Param:
    """One lobe parameter as declared in its kernel file: `name | min | max | default | text`."""
    name: str
    low: float
    high: float
    default: float
    description: str


@dataclass(frozen=True)
class Lobe:
    """A diffuse or specular lobe, read from kernels/models/<id>.cl."""
    id: str
    name: str
    kind: str          # "diffuse" or "specular"
    family: str        # "diffuse", "empirical" or "microfacet"
    formula: str
    source: str
    params: tuple[Param, ...]
    uses: frozenset[str]
    notes: tuple[str, ...]
    deviations: tuple[str, ...]
    path: Path


_HEADER = re.compile(r"/\*!\s*clshade-model(.*?)\*/", re.S)


def _parse_lobe(path: Path) -> Lobe:
    match = _HEADER.search(path.read_text(encoding="utf-8"))
    if not match:
        raise ClshadeError(f"{path}: no '/*! clshade-model' header block")
    single: dict[str, str] = {}
    multi: dict[str, list[str]] = {"param": [], "note": [], "deviation": []}
    for raw in match.group(1).splitlines():
        line = raw.strip().lstrip("*").strip()
        if not line:
            continue
        key, sep, value = line.partition(":")
        if not sep:
            raise ClshadeError(f"{path}: header line {line!r} is not 'key: value'")
        key, value = key.strip(), value.strip()
        if key in multi:
            multi[key].append(value)
        else:
            single[key] = value
    required = ("id", "name", "kind", "family", "formula", "source")
    missing = [k for k in required if k not in single]
    if missing:
        raise ClshadeError(f"{path}: header lacks {', '.join(missing)}")
    if single["id"] != path.stem:
        raise ClshadeError(f"{path}: id = {single['id']!r} differs from the file name")
    params = []
    for text in multi["param"]:
        cells = [c.strip() for c in text.split("|")]
        if len(cells) != 5:
            raise ClshadeError(f"{path}: param {text!r} is not 'name | min | max | default | text'")
        params.append(Param(cells[0], float(cells[1]), float(cells[2]), float(cells[3]), cells[4]))
    uses = frozenset(u.strip() for u in single.get("uses", "-").split(",") if u.strip() not in ("", "-"))
    return Lobe(id=single["id"], name=single["name"], kind=single["kind"], family=single["family"],
                formula=single["formula"], source=single["source"], params=tuple(params), uses=uses,
                notes=tuple(multi["note"]), deviations=tuple(multi["deviation"]), path=path)


@lru_cache(maxsize=None)
def lobes() -> dict[str, Lobe]:
    """Every lobe in kernels/models/, by id."""
    found = {}
    for path in sorted((kernels_dir() / "models").glob("*.cl")):
        lobe = _parse_lobe(path)
        found[lobe.id] = lobe
    return found


def diffuse_lobes() -> list[str]:
    return [k for k, v in lobes().items() if v.kind == "diffuse"]


def specular_lobes() -> list[str]:
    return [k for k, v in lobes().items() if v.kind == "specular"]


@dataclass(frozen=True)
class Model:
    """A lighting model: f = k_d·diffuse_color·f_d + k_s·f_s (see kernels/compose.h)."""
    diffuse: str                  # a diffuse lobe id or "none"
    specular: str                 # a specular lobe id or "none"
    fresnel: str = "schlick"
    workflow: str = "metallic"
    name: str = field(default="", compare=False)

    @property
    def id(self) -> str:
        """Canonical id: `diffuse+specular`, with non-default Fresnel/workflow appended."""
        parts = [p for p in (self.diffuse, self.specular) if p != NONE] or [NONE]
        text = "+".join(parts)
        if self.fresnel != "schlick" and self.uses_fresnel:
            text += f"@{self.fresnel}"
        if self.workflow != default_workflow(self.specular):
            text += f"/{self.workflow}"
        return text

    @property
    def label(self) -> str:
        return self.name or self.id

    @property
    def lobes(self) -> list[Lobe]:
        return [lobes()[x] for x in (self.diffuse, self.specular) if x != NONE]

    @property
    def uses(self) -> frozenset[str]:
        used: set[str] = set()
        for lobe in self.lobes:
            used |= lobe.uses
        if self.workflow == "kdks":
            used |= {"kd", "ks", "ka"}
            if "fresnel" in used and self.fresnel == "schlick":
                used.add("ior")
        else:
            used.add("metallic")
        if "fresnel" in used:
            used |= {"dielectric": {"ior"}, "conductor": {"eta", "k"}, "schlick": {"f90"}}[self.fresnel]
        return frozenset(used)

    @property
    def uses_fresnel(self) -> bool:
        return any("fresnel" in lobe.uses for lobe in self.lobes)

    @property
    def family(self) -> str:
        """The study's category: the specular lobe's family, or diffuse."""
        return lobes()[self.specular].family if self.specular != NONE else "diffuse"

    def with_options(self, fresnel: str | None = None, workflow: str | None = None) -> "Model":
        return replace(self, fresnel=fresnel or self.fresnel, workflow=workflow or self.workflow)


def default_workflow(specular: str) -> str:
    """Empirical lobes use the study's k_d + k_s = 1 rule, the rest metallic-roughness."""
    if specular != NONE and lobes()[specular].family == "empirical":
        return "kdks"
    return "metallic"


# The study's shaders by name. Diffuse presets have no specular lobe; the
# empirical and microfacet presets pair their lobe with Lambert, as the study does.
PRESETS: dict[str, tuple[str, str, str]] = {
    "lambert": ("Lambert", "lambert", NONE),
    "oren_nayar": ("Oren–Nayar", "oren_nayar", NONE),
    "burley": ("Burley", "burley", NONE),
    "phong": ("Phong", "lambert", "phong"),
    "phong_normalized": ("Normalized Phong", "lambert", "phong_normalized"),
    "blinn_phong": ("Blinn–Phong", "lambert", "blinn_phong"),
    "blinn_phong_normalized": ("Normalized Blinn–Phong", "lambert", "blinn_phong_normalized"),
    "cook_torrance": ("Cook–Torrance", "lambert", "cook_torrance"),
    "walter_ggx": ("Walter GGX", "lambert", "walter_ggx"),
    "ggx_correlated": ("GGX height-correlated", "lambert", "ggx_correlated"),
}

# The study's groups, as its figures lay them out.
GROUPS: dict[str, tuple[str, ...]] = {
    "diffuse": ("lambert", "oren_nayar", "burley"),
    "empirical": ("phong", "phong_normalized", "blinn_phong", "blinn_phong_normalized"),
    "microfacet": ("cook_torrance", "walter_ggx", "ggx_correlated"),
}


def preset(name: str) -> Model:
    label, diffuse, specular = PRESETS[name]
    return Model(diffuse, specular, "schlick", default_workflow(specular), name=label)


def presets() -> list[Model]:
    return [preset(p) for p in PRESETS]


def resolve(spec: str, fresnel: str | None = None, workflow: str | None = None) -> Model:
    """Parse a model spec: a preset (`ggx_correlated`), a pair (`oren_nayar+ggx_correlated`),
    a single lobe (`burley`), optionally `@fresnel` and `/workflow` suffixes."""
    text = spec.strip()
    if "/" in text:
        text, _, wf = text.partition("/")
        workflow = workflow or wf
    if "@" in text:
        text, _, fr = text.partition("@")
        fresnel = fresnel or fr
    if fresnel is not None and fresnel not in FRESNELS:
        raise ClshadeError(f"model {spec!r}: unknown Fresnel {fresnel!r}; choose one of {', '.join(FRESNELS)}")
    if workflow is not None and workflow not in WORKFLOWS:
        raise ClshadeError(f"model {spec!r}: unknown workflow {workflow!r}; choose one of {', '.join(WORKFLOWS)}")
    key = text.lower().replace("-", "_").replace(" ", "_")
    if key in PRESETS:
        model = preset(key)
    elif "+" in key or key in lobes():
        names = key.split("+")
        if not all(names):
            raise ClshadeError(f"model {spec!r}: an empty lobe name around '+'; write diffuse+specular, "
                               f"e.g. oren_nayar+ggx_correlated")
        diffuse, specular = NONE, NONE
        for part in names:
            if part not in lobes():
                raise _unknown(spec, part)
            if lobes()[part].kind == "diffuse":
                if diffuse != NONE:
                    raise ClshadeError(f"model {spec!r}: two diffuse lobes ({diffuse}, {part})")
                diffuse = part
            else:
                if specular != NONE:
                    raise ClshadeError(f"model {spec!r}: two specular lobes ({specular}, {part})")
                specular = part
        model = Model(diffuse, specular, "schlick", default_workflow(specular))
    else:
        raise _unknown(spec, key)
    if "@" in spec and not model.uses_fresnel:
        raise ClshadeError(f"model {spec!r}: {model.id} has no Fresnel term (no specular lobe that uses one); "
                           f"drop '@{fresnel}'")
    return model.with_options(fresnel, workflow)


def _unknown(spec: str, part: str) -> ClshadeError:
    import difflib
    choices = list(PRESETS) + list(lobes())
    near = difflib.get_close_matches(part, choices, n=1)
    hint = f"; did you mean {near[0]!r}?" if near else "; `clshade models` lists them"
    return ClshadeError(f"model {spec!r}: unknown model or lobe {part!r}{hint}")


def resolve_many(spec: str, fresnel: str | None = None, workflow: str | None = None) -> list[Model]:
    """A comma-separated list of model specs, `all` (every preset) or a group name."""
    out: list[Model] = []
    for item in [s for s in spec.split(",") if s.strip()]:
        key = item.strip().lower()
        if key == "all":
            out += [m.with_options(fresnel, workflow) for m in presets()]
        elif key in GROUPS:
            out += [preset(p).with_options(fresnel, workflow) for p in GROUPS[key]]
        else:
            out.append(resolve(item, fresnel, workflow))
    if not out:
        raise ClshadeError("no model given")
    return out
