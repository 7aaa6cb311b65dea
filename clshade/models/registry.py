"""The lobes a command may use: the built-in ones, then the user's, as one immutable Registry.

A Registry is built-ins (kernels/models/*.cl) plus the user's lobe files and folders
($CLSHADE_LOBES, --lobes, a scene's render.lobes, a lobe file named as a model) plus the
values of .brdf parameters (--param). It never changes: `with_lobes` and `with_params`
return a new one, so two scenes with different lobe folders in one process never see each
other's lobes. Model specs resolve against it into Models that carry their Lobe objects.

Every lobe file is checked before it is opened: a regular file (budget.regular_file: no FIFO,
device or socket) of at most budget.MAX_LOBE_FILE_BYTES, in a folder of at most
budget.MAX_LOBE_FOLDER_FILES lobe files, with a path a `#line` marker can name. A confined
registry (the viewer's: `confined`) reads lobe files that model specs name from given folders only.
"""
from __future__ import annotations

import difflib
import math
import os
import re
from collections import Counter
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

from clshade import budget
from clshade.errors import ClshadeError
from clshade.models.lobe import USER, Lobe, builtin_lobes, check_lobe_path, parse_lobe
from clshade.models.model import FRESNELS, GROUPS, NONE, PRESETS, WORKFLOWS, Model, default_workflow, preset, presets

#: Folders (or files) of the user's lobes, separated by os.pathsep.
LOBES_ENV = "CLSHADE_LOBES"
LOBE_SUFFIXES = (".cl", ".brdf")
#: Words a model spec gives a meaning of its own, so no lobe of the user's may take them as its id:
#: `none` (no lobe, Model's NONE), `all` and the group names (resolve_many).
RESERVED_IDS = frozenset({NONE, "all", *GROUPS})


@dataclass(frozen=True)
class Registry:
    """Built-in lobes, the user's lobe files and folders (`paths`, in the order given) and the
    .brdf parameter values (`params`, `--param NAME=VALUE`, applied to every .brdf lobe that
    has NAME). The lobes are read on first use and kept with the registry.

    `roots`: None, a model spec may name a lobe file or folder anywhere (relative to the current
    folder); else only inside these real paths, a relative one taken from `base` (`confined`)."""
    paths: tuple[Path, ...] = ()
    params: tuple[tuple[str, str], ...] = ()
    roots: tuple[Path, ...] | None = None
    base: Path | None = None

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None) -> "Registry":
        """The built-ins and the folders of $CLSHADE_LOBES (checked when the lobes are read)."""
        text = (os.environ if environ is None else environ).get(LOBES_ENV, "")
        paths = [_real(p, f"${LOBES_ENV} folder") for p in text.split(os.pathsep) if p.strip()]
        return cls(tuple(dict.fromkeys(paths)))

    def with_lobes(self, *paths: str | Path) -> "Registry":
        """This registry with more lobe folders or files (*.cl, *.brdf); itself when none is new."""
        added = list(self.paths)
        for given in paths:
            path = check_lobe_path(_real(given, "lobe file or folder"))
            if not path.exists():
                raise ClshadeError(f"{path}: no such lobe file or folder")
            if not path.is_dir():
                budget.regular_file(path, "lobe file", budget.MAX_LOBE_FILE_BYTES)
                if path.suffix not in LOBE_SUFFIXES:
                    raise ClshadeError(f"{path}: a lobe file ends in .cl (clshade's format) or .brdf (BRDF Explorer)")
            if path not in added:
                added.append(path)
        return self if len(added) == len(self.paths) else replace(self, paths=tuple(added))

    def with_params(self, values: Mapping[str, str]) -> "Registry":
        """This registry with .brdf parameter values set (`values` win over earlier ones); a value
        holding a number that is not finite (nan, inf, 1e309) is refused, naming the parameter."""
        for name, text in values.items():
            for part in str(text).split(","):
                try:
                    number = float(part)
                except ValueError:
                    continue        # a bool word, or no number: the lobe's own reader says which
                if not math.isfinite(number):
                    raise ClshadeError(f"--param {name}: {text!r} is not a finite number")
        merged = {**dict(self.params), **values}
        return self if merged == dict(self.params) else replace(self, params=tuple(merged.items()))

    def confined(self, base: Path, *more: Path) -> "Registry":
        """This registry reading lobe files that model specs name only inside `base` (relative
        specs are taken from there), its own lobe paths and `more` (files or folders)."""
        roots = tuple(dict.fromkeys(_real(p, "lobe folder") for p in (base, *self.paths, *more)))
        return replace(self, roots=roots, base=roots[0])

    # ------------------------------------------------------------ the lobes

    @cached_property
    def lobes(self) -> Mapping[str, Lobe]:
        """Every lobe by id (read-only): kernels/models/ first, then the user's in path order."""
        if not self.paths:
            return builtin_lobes()
        found = dict(builtin_lobes())
        values = dict(self.params)
        files = self._files()
        read = [_read_brdf(path, values) if path.suffix == ".brdf" else parse_lobe(path, USER) for path in files]
        taken = set(found) | set(PRESETS) | RESERVED_IDS
        for lobe, ident in zip(read, user_ids(files, [l.id for l in read], taken)):
            found[ident] = lobe if ident == lobe.id else replace(lobe, id=ident)
        return MappingProxyType(found)

    def _files(self) -> list[Path]:
        """The lobe files of `paths`, each path checked (check_lobe_path); budget.read_text refuses a special
        file (a FIFO, device or socket) before it opens it."""
        files: dict[Path, None] = {}
        for path in self.paths:
            if path.is_dir():
                found = folder_files(path)
            elif path.exists():
                found = [path]
            else:
                raise ClshadeError(f"{path}: no such lobe folder ({LOBES_ENV}, --lobes or render.lobes)")
            for file in found:
                check_lobe_path(file)
                files[file] = None
        return list(files)

    def ids_in(self, path: str | Path) -> list[str]:
        """The ids of the lobes read from a file or folder of this registry's."""
        path = _real(path, "lobe file or folder")
        return [l.id for l in self.lobes.values() if l.path == path or l.path.parent == path]

    def user_models(self) -> list[Model]:
        """One model per lobe of the user's (each lobe alone, as `-m ID` resolves it)."""
        return [self.resolve(k) for k, v in self.lobes.items() if v.is_users]

    # ------------------------------------------------------------ model specs

    def resolve(self, spec: str, fresnel: str | None = None, workflow: str | None = None) -> Model:
        """Parse a model spec: a preset (`ggx_correlated`), a pair (`oren_nayar+ggx_correlated`),
        a single lobe (`burley`), a lobe file (`ward.brdf`), optionally `@fresnel` and `/workflow`
        suffixes. A lobe file not in this registry is read for this model only."""
        text = spec.strip()
        registry = self
        files = lobe_path(text, self.base, self.roots)
        if files is not None:
            registry = self.with_lobes(files)
            ids = registry.ids_in(files)
            if len(ids) != 1:
                raise ClshadeError(f"model {spec!r}: a folder of {len(ids)} lobes names several models; "
                                   f"use it where a list of models is accepted")
            text = ids[0]
        if "/" in text:
            text, _, wf = text.partition("/")
            workflow = workflow or wf
        suffix = None               # `@fresnel` of the spec (a lobe file's own name may hold an '@')
        if "@" in text:
            text, _, suffix = text.partition("@")
            fresnel = fresnel or suffix
        if fresnel is not None and fresnel not in FRESNELS:
            raise ClshadeError(f"model {spec!r}: unknown Fresnel {fresnel!r}; choose one of {', '.join(FRESNELS)}")
        if workflow is not None and workflow not in WORKFLOWS:
            raise ClshadeError(f"model {spec!r}: unknown workflow {workflow!r}; choose one of {', '.join(WORKFLOWS)}")
        key = text.lower().replace("-", "_").replace(" ", "_")
        lobes = registry.lobes
        if key in PRESETS:
            model = preset(key)
        elif "+" in key or key in lobes:
            names = key.split("+")
            if not all(names):
                raise ClshadeError(f"model {spec!r}: an empty lobe name around '+'; write diffuse+specular, "
                                   f"e.g. oren_nayar+ggx_correlated")
            diffuse, specular = NONE, NONE
            for part in names:
                if part not in lobes:
                    raise registry._unknown(spec, part)
                if lobes[part].kind == "diffuse":
                    if diffuse != NONE:
                        raise ClshadeError(f"model {spec!r}: two diffuse lobes ({diffuse}, {part})")
                    diffuse = part
                else:
                    if specular != NONE:
                        raise ClshadeError(f"model {spec!r}: two specular lobes ({specular}, {part})")
                    specular = part
            chosen = tuple(lobes[p] for p in (diffuse, specular) if p != NONE)
            workflow_of = default_workflow(lobes[specular] if specular != NONE else None)
            model = Model(diffuse, specular, "schlick", workflow_of, lobes=chosen)
        else:
            raise registry._unknown(spec, key)
        if suffix is not None and not model.uses_fresnel:
            raise ClshadeError(f"model {spec!r}: {model.id} has no Fresnel term (no specular lobe that uses one); "
                               f"drop '@{suffix}'")
        return model.with_options(fresnel, workflow)

    def resolve_many(self, spec: str, fresnel: str | None = None, workflow: str | None = None) -> list[Model]:
        """A comma-separated list of model specs, `all` (every preset), a group name or a folder of lobes."""
        out: list[Model] = []
        for item in [s for s in spec.split(",") if s.strip()]:
            key = item.strip().lower()
            files = lobe_path(item.strip(), self.base, self.roots)
            if files is not None and files.is_dir():
                registry = self.with_lobes(files)
                ids = registry.ids_in(files)
                if not ids:
                    raise ClshadeError(f"model {item.strip()!r}: the folder holds no *.cl or *.brdf lobe")
                out += [registry.resolve(i, fresnel, workflow) for i in ids]
            elif key == "all":
                out += [m.with_options(fresnel, workflow) for m in presets()]
            elif key in GROUPS:
                out += [preset(p).with_options(fresnel, workflow) for p in GROUPS[key]]
            else:
                out.append(self.resolve(item, fresnel, workflow))
        if not out:
            raise ClshadeError("no model given")
        return out

    def _unknown(self, spec: str, part: str) -> ClshadeError:
        choices = list(PRESETS) + list(self.lobes)
        near = difflib.get_close_matches(part, choices, n=1)
        hint = f"; did you mean {near[0]!r}?" if near else "; `clshade models` lists them"
        return ClshadeError(f"model {spec!r}: unknown model or lobe {part!r}{hint}")


def user_ids(files: list[Path], names: list[str], taken: set[str]) -> list[str]:
    """The ids of the user's lobe files, whose own ids (their file names) are `names`: a name no
    built-in, preset (`taken`) or other user lobe has is the id; any other is prefixed with the
    file's folders, nearest first, until it is unique (two lambert.brdf in folders mine/ and
    theirs/: `mine_lambert`, `theirs_lambert`; the built-in stays `lambert`)."""
    counts = Counter(names)
    clash = {n for n in names if n in taken or counts[n] > 1}
    used = taken | (set(names) - clash)
    out = []
    for path, name in zip(files, names):
        ident = name
        if name in clash:
            folders = path.parent.parts[1:] if path.is_absolute() else path.parent.parts
            candidates = (_as_id("_".join([*folders[len(folders) - k:], name])) for k in range(1, len(folders) + 1))
            ident = next((c for c in candidates if c not in used), "")
            if not ident:
                raise ClshadeError(f"{path}: lobe id {name!r} stays taken with every folder of the path as a prefix; "
                                   f"rename the file")
        used.add(ident)
        out.append(ident)
    return out


def _as_id(text: str) -> str:
    """Text as a lobe id: lower-case letters, digits and `_`, starting with a letter."""
    text = re.sub(r"[^a-z0-9_]", "_", text.lower())
    return text if text[:1].isalpha() else "lobe_" + text


def _read_brdf(path: Path, values: Mapping[str, str]) -> Lobe:
    """A .brdf lobe with `values` set; a colour set outside its declared range (R, G, B each in
    [0, 1]: a negative one gives negative radiance) is refused, as a float outside its range is."""
    # Imported here, not at the top: the GLSL translator's ~20 AST classes cost every command's
    # start-up (scene parsing imports this module) though only a .brdf file needs them.
    from clshade.models.brdf_file import load_brdf
    lobe = load_brdf(path, values)
    for p in lobe.params:
        if p.kind == "color" and p.name in values and not all(p.low <= c <= p.high for c in p.value):
            raise ClshadeError(f"--param {p.name}={values[p.name]}: R, G and B must be within "
                               f"[{p.low:g}, {p.high:g}] (a colour of {path})")
    return lobe


def folder_files(folder: Path) -> list[Path]:
    """The lobe files (*.cl, *.brdf, not hidden) of a folder, sorted; more than
    budget.MAX_LOBE_FOLDER_FILES are refused (counted by name, before any is read)."""
    found: list[Path] = []
    try:
        with os.scandir(folder) as entries:
            for entry in entries:
                if entry.name.endswith(LOBE_SUFFIXES) and not entry.name.startswith("."):
                    found.append(folder / entry.name)
                    if len(found) > budget.MAX_LOBE_FOLDER_FILES:
                        raise ClshadeError(f"{folder}: more than {budget.MAX_LOBE_FOLDER_FILES} lobe files (*.cl, "
                                           f"*.brdf), the limit of a lobe folder; split it")
    except OSError as exc:
        raise ClshadeError(f"{folder}: cannot list the lobe folder ({exc.strerror or exc})") from None
    return sorted(found)


def _real(given: str | Path, what: str) -> Path:
    """`given` with `~` expanded, made absolute and its links resolved; a link loop or an
    unknown `~user` is a one-line error naming it and `what` it is."""
    try:
        return Path(given).expanduser().resolve()
    except (RuntimeError, OSError) as exc:      # "Symlink loop from …", "Could not determine home directory"
        raise ClshadeError(f"{ascii(str(given))[1:-1]}: cannot resolve the {what} ({exc})") from None


def lobe_path(text: str, base: Path | None = None, roots: tuple[Path, ...] | None = None) -> Path | None:
    """The lobe file (.cl, .brdf) or folder a model spec names, or None for an id. A relative path
    is taken from `base` (default: the current folder); with `roots`, a path whose real location
    is not inside one of them is refused before anything there is read (Registry.confined)."""
    named = Path(text).suffix in LOBE_SUFFIXES or "/" in text or os.sep in text
    if not named:
        return None
    check_lobe_path(Path(text))
    try:
        path = Path(text).expanduser()
    except RuntimeError:            # `~user` of no such user: the path as written
        path = Path(text)
    if base is not None and not path.is_absolute():
        path = base / path
    if roots is not None:
        real = Path(os.path.realpath(path))
        if not any(real == root or root in real.parents for root in roots):
            raise ClshadeError(f"model {text!r}: outside the folders lobe files are read from here "
                               f"({', '.join(map(str, roots))})")
        path = real
    if path.suffix in LOBE_SUFFIXES:
        if not path.exists():
            raise ClshadeError(f"model {text!r}: no such lobe file")
        budget.regular_file(path, "lobe file", budget.MAX_LOBE_FILE_BYTES)
        return path
    return path if path.is_dir() else None

