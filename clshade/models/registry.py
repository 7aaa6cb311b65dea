"""The lobes a command may use: the built-in ones, then the user's, as one immutable Registry.

A Registry is built-ins (kernels/models/*.cl) plus the user's lobe files and folders
($CLSHADE_LOBES, --lobes, a scene's render.lobes, a lobe file named as a model) plus the
values of .brdf parameters (--param). It never changes: `with_lobes` and `with_params`
return a new one, so two scenes with different lobe folders in one process never see each
other's lobes. Model specs resolve against it into Models that carry their Lobe objects.
"""
from __future__ import annotations

import difflib
import os
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

from clshade.errors import ClshadeError
from clshade.models.lobe import USER, Lobe, builtin_lobes, parse_lobe
from clshade.models.model import FRESNELS, GROUPS, NONE, PRESETS, WORKFLOWS, Model, default_workflow, preset, presets

#: Folders (or files) of the user's lobes, separated by os.pathsep.
LOBES_ENV = "CLSHADE_LOBES"
LOBE_SUFFIXES = (".cl", ".brdf")


@dataclass(frozen=True)
class Registry:
    """Built-in lobes, the user's lobe files and folders (`paths`, in the order given) and the
    .brdf parameter values (`params`, `--param NAME=VALUE`, applied to every .brdf lobe that
    has NAME). The lobes are read on first use and kept with the registry."""
    paths: tuple[Path, ...] = ()
    params: tuple[tuple[str, str], ...] = ()

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None) -> "Registry":
        """The built-ins and the folders of $CLSHADE_LOBES (checked when the lobes are read)."""
        text = (os.environ if environ is None else environ).get(LOBES_ENV, "")
        paths = [Path(p).expanduser().resolve() for p in text.split(os.pathsep) if p.strip()]
        return cls(tuple(dict.fromkeys(paths)))

    def with_lobes(self, *paths: str | Path) -> "Registry":
        """This registry with more lobe folders or files (*.cl, *.brdf); itself when none is new."""
        added = list(self.paths)
        for given in paths:
            path = Path(given).expanduser().resolve()
            if not path.exists():
                raise ClshadeError(f"{path}: no such lobe file or folder")
            if path.is_file() and path.suffix not in LOBE_SUFFIXES:
                raise ClshadeError(f"{path}: a lobe file ends in .cl (clshade's format) or .brdf (BRDF Explorer)")
            if path not in added:
                added.append(path)
        return self if len(added) == len(self.paths) else replace(self, paths=tuple(added))

    def with_params(self, values: Mapping[str, str]) -> "Registry":
        """This registry with .brdf parameter values set (`values` win over earlier ones)."""
        merged = {**dict(self.params), **values}
        return self if merged == dict(self.params) else replace(self, params=tuple(merged.items()))

    # ------------------------------------------------------------ the lobes

    @cached_property
    def lobes(self) -> Mapping[str, Lobe]:
        """Every lobe by id (read-only): kernels/models/ first, then the user's in path order."""
        if not self.paths:
            return builtin_lobes()
        found = dict(builtin_lobes())
        values = dict(self.params)
        for path in self._files():
            lobe = _read_brdf(path, values) if path.suffix == ".brdf" else parse_lobe(path, USER)
            if lobe.id in found or lobe.id in PRESETS:
                other = found[lobe.id].path if lobe.id in found else "a preset"
                raise ClshadeError(f"{path}: lobe id {lobe.id!r} is taken by {other}; rename the file")
            found[lobe.id] = lobe
        return MappingProxyType(found)

    def _files(self) -> list[Path]:
        files: list[Path] = []
        for path in self.paths:
            if path.is_dir():
                found = sorted([*path.glob("*.cl"), *path.glob("*.brdf")])
            elif path.is_file():
                found = [path]
            else:
                raise ClshadeError(f"{path}: no such lobe folder ({LOBES_ENV}, --lobes or render.lobes)")
            files += [f for f in found if f not in files]
        return files

    def ids_in(self, path: str | Path) -> list[str]:
        """The ids of the lobes read from a file or folder of this registry's."""
        path = Path(path).expanduser().resolve()
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
        files = lobe_path(text)
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
        if "@" in text:
            text, _, fr = text.partition("@")
            fresnel = fresnel or fr
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
        if "@" in spec and not model.uses_fresnel:
            raise ClshadeError(f"model {spec!r}: {model.id} has no Fresnel term (no specular lobe that uses one); "
                               f"drop '@{fresnel}'")
        return model.with_options(fresnel, workflow)

    def resolve_many(self, spec: str, fresnel: str | None = None, workflow: str | None = None) -> list[Model]:
        """A comma-separated list of model specs, `all` (every preset), a group name or a folder of lobes."""
        out: list[Model] = []
        for item in [s for s in spec.split(",") if s.strip()]:
            key = item.strip().lower()
            files = lobe_path(item.strip())
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


def _read_brdf(path: Path, values: Mapping[str, str]) -> Lobe:
    # Imported here, not at the top: the GLSL translator's ~20 AST classes cost every command's
    # start-up (scene parsing imports this module) though only a .brdf file needs them.
    from clshade.models.brdf_file import load_brdf
    return load_brdf(path, values)


def lobe_path(text: str) -> Path | None:
    """The lobe file (.cl, .brdf) or folder a model spec names, or None for an id."""
    path = Path(text).expanduser()
    if path.suffix in LOBE_SUFFIXES:
        if not path.is_file():
            raise ClshadeError(f"model {text!r}: no such lobe file")
        return path
    if ("/" in text or os.sep in text) and path.is_dir():
        return path
    return None
