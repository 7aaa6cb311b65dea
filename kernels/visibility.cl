/* visibility.cl — the G-buffer from a visibility buffer, on the device, bit for bit the
 * G-buffer that clshade/render/gbuffer.py:build_gbuffer makes from rasterize_mesh's
 * fragments (scenes without textures, hence without an occlusion channel; the live viewer,
 * clshade/device/visibility.py).
 *
 * Per pixel p of the frame (work-item p; the padding pixels past npix too):
 *   tri = visible[p]: the winning triangle of the view's triangle setup, or -1
 *         (clshade/render/raster/visibility.py);
 *   the winners' step of the rasterizer (raster/resolve.py:winners), in double:
 *         e_j = max(a_j X + (b_j Y + c_j), 0) at the pixel centre (X, Y),
 *         s = e_0 + e_1 + e_2, depth = area2 / s (clip w is the view depth),
 *         b_j = e_j / s; s not in (0, ∞) (round-off on a sliver) gives the centroid and
 *         the depth interpolated from the corners' view depths;
 *   then build_gbuffer's per-pixel step, in float: the normal interpolated from the face's
 *         corner normals, ((0 + b0 n0) + b1 n1) + b2 n2, scaled by 1/|n| (0 stays 0); the
 *         face's base colour, roughness, metallic, material (and emission).
 *   A pixel whose depth or normal is not finite keeps roughness, metallic and material,
 *   and gets zero depth, normal, base colour and emission; `cover` says which pixels are
 *   covered (1), empty (0) or so replaced (2).
 *
 * Exactness: every operation is the one NumPy performs, in its order, with no contraction
 * into fused multiply-adds (FP_CONTRACT OFF) and correctly rounded float division and
 * square root (the host builds with -cl-fp32-correctly-rounded-divide-sqrt). The device
 * must have double precision (cl_khr_fp64); without it the host builds the G-buffer.
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF

/* np.maximum(e, 0.0): NaN stays NaN, -0.0 becomes +0.0. */
inline double clamp_low(double e) { return isnan(e) ? e : (e > 0.0 ? e : 0.0); }

__kernel void visibility(
    const uint npix, const uint plane, const uint width, const uint ntri, const uint w_is_depth,
    __global const int* visible,            /* (npix,) triangle or -1 */
    __global const double* setup,           /* (10, ntri): persp a0 a1 a2, b0 b1 b2, c0 c1 c2, area2 */
    __global const int* tri_face,           /* (ntri,) the triangle's face */
    __global const double* vdepth,          /* (V,) view depth of each vertex */
    __global const int* corners,            /* (3, F) the faces' vertex indices */
    const uint nface,
    __global const float* corner_normal,    /* (9, F): n{corner}{axis} */
    __global const float* face_base,        /* (3, F) */
    __global const float* face_roughness, __global const float* face_metallic,
    __global const uchar* face_material,
#if HAS_EMISSIVE
    __global const float* face_emissive,    /* (3, F) */
    __global float* emissive,
#endif
    __global float* depth, __global float* normal, __global float* base,
    __global float* roughness, __global float* metallic, __global uchar* material,
    __global uchar* cover)
{
    const uint p = get_global_id(0);
    if (p >= plane) return;
    const int t = p < npix ? visible[p] : -1;
    if (t < 0) {
        depth[p] = 0.0f;
        for (uint d = 0; d < 3; d++) {
            normal[d * plane + p] = 0.0f;
            base[d * plane + p] = 0.0f;
#if HAS_EMISSIVE
            emissive[d * plane + p] = 0.0f;
#endif
        }
        roughness[p] = 0.0f;
        metallic[p] = 0.0f;
        material[p] = 0;
        cover[p] = 0;
        return;
    }
    /* The winners' step (raster/resolve.py), in double. */
    const uint row = p / width;
    const double X = (double)(p - row * width) + 0.5;
    const double Y = (double)row + 0.5;
    double e[3];
    for (uint j = 0; j < 3; j++) {
        double by = setup[(3 + j) * ntri + t] * Y;
        by = by + setup[(6 + j) * ntri + t];
        e[j] = clamp_low(setup[j * ntri + t] * X + by);
    }
    double s = e[0] + e[1];
    s = s + e[2];
    const int bad = !((s > 0.0) && (s < INFINITY));
    if (bad) {
        e[0] = e[1] = e[2] = 1.0;
        s = 3.0;
    }
    double z = setup[9 * ntri + t] / s;
    for (uint j = 0; j < 3; j++)
        e[j] = e[j] / s;
    const int f = tri_face[t];
    if (!w_is_depth || bad) {
        z = e[0] * vdepth[corners[f]] + e[1] * vdepth[corners[nface + f]];
        z = z + e[2] * vdepth[corners[2 * nface + f]];
    }
    const float b[3] = {(float)e[0], (float)e[1], (float)e[2]};
    const float zf = (float)z;

    /* build_gbuffer's step (render/gbuffer.py), in float. */
    float n[3];
    for (uint d = 0; d < 3; d++) {
        float acc = corner_normal[d * nface + f] * b[0];
        acc = acc + 0.0f;
        acc = acc + corner_normal[(3 + d) * nface + f] * b[1];
        acc = acc + corner_normal[(6 + d) * nface + f] * b[2];
        n[d] = acc;
    }
    float len2 = n[0] * n[0];
    len2 = len2 + n[1] * n[1];
    len2 = len2 + n[2] * n[2];
    float inv = sqrt(len2);
    inv = 1.0f / inv;
    if (!(len2 > 0.0f))
        inv = 0.0f;
    int ok = isfinite(zf);
    for (uint d = 0; d < 3; d++) {
        n[d] = n[d] * inv;
        ok = ok && isfinite(n[d]);
    }
    depth[p] = ok ? zf : 0.0f;
    for (uint d = 0; d < 3; d++) {
        normal[d * plane + p] = ok ? n[d] : 0.0f;
        base[d * plane + p] = ok ? face_base[d * nface + f] : 0.0f;
#if HAS_EMISSIVE
        emissive[d * plane + p] = ok ? face_emissive[d * nface + f] : 0.0f;
#endif
    }
    roughness[p] = face_roughness[f];
    metallic[p] = face_metallic[f];
    material[p] = face_material[f];
    cover[p] = ok ? 1 : 2;
}
