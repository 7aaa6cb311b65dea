"""The third stage of the GLSL translator: a typed emitter of OpenCL C over clshade's
lane types (simd.h: `real`, `vec3`, `mask`) and kernels/glsl.h, and `translate`, the
three stages in a row.

The output stays linear in the shader: an operand's code appears once in its expression's (a
swizzle calls a helper, `x_sw<N>_<components>`, rather than repeating its operand per component).
What the OpenCL compiler then expands is bounded too (limits.py): each function's code with the
#defines of globals and the functions it calls inlined (MAX_CODE_BYTES), and the iterations its
for loops run, loops restricted to GLSL ES 1.00's constant form (Appendix A) so that their trip
count is known (MAX_LOOP_ITERATIONS). A call graph with a cycle (recursion, which GLSL forbids)
is refused naming the functions.
"""
from __future__ import annotations

import operator
from dataclasses import dataclass, field
from pathlib import Path

from clshade.models.glsl.lexer import TranslateError, fail
from clshade.models.glsl.limits import INT_MAX, INT_MIN, MAX_CODE_BYTES, MAX_FLOAT, MAX_LOOP_ITERATIONS
from clshade.models.glsl.parser import (UNSUPPORTED_TYPES, Assign, Binary, Block, Call, Decl, ExprStmt, For,
                                        Function, If, Index, Member, Name, Node, Num, Program, Return, Ternary,
                                        Unary, parse)


CTYPE = {"float": "real", "int": "int", "bool": "mask", "vec2": "vec2", "vec3": "vec3"}
DIM = {"float": 1, "int": 1, "vec2": 2, "vec3": 3}
ZERO = {"float": "((real)(0.0f))", "int": "0", "bool": "G_FALSE", "vec2": "v2s((real)(0.0f))",
        "vec3": "v3s((real)(0.0f))"}
SWIZZLE_SETS = ("xyzw", "rgba", "stpq")
# The C names of a shader's identifiers: one namespace per kind, all under `u_`, which no name of
# clshade's kernels or of the translator's own (s, x_ret, x_if1 ...) starts with, so that a user's
# name meets neither another kind's nor clshade's: a parameter of the file u_p_NAME, a global
# u_g_NAME, a function argument u_a_NAME, the k-th local of a function u_l<k>_NAME, a function
# u_f_NAME (u_f<k>_NAME for the k-th overload of a name defined several times).
PARAM, GLOBAL, ARG, FUNC = "u_p_", "u_g_", "u_a_", "u_f_"

# GLSL built-ins applied component-wise: name → arity; glsl.h defines g1_<name> (real),
# g2_<name> and g3_<name>.
COMPONENTWISE = {"abs": 1, "sign": 1, "floor": 1, "ceil": 1, "fract": 1, "sqrt": 1, "inversesqrt": 1,
                 "exp": 1, "exp2": 1, "log": 1, "log2": 1, "sin": 1, "cos": 1, "tan": 1, "asin": 1,
                 "acos": 1, "atan": 1, "sinh": 1, "cosh": 1, "tanh": 1, "radians": 1, "degrees": 1,
                 "mod": 2, "min": 2, "max": 2, "pow": 2, "step": 2, "clamp": 3, "mix": 3, "smoothstep": 3}
GEOMETRIC = {"dot", "length", "distance", "normalize", "cross", "reflect"}
# Constant int expressions folded to literals (a constant index `v[N - 1]`, an exponent).
INT_FOLD = {"+": operator.add, "-": operator.sub, "*": operator.mul}


# A for loop's condition and the comparison it becomes with the counter on the left (`3 > i`: `i < 3`).
RELATIONS = ("<", "<=", ">", ">=", "==", "!=")
MIRRORED = {"<": ">", "<=": ">=", ">": "<", ">=": "<=", "==": "==", "!=": "!="}


@dataclass
class Cost:
    """What a function (or a global's #define) puts before the OpenCL compiler where it is used:
    its bytes of code (the #defines of globals it reads expanded), the iterations of its own for
    loops, and its calls (callee's C name, the product of the trip counts of the loops around the
    call, line), in source order with its loops as calls of None."""
    bytes: int = 0
    steps: list[tuple[str | None, int, int]] = field(default_factory=list)


class _Code(list):
    """Lines of generated code that count their bytes as they are appended (MAX_CODE_BYTES)."""

    def __init__(self, count) -> None:
        super().__init__()
        self._count = count

    def append(self, line: str) -> None:
        self._count(line)
        super().append(line)


@dataclass
class Value:
    type: str
    code: str
    literal: str | None = None     # the text of a numeric literal (int-to-float converts it exactly)
    known: bool | None = None      # a bool fixed at translation time: true/false, a bool parameter


@dataclass(eq=False)
class Symbol:
    type: str
    cname: str
    assignable: bool
    literal: str | None = None     # a const int's value (a constant index, an exponent)
    role: str | None = None        # which of BRDF's L, V, N, X, Y an argument of BRDF is
    cost: Cost | None = None       # a global's: its #define, expanded where it is read


@dataclass(eq=False)
class GlobalVar(Symbol):
    """A non-const global: a constant where no function assigns it, else a variable of BRDF's
    (initialised at the start of every evaluation, as GLSL initialises a global per invocation)."""
    name: str = ""
    line: int = 0
    init: str = ""
    used_in: dict[str, int] = field(default_factory=dict)       # function's C name → first line
    assigned_in: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class Defined:
    """A function definition of the shader and its C name."""
    fn: Function
    cname: str

    @property
    def types(self) -> list[str]:
        return [t for t, _ in self.fn.params]

    @property
    def signature(self) -> str:
        return f"{self.fn.name}({', '.join(self.types)})"


class Emitter:
    """Typed OpenCL C for one parsed shader."""

    def __init__(self, program: Program, path: str, params: dict[str, tuple[str, str]]) -> None:
        """`params`: the file's parameters by name, (GLSL type, OpenCL C value)."""
        self.prog, self.path = program, path
        self.total = 0                     # bytes of generated code so far (MAX_CODE_BYTES)
        self.at = 1                        # the line being emitted, for a limit's message
        self.head: list[str] = _Code(self._count)     # the #defines of parameters and constant globals
        self.out: list[str] = _Code(self._count)      # the functions
        self.swizzles: dict[str, str] = {}            # helper name → definition (`x_sw3_zyx`)
        self.cost = Cost()                 # of the function (or global) being emitted
        self.costs: dict[str, tuple[Defined, Cost]] = {}    # by function C name
        self.loops = 1                     # trip counts of the loops around what is emitted, multiplied
        self.globals: dict[str, Symbol] = {}
        self.global_vars: list[GlobalVar] = []
        self.functions: dict[str, list[Defined]] = {}
        self.defined: dict[int, Defined] = {}      # by id() of the Function node
        self.entry = ""                    # BRDF's C name
        self.brdf_at = 0                   # where BRDF's body starts in self.out
        self.scopes: list[dict[str, Symbol]] = []
        self.counter = 0
        self.params = params
        self.current: Defined | None = None
        self.predicated = False
        self.reads: set[str] = set()       # names of BRDF()'s parameters the shader reads (L V N X Y)

    def error(self, line: int, message: str) -> TranslateError:
        return fail(self.path, line, message)

    def _count(self, line: str) -> None:
        """Count a line of generated code; refused once the code passes MAX_CODE_BYTES."""
        self.total += len(line) + 1
        self.cost.bytes += len(line) + 1
        if self.total > MAX_CODE_BYTES or self.cost.bytes > MAX_CODE_BYTES:
            raise self.error(self.at, _too_much_code("the generated OpenCL C"))

    # -- program
    def emit(self) -> str:
        for name, (kind, value) in self.params.items():
            self.globals[name] = Symbol(kind, PARAM + name, False)
            self.head.append(f"#define {PARAM}{name} {value}")
        for kind, name, line in self.prog.uniforms:
            if name not in self.params:
                raise self.error(line, f"uniform {name!r} is not a parameter of the file")
            if self.params[name][0] != kind:
                raise self.error(line, f"uniform {name!r} is declared {kind}, the parameter is {self.params[name][0]}")
        self.register_functions()
        # Globals and functions in source order: a function sees the globals declared above it.
        for item in self.prog.items:
            if isinstance(item, Decl):
                self.global_decl(item)
            elif item.body is not None:
                self.function(item)
        self.place_globals()
        self.check_calls()
        # Prototypes first: GLSL lets a function call one defined further down after a prototype.
        protos = [f"INLINE {CTYPE[d.fn.type]} {d.cname}({', '.join(self._signature(d.fn))});"
                  for same in self.functions.values() for d in same if d.fn.type != "void"]
        return "\n".join([*self.head, *self.swizzles.values(), *protos, *self.out]) + "\n"

    def check_calls(self) -> None:
        """Refuse recursion (a cycle of calls, named), then any function whose code with its calls
        inlined passes MAX_CODE_BYTES or whose loops, with those of the functions it calls, run
        more than MAX_LOOP_ITERATIONS iterations; callees are measured before their callers."""
        inlined: dict[str, int] = {}
        iterations: dict[str, int] = {}
        state: dict[str, int] = {}          # 1: on the path being explored, 2: measured
        for root in self.costs:
            if root in state:
                continue
            path = [root]
            state[root] = 1
            pending = [iter(self.costs[root][1].steps)]
            while pending:
                step = next(pending[-1], None)
                if step is None:
                    pending.pop()
                    done = path.pop()
                    state[done] = 2
                    self._measure(done, inlined, iterations)
                    continue
                callee, _, line = step
                if callee is None or state.get(callee) == 2:
                    continue
                if state.get(callee) == 1:
                    cycle = path[path.index(callee):] + [callee]
                    names = " → ".join(repr(self.costs[c][0].fn.name) for c in cycle)
                    raise self.error(line, f"recursion: {names} (GLSL forbids a function calling itself, "
                                           f"directly or through others)")
                path.append(callee)
                state[callee] = 1
                pending.append(iter(self.costs[callee][1].steps))

    def _measure(self, cname: str, inlined: dict[str, int], iterations: dict[str, int]) -> None:
        """Inlined bytes and loop iterations of one function whose callees are measured; both
        saturate just past their limit (sums of products grow without bound otherwise)."""
        d, cost = self.costs[cname]
        size, runs = cost.bytes, 0
        for callee, times, line in cost.steps:
            if callee is not None:
                size = min(size + inlined[callee], MAX_CODE_BYTES + 1)
                if size > MAX_CODE_BYTES:
                    raise self.error(line, _too_much_code(f"{d.fn.name!r} with the functions it calls inlined"))
            runs = min(runs + times * (1 if callee is None else iterations[callee]), MAX_LOOP_ITERATIONS + 1)
            if runs > MAX_LOOP_ITERATIONS:
                raise self.error(line, f"one call of {d.fn.name!r} runs more than {MAX_LOOP_ITERATIONS} for loop "
                                       f"iterations, those of the functions it calls included (the translator's "
                                       f"MAX_LOOP_ITERATIONS)")
        inlined[cname], iterations[cname] = size, runs

    def register_functions(self) -> None:
        """Every function definition by name (several for an overloaded name), and BRDF's C name.
        A user's function named like a built-in hides the built-in (GLSL 1.20, which BRDF Explorer's
        shaders are written in)."""
        found: dict[str, list[Function]] = {}
        for fn in self.prog.functions:
            if fn.body is None:
                continue
            if fn.name in self.params:
                raise self.error(fn.line, f"function {fn.name!r} has the name of a parameter of the file")
            names = [n for _, n in fn.params]
            for i, n in enumerate(names):
                if n in names[:i]:
                    raise self.error(fn.line, f"function {fn.name!r} has two arguments named {n!r}")
            same = found.setdefault(fn.name, [])
            types = [t for t, _ in fn.params]
            if any([t for t, _ in g.params] == types for g in same):
                raise self.error(fn.line, f"function '{fn.name}({', '.join(types)})' is defined twice")
            same.append(fn)
        for name, same in found.items():
            self.functions[name] = [Defined(fn, FUNC + name if len(same) == 1 else f"u_f{k}_{name}")
                                    for k, fn in enumerate(same, 1)]
            for d in self.functions[name]:
                self.defined[id(d.fn)] = d
        if "BRDF" not in self.functions:
            raise self.error(self.prog.functions[-1].line if self.prog.functions else 1,
                             "the shader defines no 'vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)'")
        brdf = [d for d in self.functions["BRDF"] if d.types == ["vec3"] * 5]
        if not brdf or brdf[0].fn.type != "vec3":
            raise self.error(self.functions["BRDF"][0].fn.line,
                             "BRDF must be 'vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)'")
        self.entry = brdf[0].cname

    @staticmethod
    def _signature(fn: Function) -> list[str]:
        """The C parameters of a translated function: its own, then the pixel's Surface."""
        return [f"{CTYPE[t]} {ARG}{n}" for t, n in fn.params] + ["const Surface s"]

    def line(self, line: int) -> None:
        self.out.append(f'#line {line} "{self.path}"')

    def global_decl(self, decl: Decl) -> None:
        """A global: `const` ones are #defines; a non-const one is placed by place_globals. Either
        is expanded where it is read: its Cost goes with its Symbol."""
        for name, init, line in decl.names:
            self._declare_global(name, line)
            self.at, self.cost = line, Cost()
            value = self.coerce(self.expr(init), decl.type, line) if init is not None else Value(decl.type, ZERO[decl.type])
            cost, self.cost = self.cost, Cost()
            cost.bytes += len(value.code)
            literal = value.literal if decl.type == "int" else None
            if decl.const:
                self.globals[name] = Symbol(decl.type, GLOBAL + name, False, literal, cost=cost)
                self.head.append(f'#line {line} "{self.path}"')
                self.head.append(f"#define {GLOBAL}{name} ({value.code})")
            else:
                var = GlobalVar(decl.type, GLOBAL + name, True, cost=cost, name=name, line=line, init=value.code)
                self.globals[name] = var
                self.global_vars.append(var)

    def _declare_global(self, name: str, line: int) -> None:
        if name in self.globals:
            raise self.error(line, f"{name!r} is declared twice")
        if name in self.functions:
            raise self.error(line, f"{name!r} is declared as a variable and as a function")

    def place_globals(self) -> None:
        """A non-const global no function assigns is a constant (a #define); one that only BRDF uses
        is a variable of BRDF's, initialised where its body starts; any other is refused."""
        names = {d.cname: d.fn.name for same in self.functions.values() for d in same}
        decls = []
        for g in self.global_vars:
            if not g.assigned_in:
                self.head.append(f'#line {g.line} "{self.path}"')
                self.head.append(f"#define {g.cname} ({g.init})")
                continue
            writer = next(iter(g.assigned_in))
            others = {**g.used_in, **g.assigned_in}
            other = next((f for f in others if f != self.entry), None)
            if other is not None:
                user = next((f for f in others if f != writer), writer)
                also = f" and used in {names[user]!r}" if user != writer else ""
                raise self.error(others[other], f"unsupported construct: global variable {g.name!r} is assigned in "
                                                f"{names[writer]!r}{also} (clshade translates a global that no "
                                                f"function assigns, or one that only BRDF uses)")
            decls.append(f"    {CTYPE[g.type]} {g.cname} = {g.init};")
        for line in decls:
            self._count(line)
        self.out[self.brdf_at:self.brdf_at] = decls

    # -- functions
    def function(self, fn: Function) -> None:
        if fn.type == "void":
            raise self.error(fn.line, f"unsupported construct: void function {fn.name!r} (a function must return a value)")
        d = self.defined[id(fn)]
        brdf = d.cname == self.entry
        self.scopes = [{}]
        self.counter = 0
        for i, (ptype, pname) in enumerate(fn.params):
            self.scopes[0][pname] = Symbol(ptype, ARG + pname, True, role="LVNXY"[i] if brdf else None)
        self.current = d
        self.at, self.cost, self.loops = fn.line, Cost(), 1
        self.costs[d.cname] = (d, self.cost)
        self.line(fn.line)
        # The pixel's Surface goes last: parameters that are material keys read it.
        self.out.append(f"INLINE {CTYPE[fn.type]} {d.cname}({', '.join(self._signature(fn))}) {{")
        if brdf:
            self.brdf_at = len(self.out)
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
        # The arguments and the body's outermost declarations share one scope (GLSL 4.30, 4.2.3).
        self.block(fn.body, None, 1, scope=self.scopes.pop())
        if self.predicated:
            self.out.append("    return x_ret;")
        self.out.append("}")

    def block(self, stmts: list[Node], pred: str | None, depth: int, scope: dict[str, Symbol] | None = None) -> None:
        """Statements in a new scope (or `scope`: a function's arguments, a for loop's counter)."""
        self.scopes.append({} if scope is None else scope)
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
        self.at = s.line
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
                cname = f"u_l{self._next()}_{name}"
                self.out.append(f"{pad}{'const ' if s.const else ''}{CTYPE[s.type]} {cname} = {value.code};")
                literal = value.literal if s.const and s.type == "int" else None
                self.scopes[-1][name] = Symbol(s.type, cname, not s.const, literal)
        elif isinstance(s, ExprStmt):
            if not isinstance(s.expr, Assign):
                raise self.error(s.line, "a statement must be an assignment, a declaration, if, for or return")
            self.assign(s.expr, pred, pad)
        elif isinstance(s, Return):
            fn = self.current.fn
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
            if cond.known is not None:
                self.fixed_if(s, cond.known, pred, depth)
                return
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

    def fixed_if(self, s: If, taken: bool, pred: str | None, depth: int) -> None:
        """An if whose condition is fixed at translation time (a bool parameter compiled in): the
        branch taken is emitted under the enclosing predicate; the other is translated (its errors
        are the file's) and left out of the kernel, with what it reads."""
        branches = (s.then, s.other) if taken else (s.other, s.then)
        pad = "    " * depth
        if branches[0] is not None:
            self.out.append(f"{pad}{{")
            self.block(branches[0], pred, depth + 1)
            self.out.append(f"{pad}}}")
        if branches[1] is not None:
            out, reads = self.out, set(self.reads)
            self.out = _Code(self._count)      # counted all the same: a hostile dead branch meets the limit
            self.block(branches[1], pred, depth + 1)
            self.out, self.reads = out, reads

    def for_loop(self, s: For, pred: str | None, depth: int) -> None:
        """A for loop of GLSL ES 1.00's form (Appendix A): an int counter from a constant, compared
        with a constant, stepped by a constant, not assigned in the body; so its trip count is
        known: one that never ends, or runs past MAX_LOOP_ITERATIONS with the loops around it, is
        refused."""
        pad = "    " * depth
        start = self.expr(s.start)
        if start.type != "int":
            raise self.error(s.line, f"for loop counter {s.var!r} starts at a {start.type}, not an int")
        if start.literal is None:
            raise self.error(s.line, f"{_LOOP_FORM}: {s.var!r} does not start at a constant int")
        cname = f"u_l{self._next()}_{s.var}"
        # The counter and the body share one scope (GLSL's for-statement has no new scope).
        counter = {s.var: Symbol("int", cname, False)}
        self.scopes.append(counter)
        cond = self.expr(s.cond, int_compare=True)
        if cond.type != "int_bool":
            raise self.error(s.line, "unsupported construct: a for loop condition other than a comparison of ints")
        relation, bound = self._loop_bound(s)
        step, inc = self._loop_step(s)
        self.line(s.line)
        self.out.append(f"{pad}for (int {cname} = {start.code}; {cond.code}; {cname} += {inc.code}) {{")
        self.scopes.pop()
        first = int(start.literal)
        trips = trip_count(first, relation, bound, step)
        if trips is None:
            raise self.error(s.line, f"for loop over {s.var!r} never ends: from {first} in steps of {step}, "
                                     f"{s.var} {relation} {bound} stays true")
        outer = self.loops
        self.loops = min(outer * trips, MAX_LOOP_ITERATIONS + 1)
        if self.loops > MAX_LOOP_ITERATIONS:
            around = f" inside loops of {outer} iterations" if outer > 1 else ""
            raise self.error(s.line, f"for loop over {s.var!r} runs {trips} iterations{around}, past the translator's "
                                     f"MAX_LOOP_ITERATIONS ({MAX_LOOP_ITERATIONS})")
        self.cost.steps.append((None, self.loops, s.line))
        self.block(s.body, pred, depth + 1, scope=counter)
        self.loops = outer
        self.out.append(f"{pad}}}")

    def _loop_bound(self, s: For) -> tuple[str, int]:
        """(relation, bound) of a loop condition `i < N` or `N > i` with N a constant int."""
        c = s.cond
        if isinstance(c, Binary) and c.op in RELATIONS:
            for mine, other, relation in ((c.left, c.right, c.op), (c.right, c.left, MIRRORED[c.op])):
                if isinstance(mine, Name) and mine.id == s.var:
                    bound = self.expr(other)
                    if bound.type == "int" and bound.literal is not None:
                        return relation, int(bound.literal)
        raise self.error(s.line, f"{_LOOP_FORM}: its condition does not compare {s.var!r} with a constant int")

    def _loop_step(self, s: For) -> tuple[int, Value]:
        """The constant a loop's step adds to its counter: `i++`, `i--`, `i += N`, `i -= N`, `i = i ± N`."""
        a = s.step
        assert isinstance(a, Assign)
        value = a.value
        sign = {"+=": 1, "-=": -1}.get(a.op)
        if a.op == "=" and isinstance(value, Binary) and value.op in ("+", "-") and \
                isinstance(value.left, Name) and value.left.id == s.var:
            sign, value = (1 if value.op == "+" else -1), value.right
        if sign is not None:
            inc = self.expr(value)
            if inc.type == "int" and inc.literal is not None:
                step = sign * int(inc.literal)
                return step, Value("int", str(step), str(step))
        raise self.error(s.line, f"{_LOOP_FORM}: its step does not add a constant int to {s.var!r}")

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
            self._assigned(sym, a.line)
        elif isinstance(target, (Member, Index)) and isinstance(target.value, Name):
            sym = self.lookup(target.value.id, target.line)
            if not sym.assignable:
                raise self.error(a.line, f"cannot assign to {target.value.id!r}")
            self._assigned(sym, a.line)
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

    def _assigned(self, sym: Symbol, line: int) -> None:
        if isinstance(sym, GlobalVar):
            sym.assigned_in.setdefault(self.current.cname, line)

    def find(self, name: str) -> Symbol | None:
        """The variable a name means here: the innermost scope's, else the global one."""
        for scope in reversed(self.scopes):
            if name in scope:
                return scope[name]
        return self.globals.get(name)

    def lookup(self, name: str, line: int) -> Symbol:
        sym = self.find(name)
        if sym is None:
            raise self.error(line, f"unknown name {name!r}")
        if isinstance(sym, GlobalVar) and self.current is not None:
            sym.used_in.setdefault(self.current.cname, line)
        return sym

    # -- expressions
    def expr(self, n: Node, int_compare: bool = False) -> Value:
        """The typed code of an expression; refused past MAX_CODE_BYTES before it is appended."""
        v = self._expr(n, int_compare)
        if len(v.code) > MAX_CODE_BYTES:
            raise self.error(n.line, _too_much_code("an expression's OpenCL C"))
        return v

    def _expr(self, n: Node, int_compare: bool) -> Value:
        if isinstance(n, Num):
            if n.is_int:
                return Value("int", n.text, n.text)
            if float(n.text) > MAX_FLOAT:
                raise self.error(n.line, f"float literal {n.text} is past the largest float ({MAX_FLOAT:.8g}): "
                                         f"infinite in the kernel")
            return Value("float", f"G_LIT({_float_text(n.text)})", n.text)
        if isinstance(n, Name):
            if n.id in ("true", "false"):
                return _bool(n.id == "true")
            sym = self.lookup(n.id, n.line)
            if sym.role is not None:
                self.reads.add(sym.role)
            if sym.cost is not None:
                self._expand(sym.cost, n.line)
            if sym.cname.startswith(PARAM) and sym.type == "bool":
                return _bool(self.params[sym.cname[len(PARAM):]][1] == "G_TRUE")
            return Value(sym.type, sym.cname, sym.literal)
        if isinstance(n, Unary):
            v = self.expr(n.operand)
            if n.op == "!":
                if v.type != "bool":
                    raise self.error(n.line, f"'!' needs a bool, got {v.type}")
                return _bool(not v.known) if v.known is not None else Value("bool", f"(!{v.code})")
            if v.type == "bool":
                raise self.error(n.line, f"unary {n.op!r} on a bool")
            if n.op == "+":
                return v
            if v.type in ("vec2", "vec3"):
                return Value(v.type, f"g{DIM[v.type]}_neg({v.code})")
            lit = None if v.literal is None or v.type != "int" else self._folded(-int(v.literal), n.line)
            return Value(v.type, f"(-{v.code})", lit)
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
            if c.known is not None:        # a fixed condition: only its branch is in the kernel
                return self.coerce(a if c.known else b, kind, n.line)
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
            return Value(f"vec{len(comps)}", f"{self._swizzler(DIM[v.type], comps)}({v.code})")
        if isinstance(n, Index):
            v = self.expr(n.value)
            if v.type not in ("vec2", "vec3"):
                raise self.error(n.line, f"unsupported construct: indexing a {v.type} (only vectors)")
            return Value("float", f"({v.code}).{'xyz'[self._const_index(n, DIM[v.type])]}")
        if isinstance(n, Assign):
            raise self.error(n.line, "unsupported construct: assignment inside an expression")
        raise self.error(n.line, f"unsupported construct: {type(n).__name__}")

    def _expand(self, cost: Cost, line: int) -> None:
        """A global's #define read here: its code and calls count where it is expanded."""
        self.cost.bytes += cost.bytes
        if self.cost.bytes > MAX_CODE_BYTES:
            raise self.error(line, _too_much_code("the OpenCL C with the #defines of globals expanded"))
        self.cost.steps += [(callee, self.loops * times, at) for callee, times, at in cost.steps]

    def _const_index(self, n: Index, size: int) -> int:
        idx = self.expr(n.index)
        if idx.type != "int" or idx.literal is None:
            raise self.error(n.line, "unsupported construct: x[i] with an index that is not a constant int")
        i = int(idx.literal)
        if not 0 <= i < size:
            raise self.error(n.line, f"index {i} out of range for a vec{size}")
        return i

    def _swizzler(self, size: int, comps: list[str]) -> str:
        """The helper reading components `comps` of a vec<size>: the operand is evaluated once."""
        name = f"x_sw{size}_{''.join(comps)}"
        if name not in self.swizzles:
            parts = ", ".join(f"v.{c}" for c in comps)
            self.swizzles[name] = (f"INLINE vec{len(comps)} {name}(const vec{size} v) "
                                   f"{{ return v{len(comps)}({parts}); }}")
            self._count(self.swizzles[name])
        return name

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
            if a.known is not None and b.known is not None:
                return _bool(a.known != b.known if op == "^^" else
                             (a.known and b.known) if op == "&&" else (a.known or b.known))
            if op != "^^":
                # A fixed left side decides as GLSL's short circuit does; a fixed right side
                # that leaves the result to the left (x && true, x || false) drops out.
                if a.known is not None:
                    return _bool(a.known) if a.known == (op == "||") else b
                if b.known is not None and b.known == (op == "&&"):
                    return a
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
                lit = self._folded(INT_FOLD[op](int(a.literal), int(b.literal)), line)
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

    def _folded(self, value: int, line: int) -> str:
        """A folded constant int expression's value; refused outside GLSL's 32-bit int."""
        if not INT_MIN <= value <= INT_MAX:
            raise self.error(line, f"constant int expression is {value}, outside GLSL's int range "
                                   f"[{INT_MIN}, {INT_MAX}]")
        return str(value)

    def call(self, n: Call) -> Value:
        name = n.name
        if name in UNSUPPORTED_TYPES:
            raise self.error(n.line, f"unsupported construct: type {name}")
        args = [self.expr(a) for a in n.args]
        if name in ("float", "int", "bool", "vec2", "vec3"):
            return self.construct(name, args, n.line)
        if self.find(name) is not None:
            raise self.error(n.line, f"{name!r} is a variable here, not a function")
        if name in self.functions:
            d = self.overload(name, args, n.line)
            if d.cname == self.entry:
                raise self.error(n.line, "BRDF may not be called by the shader")
            self.cost.steps.append((d.cname, self.loops, n.line))
            code = [self.coerce(a, t, n.line).code for a, t in zip(args, d.types)]
            return Value(d.fn.type, f"{d.cname}({', '.join([*code, 's'])})")
        if name in COMPONENTWISE or (name == "atan" and len(args) == 2):
            return self.componentwise(name, args, n.line)
        if name in GEOMETRIC:
            return self.geometric(name, args, n.line)
        if name.startswith("texture") or name in ("dFdx", "dFdy", "fwidth", "noise1"):
            raise self.error(n.line, f"unsupported construct: {name}()")
        raise self.error(n.line, f"unknown function {name!r}")

    def overload(self, name: str, args: list[Value], line: int) -> Defined:
        """The definition a call means: the one whose argument types match exactly, else the one
        matching with ints converted to float (GLSL's implicit conversion)."""
        types = [a.type for a in args]
        same = self.functions[name]
        exact = [d for d in same if d.types == types]
        if exact:
            return exact[0]
        fits = [d for d in same if len(d.types) == len(types)
                and all(a == t or (a == "int" and t == "float") for a, t in zip(types, d.types))]
        if len(fits) == 1:
            return fits[0]
        call = f"{name}({', '.join(types)})"
        if fits:
            raise self.error(line, f"ambiguous call {call}: {' or '.join(d.signature for d in fits)}")
        raise self.error(line, f"no function {call}; {name} is defined for "
                               f"{' and '.join(d.signature for d in same)}")

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
        # An int argument is a float (GLSL's implicit conversion): dot(0.5, 2) is a product.
        kinds = {"float" if a.type == "int" else a.type for a in args}
        if len(kinds) != 1 or next(iter(kinds)) not in ("float", "vec2", "vec3"):
            raise self.error(line, f"{name}({', '.join(a.type for a in args)}): arguments must be one vector type")
        kind = kinds.pop()
        d = DIM[kind]
        if name in ("cross", "reflect") and d != 3:
            raise self.error(line, f"{name}() takes vec3 arguments")
        code = [self.coerce(a, kind, line).code for a in args]
        result = "float" if name in ("dot", "length", "distance") else kind
        if name == "dot" and d == 1:
            return Value("float", f"({code[0]} * {code[1]})")
        return Value(result, f"g{d}_{name}({', '.join(code)})")


_LOOP_FORM = ("unsupported construct: a for loop not of the form 'for (int i = A; i < B; i += C)' with constant "
              "A, B and C (GLSL ES 1.00, Appendix A)")


def trip_count(first: int, relation: str, bound: int, step: int) -> int | None:
    """How many times `for (i = first; i RELATION bound; i += step)` runs its body; None if never
    stops (the counter moves away from the bound, stays put, or steps over the value it must meet)."""
    holds = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge, "==": operator.eq,
             "!=": operator.ne}[relation]
    if not holds(first, bound):
        return 0
    if relation == "==":
        return None if step == 0 else 1
    if relation == "!=":
        gap = bound - first
        return gap // step if step != 0 and gap % step == 0 and gap // step > 0 else None
    if relation in ("<", "<="):
        last = bound if relation == "<=" else bound - 1
        return (last - first) // step + 1 if step > 0 else None
    last = bound if relation == ">=" else bound + 1
    return (first - last) // -step + 1 if step < 0 else None


def _too_much_code(what: str) -> str:
    return f"{what} passes {MAX_CODE_BYTES} bytes (the translator's MAX_CODE_BYTES)"


def _float_text(text: str) -> str:
    """A literal's text as C accepts it before an `f` suffix (1. → 1.0, .5 → 0.5, 2 → 2.0)."""
    value = float(text)
    out = repr(value)
    return out if ("." in out or "e" in out) else out + ".0"


def _small_int(text: str) -> int | None:
    """An exponent of 1 to 5 that pow() may expand into products, else None."""
    value = float(text)
    return int(value) if value in (1.0, 2.0, 3.0, 4.0, 5.0) else None


def _bool(value: bool) -> Value:
    return Value("bool", "G_TRUE" if value else "G_FALSE", known=value)


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
    """The OpenCL C of a shader, the C name of its BRDF and which of L, V, N, X, Y BRDF reads."""
    code: str
    reads: frozenset[str]
    entry: str


def translate(text: str, path: str | Path, params: dict[str, tuple[str, str]], first_line: int = 1) -> Translation:
    """OpenCL C defining `entry(L, V, N, X, Y, s)` for the GLSL shader `text` (every translated
    function takes the pixel's Surface `s` last: `params` values may read it)."""
    path = str(path)
    emitter = Emitter(parse(text, path, first_line), path, params)
    code = emitter.emit()
    return Translation(code, frozenset(emitter.reads), emitter.entry)
