"""The translator's resource limits: what a shader may ask of it before it is refused.

Each limit is checked while the shader is read, parsed or emitted, before the work it bounds is
done, so that no input makes the translator (or the OpenCL compiler after it) run for minutes,
fill memory or overflow Python's stack. The shaders of BRDF Explorer's collection stay far below
every one (docs/user-lobes.md, "Translator limits"; README.md, "Resource limits").
"""
from __future__ import annotations

# A .brdf file's size. BRDF Explorer's largest file (compare.brdf) is 3.5 KB: 70 times that
# leaves room for long generated fits while bounding what is read into memory.
MAX_SOURCE_BYTES = 256 * 1024

# Tokens of a shader once its #defines are expanded. The collection's largest has 803;
# nested #defines can multiply a file's tokens exponentially, so the count is checked as they
# are expanded.
MAX_TOKENS = 65_536

# Expressions, statements and blocks nested inside one another (parentheses, operators, calls,
# `?:`, `a = b = …`, blocks, if/for bodies). The parser and the emitter recurse once or a few
# times per level: 64 levels take at most about 400 of Python's 1,000 frames, and stay below the
# OpenCL C compiler's 256 nested brackets. The collection nests 13 deep at most.
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

# Generated OpenCL C, the #defines of globals expanded and each function counted once per call
# site (the kernel inlines every call: f calling g twice, g calling h twice … is what the
# compiler sees). The collection's largest translation is 10 KB, 25 times less. Build time grows
# with the code: 36 KB of straight-line arithmetic builds in 2.5 s on PoCL, with a sin() per
# line in 30 s.
MAX_CODE_BYTES = 256 * 1024

# Iterations of for loops in one evaluation of BRDF, nested loops multiplied and loops in a
# called function counted once per call. 4,096 per pixel shades a 1024² frame in seconds on a
# CPU; a loop that never ends (a step of 0, a counter going the wrong way) is refused outright.
MAX_LOOP_ITERATIONS = 4096
