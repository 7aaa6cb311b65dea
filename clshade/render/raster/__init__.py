"""Vectorised NumPy triangle rasterizer producing per-pixel fragments.

The rasterizer knows nothing about lighting or materials (PyTorch3D style): it
turns a triangle mesh, a view and an OpenGL projection into, per pixel, the
index of the visible face, its view-space depth and perspective-correct
barycentrics with respect to that face's three vertices.

Pipeline (no Python loop per triangle or per pixel):

1. vertices → clip space (``proj @ view``), float64;
2. faces are processed in batches of :data:`FACE_BATCH`; culled faces that face
   away from the camera's centre by more than a margin are dropped first, from
   their world-space planes kept in a :class:`RasterMesh` kept for many views
   (a dot product per face, no per-corner work; setup would drop them too);
   trivially invisible
   faces (non-finite, fully outside one frustum plane) are dropped;
3. faces crossing the near plane (``z_clip + w_clip = 0``, i.e. ``w = near``
   for a perspective matrix) are clipped Sutherland–Hodgman style into one or
   two triangles, each clipped vertex carrying its barycentric coordinates in
   the original face (folded into the triangle's barycentric coefficients);
4. per triangle: screen-space edge functions in float64 (written so that an
   edge shared by two triangles gives exactly negated values, plus a top-left
   tie rule: watertight, no pixel covered twice), a depth plane, a pixel
   bounding box; boxes larger than :data:`TILE` are split into tiles, and
   full tiles inside all three edges are marked interior (no edge tests);
   a triangle whose box's corner depths lie in [-1, 1] needs no per-fragment
   depth-range test (the depth is monotone along rows and columns);
5. boxes/tiles are grouped by power-of-two size class ``(sy, sx)`` (a class of
   few tiles joins the square class of its longer side) and tested
   against the pixel centres of a dense ``(sy, sx, n)`` grid by broadcasting
   (one add, one compare and one ``and`` per edge and candidate pixel; the
   tile axis is innermost so NumPy's loops are long), in chunks of at most
   ``min(max_fragments, GRID_CHUNK_CELLS)`` candidate pixels;
6. covered fragments are depth-resolved with ``np.minimum.at`` on int64
   keys packing (NDC depth quantised to 2**-44, triangle index; equal keys:
   the lower index wins); only the winning fragments of a batch get their
   perspective-correct barycentrics and view depth computed.

Steps 3–6 run on worker threads (clshade.render.arrays; NumPy releases the
GIL in its loops): the triangle setup in parts of the batch, the grids of
step 5 shared out with one key array per thread (merged by a minimum), the
winners in chunks. The result does not depend on the thread count.
The output is the list of covered pixels (what the G-buffer reads);
full-frame arrays are made from it on demand (:class:`Fragments`).

Pixel conventions: row 0 is the top of the image; pixel ``(i, j)`` has its
centre at NDC ``x = (j + 0.5) / W * 2 - 1``, ``y = 1 - (i + 0.5) / H * 2``.
Front faces are counter-clockwise in NDC.

Modules, in the order a batch of faces goes through them:

- ``mesh``: :class:`RasterMesh`, the checked input and its faces' planes (kept
  between views of one mesh: :func:`rasterize_mesh`), and the back-face pre-cull;
- ``triangles``: cull, near-plane clipping, projection, edge functions and depth
  planes (steps 1–4), in parts of the batch on the worker threads;
- ``tiles``: bounding boxes split into tiles, grouped by size class and tested
  against pixel centres, each worker resolving into its own key array (step 5–6);
- ``resolve``: the packed depth keys, their arrays kept between calls, the merge of
  the workers' arrays and the winners' barycentrics and depth (step 6);
- ``batches``: :func:`rasterize` itself (checks, clip transform, face batches);
- ``fragments``: the result, :class:`Fragments`;
- ``visibility``: :func:`setup_view`'s result, a view's triangle setup for a pass that does
  steps 5–6 and the G-buffer on its own (the live viewer's visibility buffer on the device).
"""
from clshade.render.raster.batches import rasterize, rasterize_mesh, setup_view
from clshade.render.raster.fragments import Fragments
from clshade.render.raster.mesh import RasterMesh
from clshade.render.raster.visibility import ViewSetup

__all__ = ["Fragments", "RasterMesh", "ViewSetup", "rasterize", "rasterize_mesh", "setup_view"]
