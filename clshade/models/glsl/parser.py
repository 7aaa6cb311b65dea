"""The second stage of the GLSL translator: tokens into an AST by recursive descent.

The grammar is the subset clshade.models.glsl translates (its package docstring);
any other construct is refused with one error naming it, the file and the line.

Nesting is bounded (limits.MAX_NESTING) twice: the parser counts the levels it recurses into
(a parenthesis, an operand, a block) and refuses past the limit before Python's stack runs out;
`check_nesting` then measures the tree without recursion, which also bounds what the parser
builds in a loop (`a + b + c …`, `v.x.x …`), so that the emitter's recursion over the tree is
bounded as well.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field, fields

from clshade.models.glsl.lexer import Token, TranslateError, fail, tokenize
from clshade.models.glsl.limits import INT_MAX, MAX_NESTING


@dataclass
class Node:
    line: int


@dataclass
class Num(Node):
    text: str
    is_int: bool


@dataclass
class Name(Node):
    id: str


@dataclass
class Unary(Node):
    op: str
    operand: Node


@dataclass
class Binary(Node):
    op: str
    left: Node
    right: Node


@dataclass
class Ternary(Node):
    cond: Node
    then: Node
    other: Node


@dataclass
class Call(Node):
    name: str
    args: list[Node]


@dataclass
class Member(Node):
    value: Node
    field: str


@dataclass
class Index(Node):
    value: Node
    index: Node


@dataclass
class Assign(Node):
    op: str          # "=", "+=", "-=", "*=", "/="
    target: Node
    value: Node


@dataclass
class Decl(Node):
    type: str
    names: list[tuple[str, Node | None, int]]   # (name, initialiser, line)
    const: bool = False


@dataclass
class ExprStmt(Node):
    expr: Node


@dataclass
class If(Node):
    cond: Node
    then: list[Node]
    other: list[Node] | None


@dataclass
class Block(Node):
    body: list[Node]      # `{ … }` inside a function (or `;`: empty)


@dataclass
class For(Node):
    var: str
    start: Node
    cond: Node
    step: Node       # an Assign of the counter
    body: list[Node]


@dataclass
class Return(Node):
    value: Node | None


@dataclass
class Function(Node):
    type: str
    name: str
    params: list[tuple[str, str]]    # (type, name)
    body: list[Node] | None          # None: a prototype


@dataclass
class Program:
    items: list[Decl | Function] = field(default_factory=list)     # globals and functions in source order
    uniforms: list[tuple[str, str, int]] = field(default_factory=list)

    @property
    def functions(self) -> list[Function]:
        return [f for f in self.items if isinstance(f, Function)]


TYPES = ("float", "int", "bool", "vec2", "vec3")
UNSUPPORTED_TYPES = ("vec4", "mat2", "mat3", "mat4", "ivec2", "ivec3", "ivec4", "bvec2", "bvec3", "bvec4",
                     "dvec2", "dvec3", "double", "uint", "sampler2D", "samplerCube", "sampler1D", "sampler3D")
UNSUPPORTED_WORDS = {"while": "while loop", "do": "do loop", "switch": "switch statement", "discard": "discard",
                     "break": "break", "continue": "continue", "struct": "struct", "out": "out parameter",
                     "inout": "inout parameter", "varying": "varying declaration", "attribute": "attribute declaration"}
ASSIGN_OPS = ("=", "+=", "-=", "*=", "/=")


class Parser:
    """Recursive descent over the token list; one method per grammar rule."""

    def __init__(self, tokens: list[Token], path: str) -> None:
        self.t, self.i, self.path = tokens, 0, path
        self.depth = 0         # levels of nesting the parser is inside (MAX_NESTING)

    def deeper(self, levels: int = 1) -> None:
        """Enter `levels` more levels of nesting; refused past MAX_NESTING."""
        self.depth += levels
        if self.depth > MAX_NESTING:
            raise self.error(too_deep())

    # -- token helpers
    @property
    def tok(self) -> Token:
        return self.t[self.i]

    def peek(self, k: int = 1) -> Token:
        return self.t[min(self.i + k, len(self.t) - 1)]

    def error(self, message: str, tok: Token | None = None) -> TranslateError:
        return fail(self.path, (tok or self.tok).line, message)

    def accept(self, text: str) -> bool:
        if self.tok.text == text and self.tok.kind != "eof":
            self.i += 1
            return True
        return False

    def expect(self, text: str) -> Token:
        if self.tok.text != text:
            found = self.tok.text or "end of shader"
            raise self.error(f"syntax error: expected {text!r}, found {found!r}")
        tok = self.tok
        self.i += 1
        return tok

    def ident(self) -> str:
        if self.tok.kind != "id":
            raise self.error(f"syntax error: expected a name, found {self.tok.text or 'end of shader'!r}")
        self._refuse_word(self.tok)
        name = self.tok.text
        self.i += 1
        return name

    def _refuse_word(self, tok: Token) -> None:
        if tok.text in UNSUPPORTED_WORDS:
            raise self.error(f"unsupported construct: {UNSUPPORTED_WORDS[tok.text]}", tok)
        if tok.text in UNSUPPORTED_TYPES:
            raise self.error(f"unsupported construct: type {tok.text}", tok)

    def type_name(self) -> str:
        self._refuse_word(self.tok)
        if self.tok.text not in TYPES and self.tok.text != "void":
            raise self.error(f"syntax error: expected a type, found {self.tok.text or 'end of shader'!r}")
        name = self.tok.text
        self.i += 1
        return name

    def is_type(self) -> bool:
        return self.tok.kind == "id" and (self.tok.text in TYPES or self.tok.text in UNSUPPORTED_TYPES
                                          or self.tok.text == "void")

    # -- top level
    def program(self) -> Program:
        prog = Program()
        while self.tok.kind != "eof":
            line = self.tok.line
            for qualifier in ("precision",):
                if self.tok.text == qualifier:
                    raise self.error("unsupported construct: precision qualifier")
            if self.accept("uniform"):
                kind = self.type_name()
                prog.uniforms.append((kind, self.ident(), line))
                self.expect(";")
            elif self.accept("const"):
                prog.items.append(self.declaration(line, const=True))
            elif self.is_type():
                start = self.i
                kind = self.type_name()
                name = self.ident()
                if self.tok.text == "(":
                    prog.items.append(self.function(kind, name, line))
                else:
                    self.i = start
                    prog.items.append(self.declaration(line))
            else:
                self._refuse_word(self.tok)
                raise self.error(f"syntax error: unexpected {self.tok.text!r} at file scope")
        return prog

    def function(self, kind: str, name: str, line: int) -> Function:
        self.expect("(")
        params: list[tuple[str, str]] = []
        if not self.accept(")"):
            if self.tok.text == "void" and self.peek().text == ")":
                self.i += 2
            else:
                while True:
                    self.accept("in")
                    self.accept("const")
                    ptype = self.type_name()
                    params.append((ptype, self.ident()))
                    if self.tok.text == "[":
                        raise self.error("unsupported construct: array parameter")
                    if self.accept(")"):
                        break
                    self.expect(",")
        if self.accept(";"):
            return Function(line, kind, name, params, None)
        return Function(line, kind, name, params, self.block())

    def declaration(self, line: int, const: bool = False) -> Decl:
        kind = self.type_name()
        names = []
        while True:
            nline = self.tok.line
            name = self.ident()
            if self.tok.text == "[":
                raise self.error(f"unsupported construct: array {name!r}")
            init = self.expression() if self.accept("=") else None
            if const and init is None:
                raise self.error(f"const {name!r} needs a value")
            names.append((name, init, nline))
            if self.accept(";"):
                break
            self.expect(",")
        return Decl(line, kind, names, const)

    # -- statements
    def block(self) -> list[Node]:
        self.expect("{")
        out = []
        while not self.accept("}"):
            if self.tok.kind == "eof":
                raise self.error("syntax error: missing '}'")
            out.append(self.statement())
        return out

    def body(self) -> list[Node]:
        return self.block() if self.tok.text == "{" else [self.statement()]

    def statement(self) -> Node:
        self.deeper()
        node = self._statement()
        self.depth -= 1
        return node

    def _statement(self) -> Node:
        tok = self.tok
        self._refuse_word(tok)
        if tok.text == "{":
            return Block(tok.line, self.block())
        if self.accept(";"):
            return Block(tok.line, [])
        if self.accept("if"):
            self.expect("(")
            cond = self.expression()
            self.expect(")")
            then = self.body()
            other = self.body() if self.accept("else") else None
            return If(tok.line, cond, then, other)
        if self.accept("for"):
            return self.for_loop(tok)
        if self.accept("return"):
            value = None if self.tok.text == ";" else self.expression()
            self.expect(";")
            return Return(tok.line, value)
        if self.accept("const"):
            return self.declaration(tok.line, const=True)
        if self.is_type():
            return self.declaration(tok.line)
        expr = self.expression()
        self.expect(";")
        return ExprStmt(tok.line, expr)

    def for_loop(self, tok: Token) -> For:
        self.expect("(")
        if self.tok.text != "int":
            raise self.error("unsupported construct: a for loop whose counter is not a new int variable")
        self.i += 1
        var = self.ident()
        self.expect("=")
        start = self.expression()
        self.expect(";")
        cond = self.expression()
        self.expect(";")
        sline = self.tok.line
        if self.tok.text in ("++", "--") and self.peek().text == var:
            op = self.tok.text
            self.i += 2
            step: Node = Assign(sline, op[0] + "=", Name(sline, var), Num(sline, "1", True))
        elif self.tok.text == var and self.peek().text in ("++", "--"):
            op = self.peek().text
            self.i += 2
            step = Assign(sline, op[0] + "=", Name(sline, var), Num(sline, "1", True))
        else:
            step = self.expression()
            if not (isinstance(step, Assign) and isinstance(step.target, Name) and step.target.id == var):
                raise self.error(f"unsupported construct: a for loop step that does not update {var!r}")
        self.expect(")")
        return For(tok.line, var, start, cond, step, self.body())

    # -- expressions, lowest precedence first
    def expression(self) -> Node:
        """An expression, assignments included (right-associative: `a = b = c`)."""
        self.deeper()
        left = self.ternary()
        if self.tok.text in ASSIGN_OPS:
            op = self.tok
            self.i += 1
            left = Assign(op.line, op.text, left, self.expression())
        self.depth -= 1
        return left

    def ternary(self) -> Node:
        cond = self.binary(0)
        if self.tok.text == "?":
            line = self.tok.line
            self.i += 1
            then = self.expression()
            self.expect(":")
            self.deeper()
            other = self.ternary()
            self.depth -= 1
            return Ternary(line, cond, then, other)
        return cond

    # GLSL's binary operators by precedence, loosest first (the bitwise ones are refused).
    LEVELS = (("||",), ("^^",), ("&&",), ("==", "!="), ("<", ">", "<=", ">="), ("+", "-"), ("*", "/", "%"))
    PRECEDENCE = {op: level for level, ops in enumerate(LEVELS) for op in ops}

    def binary(self, level: int) -> Node:
        """Operators of precedence `level` or tighter, left-associative (precedence climbing: one
        recursion per tighter operator on the right, not one per level of the table)."""
        left = self.unary()
        while self.tok.kind == "op" and self.PRECEDENCE.get(self.tok.text, -1) >= level:
            op = self.tok
            self.i += 1
            self.deeper()
            right = self.binary(self.PRECEDENCE[op.text] + 1)
            self.depth -= 1
            left = Binary(op.line, op.text, left, right)
        if self.tok.text in ("&", "|", "^", "~", "<<", ">>") and self.tok.kind == "op":
            raise self.error(f"unsupported construct: bitwise operator {self.tok.text!r}")
        return left

    def unary(self) -> Node:
        """Prefix operators (a loop: `- - - x` costs no stack), then a postfix expression."""
        ops: list[Token] = []
        while True:
            tok = self.tok
            if tok.text in ("-", "+", "!") and tok.kind == "op":
                self.i += 1
                ops.append(tok)
                self.deeper()
                continue
            if tok.text in ("++", "--"):
                raise self.error(f"unsupported construct: {tok.text} outside a for loop's step")
            if tok.text == "~":
                raise self.error("unsupported construct: bitwise operator '~'")
            break
        node = self.postfix()
        for tok in reversed(ops):
            node = Unary(tok.line, tok.text, node)
        self.depth -= len(ops)
        return node

    def postfix(self) -> Node:
        node = self.primary()
        while True:
            tok = self.tok
            if self.accept("."):
                node = Member(tok.line, node, self.ident())
            elif self.accept("["):
                node = Index(tok.line, node, self.expression())
                self.expect("]")
            elif tok.text in ("++", "--"):
                raise self.error(f"unsupported construct: {tok.text} outside a for loop's step")
            else:
                return node

    def primary(self) -> Node:
        tok = self.tok
        if tok.kind == "num":
            self.i += 1
            text = tok.text.rstrip("fF")
            is_int = re.fullmatch(r"\d+", text) is not None
            if is_int and int(text) > INT_MAX:
                raise self.error(f"integer literal {text} is past GLSL's int range (largest {INT_MAX})")
            return Num(tok.line, text, is_int)
        if self.accept("("):
            node = self.expression()
            self.expect(")")
            return node
        if tok.kind == "id":
            self._refuse_word(tok)
            self.i += 1
            if self.accept("("):
                args = []
                if not self.accept(")"):
                    if self.tok.text == "void" and self.peek().text == ")":
                        self.i += 2
                    else:
                        self.deeper()
                        while True:
                            args.append(self.ternary())
                            if self.accept(")"):
                                break
                            self.expect(",")
                        self.depth -= 1
                return Call(tok.line, tok.text, args)
            return Name(tok.line, tok.text)
        raise self.error(f"syntax error: unexpected {tok.text or 'end of shader'!r}")


def too_deep() -> str:
    return (f"nested deeper than {MAX_NESTING} levels (expressions, statements and blocks inside one another; "
            f"the translator's MAX_NESTING)")


def _children(node: Node) -> list[Node]:
    """The nodes directly below `node`: its Node fields, the nodes of its list fields, and a
    declaration's initialisers."""
    out: list[Node] = []
    for f in fields(node):
        value = getattr(node, f.name)
        if isinstance(value, Node):
            out.append(value)
        elif isinstance(value, list):
            for item in value:
                if isinstance(item, Node):
                    out.append(item)
                elif isinstance(item, tuple) and len(item) == 3 and isinstance(item[1], Node):
                    out.append(item[1])      # Decl.names: (name, initialiser, line)
    return out


def check_nesting(prog: Program, path: str) -> None:
    """Refuse a tree deeper than MAX_NESTING (counted from a function's statements or a global's
    declaration), at the line of its first node past the limit; an explicit stack, no recursion."""
    stack: list[tuple[Node, int]] = []
    for item in prog.items:
        roots = (item.body or []) if isinstance(item, Function) else [item]
        stack.extend((node, 1) for node in roots)
    while stack:
        node, depth = stack.pop()
        if depth > MAX_NESTING:
            raise fail(path, node.line, too_deep())
        stack.extend((child, depth + 1) for child in _children(node))


def parse(text: str, path: str, first_line: int = 1) -> Program:
    """The AST of a shader (GLSL subset); TranslateError on anything outside it."""
    prog = Parser(tokenize(text, path, first_line), path).program()
    check_nesting(prog, path)
    return prog
