"""Render stage: scene file → scene objects → world triangles → fragments → G-buffer; and radiance → image.

Nothing here knows about OpenCL or lighting models' kernels.
"""
