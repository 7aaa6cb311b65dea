"""clshade — an OpenCL compute-kernel shading engine for comparing lighting models.

Data flow, one module per stage:
    scene file (scene.py) → meshes (meshes.py) → rasterizer (raster.py)
    → G-buffer (gbuffer.py) → kernel variant (variants.py, runtime.py)
    → shading (shade.py) → image (image.py)
"""
__version__ = "0.1.0"
