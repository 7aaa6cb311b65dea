/* visibility.cl — the visibility buffer and the G-buffer from it, on the device, bit for bit
 * the G-buffer that clshade/render/gbuffer.py:build_gbuffer makes from rasterize_mesh's
 * fragments (the live viewer, clshade/device/visibility.py). Two kernels, after the host's
 * triangle setup (clshade/render/raster/batches.py:setup_view), and a third, `texture` (at the
 * end of this file), for textured faces:
 *
 * cover — the rasterizer's coverage and depth resolve (raster/tiles.py), one work-item per
 *   TILE x TILE tile of a triangle's pixel box, a row LANES columns at a time, one per lane:
 *         a pixel centre (X, Y) is inside when E_i = A_i X + (B_i Y + C_i) >= thr_i for the
 *         three edges (thr: the top-left rule's 0 or TIE_EPS); its NDC depth
 *         z = z_a X + (z_b Y + z_c) is kept within [-1 - eps, 1 + eps], clamped to [-1, 1];
 *         key = (int64((z + 1) z_scale) << tri_bits) | triangle, and the pixel keeps the
 *         least key (atom_min: the same minimum in any order). A dispatch of one triangle's
 *         tiles alone (`exclusive`: the host's largest triangles, before the others) keeps it
 *         by a plain compare and store: each pixel is in one of its tiles, so no other
 *         work-item writes it meanwhile, and the locked operation per fragment is saved.
 *   The host's grids skip the tiles outside an edge and the edge tests of interior tiles;
 *   both only leave out tests that fail or pass, so testing every pixel of the box gives
 *   the same keys.
 *
 * visibility — per pixel p (the padding pixels past npix too), from its key:
 *   tri = key & (2^tri_bits - 1), or none where the key is empty (the key is then reset
 *         to empty for the next frame);
 *   the winners' step of the rasterizer (raster/resolve.py:winners), in double:
 *         e_j = max(a_j X + (b_j Y + c_j), 0) at the pixel centre (X, Y),
 *         s = e_0 + e_1 + e_2, depth = area2 / s (clip w is the view depth),
 *         b_j = e_j / s; s not in (0, ∞) (round-off on a sliver) gives the centroid and
 *         the depth interpolated from the corners' view depths (as any projection whose
 *         clip w is not the view depth);
 *   then build_gbuffer's per-pixel step, in float: the normal interpolated from the face's
 *         corner normals, ((0 + b0 n0) + b1 n1) + b2 n2, scaled by 1/|n| (0 stays 0); the
 *         face's base colour, roughness, metallic, material (and emission).
 *   Where HAS_TEXTURES, the pixel's face when it has a texture set and its barycentrics, for
 *   kernel `texture`; where HAS_OCCLUSION, occlusion 1 (covered) or 0.
 *   A pixel whose depth or normal is not finite keeps roughness, metallic and material,
 *   and gets zero depth, normal, base colour and emission; `cover` says which pixels are
 *   covered (1), empty (0) or so replaced (2). Empty pixels get zero everywhere.
 *
 * Exactness: every operation is the one NumPy performs, in its order, with no contraction
 * into fused multiply-adds (FP_CONTRACT OFF) and correctly rounded float division and
 * square root (the host builds with -cl-fp32-correctly-rounded-divide-sqrt); conversions
 * from double to float round to nearest even and from double to integer toward zero, as
 * NumPy's. The device must have double precision (cl_khr_fp64) and 64-bit atomics
 * (cl_khr_int64_extended_atomics); without them the host rasterizes.
 *
 * Speed: a work-item does LANES adjacent pixels, one per vector lane (the reason is
 * simd.h's: PoCL vectorises no scalar code of this shape, which then runs a pixel at a
 * time), gathering each lane's triangle and face constants — read once and broadcast where
 * every lane is on one triangle (UNIFORM_READ), as most work-items are; a work-item whose pixels are
 * all empty (sky) only writes zeros. `visibility` writes its planes and the emptied keys by streaming
 * stores (VSTORE_NT): the G-buffer is several times the last-level cache, and a plain store first reads
 * each output line (faster on PoCL 3.1 with AVX-512 in alternated runs, docs/bench-notes.md; Intel's
 * compiler gives the same time either way). CLSHADE_VIS_PLAIN_STORES keeps plain stores.
 */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable
#pragma OPENCL EXTENSION cl_khr_int64_extended_atomics : enable
#pragma OPENCL FP_CONTRACT OFF

/* LANES (the host's -DLANES, Runtime.double_lanes): pixels per work-item, one per lane of a
 * double vector — 8 where the device compiles 512-bit vectors natively, else 4 (pip's PoCL 3.0
 * on an AVX-512 host compiles for a target without AVX-512, and a program passing double8 to
 * its builtins there lists no kernels once cached). */
#if LANES == 8
typedef double8 dvec;
typedef float8 fvec;
typedef int8 ivec;
typedef long8 lvec;
typedef uchar8 cvec;
#define LANE_IOTA ((ivec)(0, 1, 2, 3, 4, 5, 6, 7))
#define GATHER(T, p, i) ((T)((p)[(i).s0], (p)[(i).s1], (p)[(i).s2], (p)[(i).s3], \
                             (p)[(i).s4], (p)[(i).s5], (p)[(i).s6], (p)[(i).s7]))
#define VLOAD vload8
#define VSTORE vstore8
#define convert_dvec convert_double8
#define convert_fvec convert_float8
#define convert_ivec convert_int8
#define convert_lvec convert_long8
#define convert_cvec convert_uchar8
#elif LANES == 4
typedef double4 dvec;
typedef float4 fvec;
typedef int4 ivec;
typedef long4 lvec;
typedef uchar4 cvec;
#define LANE_IOTA ((ivec)(0, 1, 2, 3))
#define GATHER(T, p, i) ((T)((p)[(i).s0], (p)[(i).s1], (p)[(i).s2], (p)[(i).s3]))
#define VLOAD vload4
#define VSTORE vstore4
#define convert_dvec convert_double4
#define convert_fvec convert_float4
#define convert_ivec convert_int4
#define convert_lvec convert_long4
#define convert_cvec convert_uchar4
#else
#error "LANES must be 4 or 8"
#endif
#define EMPTY_KEY LONG_MAX
/* VSTORE_NT(T, v, i, p): VSTORE of one vector T at p[i·LANES], on x86 with AVX a streaming store, which skips the
 * read for ownership of each output line (simd.h's STORE_ROW8 says why that matters); the planes and the
 * key plane are aligned to their vectors (PLANE_ALIGN, PIXEL_PAD). */
#if defined(__x86_64__) && defined(__AVX__) && !defined(CLSHADE_VIS_PLAIN_STORES)
#define VSTORE_NT(T, v, i, p) __builtin_nontemporal_store((T)(v), (__global T*)(p) + (i))
#else
#define VSTORE_NT(T, v, i, p) VSTORE((T)(v), (i), (p))
#endif
#define TILE 8                              /* raster/tiles.py's TILE: a tile's row is TILE / LANES vectors */

/* Lane k of each: p[i.sk]. */
#define GD(p, i) GATHER(dvec, p, i)
#define GF(p, i) GATHER(fvec, p, i)
#define GI(p, i) GATHER(ivec, p, i)
/* p[index] lane by lane, or p[one_index] read once and broadcast where `one` says every lane's index is
 * one_index (the lanes of one triangle, face, texture or mip level: most work-items): the same values. */
#define UNIFORM_READ(one, T, p, index, one_index) ((one) ? (T)((p)[one_index]) : GATHER(T, p, index))

/* np.maximum(e, 0.0): NaN stays NaN, -0.0 becomes +0.0. */
inline dvec clamp_low(dvec e) { return select(select((dvec)(0.0), e, e > 0.0), e, isnan(e)); }

__kernel void cover(
    const uint ntiles, const uint ntri, const uint width, const uint tri_bits, const double z_scale,
    const double z_lo, const double z_hi,
    const uint first,                       /* the batch's first triangle (exclusive: the triangle) */
    const uint exclusive,                   /* 1: the dispatch holds triangle `first`'s tiles only */
    __global const uint* tile_end,          /* (batch,) tiles of triangles first..first + j, inclusive */
    __global const uint* tile_tri,          /* (ntiles,) the triangle of each tile (the host's np.repeat);
                                               neither is read where exclusive */
    __global const int* box,                /* (4, ntri): col0, row0, col1, row1 (inclusive) */
    __global const double* edge,            /* (15, ntri): A0 A1 A2, B0 B1 B2, C0 C1 C2, thr0 thr1 thr2, z_a z_b z_c */
    __global long* keys)                    /* (plane,) packed keys, EMPTY_KEY where none */
{
    const uint i = get_global_id(0);
    if (i >= ntiles) return;
    const int t = exclusive ? (int)first : (int)tile_tri[i];    /* else: the first triangle with tile_end > i */
    const uint k = i - ((uint)t > first ? tile_end[t - first - 1] : 0u);
    const int col0 = box[t], row0 = box[ntri + t], col1 = box[2 * ntri + t], row1 = box[3 * ntri + t];
    const uint ntx = (uint)((col1 - col0) / TILE) + 1u;
    const int x0 = col0 + (int)(k % ntx) * TILE, y0 = row0 + (int)(k / ntx) * TILE;
    const int bw = min(TILE, col1 - x0 + 1), bh = min(TILE, row1 - y0 + 1);
    double a[3], b[3], c[3], thr[3];
    for (uint j = 0; j < 3; j++) {
        a[j] = edge[j * ntri + t];
        b[j] = edge[(3 + j) * ntri + t];
        c[j] = edge[(6 + j) * ntri + t];
        thr[j] = edge[(9 + j) * ntri + t];
    }
    const double za = edge[12 * ntri + t], zb = edge[13 * ntri + t], zc = edge[14 * ntri + t];
    for (int h = 0; h < bw; h += LANES) {   /* the tile's columns, LANES at a time */
        const dvec xc = convert_dvec((ivec)(x0 + h) + LANE_IOTA) + 0.5;
        const lvec in_box = convert_lvec(LANE_IOTA < bw - h);
        const dvec ax0 = a[0] * xc, ax1 = a[1] * xc, ax2 = a[2] * xc, zx = za * xc;
        for (int r = 0; r < bh; r++) {
            const double yc = (double)(y0 + r) + 0.5;
            double byc0 = b[0] * yc, byc1 = b[1] * yc, byc2 = b[2] * yc, zy = zb * yc;
            byc0 = byc0 + c[0];
            byc1 = byc1 + c[1];
            byc2 = byc2 + c[2];
            zy = zy + zc;
            dvec z = zx + zy;
            const lvec keep = in_box & ((ax0 + byc0) >= thr[0]) & ((ax1 + byc1) >= thr[1])
                              & ((ax2 + byc2) >= thr[2]) & (z >= z_lo) & (z <= z_hi);
            if (!any(keep)) continue;
            z = select(z, (dvec)(-1.0), z < -1.0);
            z = select(z, (dvec)(1.0), z > 1.0);
            z = z + 1.0;
            z = z * z_scale;
            const lvec key = (convert_lvec(z) << (long)tri_bits) | (long)t;
            __global long* row = keys + (size_t)(y0 + r) * width + x0 + h;
            for (int x = 0; x < LANES; x++) {
                const long kx = ((const long*)&key)[x];
                if (((const long*)&keep)[x] && kx < row[x]) {
                    if (exclusive)
                        row[x] = kx;
                    else
                        atom_min(row + x, kx);
                }
            }
        }
    }
}

__kernel void visibility(
    const uint plane, const uint width, const uint ntri, const uint w_is_depth, const uint tri_bits,
    __global long* keys,                    /* (plane,) cover's keys; left empty again */
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
#if HAS_TEXTURES
    __global const int* face_texture,       /* (F,) the face's texture set, -1 for none */
    __global int* tex_face,                 /* (plane,) the covered pixel's face where it is textured, else -1 */
    __global float* tex_bary,               /* (3, plane) its barycentrics (the rasterizer's float32) */
#endif
#if HAS_OCCLUSION
    __global float* occlusion,
#endif
    __global float* depth, __global float* normal, __global float* base,
    __global float* roughness, __global float* metallic, __global uchar* material,
    __global uchar* cover)
{
    const uint i = get_global_id(0);
    const uint p0 = i * LANES;              /* plane is a multiple of LANES (PIXEL_PAD) */
    if (p0 >= plane) return;
    const lvec key = VLOAD(i, keys);
    const lvec tri = key & (lvec)((1L << tri_bits) - 1);
    /* A key never names a triangle past ntri (cover writes this frame's); checked all the same, so
     * that a key left over by a bug is an empty pixel, never a read out of bounds. */
    const lvec hitl = (key != (lvec)(EMPTY_KEY)) & (tri < (lvec)(ntri));
    const ivec hit = convert_ivec(hitl);
    const ivec vis = convert_ivec(tri);
    const fvec fzero = (fvec)(0.0f);
    if (!any(hit)) {                        /* sky: zeros everywhere */
        VSTORE_NT(fvec, fzero, i, depth);
        for (uint d = 0; d < 3; d++) {
            VSTORE_NT(fvec, fzero, i, normal + d * plane);
            VSTORE_NT(fvec, fzero, i, base + d * plane);
#if HAS_EMISSIVE
            VSTORE_NT(fvec, fzero, i, emissive + d * plane);
#endif
        }
        VSTORE_NT(fvec, fzero, i, roughness);
        VSTORE_NT(fvec, fzero, i, metallic);
        VSTORE_NT(cvec, (cvec)(0), i, material);
        VSTORE_NT(cvec, (cvec)(0), i, cover);
#if HAS_TEXTURES
        VSTORE_NT(ivec, (ivec)(-1), i, tex_face);
#endif
#if HAS_OCCLUSION
        VSTORE_NT(fvec, fzero, i, occlusion);
#endif
        return;
    }
    VSTORE_NT(lvec, (lvec)(EMPTY_KEY), i, keys);    /* empty again for the next frame's cover */
    const ivec t = select((ivec)(0), vis, hit);   /* empty lanes compute on triangle 0, then get zeros */

    /* Where every lane is on one triangle (most work-items: a large triangle's pixels), its values
     * and its face's are read once and broadcast, not gathered lane by lane: the same values. */
    const int one = all(t == (ivec)(t.s0));
    const int t1 = t.s0;

    /* The winners' step (raster/resolve.py), in double. */
    const ivec pix = (ivec)((int)p0) + LANE_IOTA;
    const ivec row = pix / (int)width;
    const dvec X = convert_dvec(pix - row * (int)width) + 0.5;
    const dvec Y = convert_dvec(row) + 0.5;
    dvec by0 = UNIFORM_READ(one, dvec, setup + 3 * ntri, t, t1) * Y;
    dvec by1 = UNIFORM_READ(one, dvec, setup + 4 * ntri, t, t1) * Y;
    dvec by2 = UNIFORM_READ(one, dvec, setup + 5 * ntri, t, t1) * Y;
    by0 = by0 + UNIFORM_READ(one, dvec, setup + 6 * ntri, t, t1);
    by1 = by1 + UNIFORM_READ(one, dvec, setup + 7 * ntri, t, t1);
    by2 = by2 + UNIFORM_READ(one, dvec, setup + 8 * ntri, t, t1);
    dvec e0 = UNIFORM_READ(one, dvec, setup, t, t1) * X, e1 = UNIFORM_READ(one, dvec, setup + ntri, t, t1) * X;
    dvec e2 = UNIFORM_READ(one, dvec, setup + 2 * ntri, t, t1) * X;
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
    dvec z = UNIFORM_READ(one, dvec, setup + 9 * ntri, t, t1) / s;
    e0 = e0 / s;
    e1 = e1 / s;
    e2 = e2 / s;
    const ivec f = UNIFORM_READ(one, ivec, tri_face, t, t1);
    const int f1 = tri_face[t1];
    if (!w_is_depth || any(bad & hitl)) {
        dvec zi = e0 * GD(vdepth, GI(corners, f));
        zi = zi + e1 * GD(vdepth, GI(corners + nface, f));
        zi = zi + e2 * GD(vdepth, GI(corners + 2 * nface, f));
        z = w_is_depth ? select(z, zi, bad) : zi;
    }
    const fvec b0 = convert_fvec(e0), b1 = convert_fvec(e1), b2 = convert_fvec(e2);
    const fvec zf = convert_fvec(z);

    /* build_gbuffer's step (render/gbuffer.py), in float. */
    fvec nx = UNIFORM_READ(one, fvec, corner_normal, f, f1) * b0;
    fvec ny = UNIFORM_READ(one, fvec, corner_normal + nface, f, f1) * b0;
    fvec nz = UNIFORM_READ(one, fvec, corner_normal + 2 * nface, f, f1) * b0;
    nx = nx + 0.0f;
    ny = ny + 0.0f;
    nz = nz + 0.0f;
    nx = nx + UNIFORM_READ(one, fvec, corner_normal + 3 * nface, f, f1) * b1;
    ny = ny + UNIFORM_READ(one, fvec, corner_normal + 4 * nface, f, f1) * b1;
    nz = nz + UNIFORM_READ(one, fvec, corner_normal + 5 * nface, f, f1) * b1;
    nx = nx + UNIFORM_READ(one, fvec, corner_normal + 6 * nface, f, f1) * b2;
    ny = ny + UNIFORM_READ(one, fvec, corner_normal + 7 * nface, f, f1) * b2;
    nz = nz + UNIFORM_READ(one, fvec, corner_normal + 8 * nface, f, f1) * b2;
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
    VSTORE_NT(fvec, select(fzero, zf, ok), i, depth);
    VSTORE_NT(fvec, select(fzero, nx, ok), i, normal);
    VSTORE_NT(fvec, select(fzero, ny, ok), i, normal + plane);
    VSTORE_NT(fvec, select(fzero, nz, ok), i, normal + 2 * plane);
    for (uint d = 0; d < 3; d++) {
        VSTORE_NT(fvec, select(fzero, UNIFORM_READ(one, fvec, face_base + d * nface, f, f1), ok), i, base + d * plane);
#if HAS_EMISSIVE
        VSTORE_NT(fvec, select(fzero, UNIFORM_READ(one, fvec, face_emissive + d * nface, f, f1), ok), i,
                  emissive + d * plane);
#endif
    }
    VSTORE_NT(fvec, select(fzero, UNIFORM_READ(one, fvec, face_roughness, f, f1), hit), i, roughness);
    VSTORE_NT(fvec, select(fzero, UNIFORM_READ(one, fvec, face_metallic, f, f1), hit), i, metallic);
    const ivec mat = convert_ivec(UNIFORM_READ(one, cvec, face_material, f, f1));
    VSTORE_NT(cvec, convert_cvec(select((ivec)(0), mat, hit)), i, material);
    VSTORE_NT(cvec, convert_cvec(select(select((ivec)(0), (ivec)(2), hit), (ivec)(1), ok)), i, cover);
#if HAS_OCCLUSION
    VSTORE_NT(fvec, select(fzero, (fvec)(1.0f), hit), i, occlusion);   /* textured pixels: kernel `texture` */
#endif
#if HAS_TEXTURES
    VSTORE_NT(ivec, select((ivec)(-1), f, hit & (UNIFORM_READ(one, ivec, face_texture, f, f1) >= 0)), i, tex_face);
    VSTORE_NT(fvec, b0, i, tex_bary);
    VSTORE_NT(fvec, b1, i, tex_bary + plane);
    VSTORE_NT(fvec, b2, i, tex_bary + 2 * plane);
#endif
}
#if HAS_TEXTURES
/* ---------------------------------------------------------------- textures
 * texture — per textured pixel (tex_face >= 0), gbuffer.py:_texture_pixels and
 * _apply_texture_set with textures.py's sampling, in their order of operations:
 *   uv = (b0 uv0 + b1 uv1) + b2 uv2 and the tangent likewise, in double;
 *   the screen derivatives of uv (gbuffer.uv_derivatives): with A = [c0 c1 c2] the clip
 *         (x, y, w) of the face's corners, b = A^-1 (s, 1) normalised to sum 1 at the pixel
 *         centre and one pixel right and down; 0 where det A = 0 or a difference is not finite;
 *   per texture: λ = log2 max(|∂uv/∂x|, |∂uv/∂y|) in level-0 texels, clamped to the pyramid
 *         (NaN and -inf give 0, +inf the last level); trilinear: (0 + (1 - f) bil(l0)) + f bil(l1),
 *         l0 = floor λ, f = λ - l0 in float; bilinear with repeat wrapping, texel centres at
 *         (i + 0.5) / size, row 0 at V = 1;
 *   value = factor x texture (glTF); metallic-roughness: G roughness, B metallic; occlusion
 *         1 + strength (R - 1); the normal map m = 2 t - 1, m.xy *= scale, in the frame
 *         T = t - n (t.n) normalised (kept where |T|^2 <= MIN_TANGENT_LEN2), B = ±(n x T),
 *         mapped = (m.x T + m.y B) + m.z n, normalised (kept where its length is 0).
 *   A pixel whose depth, normal or base colour is then not finite is replaced as in `visibility`
 *   (it keeps roughness, metallic and occlusion); so is one whose UV is not (build_geometry
 *   refuses such texture coordinates; the host has no rule for them). Sums of three products that NumPy forms with
 *   einsum are added (p0 + p2) + p1, as its SIMD loop does; the others in order.
 * Not bit for bit: A^-1 (LAPACK's LU on the host, the adjugate here) and log2 round otherwise
 * in the last bits of the level λ (clshade/device/visibility.py: TEXTURE_TOLERANCE).
 *
 * Speed: as `visibility`, a work-item does LANES adjacent pixels, one per lane (a pixel at a
 * time, its double arithmetic and branches run scalar, several times slower: the textured row
 * of benchmarks/results/frame_scale.md); each lane
 * gathers its own face, texture set, level and texels — except where all its lanes share the face
 * (most work-items: a large triangle's pixels), the texture or the mip level, whose values are then
 * read once and broadcast (UNIFORM_READ: the same values) — and a texture slot is sampled
 * where any lane uses it (the others' results are discarded by select). A work-item without a textured
 * pixel returns at once; the lanes that are not textured compute on the first textured lane's
 * face and keep what `visibility` wrote.
 */
#define MIN_TANGENT_LEN2 1e-20              /* textures.py's */
#define SET_FLOATS 10                       /* base factor 3, roughness, metallic, emissive 3, normal scale, occlusion strength */
#define SET_SLOTS 5                         /* base colour, metallic-roughness, normal, emissive, occlusion */
/* np.mod of an integral double by the remainder of its int: exact below 2^31 in magnitude, and
 * far cheaper than fmod (which PoCL computes in software, and which a repeated UV, uv_scale > 1,
 * needs at most texels); fmod beyond it and for a NaN. */
#define WRAP_INT 2147483648.0

/* np.mod(a, n) of an integral double, lane by lane: the sign of n. */
inline ivec wrap(dvec a, ivec n) {
    const ivec inside = convert_ivec((a >= 0.0) & (a < convert_dvec(n)));
    const ivec small = convert_ivec(fabs(a) < WRAP_INT);
    ivec r = convert_ivec(select((dvec)(0.0), a, convert_lvec(small)));
    if (all(inside)) return r;
    if (all(small) && all((n & (n - 1)) == 0))   /* sizes of powers of two: r & (n - 1) is np.mod (two's
                                                    complement), without the integer division */
        return r & (n - 1);
    ivec m = r % n;
    m = select(m, m + n, m < 0);
    r = select(m, r, inside);
    if (!all(small)) {                      /* the rare case: the scalar fmod of those lanes */
        for (int k = 0; k < LANES; k++) {
            if (((const int*)&small)[k]) continue;
            const double ak = ((const double*)&a)[k], nk = (double)((const int*)&n)[k];
            double q = fmod(ak, nk);
            if (q < 0.0) q = q + nk;
            ((int*)&r)[k] = isnan(q) ? 0 : (int)q;  /* a NaN or infinite coordinate (build_geometry refuses
                                                        them) reads texel 0, never outside the level */
        }
    }
    return r;
}

/* An RGB value per lane. */
typedef struct { fvec x, y, z; } fvec3;

/* textures.py:_bilinear on one level per lane (w x h texels of 3 floats at `offset` of `texels`). */
inline fvec3 bilinear(__global const float* texels, ivec offset, ivec w, ivec h, dvec u, dvec v) {
    const dvec x = u * convert_dvec(w) - 0.5;
    dvec y = 1.0 - v;
    y = y * convert_dvec(h) - 0.5;
    const dvec x0 = floor(x), y0 = floor(y);
    const fvec fx = convert_fvec(x - x0), fy = convert_fvec(y - y0);
    const ivec i0 = wrap(y0, h), j0 = wrap(x0, w);
    const ivec i1 = select((ivec)(0), i0 + 1, i0 + 1 < h), j1 = select((ivec)(0), j0 + 1, j0 + 1 < w);
    const ivec r0 = i0 * w, r1 = i1 * w;     /* fewer than 2^31 texel floats (visibility.supports) */
    const ivec ia = offset + 3 * (r0 + j0), ib = offset + 3 * (r0 + j1);
    const ivec ic = offset + 3 * (r1 + j0), id = offset + 3 * (r1 + j1);
    const fvec gx = 1.0f - fx, gy = 1.0f - fy;
    fvec3 out;
#define BILINEAR_CHANNEL(C, k) {                                                   \
        const fvec top = GF(texels + (k), ia) * gx + GF(texels + (k), ib) * fx;    \
        const fvec bottom = GF(texels + (k), ic) * gx + GF(texels + (k), id) * fx; \
        out.C = top * gy + bottom * fy; }
    BILINEAR_CHANNEL(x, 0)
    BILINEAR_CHANNEL(y, 1)
    BILINEAR_CHANNEL(z, 2)
#undef BILINEAR_CHANNEL
    return out;
}

/* Texture.lod then Texture.sample per lane, of each lane's texture `index` (its row of `info`: first
 * level, levels, width, height; `level` rows: offset, w, h). */
inline fvec3 sample(__global const int* info, __global const int* level, __global const float* texels, ivec index,
                    dvec u, dvec v, dvec dx0, dvec dx1, dvec dy0, dvec dy1) {
    /* One texture in every lane (a work-item on one face): its row read once, not gathered. */
    const int one = all(index == (ivec)(index.s0));
    const ivec row = 4 * index;
    const int row1 = 4 * index.s0;
    const ivec first = UNIFORM_READ(one, ivec, info, row, row1);
    const ivec levels = UNIFORM_READ(one, ivec, info + 1, row, row1);
    const dvec w = convert_dvec(UNIFORM_READ(one, ivec, info + 2, row, row1));
    const dvec h = convert_dvec(UNIFORM_READ(one, ivec, info + 3, row, row1));
    const dvec ax = dx0 * w, ay = dx1 * h, bx = dy0 * w, by = dy1 * h;
    const dvec rx = sqrt(ax * ax + ay * ay), ry = sqrt(bx * bx + by * by);
    const dvec rho = select(fmax(rx, ry), (dvec)(NAN), isnan(rx) | isnan(ry));
    const dvec top = convert_dvec(levels - 1);
    dvec lam = log2(rho);
    lam = select(lam, select((dvec)(0.0), top, lam > 0.0), isinf(lam));
    lam = select(lam, (dvec)(0.0), isnan(lam));
    lam = fmin(fmax(lam, 0.0), top);
    const dvec fl = floor(lam);
    const ivec l0 = convert_ivec(fl);
    const fvec frac = convert_fvec(lam - fl);
    const ivec l1 = min(l0 + 1, levels - 1);
    const ivec a = 3 * (first + l0);
    /* The bilinear footprint on level row `r` of each lane; one row in every lane is read once. */
#define LEVEL_READ(r, k) UNIFORM_READ(all((r) == (ivec)((r).s0)), ivec, level + (k), (r), (r).s0)
#define LEVEL_BILINEAR(r) bilinear(texels, LEVEL_READ(r, 0), LEVEL_READ(r, 1), LEVEL_READ(r, 2), u, v)
    const fvec keep = 1.0f - frac;
    fvec3 out = LEVEL_BILINEAR(a);
    out.x = 0.0f + keep * out.x;
    out.y = 0.0f + keep * out.y;
    out.z = 0.0f + keep * out.z;
    const ivec two = l1 != l0;
    if (any(two)) {
        const ivec b = 3 * (first + l1);
        const fvec3 more = LEVEL_BILINEAR(b);
        out.x = select(out.x, out.x + frac * more.x, two);
        out.y = select(out.y, out.y + frac * more.y, two);
        out.z = select(out.z, out.z + frac * more.z, two);
    }
#undef LEVEL_BILINEAR
#undef LEVEL_READ
    return out;
}

/* uv_derivatives' uv_at per lane: the UV at NDC point (sx, sy) of the face whose clip-space
 * inverse is `inv` (row-major 3 x 3). */
inline void uv_at(const dvec inv[9], dvec sx, dvec sy, const dvec u[3], const dvec v[3], dvec* ou, dvec* ov) {
    dvec b[3];
    for (int j = 0; j < 3; j++) {
        const dvec p0 = inv[3 * j] * sx, p1 = inv[3 * j + 1] * sy, p2 = inv[3 * j + 2];
        b[j] = (p0 + p2) + p1;
    }
    const dvec total = (b[0] + b[1]) + b[2];
    const lvec some = fabs(total) > 0.0;
    for (int j = 0; j < 3; j++)
        b[j] = select((dvec)(1.0 / 3.0), b[j] / total, some);
    *ou = (b[0] * u[0] + b[1] * u[1]) + b[2] * u[2];
    *ov = (b[0] * v[0] + b[1] * v[1]) + b[2] * v[2];
}

__kernel void texture(
    const uint npix, const uint plane, const uint width, const uint height, const uint nface,
    __global const int* tex_face, __global const float* tex_bary,
    __global const double* mvp,             /* (3, 4): rows x, y, w of projection @ view */
    __global const int* corners,            /* (3, F) */
    __global const double* vertex,          /* (V, 3) */
    __global const float* vertex_uv,        /* (V, 2) */
    __global const float* vertex_tangent,   /* (V, 4): tangent, handedness */
    __global const int* face_texture,
    __global const float* set_value,        /* (S, SET_FLOATS) */
    __global const double* set_uv_scale,    /* (S,) */
    __global const int* set_slot,           /* (S, SET_SLOTS): texture, -1 for none */
    __global const int* texture_info,       /* (T, 4) */
    __global const int* level_info,         /* (levels, 3) */
    __global const float* texels,
#if HAS_EMISSIVE
    __global float* emissive,
#endif
#if HAS_OCCLUSION
    __global float* occlusion,
#endif
    __global float* depth, __global float* normal, __global float* base,
    __global float* roughness, __global float* metallic, __global uchar* cover)
{
    const uint i = get_global_id(0);
    const uint p0 = i * LANES;              /* plane is a multiple of LANES (PIXEL_PAD) */
    if (p0 >= plane) return;
    const ivec pix = (ivec)((int)p0) + LANE_IOTA;
    const ivec face = VLOAD(i, tex_face);
    const ivec tex = (face >= 0) & (pix < (int)npix);
    if (!any(tex)) return;
    /* Lanes that are not textured compute on a textured lane's face, then keep their values. */
    int any_face = 0;
    for (int k = 0; k < LANES; k++)
        if (((const int*)&tex)[k]) { any_face = ((const int*)&face)[k]; break; }
    const ivec f = select((ivec)(any_face), face, tex);
    /* Where every lane is on one face (most work-items: the pixels of a large triangle), the face's
     * values are read once and broadcast, not gathered lane by lane: the same values, bit for bit. */
    const int one = all(f == (ivec)(any_face));
    const ivec set = UNIFORM_READ(one, ivec, face_texture, f, any_face);
    const int set1 = face_texture[any_face];       /* any_face is a textured lane's: a set */
    const ivec sv = SET_FLOATS * set, ss = SET_SLOTS * set;
    const int sv1 = SET_FLOATS * set1, ss1 = SET_SLOTS * set1;
    const dvec uv_scale = UNIFORM_READ(one, dvec, set_uv_scale, set, set1);
    const dvec bc0 = convert_dvec(VLOAD(i, tex_bary)), bc1 = convert_dvec(VLOAD(i, tex_bary + plane));
    const dvec bc2 = convert_dvec(VLOAD(i, tex_bary + 2 * plane));
    const int c1[3] = {corners[any_face], corners[nface + any_face], corners[2 * nface + any_face]};
    ivec c[3];
    dvec uc[3], vc[3];
    for (int k = 0; k < 3; k++) {
        c[k] = UNIFORM_READ(one, ivec, corners + k * nface, f, any_face);
        uc[k] = convert_dvec(UNIFORM_READ(one, fvec, vertex_uv, 2 * c[k], 2 * c1[k]));
        vc[k] = convert_dvec(UNIFORM_READ(one, fvec, vertex_uv + 1, 2 * c[k], 2 * c1[k]));
    }
    dvec u = (bc0 * uc[0] + bc1 * uc[1]) + bc2 * uc[2];
    dvec v = (bc0 * vc[0] + bc1 * vc[1]) + bc2 * vc[2];

    /* The UV screen derivatives (uv_derivatives). */
    dvec A[9];
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 3; k++) {
            __global const double* m = mvp + 4 * r;
            const ivec q = 3 * c[k];
            const int q1 = 3 * c1[k];
            dvec clip = m[0] * UNIFORM_READ(one, dvec, vertex, q, q1);
            clip = clip + m[1] * UNIFORM_READ(one, dvec, vertex + 1, q, q1);
            clip = clip + m[2] * UNIFORM_READ(one, dvec, vertex + 2, q, q1);
            A[3 * r + k] = clip + m[3];
        }
    const dvec c00 = A[4] * A[8] - A[5] * A[7];
    const dvec c01 = A[5] * A[6] - A[3] * A[8];
    const dvec c02 = A[3] * A[7] - A[4] * A[6];
    const dvec det = (A[0] * c00 + A[1] * c01) + A[2] * c02;
    dvec dxu = (dvec)(0.0), dxv = (dvec)(0.0), dyu = (dvec)(0.0), dyv = (dvec)(0.0);
    const lvec invertible = det != 0.0;
    if (any(invertible)) {
        const dvec r = 1.0 / det;
        const dvec inv[9] = {
            c00 * r, (A[2] * A[7] - A[1] * A[8]) * r, (A[1] * A[5] - A[2] * A[4]) * r,
            c01 * r, (A[0] * A[8] - A[2] * A[6]) * r, (A[2] * A[3] - A[0] * A[5]) * r,
            c02 * r, (A[1] * A[6] - A[0] * A[7]) * r, (A[0] * A[4] - A[1] * A[3]) * r};
        const ivec py = pix / (int)width, px = pix - py * (int)width;
        dvec x = (convert_dvec(px) + 0.5) / (double)width;
        x = x * 2.0 - 1.0;
        dvec y = (convert_dvec(py) + 0.5) / (double)height;
        y = 1.0 - y * 2.0;
        dvec cu, cv, ru, rv, du, dv;
        uv_at(inv, x, y, uc, vc, &cu, &cv);
        uv_at(inv, x + 2.0 / (double)width, y, uc, vc, &ru, &rv);
        uv_at(inv, x, y - 2.0 / (double)height, uc, vc, &du, &dv);
        dxu = ru - cu; dxv = rv - cv;
        dyu = du - cu; dyv = dv - cv;
        const lvec finite = invertible & isfinite(dxu) & isfinite(dxv) & isfinite(dyu) & isfinite(dyv);
        dxu = select((dvec)(0.0), dxu, finite); dxv = select((dvec)(0.0), dxv, finite);
        dyu = select((dvec)(0.0), dyu, finite); dyv = select((dvec)(0.0), dyv, finite);
    }
    u = u * uv_scale; v = v * uv_scale;
    dxu = dxu * uv_scale; dxv = dxv * uv_scale;
    dyu = dyu * uv_scale; dyv = dyv * uv_scale;
    /* Slot k of each lane's set; the lanes that sample it (`use`); its texture there, read at the
     * lanes' UV (UV 0 elsewhere: a lane's coordinates are sampled only where its set has the map). */
#define SLOT(k) UNIFORM_READ(one, ivec, set_slot + (k), ss, ss1)
#define USES(s) (tex & ((s) >= 0))
#define SAMPLE(s, use) sample(texture_info, level_info, texels, max((s), 0), \
                              select((dvec)(0.0), u, convert_lvec(use)), select((dvec)(0.0), v, convert_lvec(use)), \
                              dxu, dxv, dyu, dyv)

    fvec bx = UNIFORM_READ(one, fvec, set_value, sv, sv1), by = UNIFORM_READ(one, fvec, set_value + 1, sv, sv1);
    fvec bz = UNIFORM_READ(one, fvec, set_value + 2, sv, sv1);
    fvec rough = UNIFORM_READ(one, fvec, set_value + 3, sv, sv1);
    fvec metal = UNIFORM_READ(one, fvec, set_value + 4, sv, sv1);
    const ivec slot0 = SLOT(0), use0 = USES(slot0), slot1 = SLOT(1), use1 = USES(slot1);
    if (any(use0)) {
        const fvec3 t = SAMPLE(slot0, use0);
        bx = select(bx, bx * t.x, use0); by = select(by, by * t.y, use0); bz = select(bz, bz * t.z, use0);
    }
    if (any(use1)) {
        const fvec3 mr = SAMPLE(slot1, use1);
        rough = select(rough, rough * mr.y, use1);
        metal = select(metal, metal * mr.z, use1);
    }
    VSTORE(select(VLOAD(i, roughness), rough, tex), i, roughness);
    VSTORE(select(VLOAD(i, metallic), metal, tex), i, metallic);
#if HAS_OCCLUSION
    fvec occ = (fvec)(1.0f);
    const ivec slot4 = SLOT(4), use4 = USES(slot4);
    if (any(use4)) {
        const fvec ao = SAMPLE(slot4, use4).x - 1.0f;
        occ = select(occ, 1.0f + UNIFORM_READ(one, fvec, set_value + 9, sv, sv1) * ao, use4);
    }
    VSTORE(select(VLOAD(i, occlusion), occ, tex), i, occlusion);
#endif
    /* Lanes `visibility` replaced (cover 2) stay so. */
    const ivec live = tex & (convert_ivec(VLOAD(i, cover)) == 1);
    if (!any(live)) return;
    const dvec nx = convert_dvec(VLOAD(i, normal)), ny = convert_dvec(VLOAD(i, normal + plane));
    const dvec nz = convert_dvec(VLOAD(i, normal + 2 * plane));
    dvec mx = nx, my = ny, mz = nz;
    const ivec slot2 = SLOT(2), use2 = USES(slot2);
    if (any(use2 & live)) {
        const fvec3 t = SAMPLE(slot2, use2);
        const fvec scale = UNIFORM_READ(one, fvec, set_value + 8, sv, sv1);
        const fvec ux = (t.x * 2.0f - 1.0f) * scale, uy = (t.y * 2.0f - 1.0f) * scale, uz = t.z * 2.0f - 1.0f;
        dvec tg[4];
        for (int k = 0; k < 4; k++) {
            const dvec t0 = convert_dvec(UNIFORM_READ(one, fvec, vertex_tangent + k, 4 * c[0], 4 * c1[0]));
            const dvec t1 = convert_dvec(UNIFORM_READ(one, fvec, vertex_tangent + k, 4 * c[1], 4 * c1[1]));
            const dvec t2 = convert_dvec(UNIFORM_READ(one, fvec, vertex_tangent + k, 4 * c[2], 4 * c1[2]));
            tg[k] = (bc0 * t0 + bc1 * t1) + bc2 * t2;
        }
        const dvec tn = (tg[0] * nx + tg[2] * nz) + tg[1] * ny;
        dvec Tx = tg[0] - nx * tn, Ty = tg[1] - ny * tn, Tz = tg[2] - nz * tn;
        const dvec tlen2 = (Tx * Tx + Tz * Tz) + Ty * Ty;
        const lvec good = tlen2 > MIN_TANGENT_LEN2;
        const dvec tlen = sqrt(select((dvec)(1.0), tlen2, good));
        Tx = Tx / tlen; Ty = Ty / tlen; Tz = Tz / tlen;
        const dvec sign = select((dvec)(1.0), (dvec)(-1.0), tg[3] < 0.0);
        const dvec Bx = sign * (ny * Tz - nz * Ty), By = sign * (nz * Tx - nx * Tz), Bz = sign * (nx * Ty - ny * Tx);
        const dvec wx = convert_dvec(ux), wy = convert_dvec(uy), wz = convert_dvec(uz);
        dvec ox = wx * Tx + wy * Bx, oy = wx * Ty + wy * By, oz = wx * Tz + wy * Bz;
        ox = ox + wz * nx; oy = oy + wz * ny; oz = oz + wz * nz;
        const dvec length = sqrt((ox * ox + oy * oy) + oz * oz);
        const lvec mapped = convert_lvec(use2) & good & (length > 0.0);
        mx = select(mx, ox / length, mapped);
        my = select(my, oy / length, mapped);
        mz = select(mz, oz / length, mapped);
    }
    const fvec fx = convert_fvec(mx), fy = convert_fvec(my), fz = convert_fvec(mz);
    const ivec ok = isfinite(VLOAD(i, depth)) & isfinite(fx) & isfinite(fy) & isfinite(fz)
                    & isfinite(bx) & isfinite(by) & isfinite(bz) & convert_ivec(isfinite(u) & isfinite(v));
    const fvec zero = (fvec)(0.0f);
#define WRITE(plane_ptr, value) VSTORE(select(VLOAD(i, plane_ptr), select(zero, (value), ok), live), i, plane_ptr)
    WRITE(normal, fx); WRITE(normal + plane, fy); WRITE(normal + 2 * plane, fz);
    WRITE(base, bx); WRITE(base + plane, by); WRITE(base + 2 * plane, bz);
#if HAS_EMISSIVE
    fvec ex = UNIFORM_READ(one, fvec, set_value + 5, sv, sv1), ey = UNIFORM_READ(one, fvec, set_value + 6, sv, sv1);
    fvec ez = UNIFORM_READ(one, fvec, set_value + 7, sv, sv1);
    const ivec slot3 = SLOT(3), use3 = USES(slot3);
    if (any(use3 & live)) {
        const fvec3 e = SAMPLE(slot3, use3);
        ex = select(ex, ex * e.x, use3); ey = select(ey, ey * e.y, use3); ez = select(ez, ez * e.z, use3);
    }
    WRITE(emissive, ex); WRITE(emissive + plane, ey); WRITE(emissive + 2 * plane, ez);
#endif
#undef WRITE
#undef SLOT
#undef USES
#undef SAMPLE
    const ivec bad = live & ~ok;
    VSTORE(select(VLOAD(i, depth), (fvec)(0.0f), bad), i, depth);
    VSTORE(convert_cvec(select(convert_ivec(VLOAD(i, cover)), (ivec)(2), bad)), i, cover);
}
#endif
