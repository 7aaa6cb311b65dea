/* visibility.cl — the G-buffer from a visibility buffer, on the device, bit for bit the
 * G-buffer that clshade/render/gbuffer.py:build_gbuffer makes from rasterize_mesh's
 * fragments (scenes without textures, hence without an occlusion channel; the live viewer,
 * clshade/device/visibility.py).
 *
 * Per pixel p of the frame (the padding pixels past npix too):
 *   tri = visible[p]: the winning triangle of the view's triangle setup, or -1
 *         (clshade/render/raster/visibility.py);
 *   the winners' step of the rasterizer (raster/resolve.py:winners), in double:
 *         e_j = max(a_j X + (b_j Y + c_j), 0) at the pixel centre (X, Y),
 *         s = e_0 + e_1 + e_2, depth = area2 / s (clip w is the view depth),
 *         b_j = e_j / s; s not in (0, ∞) (round-off on a sliver) gives the centroid and
 *         the depth interpolated from the corners' view depths (as any projection whose
 *         clip w is not the view depth);
 *   then build_gbuffer's per-pixel step, in float: the normal interpolated from the face's
 *         corner normals, ((0 + b0 n0) + b1 n1) + b2 n2, scaled by 1/|n| (0 stays 0); the
 *         face's base colour, roughness, metallic, material (and emission).
 *   A pixel whose depth or normal is not finite keeps roughness, metallic and material,
 *   and gets zero depth, normal, base colour and emission; `cover` says which pixels are
 *   covered (1), empty (0) or so replaced (2). Empty pixels get zero everywhere.
 *
 * Exactness: every operation is the one NumPy performs, in its order, with no contraction
 * into fused multiply-adds (FP_CONTRACT OFF) and correctly rounded float division and
 * square root (the host builds with -cl-fp32-correctly-rounded-divide-sqrt); conversions
 * from double to float round to nearest even, as NumPy's. The device must have double
 * precision (cl_khr_fp64); without it the host builds the G-buffer.
 *
 * Speed: a work-item does LANES adjacent pixels, one per vector lane (the reason is
 * simd.h's: PoCL vectorises no scalar code of this shape, which ran a pixel at a time at
 * about 3x the time), gathering each lane's triangle and face constants; a work-item whose
 * pixels are all empty (sky) only writes zeros.
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL FP_CONTRACT OFF

#define LANES 8
typedef double8 dvec;
typedef float8 fvec;
typedef int8 ivec;
typedef long8 lvec;

/* Lane k of each: p[i.sk]. */
#define GATHER(T, p, i) ((T)((p)[(i).s0], (p)[(i).s1], (p)[(i).s2], (p)[(i).s3], \
                             (p)[(i).s4], (p)[(i).s5], (p)[(i).s6], (p)[(i).s7]))
#define GD(p, i) GATHER(dvec, p, i)
#define GF(p, i) GATHER(fvec, p, i)
#define GI(p, i) GATHER(ivec, p, i)

/* np.maximum(e, 0.0): NaN stays NaN, -0.0 becomes +0.0. */
inline dvec clamp_low(dvec e) { return select(select((dvec)(0.0), e, e > 0.0), e, isnan(e)); }

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
    const uint i = get_global_id(0);
    const uint p0 = i * LANES;              /* plane is a multiple of LANES (PIXEL_PAD) */
    if (p0 >= plane) return;
    const ivec lane = (ivec)(0, 1, 2, 3, 4, 5, 6, 7);
    ivec vis;
    if (p0 + LANES <= npix) {
        vis = vload8(0, visible + p0);
    } else {                                /* the last pixels and the padding */
        vis = (ivec)(-1);
        for (uint k = 0; p0 + k < npix && k < LANES; k++)
            ((int*)&vis)[k] = visible[p0 + k];
    }
    const ivec hit = vis >= 0;
    const fvec fzero = (fvec)(0.0f);
    if (!any(hit)) {                        /* sky: zeros everywhere */
        vstore8(fzero, i, depth);
        for (uint d = 0; d < 3; d++) {
            vstore8(fzero, i, normal + d * plane);
            vstore8(fzero, i, base + d * plane);
#if HAS_EMISSIVE
            vstore8(fzero, i, emissive + d * plane);
#endif
        }
        vstore8(fzero, i, roughness);
        vstore8(fzero, i, metallic);
        vstore8((uchar8)(0), i, material);
        vstore8((uchar8)(0), i, cover);
        return;
    }
    const ivec t = select((ivec)(0), vis, hit);   /* empty lanes compute on triangle 0, then get zeros */
    const lvec hitl = convert_long8(hit);

    /* The winners' step (raster/resolve.py), in double. */
    const ivec pix = (ivec)((int)p0) + lane;
    const ivec row = pix / (int)width;
    const dvec X = convert_double8(pix - row * (int)width) + 0.5;
    const dvec Y = convert_double8(row) + 0.5;
    dvec by0 = GD(setup + 3 * ntri, t) * Y, by1 = GD(setup + 4 * ntri, t) * Y, by2 = GD(setup + 5 * ntri, t) * Y;
    by0 = by0 + GD(setup + 6 * ntri, t);
    by1 = by1 + GD(setup + 7 * ntri, t);
    by2 = by2 + GD(setup + 8 * ntri, t);
    dvec e0 = GD(setup, t) * X, e1 = GD(setup + ntri, t) * X, e2 = GD(setup + 2 * ntri, t) * X;
    e0 = clamp_low(e0 + by0);
    e1 = clamp_low(e1 + by1);
    e2 = clamp_low(e2 + by2);
    dvec s = e0 + e1;
    s = s + e2;
    const lvec bad = !((s > 0.0) && (s < (dvec)(INFINITY)));
    e0 = select(e0, (dvec)(1.0), bad);
    e1 = select(e1, (dvec)(1.0), bad);
    e2 = select(e2, (dvec)(1.0), bad);
    s = select(s, (dvec)(3.0), bad);
    dvec z = GD(setup + 9 * ntri, t) / s;
    e0 = e0 / s;
    e1 = e1 / s;
    e2 = e2 / s;
    const ivec f = GI(tri_face, t);
    if (!w_is_depth || any(bad & hitl)) {
        dvec zi = e0 * GD(vdepth, GI(corners, f));
        zi = zi + e1 * GD(vdepth, GI(corners + nface, f));
        zi = zi + e2 * GD(vdepth, GI(corners + 2 * nface, f));
        z = w_is_depth ? select(z, zi, bad) : zi;
    }
    const fvec b0 = convert_float8(e0), b1 = convert_float8(e1), b2 = convert_float8(e2);
    const fvec zf = convert_float8(z);

    /* build_gbuffer's step (render/gbuffer.py), in float. */
    fvec nx = GF(corner_normal, f) * b0, ny = GF(corner_normal + nface, f) * b0;
    fvec nz = GF(corner_normal + 2 * nface, f) * b0;
    nx = nx + 0.0f;
    ny = ny + 0.0f;
    nz = nz + 0.0f;
    nx = nx + GF(corner_normal + 3 * nface, f) * b1;
    ny = ny + GF(corner_normal + 4 * nface, f) * b1;
    nz = nz + GF(corner_normal + 5 * nface, f) * b1;
    nx = nx + GF(corner_normal + 6 * nface, f) * b2;
    ny = ny + GF(corner_normal + 7 * nface, f) * b2;
    nz = nz + GF(corner_normal + 8 * nface, f) * b2;
    fvec len2 = nx * nx;
    len2 = len2 + ny * ny;
    len2 = len2 + nz * nz;
    fvec inv = sqrt(len2);
    inv = 1.0f / inv;
    inv = select(fzero, inv, len2 > 0.0f);
    nx = nx * inv;
    ny = ny * inv;
    nz = nz * inv;
    const ivec ok = hit & isfinite(zf) & isfinite(nx) & isfinite(ny) & isfinite(nz);
    vstore8(select(fzero, zf, ok), i, depth);
    vstore8(select(fzero, nx, ok), i, normal);
    vstore8(select(fzero, ny, ok), i, normal + plane);
    vstore8(select(fzero, nz, ok), i, normal + 2 * plane);
    for (uint d = 0; d < 3; d++) {
        vstore8(select(fzero, GF(face_base + d * nface, f), ok), i, base + d * plane);
#if HAS_EMISSIVE
        vstore8(select(fzero, GF(face_emissive + d * nface, f), ok), i, emissive + d * plane);
#endif
    }
    vstore8(select(fzero, GF(face_roughness, f), hit), i, roughness);
    vstore8(select(fzero, GF(face_metallic, f), hit), i, metallic);
    vstore8(convert_uchar8(select((ivec)(0), convert_int8(GATHER(uchar8, face_material, f)), hit)), i, material);
    vstore8(convert_uchar8(select(select((ivec)(0), (ivec)(2), hit), (ivec)(1), ok)), i, cover);
}
