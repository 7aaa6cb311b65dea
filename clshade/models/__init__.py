"""The lighting-model registry: the one source of truth for model metadata.

Dependencies run one way: lobe (Lobe, Param, the `/*! clshade-model` header) ← glsl (the
GLSL translator: lexer, parser, emitter) ← brdf_file (BRDF Explorer's .brdf format) ←
registry (Registry: built-in and user lobes, model specs); model (Model, presets) needs
only lobe.
"""
