"""The mutation catalogue (catalogue.toml): each mutant is one small semantic bug, anchored to a file, a function
in it (benchmarks/mutation/anchors.py) and a text that occurs exactly once inside that function.

A mutant resolves in a tree in three steps: its file; the anchor in that file; the text inside the anchor. Where
the file no longer defines the anchor (the file moved, or the function moved to another file), the tree is searched:
the mutant resolves to the one file (of the same language, C and OpenCL counting as one; outside tests/ and the
results) whose anchor of that name holds the text exactly once, and is reported as moved. A mutant that resolves
nowhere, or in several files, has its anchor *gone*: reported with the reason, never applied. A text found more than
once inside its anchor is an error in the catalogue (the mutant would be ambiguous), as are malformed entries.
"""
from __future__ import annotations

import json
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

from benchmarks.mutation.anchors import C_SUFFIXES, SUFFIXES, AnchorError, regions

CATALOGUE_FILE = Path(__file__).with_name("catalogue.toml")
FIELDS = ("name", "file", "anchor", "original", "replacement", "description")
#: Folders never searched for a moved anchor: tests, measured results, and what is not source.
NOT_SEARCHED = {"tests", ".git", "__pycache__", "build", "dist", ".venv", "out", ".pytest_cache", ".hypothesis"}
NOT_SEARCHED_PATHS = ("benchmarks/results", "benchmarks/report")


class CatalogueError(ValueError):
    """A mistake in the catalogue itself: a malformed entry, a duplicate name, a text not unique in its anchor."""


@dataclass(frozen=True)
class Mutant:
    name: str
    file: str
    anchor: str
    original: str
    replacement: str
    description: str


@dataclass(frozen=True)
class Site:
    """Where `mutant` applies in one tree: text[start:end] of `file`; `gone` says why it applies nowhere."""
    mutant: Mutant
    file: str | None
    start: int = 0
    end: int = 0
    gone: str = ""

    @property
    def moved(self) -> bool:
        return self.file is not None and self.file != self.mutant.file


def load(path: Path = CATALOGUE_FILE) -> list[Mutant]:
    """The catalogue's mutants, in file order; a malformed entry or a duplicate name is a CatalogueError."""
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise CatalogueError(f"{path}: {err}") from None
    out: list[Mutant] = []
    for i, entry in enumerate(doc.get("mutant", [])):
        label = entry.get("name", f"entry {i + 1}")
        if set(entry) != set(FIELDS) or not all(isinstance(entry[k], str) for k in FIELDS):
            raise CatalogueError(f"{path}: mutant {label}: needs exactly the string fields {', '.join(FIELDS)} "
                                 f"(has {', '.join(sorted(entry))})")
        if not entry["name"] or not entry["anchor"] or not entry["original"]:
            raise CatalogueError(f"{path}: mutant {label}: empty name, anchor or original text")
        if not entry["file"].endswith(SUFFIXES):
            raise CatalogueError(f"{path}: mutant {label}: {entry['file']} is not a file with anchors "
                                 f"({', '.join(SUFFIXES)})")
        out.append(Mutant(**{k: entry[k] for k in FIELDS}))
    names = [m.name for m in out]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise CatalogueError(f"{path}: duplicate mutant names: {', '.join(dupes)}")
    if set(doc) - {"mutant"}:
        raise CatalogueError(f"{path}: unknown tables {', '.join(sorted(set(doc) - {'mutant'}))}")
    return out


class Tree:
    """A source tree read lazily: each file's text and anchor regions, read once."""

    def __init__(self, root: Path):
        self.root = root
        self._texts: dict[str, str | None] = {}
        self._regions: dict[str, list] = {}
        self._listing: dict[tuple[str, ...], list[str]] = {}

    def text(self, rel: str) -> str | None:
        if rel not in self._texts:
            path = self.root / rel
            self._texts[rel] = path.read_text(encoding="utf-8") if path.is_file() else None
        return self._texts[rel]

    def regions(self, rel: str) -> list:
        if rel not in self._regions:
            self._regions[rel] = regions(rel, self.text(rel) or "")
        return self._regions[rel]

    def files(self, like: str) -> list[str]:
        """Every source file of the tree in the language of the file `like` (C and OpenCL: .cl, .h, .c together),
        outside the folders never searched."""
        suffixes = C_SUFFIXES if like.endswith(C_SUFFIXES) else (Path(like).suffix,)
        if suffixes not in self._listing:
            found = []
            for folder, dirs, names in os.walk(self.root):
                rel_folder = Path(folder).relative_to(self.root).as_posix()
                dirs[:] = sorted(d for d in dirs if d not in NOT_SEARCHED and not d.endswith(".egg-info")
                                 and f"{rel_folder}/{d}".removeprefix("./") not in NOT_SEARCHED_PATHS)
                found += [f"{rel_folder}/{n}".removeprefix("./") for n in names if n.endswith(suffixes)]
            self._listing[suffixes] = sorted(found)
        return self._listing[suffixes]

    def occurrences(self, rel: str, anchor: str, original: str) -> list[int] | None:
        """Offsets where `original` lies wholly inside the anchor's regions of file `rel`; None where the file
        does not define the anchor."""
        mine = [r for r in self.regions(rel) if r.name == anchor]
        if not mine:
            return None
        text = self.text(rel) or ""
        found: set[int] = set()
        for r in mine:
            at = text.find(original, r.start, r.end)
            while at >= 0:
                found.add(at)
                at = text.find(original, at + 1, r.end)
        return sorted(found)


def resolve(tree: Tree, mutant: Mutant) -> Site:
    """Where `mutant` applies in `tree` (see the module's docstring); CatalogueError where its text is not unique
    inside its anchor in the catalogue's file."""
    text = tree.text(mutant.file)
    where = f"{mutant.anchor} of {mutant.file}"
    if text is not None:
        try:
            found = tree.occurrences(mutant.file, mutant.anchor, mutant.original)
        except AnchorError as err:
            raise CatalogueError(f"mutant {mutant.name}: {mutant.file}: {err}") from None
        if found is not None:
            if len(found) > 1:
                raise CatalogueError(f"mutant {mutant.name}: text found {len(found)} times in {where} (it must "
                                     f"occur once inside its anchor): {mutant.original!r}")
            if not found:
                return Site(mutant, None, gone=f"{where} no longer holds the text {mutant.original!r}")
            return Site(mutant, mutant.file, found[0], found[0] + len(mutant.original))
    missing = f"{mutant.file} not found" if text is None else f"no {mutant.anchor} in {mutant.file}"
    elsewhere = []
    for rel in tree.files(mutant.file):
        if rel == mutant.file:
            continue
        try:
            found = tree.occurrences(rel, mutant.anchor, mutant.original)
        except AnchorError:          # a file that does not parse defines no anchor
            continue
        if found and len(found) == 1:
            elsewhere.append((rel, found[0]))
    if len(elsewhere) == 1:
        rel, at = elsewhere[0]
        return Site(mutant, rel, at, at + len(mutant.original))
    if elsewhere:
        return Site(mutant, None, gone=f"{missing}; {mutant.anchor} holding the text is in {len(elsewhere)} files "
                                       f"({', '.join(r for r, _ in elsewhere)}): ambiguous")
    return Site(mutant, None, gone=f"{missing}, nor anywhere else in the tree holding the text")


def resolve_all(root: Path, mutants: list[Mutant]) -> list[Site]:
    """Every mutant's site in the tree at `root`; the CatalogueErrors of all mutants raised together."""
    tree = Tree(root)
    sites, errors = [], []
    for m in mutants:
        try:
            sites.append(resolve(tree, m))
        except CatalogueError as err:
            errors.append(str(err))
    if errors:
        raise CatalogueError("\n".join(errors))
    return sites


def apply(root: Path, site: Site) -> None:
    """Apply a resolved mutant in the tree at `root` (the tree it was resolved in, or a copy of it)."""
    if site.file is None:
        raise CatalogueError(f"mutant {site.mutant.name}: anchor gone ({site.gone}); nothing to apply")
    path = root / site.file
    text = path.read_text(encoding="utf-8")
    if text[site.start:site.end] != site.mutant.original:
        raise CatalogueError(f"mutant {site.mutant.name}: {site.file} differs from the tree it was resolved in")
    path.write_text(text[:site.start] + site.mutant.replacement + text[site.end:], encoding="utf-8")


def rewrite_files(path: Path, files: dict[str, str]) -> None:
    """Set the `file` of the mutants named in `files` (name → new file) in the catalogue at `path`, keeping every
    other line as it is (comments, order, quoting)."""
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    blocks: list[list[int]] = []            # line indices of each [[mutant]] table
    for i, line in enumerate(lines):
        if line.strip() == "[[mutant]]":
            blocks.append([])
        elif blocks:
            blocks[-1].append(i)
    for block in blocks:
        keys = {}
        for i in block:
            if "=" in lines[i] and not lines[i].lstrip().startswith("#"):
                try:
                    keys.update({k: (i, v) for k, v in tomllib.loads(lines[i]).items()})
                except tomllib.TOMLDecodeError:
                    continue           # a line of a multi-line value
        name = keys.get("name", (0, None))[1]
        if name in files and "file" in keys:
            lines[keys["file"][0]] = f"file = {_toml_string(files[name])}\n"
    path.write_text("".join(lines), encoding="utf-8")
    load(path)


def _toml_string(value: str) -> str:
    """A TOML string for a path: literal where it can be."""
    return f"'{value}'" if "'" not in value and value.isprintable() else json.dumps(value)
