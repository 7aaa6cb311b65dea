"""Translate the GLSL subset of BRDF Explorer shaders into a clshade lobe (OpenCL C).

Three stages, each its own code: a tokenizer (`tokenize`), a recursive-descent
parser into an AST (`Parser`), and a typed emitter (`Emitter`) that checks every
expression's type (float, int, bool, vec2, vec3) and writes OpenCL C over
clshade's lane types (simd.h: `real`, `vec3`, `mask`) and kernels/glsl.h.

The subset: `const` globals, helper functions (`in` parameters), local
declarations, `if`/`else`, `return`, `for` loops over an int counter, the
operators of GLSL expressions with its precedence, `?:`, swizzles
(`.x`, `.xy`, `.rgb` …), constant indexing `v[i]`, `vec2`/`vec3` constructors,
the usual built-ins (mix, clamp, pow, dot, normalize …), object-like
`#define`s, and GLSL's implicit int-to-float conversion. Anything else (vec4,
matrices, `out` parameters, `while`, `discard`, texture lookups, function-like
macros …) is refused with one error naming the construct, the file and the line.

Lanes are pixels, so control flow that depends on a pixel cannot branch:
`if` and `?:` are converted to selects (if-conversion). Inside a branch every
assignment is `x = p ? new : x` with p the branch's mask; a `return` inside a
branch sets the result where p holds and marks those lanes done, and later
statements act only on lanes not done. Expressions have no side effects
(GLSL has no pointers here and helpers take `in` parameters only), so
evaluating both sides of a branch is exact: the untaken side's values are
discarded lane by lane.
"""
from __future__ import annotations

import operator
import re
from dataclasses import dataclass, field
from pathlib import Path

from clshade.errors import ClshadeError

# ------------------------------------------------------------------ tokens


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


def _fail(path: str, line: int, message: str) -> TranslateError:
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
            raise _fail(path, line, f"unexpected character {text[pos]!r}")
        kind, value = m.lastgroup, m.group()
        pos = m.end()
        if kind == "pp":
            directive = value[1:].strip()
            dm = re.match(r"define\s+([A-Za-z_]\w*)(\(?)\s*(.*)$", directive)
            if not dm:
                raise _fail(path, line, f"unsupported construct: preprocessor directive {value.strip()!r}")
            if dm.group(2):
                raise _fail(path, line, f"unsupported construct: function-like macro {dm.group(1)!r}")
            macros[dm.group(1)] = [t for t in tokenize(dm.group(3), path, line) if t.kind != "eof"]
        elif kind in ("num", "id", "op"):
            if kind == "id" and value in macros:
                out += [Token(t.kind, t.text, line) for t in macros[value]]
            else:
                out.append(Token(kind, value, line))
        line += value.count("\n")
    out.append(Token("eof", "", line))
    return out


# --------------------------------------------------------------------- AST


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
    consts: list[Decl] = field(default_factory=list)
    functions: list[Function] = field(default_factory=list)
    uniforms: list[tuple[str, str, int]] = field(default_factory=list)


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

    # -- token helpers
    @property
    def tok(self) -> Token:
        return self.t[self.i]

    def peek(self, k: int = 1) -> Token:
        return self.t[min(self.i + k, len(self.t) - 1)]

    def error(self, message: str, tok: Token | None = None) -> TranslateError:
        return _fail(self.path, (tok or self.tok).line, message)

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
                prog.consts.append(self.declaration(line, const=True))
            elif self.is_type():
                kind = self.type_name()
                name = self.ident()
                if self.tok.text == "(":
                    prog.functions.append(self.function(kind, name, line))
                else:
                    raise self.error(f"unsupported construct: non-const global variable {name!r}")
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
        left = self.ternary()
        if self.tok.text in ASSIGN_OPS:
            op = self.tok
            self.i += 1
            return Assign(op.line, op.text, left, self.expression())
        return left

    def ternary(self) -> Node:
        cond = self.binary(0)
        if self.tok.text == "?":
            line = self.tok.line
            self.i += 1
            then = self.expression()
            self.expect(":")
            return Ternary(line, cond, then, self.ternary())
        return cond

    # GLSL's binary operators by precedence, loosest first (the bitwise ones are refused).
    LEVELS = (("||",), ("^^",), ("&&",), ("==", "!="), ("<", ">", "<=", ">="), ("+", "-"), ("*", "/", "%"))

    def binary(self, level: int) -> Node:
        if level == len(self.LEVELS):
            return self.unary()
        left = self.binary(level + 1)
        while self.tok.kind == "op" and self.tok.text in self.LEVELS[level]:
            op = self.tok
            self.i += 1
            left = Binary(op.line, op.text, left, self.binary(level + 1))
        if self.tok.text in ("&", "|", "^", "~", "<<", ">>") and self.tok.kind == "op":
            raise self.error(f"unsupported construct: bitwise operator {self.tok.text!r}")
        return left

    def unary(self) -> Node:
        tok = self.tok
        if tok.text in ("-", "+", "!") and tok.kind == "op":
            self.i += 1
            return Unary(tok.line, tok.text, self.unary())
        if tok.text in ("++", "--"):
            raise self.error(f"unsupported construct: {tok.text} outside a for loop's step")
        if tok.text == "~":
            raise self.error("unsupported construct: bitwise operator '~'")
        return self.postfix()

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
                        while True:
                            args.append(self.ternary())
                            if self.accept(")"):
                                break
                            self.expect(",")
                return Call(tok.line, tok.text, args)
            return Name(tok.line, tok.text)
        raise self.error(f"syntax error: unexpected {tok.text or 'end of shader'!r}")


def parse(text: str, path: str, first_line: int = 1) -> Program:
    """The AST of a shader (GLSL subset); TranslateError on anything outside it."""
    return Parser(tokenize(text, path, first_line), path).program()


# ----------------------------------------------------------------- emitter

CTYPE = {"float": "real", "int": "int", "bool": "mask", "vec2": "vec2", "vec3": "vec3"}
DIM = {"float": 1, "int": 1, "vec2": 2, "vec3": 3}
ZERO = {"float": "((real)(0.0f))", "int": "0", "bool": "G_FALSE", "vec2": "v2s((real)(0.0f))",
        "vec3": "v3s((real)(0.0f))"}
SWIZZLE_SETS = ("xyzw", "rgba", "stpq")
PREFIX = "u_"

# GLSL built-ins applied component-wise: name → arity; glsl.h defines g1_<name> (real),
# g2_<name> and g3_<name>.
COMPONENTWISE = {"abs": 1, "sign": 1, "floor": 1, "ceil": 1, "fract": 1, "sqrt": 1, "inversesqrt": 1,
                 "exp": 1, "exp2": 1, "log": 1, "log2": 1, "sin": 1, "cos": 1, "tan": 1, "asin": 1,
                 "acos": 1, "atan": 1, "sinh": 1, "cosh": 1, "tanh": 1, "radians": 1, "degrees": 1,
                 "mod": 2, "min": 2, "max": 2, "pow": 2, "step": 2, "clamp": 3, "mix": 3, "smoothstep": 3}
GEOMETRIC = {"dot", "length", "distance", "normalize", "cross", "reflect"}
# Constant int expressions folded to literals (a constant index `v[N - 1]`, an exponent).
INT_FOLD = {"+": operator.add, "-": operator.sub, "*": operator.mul}


@dataclass
class Value:
    type: str
    code: str
    literal: str | None = None     # the text of a numeric literal (int-to-float converts it exactly)


@dataclass
class Symbol:
    type: str
    cname: str
    assignable: bool


class Emitter:
    """Typed OpenCL C for one parsed shader."""

    def __init__(self, program: Program, path: str, params: dict[str, tuple[str, str]]) -> None:
        """`params`: the file's parameters by name, (GLSL type, OpenCL C value)."""
        self.prog, self.path = program, path
        self.out: list[str] = []
        self.globals: dict[str, Symbol] = {}
        self.const_ints: dict[str, int] = {}
        self.functions: dict[str, Function] = {}
        self.scopes: list[dict[str, Symbol]] = []
        self.counter = 0
        self.params = params
        self.current: Function | None = None
        self.predicated = False
        self.reads: set[str] = set()       # names of BRDF()'s parameters the shader reads (L V N X Y)

    def error(self, line: int, message: str) -> TranslateError:
        return _fail(self.path, line, message)

    # -- program
    def emit(self) -> str:
        for name, (kind, value) in self.params.items():
            self.globals[name] = Symbol(kind, PREFIX + name, False)
            self.out.append(f"#define {PREFIX}{name} {value}")
        for kind, name, line in self.prog.uniforms:
            if name not in self.params:
                raise self.error(line, f"uniform {name!r} is not a parameter of the file")
            if self.params[name][0] != kind:
                raise self.error(line, f"uniform {name!r} is declared {kind}, the parameter is {self.params[name][0]}")
        for decl in self.prog.consts:
            self.const_decl(decl)
        for fn in self.prog.functions:
            if fn.body is None:
                continue
            if fn.name in self.functions or fn.name in COMPONENTWISE or fn.name in GEOMETRIC:
                raise self.error(fn.line, f"function {fn.name!r} is defined twice (overloading is not supported)")
            self.functions[fn.name] = fn
        if "BRDF" not in self.functions:
            raise self.error(self.prog.functions[-1].line if self.prog.functions else 1,
                             "the shader defines no 'vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)'")
        brdf = self.functions["BRDF"]
        if brdf.type != "vec3" or [t for t, _ in brdf.params] != ["vec3"] * 5:
            raise self.error(brdf.line, "BRDF must be 'vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)'")
        # Prototypes first: GLSL lets a function call one defined further down after a prototype.
        for fn in self.functions.values():
            if fn.type != "void":
                self.out.append(f"INLINE {CTYPE[fn.type]} {PREFIX}{fn.name}({', '.join(self._signature(fn))});")
        for fn in self.functions.values():
            self.function(fn)
        return "\n".join(self.out) + "\n"

    @staticmethod
    def _signature(fn: Function) -> list[str]:
        """The C parameters of a translated function: its own, then the pixel's Surface."""
        return [f"{CTYPE[t]} {PREFIX}{n}" for t, n in fn.params] + ["const Surface s"]

    def line(self, line: int) -> None:
        self.out.append(f'#line {line} "{self.path}"')

    def const_decl(self, decl: Decl) -> None:
        for name, init, line in decl.names:
            value = self.coerce(self.expr(init), decl.type, line)
            self._declare_global(name, line)
            self.globals[name] = Symbol(decl.type, PREFIX + name, False)
            if decl.type == "int" and value.literal is not None:
                self.const_ints[name] = int(value.literal)
            self.line(line)
            self.out.append(f"#define {PREFIX}{name} ({value.code})")

    def _declare_global(self, name: str, line: int) -> None:
        if name in self.globals:
            raise self.error(line, f"{name!r} is declared twice")

    # -- functions
    def function(self, fn: Function) -> None:
        if fn.type == "void":
            raise self.error(fn.line, f"unsupported construct: void function {fn.name!r} (a function must return a value)")
        self.scopes = [{}]
        self.counter = 0
        for ptype, pname in fn.params:
            self.scopes[0][pname] = Symbol(ptype, PREFIX + pname, True)
        self.current = fn
        self.line(fn.line)
        # The pixel's Surface goes last: parameters that are material keys read it.
        self.out.append(f"INLINE {CTYPE[fn.type]} {PREFIX}{fn.name}({', '.join(self._signature(fn))}) {{")
        # A body whose one return is its last statement is emitted as written; any
        # other return is if-converted (module docstring).
        returns = _count_returns(fn.body)
        simple = returns == 1 and isinstance(fn.body[-1], Return)
        if returns == 0:
            raise self.error(fn.line, f"function {fn.name!r} never returns a value")
        self.predicated = not simple
        if self.predicated:
            self.out.append(f"    {CTYPE[fn.type]} x_ret = {ZERO[fn.type]};")
            self.out.append("    mask x_done = G_FALSE;")
        self.block(fn.body, None, 1)
        if self.predicated:
            self.out.append("    return x_ret;")
        self.out.append("}")

    def block(self, stmts: list[Node], pred: str | None, depth: int) -> None:
        self.scopes.append({})
        for s in stmts:
            self.statement(s, pred, depth)
        self.scopes.pop()

    def active(self, pred: str | None) -> str | None:
        """The mask of the lanes a statement acts on: the branch's, less the lanes done."""
        if not self.predicated:
            return pred
        return f"({pred} && !x_done)" if pred else "(!x_done)"

    def statement(self, s: Node, pred: str | None, depth: int) -> None:
        pad = "    " * depth
        if isinstance(s, Block):
            self.out.append(f"{pad}{{")
            self.block(s.body, pred, depth + 1)
            self.out.append(f"{pad}}}")
        elif isinstance(s, Decl):
            for name, init, line in s.names:
                if name in self.scopes[-1]:
                    raise self.error(line, f"{name!r} is declared twice in one block")
                value = self.coerce(self.expr(init), s.type, line) if init is not None else Value(s.type, ZERO[s.type])
                self.line(line)
                cname = f"{PREFIX}{name}_{self._next()}"
                self.out.append(f"{pad}{'const ' if s.const else ''}{CTYPE[s.type]} {cname} = {value.code};")
                self.scopes[-1][name] = Symbol(s.type, cname, not s.const)
        elif isinstance(s, ExprStmt):
            if not isinstance(s.expr, Assign):
                raise self.error(s.line, "a statement must be an assignment, a declaration, if, for or return")
            self.assign(s.expr, pred, pad)
        elif isinstance(s, Return):
            fn = self.current
            if s.value is None:
                raise self.error(s.line, f"return without a value in {fn.name!r}")
            value = self.coerce(self.expr(s.value), fn.type, s.line)
            self.line(s.line)
            if not self.predicated:
                self.out.append(f"{pad}return {value.code};")
            else:
                p = self.active(pred)
                self.out.append(f"{pad}x_ret = {self.select(fn.type, p, value.code, 'x_ret')};")
                self.out.append(f"{pad}x_done = x_done || {p};")
        elif isinstance(s, If):
            cond = self.expr(s.cond)
            if cond.type != "bool":
                raise self.error(s.line, f"if condition is {cond.type}, not bool")
            k = self._next()
            self.line(s.line)
            outer = f"{pred} && " if pred else ""
            self.out.append(f"{pad}mask x_if{k} = {outer}({cond.code});")
            if s.other is not None:
                self.out.append(f"{pad}mask x_else{k} = {outer}!({cond.code});")
            self.out.append(f"{pad}{{")
            self.block(s.then, f"x_if{k}", depth + 1)
            self.out.append(f"{pad}}}")
            if s.other is not None:
                self.out.append(f"{pad}{{")
                self.block(s.other, f"x_else{k}", depth + 1)
                self.out.append(f"{pad}}}")
        elif isinstance(s, For):
            self.for_loop(s, pred, depth)
        else:
            raise self.error(s.line, f"unsupported construct: {type(s).__name__}")

    def for_loop(self, s: For, pred: str | None, depth: int) -> None:
        pad = "    " * depth
        start = self.expr(s.start)
        if start.type != "int":
            raise self.error(s.line, f"for loop counter {s.var!r} starts at a {start.type}, not an int")
        cname = f"{PREFIX}{s.var}_{self._next()}"
        self.scopes.append({s.var: Symbol("int", cname, False)})
        cond = self.expr(s.cond, int_compare=True)
        if cond.type != "int_bool":
            raise self.error(s.line, "unsupported construct: a for loop condition other than a comparison of ints")
        step = s.step
        assert isinstance(step, Assign)
        inc = self.expr(step.value)
        if inc.type != "int":
            raise self.error(s.line, "for loop step must add or subtract an int")
        self.line(s.line)
        self.out.append(f"{pad}for (int {cname} = {start.code}; {cond.code}; {cname} {step.op} {inc.code}) {{")
        self.block(s.body, pred, depth + 1)
        self.out.append(f"{pad}}}")
        self.scopes.pop()

    def _next(self) -> int:
        self.counter += 1
        return self.counter

    def assign(self, a: Assign, pred: str | None, pad: str) -> None:
        target = a.target
        if isinstance(target, Name):
            sym = self.lookup(target.id, target.line)
            if not sym.assignable:
                raise self.error(a.line, f"cannot assign to {target.id!r} (a parameter of the file, a constant or a loop counter)")
            kind, lvalue = sym.type, sym.cname
        elif isinstance(target, (Member, Index)) and isinstance(target.value, Name):
            sym = self.lookup(target.value.id, target.line)
            if not sym.assignable:
                raise self.error(a.line, f"cannot assign to {target.value.id!r}")
            comp = self.component(target, sym.type)
            kind, lvalue = "float", f"{sym.cname}.{comp}"
        else:
            raise self.error(a.line, "unsupported construct: assignment to this expression "
                                     "(only a variable, or one component of one)")
        if kind == "int" and (pred or self.predicated):
            raise self.error(a.line, "unsupported construct: assignment to an int variable inside an if "
                                     "(ints are the same for every pixel)")
        value = self.expr(a.value)
        if a.op != "=":
            value = self.arith(a.op[0], Value(kind, lvalue), value, a.line)
        value = self.coerce(value, kind, a.line)
        self.line(a.line)
        p = self.active(pred)
        code = value.code if p is None else self.select(kind, p, value.code, lvalue)
        self.out.append(f"{pad}{lvalue} = {code};")

    def component(self, node: Member | Index, kind: str) -> str:
        if kind not in ("vec2", "vec3"):
            raise self.error(node.line, f"{kind} has no components")
        if isinstance(node, Member):
            if len(node.field) != 1:
                raise self.error(node.line, f"unsupported construct: assignment to swizzle .{node.field}")
            return self._swizzle(node.field, DIM[kind], node.line)[0]
        return "xyz"[self._const_index(node, DIM[kind])]

    def select(self, kind: str, p: str, a: str, b: str) -> str:
        if kind == "vec3":
            return f"v3select({p}, {a}, {b})"
        if kind == "vec2":
            return f"g2_select({p}, {a}, {b})"
        return f"({p} ? {a} : {b})"

    def lookup(self, name: str, line: int) -> Symbol:
        for scope in reversed(self.scopes):
            if name in scope:
                return scope[name]
        if name in self.globals:
            return self.globals[name]
        raise self.error(line, f"unknown name {name!r}")

    # -- expressions
    def expr(self, n: Node, int_compare: bool = False) -> Value:
        if isinstance(n, Num):
            if n.is_int:
                return Value("int", n.text, n.text)
            return Value("float", f"G_LIT({_float_text(n.text)})", n.text)
        if isinstance(n, Name):
            if n.id in ("true", "false"):
                return Value("bool", "G_TRUE" if n.id == "true" else "G_FALSE")
            sym = self.lookup(n.id, n.line)
            if self.current is not None and self.current.name == "BRDF" and n.id in "LVNXY" \
                    and sym is self.scopes[0].get(n.id):
                self.reads.add(n.id)
            return Value(sym.type, sym.cname, str(self.const_ints[n.id]) if n.id in self.const_ints
                         and not any(n.id in s for s in self.scopes) else None)
        if isinstance(n, Unary):
            v = self.expr(n.operand)
            if n.op == "!":
                if v.type != "bool":
                    raise self.error(n.line, f"'!' needs a bool, got {v.type}")
                return Value("bool", f"(!{v.code})")
            if v.type == "bool":
                raise self.error(n.line, f"unary {n.op!r} on a bool")
            if n.op == "+":
                return v
            if v.type in ("vec2", "vec3"):
                return Value(v.type, f"g{DIM[v.type]}_neg({v.code})")
            lit = None if v.literal is None else "-" + v.literal
            return Value(v.type, f"(-{v.code})", lit if v.type == "int" else None)
        if isinstance(n, Binary):
            return self.binary(n, int_compare)
        if isinstance(n, Ternary):
            c = self.expr(n.cond)
            if c.type != "bool":
                raise self.error(n.line, f"?: condition is {c.type}, not bool")
            a, b = self.expr(n.then), self.expr(n.other)
            kind = self.common(a, b, n.line)
            if kind == "int":
                kind = "float"
            return Value(kind, self.select(kind, c.code, self.coerce(a, kind, n.line).code,
                                           self.coerce(b, kind, n.line).code))
        if isinstance(n, Call):
            return self.call(n)
        if isinstance(n, Member):
            v = self.expr(n.value)
            if v.type not in ("vec2", "vec3"):
                raise self.error(n.line, f"{v.type} has no component .{n.field}")
            comps = self._swizzle(n.field, DIM[v.type], n.line)
            if len(comps) == 1:
                return Value("float", f"({v.code}).{comps[0]}")
            if len(comps) == 4:
                raise self.error(n.line, f"unsupported construct: four-component swizzle .{n.field} (vec4)")
            parts = ", ".join(f"({v.code}).{c}" for c in comps)
            return Value(f"vec{len(comps)}", f"v{len(comps)}({parts})")
        if isinstance(n, Index):
            v = self.expr(n.value)
            if v.type not in ("vec2", "vec3"):
                raise self.error(n.line, f"unsupported construct: indexing a {v.type} (only vectors)")
            return Value("float", f"({v.code}).{'xyz'[self._const_index(n, DIM[v.type])]}")
        if isinstance(n, Assign):
            raise self.error(n.line, "unsupported construct: assignment inside an expression")
        raise self.error(n.line, f"unsupported construct: {type(n).__name__}")

    def _const_index(self, n: Index, size: int) -> int:
        idx = self.expr(n.index)
        if idx.type != "int" or idx.literal is None:
            raise self.error(n.line, "unsupported construct: x[i] with an index that is not a constant int")
        i = int(idx.literal)
        if not 0 <= i < size:
            raise self.error(n.line, f"index {i} out of range for a vec{size}")
        return i

    def _swizzle(self, text: str, size: int, line: int) -> list[str]:
        for names in SWIZZLE_SETS:
            if all(c in names for c in text):
                idx = [names.index(c) for c in text]
                if max(idx) >= size:
                    raise self.error(line, f"swizzle .{text} reads past a vec{size}")
                if len(text) > 4:
                    break
                return ["xyzw"[i] for i in idx]
        raise self.error(line, f"invalid swizzle .{text}")

    def common(self, a: Value, b: Value, line: int) -> str:
        """The type both operands convert to (GLSL: int → float, scalar with a vector)."""
        if a.type == b.type:
            return a.type
        if "bool" in (a.type, b.type):
            raise self.error(line, f"cannot combine {a.type} and {b.type}")
        if a.type in ("vec2", "vec3") and b.type in ("vec2", "vec3"):
            raise self.error(line, f"cannot combine {a.type} and {b.type}")
        for v in ("vec3", "vec2"):
            if v in (a.type, b.type):
                return v
        return "float"

    def coerce(self, v: Value, kind: str, line: int) -> Value:
        if v.type == kind:
            return v
        if v.type == "int" and kind == "float":
            if v.literal is not None:
                return Value("float", f"G_LIT({_float_text(v.literal)})", v.literal)
            return Value("float", f"((real)({v.code}))")
        if v.type in ("int", "float") and kind in ("vec2", "vec3"):
            f = self.coerce(v, "float", line)
            return Value(kind, f"v{DIM[kind]}s({f.code})")
        raise self.error(line, f"cannot convert {v.type} to {kind}")

    def binary(self, n: Binary, int_compare: bool) -> Value:
        a, b = self.expr(n.left), self.expr(n.right)
        op = n.op
        if op in ("&&", "||", "^^"):
            if a.type != "bool" or b.type != "bool":
                raise self.error(n.line, f"{op!r} needs bools, got {a.type} and {b.type}")
            if op == "^^":
                return Value("bool", f"({a.code} != {b.code})")
            return Value("bool", f"({a.code} {op} {b.code})")
        if op in ("<", ">", "<=", ">=", "==", "!="):
            if int_compare and a.type == b.type == "int":
                return Value("int_bool", f"({a.code} {op} {b.code})")
            if a.type == b.type == "bool" and op in ("==", "!="):
                return Value("bool", f"({a.code} {op} {b.code})")
            if a.type not in ("int", "float") or b.type not in ("int", "float"):
                raise self.error(n.line, f"unsupported construct: {op!r} on {a.type} and {b.type}")
            # Both sides as real: the result is a lane mask even between two constants.
            fa, fb = self.coerce(a, "float", n.line), self.coerce(b, "float", n.line)
            return Value("bool", f"((real)({fa.code}) {op} ({fb.code}))")
        if op == "%":
            raise self.error(n.line, "unsupported construct: operator '%' (use mod())")
        return self.arith(op, a, b, n.line)

    def arith(self, op: str, a: Value, b: Value, line: int) -> Value:
        kind = self.common(a, b, line)
        if kind == "bool":
            raise self.error(line, f"arithmetic {op!r} on bools")
        if kind == "int":
            lit = None
            if a.literal is not None and b.literal is not None and op in INT_FOLD:
                lit = str(INT_FOLD[op](int(a.literal), int(b.literal)))
            return Value("int", f"({a.code} {op} {b.code})", lit)
        if kind == "float":
            fa, fb = self.coerce(a, kind, line), self.coerce(b, kind, line)
            return Value("float", f"({fa.code} {op} {fb.code})")
        d = DIM[kind]
        name = {"+": "add", "-": "sub", "*": "mul", "/": "div"}[op]
        if op == "*" and d == 3 and a.type != b.type:    # vec3 · scalar: one multiply per component
            vec, sc = (a, b) if a.type == "vec3" else (b, a)
            return Value("vec3", f"v3scale({vec.code}, {self.coerce(sc, 'float', line).code})")
        fa, fb = self.coerce(a, kind, line), self.coerce(b, kind, line)
        return Value(kind, f"g{d}_{name}({fa.code}, {fb.code})")

    def call(self, n: Call) -> Value:
        name = n.name
        if name in UNSUPPORTED_TYPES:
            raise self.error(n.line, f"unsupported construct: type {name}")
        args = [self.expr(a) for a in n.args]
        if name in ("float", "int", "bool", "vec2", "vec3"):
            return self.construct(name, args, n.line)
        if name in self.functions:
            fn = self.functions[name]
            if name == "BRDF":
                raise self.error(n.line, "BRDF may not be called by the shader")
            if len(args) != len(fn.params):
                raise self.error(n.line, f"{name}() takes {len(fn.params)} arguments, got {len(args)}")
            code = [self.coerce(a, t, n.line).code for a, (t, _) in zip(args, fn.params)]
            return Value(fn.type, f"{PREFIX}{name}({', '.join([*code, 's'])})")
        if name in COMPONENTWISE or (name == "atan" and len(args) == 2):
            return self.componentwise(name, args, n.line)
        if name in GEOMETRIC:
            return self.geometric(name, args, n.line)
        if name.startswith("texture") or name in ("dFdx", "dFdy", "fwidth", "noise1"):
            raise self.error(n.line, f"unsupported construct: {name}()")
        raise self.error(n.line, f"unknown function {name!r}")

    def construct(self, kind: str, args: list[Value], line: int) -> Value:
        if kind in ("float", "int", "bool"):
            if len(args) != 1:
                raise self.error(line, f"{kind}() takes one argument")
            a = args[0]
            if kind == "float":
                if a.type == "bool":
                    return Value("float", f"({a.code} ? (real)(1.0f) : (real)(0.0f))")
                return self.coerce(a, "float", line)
            if kind == "int":
                if a.type != "int":
                    raise self.error(line, "unsupported construct: int() of a float value (ints are the same for every pixel)")
                return a
            if a.type != "bool":
                raise self.error(line, f"unsupported construct: bool() of a {a.type}")
            return a
        d = DIM[kind]
        types = [a.type for a in args]
        if any(t == "bool" for t in types):
            raise self.error(line, f"{kind}() of a bool")
        if len(args) == 1 and types[0] in ("int", "float"):
            return self.coerce(args[0], kind, line)
        if len(args) == 1 and types[0] == kind:
            return args[0]
        if len(args) == 1 and kind == "vec2" and types[0] == "vec3":
            return Value("vec2", f"g2_from3({args[0].code})")
        if all(t in ("int", "float") for t in types) and len(args) == d:
            parts = ", ".join(self.coerce(a, "float", line).code for a in args)
            return Value(kind, f"v{d}({parts})")
        if kind == "vec3" and len(args) == 2 and types[0] == "vec2" and types[1] in ("int", "float"):
            return Value("vec3", f"g3_from21({args[0].code}, {self.coerce(args[1], 'float', line).code})")
        if kind == "vec3" and len(args) == 2 and types[1] == "vec2" and types[0] in ("int", "float"):
            return Value("vec3", f"g3_from12({self.coerce(args[0], 'float', line).code}, {args[1].code})")
        raise self.error(line, f"{kind}({', '.join(types)}): no such constructor")

    def componentwise(self, name: str, args: list[Value], line: int) -> Value:
        if name == "atan" and len(args) == 2:
            name = "atan2"
        elif len(args) != COMPONENTWISE[name]:
            raise self.error(line, f"{name}() takes {COMPONENTWISE[name]} arguments, got {len(args)}")
        if any(a.type == "bool" for a in args):
            raise self.error(line, f"{name}() of a bool")
        dims = {DIM[a.type] for a in args if a.type in ("vec2", "vec3")}
        if len(dims) > 1:
            raise self.error(line, f"{name}() mixes vec2 and vec3")
        d = dims.pop() if dims else 1
        kind = {1: "float", 2: "vec2", 3: "vec3"}[d]
        if name == "mix" and d > 1 and args[2].type in ("int", "float"):      # mix(vecN, vecN, float)
            a, b = self.coerce(args[0], kind, line), self.coerce(args[1], kind, line)
            if d == 3:
                return Value(kind, f"v3mix({a.code}, {b.code}, {self.coerce(args[2], 'float', line).code})")
        code = [self.coerce(a, kind, line).code for a in args]
        if d == 1:
            if name == "pow" and args[1].literal is not None and _small_int(args[1].literal):
                k = _small_int(args[1].literal)
                return Value("float", {1: f"({code[0]})", 2: f"sq({code[0]})", 3: f"g1_pow3({code[0]})",
                                       4: f"g1_pow4({code[0]})", 5: f"pow5({code[0]})"}[k])
            return Value("float", f"g1_{name}({', '.join(code)})")
        return Value(kind, f"g{d}_{name}({', '.join(code)})")

    def geometric(self, name: str, args: list[Value], line: int) -> Value:
        arity = {"dot": 2, "length": 1, "distance": 2, "normalize": 1, "cross": 2, "reflect": 2}[name]
        if len(args) != arity:
            raise self.error(line, f"{name}() takes {arity} argument{'s' if arity > 1 else ''}, got {len(args)}")
        kinds = {a.type for a in args}
        if len(kinds) != 1 or kinds.pop() not in ("float", "vec2", "vec3", "int"):
            raise self.error(line, f"{name}({', '.join(a.type for a in args)}): arguments must be one vector type")
        kind = "float" if args[0].type == "int" else args[0].type
        d = DIM[kind]
        if name in ("cross", "reflect") and d != 3:
            raise self.error(line, f"{name}() takes vec3 arguments")
        code = ", ".join(self.coerce(a, kind, line).code for a in args)
        result = "float" if name in ("dot", "length", "distance") else kind
        if name == "dot" and d == 1:
            return Value("float", f"({code.replace(', ', ' * ', 1)})")
        return Value(result, f"g{d}_{name}({code})")


def _float_text(text: str) -> str:
    """A literal's text as C accepts it before an `f` suffix (1. → 1.0, .5 → 0.5, 2 → 2.0)."""
    value = float(text)
    out = repr(value)
    return out if ("." in out or "e" in out) else out + ".0"


def _small_int(text: str) -> int | None:
    """An exponent of 1 to 5 that pow() may expand into products, else None."""
    value = float(text)
    return int(value) if value in (1.0, 2.0, 3.0, 4.0, 5.0) else None


def _count_returns(stmts: list[Node] | None) -> int:
    count = 0
    for s in stmts or []:
        if isinstance(s, Return):
            count += 1
        elif isinstance(s, If):
            count += _count_returns(s.then) + _count_returns(s.other)
        elif isinstance(s, (For, Block)):
            count += _count_returns(s.body)
    return count


@dataclass(frozen=True)
class Translation:
    """The OpenCL C of a shader and which of L, V, N, X, Y its BRDF reads."""
    code: str
    reads: frozenset[str]


def translate(text: str, path: str | Path, params: dict[str, tuple[str, str]], first_line: int = 1) -> Translation:
    """OpenCL C defining `u_BRDF(L, V, N, X, Y, s)` for the GLSL shader `text` (every translated
    function takes the pixel's Surface `s` last: `params` values may read it)."""
    path = str(path)
    emitter = Emitter(parse(text, path, first_line), path, params)
    code = emitter.emit()
    return Translation(code, frozenset(emitter.reads))
