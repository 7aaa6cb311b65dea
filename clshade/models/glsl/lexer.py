"""The first stage of the GLSL translator: the shader's text as tokens.

Object-like `#define NAME tokens` are expanded here, where they are used (a macro may name
another, defined before or after it, as in C; one is not expanded inside its own expansion); a
function-like macro or any other preprocessor directive is refused with the file and the line.
Block comments are found with one search for their end, so scanning is linear in the text.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from clshade.errors import ClshadeError
from clshade.models.glsl.limits import MAX_LITERAL_CHARS, MAX_TOKENS


@dataclass(frozen=True)
class Token:
    kind: str      # "num", "id", "op", "eof"
    text: str
    line: int


_TOKEN = re.compile(r"""
    (?P<ws>[ \t\r\f\v]+)
  | (?P<nl>\n)
  | (?P<linecomment>//[^\n]*)
  | (?P<pp>\#[^\n]*)
  | (?P<num>(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?[fF]?)
  | (?P<id>[A-Za-z_]\w*)
  | (?P<op>\+\+|--|\+=|-=|\*=|/=|==|!=|<=|>=|&&|\|\||\^\^|[-+*/%=<>!?:;,(){}\[\].&|^~])
""", re.X)
_DEFINE = re.compile(r"define\s+([A-Za-z_]\w*)(\(?)\s*(.*)$", re.S)


class TranslateError(ClshadeError):
    """A construct of the shader clshade cannot translate, with its file and line."""


def fail(path: str, line: int, message: str) -> TranslateError:
    return TranslateError(f"{path}:{line}: {message}")


def _too_many(path: str, line: int) -> TranslateError:
    return fail(path, line, f"more than {MAX_TOKENS} tokens once #defines are expanded (the translator's MAX_TOKENS)")


def _lex(text: str, path: str, first_line: int) -> tuple[list[tuple[str, str, int]], int]:
    """(kind, text, line) of every token and directive of `text`, comments and blanks left out,
    and the line `text` ends on."""
    out: list[tuple[str, str, int]] = []
    line, pos, end = first_line, 0, len(text)
    while pos < end:
        if text.startswith("/*", pos):
            close = text.find("*/", pos + 2)
            if close < 0:
                raise fail(path, line, "unterminated comment: '/*' without '*/'")
            line += text.count("\n", pos, close)
            pos = close + 2
            continue
        m = _TOKEN.match(text, pos)
        if m is None:
            raise fail(path, line, f"unexpected character {text[pos]!r}")
        kind, value = m.lastgroup, m.group()
        pos = m.end()
        if kind == "num" and len(value) > MAX_LITERAL_CHARS:
            raise fail(path, line, f"a number of {len(value)} characters, past the translator's MAX_LITERAL_CHARS "
                                   f"({MAX_LITERAL_CHARS})")
        if kind in ("num", "id", "op", "pp"):
            out.append((kind, value, line))
            if len(out) > MAX_TOKENS:
                raise _too_many(path, line)
        elif kind == "nl":
            line += 1
    return out, line


def tokenize(text: str, path: str, first_line: int = 1) -> list[Token]:
    """Tokens of `text`, line numbers counted from `first_line`; object-like
    `#define NAME tokens` are expanded (a function-like macro or any other
    preprocessor directive is refused)."""
    out: list[Token] = []
    macros: dict[str, list[tuple[str, str, int]]] = {}
    tokens, end = _lex(text, path, first_line)
    for kind, value, line in tokens:
        if kind == "pp":
            directive = value[1:].strip()
            dm = _DEFINE.match(directive)
            if not dm:
                raise fail(path, line, f"unsupported construct: preprocessor directive {value.strip()!r}")
            if dm.group(2):
                raise fail(path, line, f"unsupported construct: function-like macro {dm.group(1)!r}")
            body, _ = _lex(dm.group(3), path, line)
            if any(k == "pp" for k, _, _ in body):
                raise fail(path, line, f"unsupported construct: '#' in the body of #define {dm.group(1)}")
            macros[dm.group(1)] = body
        elif kind == "id" and value in macros:
            _expand(value, line, macros, out, path)
        else:
            out.append(Token(kind, value, line))
            if len(out) > MAX_TOKENS:
                raise _too_many(path, line)
    out.append(Token("eof", "", end))
    return out


def _expand(name: str, line: int, macros: dict[str, list[tuple[str, str, int]]], out: list[Token], path: str) -> None:
    """Append the expansion of macro `name` used at `line`: macros in its body are expanded in
    turn (iteratively: a chain of thousands is no deeper on the stack), except one already being
    expanded, which stays a name (C's rule against endless expansion)."""
    stack = [(name, iter(macros[name]))]
    active = {name}
    while stack:
        current, body = stack[-1]
        item = next(body, None)
        if item is None:
            stack.pop()
            active.discard(current)
            continue
        kind, value, _ = item
        if kind == "id" and value in macros and value not in active:
            stack.append((value, iter(macros[value])))
            active.add(value)
            continue
        out.append(Token(kind, value, line))
        if len(out) > MAX_TOKENS:
            raise _too_many(path, line)
