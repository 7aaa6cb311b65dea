"""Where a mutant may apply: the named regions ("anchors") of a source file.

An anchor is
- in Python: the qualified name of a function, method or class (`Session.step`), or a name a module-level
  statement assigns (`RECORDER`), the whole statement;
- in OpenCL/C (`.cl`, `.h`): a function or kernel (`D_GGX`), a macro (`#define ALL`), a struct or typedef;
- in JavaScript: a `function` declaration;
- in every language, `<top level>`: the text outside every function (C and JavaScript) or outside every def,
  class and named assignment (Python).

A name may have several regions (an overloaded OpenCL function, a macro defined under `#if` alternatives, a
Python property's getter and setter): the anchor is all of them together.
C and JavaScript are read with a definition pattern and brace matching on the text with comments, strings and
preprocessor lines blanked; a JavaScript regular-expression literal is not recognised (the viewer's page has none).
"""
from __future__ import annotations

import ast
import re
from dataclasses import dataclass

TOP = "<top level>"
C_SUFFIXES = (".cl", ".h", ".c")
SUFFIXES = (".py", ".js", *C_SUFFIXES)


class AnchorError(ValueError):
    """A file that cannot be read into anchors (a syntax error, an unknown language)."""


@dataclass(frozen=True)
class Region:
    """One region of an anchor: text[start:end]."""
    name: str
    start: int
    end: int


def regions(path: str, text: str) -> list[Region]:
    """Every anchor region of the file `path` (its suffix says the language) with contents `text`, the
    `<top level>` segments included."""
    if path.endswith(".py"):
        found = _python(text)
    elif path.endswith(C_SUFFIXES):
        found = _braced(text, _mask(text, c=True), c=True)
    elif path.endswith(".js"):
        found = _braced(text, _mask(text, c=False), c=False)
    else:
        raise AnchorError(f"{path}: no anchors in a file of this kind (known: {', '.join(SUFFIXES)})")
    return found + _top(text, found)


def innermost(found: list[Region], start: int, end: int) -> str:
    """The name of the smallest named region holding text[start:end]; `<top level>` where none does."""
    holding = [r for r in found if r.name != TOP and r.start <= start and end <= r.end]
    return min(holding, key=lambda r: r.end - r.start).name if holding else TOP


def _top(text: str, found: list[Region]) -> list[Region]:
    """The segments of `text` outside every top-most named region."""
    out, at = [], 0
    for r in sorted(found, key=lambda r: (r.start, -r.end)):
        if r.start >= at:
            out.append(Region(TOP, at, r.start))
        at = max(at, r.end)
    return out + [Region(TOP, at, len(text))]


def _line_starts(text: str) -> list[int]:
    starts = [0]
    starts += [m.end() for m in re.finditer("\n", text)]
    return starts


def _python(text: str) -> list[Region]:
    try:
        tree = ast.parse(text)
    except SyntaxError as err:
        raise AnchorError(f"Python syntax error at line {err.lineno}: {err.msg}") from None
    starts = _line_starts(text) + [len(text)]

    def span(node: ast.AST, first: int) -> tuple[int, int]:       # whole lines, first..end_lineno
        return starts[first - 1], starts[min(node.end_lineno, len(starts) - 1)]

    out: list[Region] = []

    def visit(body: list[ast.stmt], prefix: str, top: bool) -> None:
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                first = min([node.lineno] + [d.lineno for d in node.decorator_list])
                out.append(Region(prefix + node.name, *span(node, first)))
                visit(node.body, f"{prefix}{node.name}.", False)
            elif top and isinstance(node, (ast.Assign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                for t in targets:
                    if isinstance(t, ast.Name):
                        out.append(Region(t.id, *span(node, node.lineno)))
            else:       # defs inside if/try/with/for blocks keep the enclosing prefix
                for field in ("body", "orelse", "finalbody", "handlers"):
                    inner = getattr(node, field, None)
                    if isinstance(inner, list):
                        visit([n for n in inner if isinstance(n, ast.AST)], prefix, False)
    visit(tree.body, "", True)
    return out


_C_KEYWORDS = {"if", "for", "while", "switch", "return", "sizeof", "do", "else", "case"}
_NAME = re.compile(r"[A-Za-z_]\w*")


def _mask(text: str, c: bool) -> str:
    """`text` with comments and string/char literals blanked (newlines kept), and in C every preprocessor line
    (with its continuations) blanked too; offsets are unchanged."""
    out = list(text)
    i, n = 0, len(text)
    at_line_start = True

    def blank(a: int, b: int) -> None:
        for k in range(a, b):
            if out[k] != "\n":
                out[k] = " "

    while i < n:
        ch = text[i]
        if c and at_line_start and ch == "#":
            j = i
            while j < n and text[j] != "\n":
                if text.startswith("/*", j):       # a comment on a directive line may run on
                    close = text.find("*/", j + 2)
                    j = n if close < 0 else close + 2
                    continue
                if text[j] == "\\" and j + 1 < n and text[j + 1] == "\n":
                    j += 2
                    continue
                j += 1
            blank(i, j)
            i = j
            continue
        if ch == "\n":
            at_line_start = True
            i += 1
            continue
        if ch in " \t":
            i += 1
            continue
        at_line_start = False
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            blank(i, j)
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            blank(i, j)
            i = j
        elif ch in "\"'" or (not c and ch == "`"):
            j = i + 1
            while j < n and text[j] != ch and (ch == "`" or text[j] != "\n"):
                j += 2 if text[j] == "\\" else 1
            blank(i + 1, min(j, n))
            i = j + 1
        else:
            i += 1
    return "".join(out)


def _close(masked: str, i: int, open_: str, close: str) -> int:
    """The index just past the bracket that closes the one at `i`; -1 if none."""
    depth = 0
    for j in range(i, len(masked)):
        if masked[j] == open_:
            depth += 1
        elif masked[j] == close:
            depth -= 1
            if depth == 0:
                return j + 1
    return -1


_ATTRIBUTE = re.compile(r"\s*__attribute__\s*\(")


def _braced(text: str, masked: str, c: bool) -> list[Region]:
    """Functions (C: any `name(...) {` at file level; JavaScript: `function name(...) {` at any depth),
    C macros, structs and typedefs."""
    out: list[Region] = []
    starts = _line_starts(text)
    depth_at = _depths(masked)
    pattern = re.compile(r"\b([A-Za-z_]\w*)\s*\(") if c else re.compile(r"\bfunction\s+([A-Za-z_$][\w$]*)\s*\(")
    for m in pattern.finditer(masked):
        name = m.group(1)
        if name in _C_KEYWORDS or (c and depth_at[m.start()] != 0):
            continue
        after = _close(masked, m.end() - 1, "(", ")")
        if after < 0:
            continue
        while (attr := _ATTRIBUTE.match(masked, after)):
            after = _close(masked, attr.end() - 1, "(", ")")
        body = re.compile(r"\s*\{").match(masked, after)
        if not body:
            continue
        end = _close(masked, body.end() - 1, "{", "}")
        if end < 0:
            continue
        out.append(Region(name, _declaration_start(masked, starts, m.start()), _line_end(text, end)))
    if c:
        out += _macros(text)
        out += _structs(text, masked, starts)
    return out


def _depths(masked: str) -> list[int]:
    """The brace depth before each character."""
    out, depth = [], 0
    for ch in masked:
        out.append(depth)
        depth += (ch == "{") - (ch == "}")
    return out


def _declaration_start(masked: str, starts: list[int], at: int) -> int:
    """The start of the line of `at`, taken back over earlier lines of the same declaration (a return type on a
    line of its own)."""
    line = max(k for k, s in enumerate(starts) if s <= at)
    while line > 0:
        prev = masked[starts[line - 1]:starts[line]].strip()
        if not prev or prev[-1] in ";{}" or prev.endswith("*/"):
            break
        line -= 1
    return starts[line]


def _line_end(text: str, at: int) -> int:
    """Just past the end of the line holding text[at - 1] (a trailing comment after a closing brace)."""
    j = text.find("\n", at)
    return len(text) if j < 0 else j + 1


_DEFINE = re.compile(r"^[ \t]*#[ \t]*define[ \t]+([A-Za-z_]\w*)", re.M)


def _macros(text: str) -> list[Region]:
    out = []
    for m in _DEFINE.finditer(text):
        end = m.end()
        while True:
            j = text.find("\n", end)
            if j < 0:
                end = len(text)
                break
            end = j + 1
            if not text[:j].rstrip(" \t").endswith("\\"):
                break
        out.append(Region(m.group(1), m.start(), end))
    return out


_STRUCT = re.compile(r"\b(?:typedef\s+)?(?:struct|union|enum)\s*([A-Za-z_]\w*)?\s*\{")


def _structs(text: str, masked: str, starts: list[int]) -> list[Region]:
    """`struct name {…}` and `typedef struct {…} name;` at file level, named by the struct's or typedef's name."""
    out = []
    depth_at = _depths(masked)
    for m in _STRUCT.finditer(masked):
        if depth_at[m.start()] != 0:
            continue
        end = _close(masked, m.end() - 1, "{", "}")
        if end < 0:
            continue
        semi = masked.find(";", end)
        names = [m.group(1)] if m.group(1) else []
        if masked[m.start():m.start() + 7] == "typedef" and semi >= 0:
            names += _NAME.findall(masked[end:semi])[-1:]
        stop = _line_end(text, semi + 1 if semi >= 0 else end)
        out += [Region(name, starts[max(k for k, s in enumerate(starts) if s <= m.start())], stop)
                for name in names]
    return out
