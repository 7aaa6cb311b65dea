"""The lighting-model registry: the one source of truth for model metadata.

Each lobe is one file in kernels/models/ whose header block (``/*! clshade-model``)
declares its id, name, kind, family, formula, source, parameters, the inputs
it uses and its deviations from the study. This module parses those headers;
nothing here repeats them. A lighting *model* is a diffuse lobe plus a
specular lobe, a Fresnel term and a workflow; presets carry the study's
shader names.
"""
from __future__ import annotations

import os
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
    """One lobe parameter as declared in its kernel file: `name | min | max | default | text`.
    A BRDF Explorer file's parameters are Params too (`kind` float, color or bool; a colour's
    default is its grey level, its `value` the RGB triple compiled in)."""
    name: str
    low: float
    high: float
    default: float
    description: str
    kind: str = "float"
    value: tuple[float, ...] = ()


# Where a lobe comes from: shipped in kernels/models/, a user's .cl file, a BRDF Explorer .brdf file.
BUILT_IN, USER, BRDF_FILE = "built-in", "user", "brdf"

# The inputs a lobe may declare in `uses:` (Surface fields, the Fresnel term, and the
# Geometry's vectors: `vectors` = n, l, v; `tangents` = the tangent frame x, y too).
USES = frozenset({"roughness", "metallic", "fresnel", "shininess", "kd", "ks", "ka", "ior", "f90", "eta", "k",
                  "vectors", "tangents"})
# The surface inputs every model reads besides its lobes' parameters (kernels/surface.h
# make_surface, per pixel in the G-buffer), declared as a lobe declares its parameters. The
# defaults are the scene format's (clshade.render.scene.Material; tests/test_view.py checks them).
SURFACE_PARAMS = (
    Param("base_color", 0.0, 1.0, 0.8, "linear base colour, each of R, G, B (albedo; a metal's F0)", kind="color"),
    Param("metallic", 0.0, 1.0, 0.0, "metalness (metallic workflow): 0 dielectric, 1 metal"),
)
# Uses that are Geometry options, not material inputs (compiled in: GEOMETRY_VECTORS, GEOMETRY_TANGENTS).
GEOMETRY_USES = frozenset({"vectors", "tangents"})


@dataclass(frozen=True)
class Lobe:
    """A diffuse or specular lobe, read from kernels/models/<id>.cl or a user's lobe file."""
    id: str
    name: str
    kind: str          # "diffuse" or "specular"
    family: str        # "diffuse", "empirical" or "microfacet" (built-in); any word for a user's lobe
    formula: str
    source: str
    params: tuple[Param, ...]
    uses: frozenset[str]
    notes: tuple[str, ...]
    deviations: tuple[str, ...]
    path: Path
    origin: str = BUILT_IN
    code: str = ""     # the OpenCL C that clshade.device.variants assembles (with its #line marker)

    @property
    def is_users(self) -> bool:
        return self.origin != BUILT_IN


_HEADER = re.compile(r"/\*!\s*clshade-model(.*?)\*/", re.S)
# The function a lobe file defines, by kind (compose.h calls it).
LOBE_FUNCTIONS = {"diffuse": ("real", "diffuse_lobe"), "specular": ("vec3", "specular_lobe")}
ID_PATTERN = re.compile(r"[a-z][a-z0-9_]*")


def _parse_lobe(path: Path, origin: str = BUILT_IN, label: str | None = None) -> Lobe:
    """A lobe file's header and code; errors name the file and the header line (`path:line: ...`)."""
    text = path.read_text(encoding="utf-8")
    where = label or str(path)
    match = _HEADER.search(text)
    if not match:
        raise ClshadeError(f"{where}:1: no '/*! clshade-model' header block")
    first = text.count("\n", 0, match.start(1)) + 1
    single: dict[str, str] = {}
    lines: dict[str, int] = {}
    multi: dict[str, list[tuple[str, int]]] = {"param": [], "note": [], "deviation": []}
    for offset, raw in enumerate(match.group(1).splitlines()):
        line = raw.strip().lstrip("*").strip()
        at = first + offset
        if not line:
            continue
        key, sep, value = line.partition(":")
        if not sep:
            raise ClshadeError(f"{where}:{at}: header line {line!r} is not 'key: value'")
        key, value = key.strip(), value.strip()
        lines[key] = at
        if key in multi:
            multi[key].append((value, at))
        else:
            single[key] = value
    end = text.count("\n", 0, match.end()) + 1
    required = ("id", "name", "kind", "family", "formula", "source")
    missing = [k for k in required if k not in single]
    if missing:
        raise ClshadeError(f"{where}:{end}: header lacks {', '.join(missing)}")
    if single["id"] != path.stem:
        raise ClshadeError(f"{where}:{lines['id']}: id = {single['id']!r} differs from the file name")
    if not ID_PATTERN.fullmatch(single["id"]):
        raise ClshadeError(f"{where}:{lines['id']}: id = {single['id']!r} must be lower-case letters, digits and _")
    if single["kind"] not in LOBE_FUNCTIONS:
        raise ClshadeError(f"{where}:{lines['kind']}: kind = {single['kind']!r} must be diffuse or specular")
    params = []
    for value, at in multi["param"]:
        cells = [c.strip() for c in value.split("|")]
        try:
            if len(cells) != 5:
                raise ValueError
            params.append(Param(cells[0], float(cells[1]), float(cells[2]), float(cells[3]), cells[4]))
        except ValueError:
            raise ClshadeError(f"{where}:{at}: param {value!r} is not 'name | min | max | default | text'") from None
    uses = frozenset(u.strip() for u in single.get("uses", "-").split(",") if u.strip() not in ("", "-"))
    unknown = sorted(uses - USES)
    if unknown:
        raise ClshadeError(f"{where}:{lines['uses']}: uses {', '.join(unknown)}: not an input of a lobe "
                           f"(known: {', '.join(sorted(USES))})")
    ctype, function = LOBE_FUNCTIONS[single["kind"]]
    body = text[match.end():]
    if not re.search(rf"\b{ctype}\s+{function}\s*\(", body):
        raise ClshadeError(f"{where}:{end}: kind: {single['kind']} needs a function "
                           f"'INLINE {ctype} {function}(const Geometry g, const Surface s)' after the header")
    name = f"models/{path.name}" if origin == BUILT_IN else str(path)
    return Lobe(id=single["id"], name=single["name"], kind=single["kind"], family=single["family"],
                formula=single["formula"], source=single["source"], params=tuple(params), uses=uses,
                notes=tuple(v for v, _ in multi["note"]), deviations=tuple(v for v, _ in multi["deviation"]),
                path=path, origin=origin, code=f'#line 1 "{name}"\n{text}\n')


# ------------------------------------------------------------ the user's lobes

#: Folders (or files) of the user's lobes, separated by os.pathsep.
LOBES_ENV = "CLSHADE_LOBES"
_user_paths: list[Path] = []             # added by add_lobes() (--lobes, a scene's render.lobes, -m FILE)
_param_values: dict[str, str] = {}      # --param NAME=VALUE for .brdf parameters


def add_lobes(path: str | Path) -> list[str]:
    """Register a folder of lobe files (*.cl, *.brdf) or one such file; returns their ids."""
    path = Path(path).expanduser().resolve()
    if not path.exists():
        raise ClshadeError(f"{path}: no such lobe file or folder")
    if path.is_file() and path.suffix not in (".cl", ".brdf"):
        raise ClshadeError(f"{path}: a lobe file ends in .cl (clshade's format) or .brdf (BRDF Explorer)")
    if path not in _user_paths:
        _user_paths.append(path)
        lobes.cache_clear()
    return [l.id for l in lobes().values() if l.path == path or l.path.parent == path]


def set_params(values: dict[str, str]) -> None:
    """Values of .brdf parameters (`--param NAME=VALUE`), applied to every .brdf lobe that has NAME."""
    if values != _param_values:
        _param_values.clear()
        _param_values.update(values)
        lobes.cache_clear()


def reset_user_lobes() -> None:
    """Forget the lobes and parameter values added in this process (not $CLSHADE_LOBES)."""
    _user_paths.clear()
    _param_values.clear()
    lobes.cache_clear()


def _user_files() -> list[Path]:
    paths = [Path(p).expanduser().resolve() for p in os.environ.get(LOBES_ENV, "").split(os.pathsep) if p.strip()]
    files: list[Path] = []
    for path in [*paths, *_user_paths]:
        if path.is_dir():
            found = sorted([*path.glob("*.cl"), *path.glob("*.brdf")])
        elif path.is_file():
            found = [path]
        else:
            raise ClshadeError(f"{path}: no such lobe folder ({LOBES_ENV}, --lobes or render.lobes)")
        files += [f for f in found if f not in files]
    return files


@lru_cache(maxsize=None)
def builtin_lobes() -> dict[str, Lobe]:
    """The lobes clshade ships (kernels/models/*.cl), by id."""
    found = {}
    for path in sorted((kernels_dir() / "models").glob("*.cl")):
        lobe = _parse_lobe(path)
        found[lobe.id] = lobe
    return found


@lru_cache(maxsize=None)
def lobes() -> dict[str, Lobe]:
    """Every lobe by id: kernels/models/ first, then the user's (CLSHADE_LOBES, add_lobes)."""
    from clshade.brdf_explorer import load_brdf
    found = dict(builtin_lobes())
    for path in _user_files():
        lobe = load_brdf(path, _param_values) if path.suffix == ".brdf" else _parse_lobe(path, USER)
        if lobe.id in found or lobe.id in PRESETS:
            other = found[lobe.id].path if lobe.id in found else "a preset"
            raise ClshadeError(f"{path}: lobe id {lobe.id!r} is taken by {other}; rename the file")
        found[lobe.id] = lobe
    return found


def diffuse_lobes() -> list[str]:
    return [k for k, v in lobes().items() if v.kind == "diffuse"]


def user_models() -> list["Model"]:
    """One model per lobe of the user's (each lobe alone, as `-m ID` resolves it)."""
    return [resolve(k) for k, v in lobes().items() if v.is_users]


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
            if self.specular != NONE:   # F0 = ((ior − 1)/(ior + 1))²: Schlick's F and the ambient's k_s·F0 (compose.h)
                used.add("ior")
        else:
            used.add("metallic")
        if "fresnel" in used:
            used |= {"dielectric": {"ior"}, "conductor": {"eta", "k"}, "schlick": {"f90"}}[self.fresnel]
        return frozenset(used)

    @property
    def is_users(self) -> bool:
        """Some lobe is the user's: no Python formula; the float64 reference is the lobe's
        double-precision device build (clshade.verify.reference.device_f64)."""
        return any(lobe.is_users for lobe in self.lobes)

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
    files = _lobe_path(text)
    if files is not None:
        ids = add_lobes(files)
        if len(ids) != 1:
            raise ClshadeError(f"model {spec!r}: a folder of {len(ids)} lobes names several models; "
                               f"use it where a list of models is accepted")
        text = ids[0]
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


def _lobe_path(text: str) -> Path | None:
    """The lobe file (.cl, .brdf) or folder a model spec names, or None for an id."""
    path = Path(text).expanduser()
    if path.suffix in (".cl", ".brdf"):
        if not path.is_file():
            raise ClshadeError(f"model {text!r}: no such lobe file")
        return path
    if ("/" in text or os.sep in text) and path.is_dir():
        return path
    return None


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
        files = _lobe_path(item.strip())
        if files is not None and files.is_dir():
            ids = add_lobes(files)
            if not ids:
                raise ClshadeError(f"model {item.strip()!r}: the folder holds no *.cl or *.brdf lobe")
            out += [resolve(i, fresnel, workflow) for i in ids]
        elif key == "all":
            out += [m.with_options(fresnel, workflow) for m in presets()]
        elif key in GROUPS:
            out += [preset(p).with_options(fresnel, workflow) for p in GROUPS[key]]
        else:
            out.append(resolve(item, fresnel, workflow))
    if not out:
        raise ClshadeError("no model given")
    return out
