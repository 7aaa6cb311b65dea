"""clshade — an OpenCL compute-kernel shading engine for comparing lighting models.

Data flow, one folder per stage (a stage imports only itself and lower stages):
    models/ (lobes, models, Registry) → render/ (scene → meshes → raster → G-buffer)
    → device/ (kernel variant → shading dispatch) → pipeline.py (one frame)
    → render/image.py (radiance → image)
Evidence: verify/ (float64 reference, accuracy, plausibility, stability), bench/ (cost).
"""
__version__ = "0.1.0"
