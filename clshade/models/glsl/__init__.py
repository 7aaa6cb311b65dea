"""Translate the GLSL subset of BRDF Explorer shaders into a clshade lobe (OpenCL C);
`emitter.translate` runs the three stages.

Three stages, each its own module: a tokenizer (lexer.tokenize), a recursive-descent
parser into an AST (parser.Parser), and a typed emitter (emitter.Emitter) that checks every
expression's type (float, int, bool, vec2, vec3) and writes OpenCL C over
clshade's lane types (simd.h: `real`, `vec3`, `mask`) and kernels/glsl.h. The stages check
the resource limits of limits.py (nesting, literals, tokens, generated code, loop iterations)
before the work each bounds, so that any input gets code or one error line.

The subset: globals (`const` or not), helper functions (`in` parameters, overloads), local
declarations, `if`/`else`, `return`, `for` loops of GLSL ES 1.00's constant form, the
operators of GLSL expressions with its precedence, `?:`, swizzles
(`.x`, `.xy`, `.rgb` …), constant indexing `v[i]`, `vec2`/`vec3` constructors,
the usual built-ins (mix, clamp, pow, dot, normalize …), object-like
`#define`s, and GLSL's implicit int-to-float conversion. Anything else (vec4,
matrices, `out` parameters, `while`, `discard`, texture lookups, function-like
macros, recursion …) is refused with one error naming the construct, the file and the line.

Names follow GLSL's scoping (arguments and locals hide globals and the file's parameters;
a user's function hides a built-in of its name) and each kind of name has its own C prefix
(emitter.PARAM, GLOBAL, ARG, FUNC, `u_l<k>_` for locals), so no user name meets clshade's.

Lanes are pixels, so control flow that depends on a pixel cannot branch:
`if` and `?:` are converted to selects (if-conversion). Inside a branch every
assignment is `x = p ? new : x` with p the branch's mask; a `return` inside a
branch sets the result where p holds and marks those lanes done, and later
statements act only on lanes not done. Expressions have no side effects
(GLSL has no pointers here and helpers take `in` parameters only), so
evaluating both sides of a branch is exact: the untaken side's values are
discarded lane by lane.
"""
