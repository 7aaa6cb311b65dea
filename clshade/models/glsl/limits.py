"""The translator's resource limits: what a shader may ask of it before it is refused.

Each limit is checked while the shader is read, parsed or emitted, before the work it bounds is
done, so that no input makes the translator (or the OpenCL compiler after it) run for minutes,
fill memory or overflow Python's stack. The shaders of BRDF Explorer's collection stay far below
every one (docs/user-lobes.md, "Translator limits"; README.md, "Resource limits").
"""
from __future__ import annotations

# A .brdf file's size is a lobe file's: clshade.budget.MAX_LOBE_FILE_BYTES.

# Tokens of a shader once its #defines are expanded, counted as they are (nested #defines
# multiply a file's tokens exponentially). The collection's largest has 803.
MAX_TOKENS = 65_536

# Expressions, statements and blocks inside one another. The parser and emitter recurse per level:
# 64 levels take at most about 400 of Python's 1,000 frames and stay below the OpenCL C
# compiler's 256 nested brackets. The collection nests 13 deep at most.
MAX_NESTING = 64

# Characters of one numeric literal, checked before any conversion (Python's int() of a long
# digit string is quadratic, and past 4,300 digits refused).
MAX_LITERAL_CHARS = 64

# GLSL's int is 32-bit: an int literal or a folded constant int expression past it is refused
# rather than wrapped.
INT_MIN, INT_MAX = -(2 ** 31), 2 ** 31 - 1

# The largest float32 (FLT_MAX): the kernels' float build reads every literal and parameter as a
# float, where a larger one is infinite.
MAX_FLOAT = 3.4028234663852886e38

# Generated OpenCL C as the compiler sees it: #defines of globals expanded, each call inlined (f
# calling g twice calling h twice … doubles per level). The collection's largest translation is
# 10 KB; build time grows with the code (docs/user-lobes.md, "Translator limits").
MAX_CODE_BYTES = 256 * 1024

# For-loop iterations in one call of a function (nested loops multiplied, a callee's loops per
# call): 4,096 iterations of a two-operation body per pixel shade a 1024² frame in about 3 s on
# PoCL. A loop that never ends is refused outright.
MAX_LOOP_ITERATIONS = 4096
