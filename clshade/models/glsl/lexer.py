"""The first stage of the GLSL translator: the shader's text as tokens.

Object-like `#define NAME tokens` are expanded here; a function-like macro or any
other preprocessor directive is refused with the file and the line.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from clshade.errors import ClshadeError


@dataclass(frozen=True)
class Token:
    kind: str      # "num", "id", "op", "eof"
    text: str
    line: int


_TOKEN = re.compile(r"""
    (?P<ws>[ \t\r\f\v]+)
  | (?P<nl>\n)
  | (?P<linecomment>//[^\n]*)
  | (?P<blockcomment>/\*.*?\*/)
  | (?P<pp>\#[^\n]*)
  | (?P<num>(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?[fF]?)
  | (?P<id>[A-Za-z_]\w*)
  | (?P<op>\+\+|--|\+=|-=|\*=|/=|==|!=|<=|>=|&&|\|\||[-+*/%=<>!?:;,(){}\[\].&|^~])
""", re.X | re.S)


class TranslateError(ClshadeError):
    """A construct of the shader clshade cannot translate, with its file and line."""


def fail(path: str, line: int, message: str) -> TranslateError:
    return TranslateError(f"{path}:{line}: {message}")


def tokenize(text: str, path: str, first_line: int = 1) -> list[Token]:
    """Tokens of `text`, line numbers counted from `first_line`; object-like
    `#define NAME tokens` are expanded (a function-like macro or any other
    preprocessor directive is refused)."""
    out: list[Token] = []
    macros: dict[str, list[Token]] = {}
    line, pos = first_line, 0
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            raise fail(path, line, f"unexpected character {text[pos]!r}")
        kind, value = m.lastgroup, m.group()
        pos = m.end()
        if kind == "pp":
            directive = value[1:].strip()
            dm = re.match(r"define\s+([A-Za-z_]\w*)(\(?)\s*(.*)$", directive)
            if not dm:
                raise fail(path, line, f"unsupported construct: preprocessor directive {value.strip()!r}")
            if dm.group(2):
                raise fail(path, line, f"unsupported construct: function-like macro {dm.group(1)!r}")
            macros[dm.group(1)] = [t for t in tokenize(dm.group(3), path, line) if t.kind != "eof"]
        elif kind in ("num", "id", "op"):
            if kind == "id" and value in macros:
                out += [Token(t.kind, t.text, line) for t in macros[value]]
            else:
                out.append(Token(kind, value, line))
        line += value.count("\n")
    out.append(Token("eof", "", line))
    return out
