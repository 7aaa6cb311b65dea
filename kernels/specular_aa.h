/* specular_aa.h — geometric specular anti-aliasing: the specular lobe widened
 * by the screen-space variance of the shading normal, so that a highlight
 * narrower than a pixel is spread over the pixel instead of aliasing.
 *
 * Source: Tokuyoshi & Kaplanyan 2019, "Improved Geometric Specular
 * Antialiasing" (I3D), in the form Filament uses (shading_normal filtering,
 * `normalFiltering`): with du, dv the differences of the unit normal to its
 * horizontal and vertical neighbour pixels,
 *     variance   = σ² · (|du|² + |dv|²)
 *     κ_kernel   = min(2 · variance, κ_max)
 *     α'²        = saturate(α² + κ_kernel)
 * Microfacet lobes read α' = sqrt(α'²). Phong and Blinn–Phong read an exponent
 * n; their roughness is α_n² = 2 / (n + 2) (the inverse of the scene format's
 * n = 2/α² − 2), widened alike: n' = 2 / (α_n² + κ_kernel) − 2.
 *
 * Parameters (Filament's defaults, scenes/README.md):
 *   SPECULAR_AA_VARIANCE   σ², screen-space variance of the pixel filter: 0.15
 *   SPECULAR_AA_THRESHOLD  κ_max, largest added α²: 0.2
 *
 * Neighbours: the pixel to the right (left at the image's right edge or when
 * the right one is empty), and the pixel below (above likewise); a pixel with no
 * covered neighbour on an axis gets no variance from it. Deferred shading has no
 * derivative instructions, so the G-buffer's own neighbours stand in for
 * dFdx/dFdy. Only compiled into variants of scenes with
 * `[render] specular_aa = true` (clshade/device/variants.py).
 */
#ifndef CLSHADE_SPECULAR_AA_H
#define CLSHADE_SPECULAR_AA_H

#ifndef SPECULAR_AA_VARIANCE
#define SPECULAR_AA_VARIANCE 0.15f
#endif
#ifndef SPECULAR_AA_THRESHOLD
#define SPECULAR_AA_THRESHOLD 0.2f
#endif

/* One G-buffer normal component at pixel k (float or half storage). */
#ifdef HALF_GBUFFER
#define GB3_AT(p, k) vload_half((k), (p))
#else
#define GB3_AT(p, k) ((p)[k])
#endif

/* Pixel k's neighbour on one axis: k + step if it exists and is covered, else
 * k − step if that one is, else k itself (a zero difference). */
INLINE uint aa_neighbour(__global const float* depth, uint k, uint step, int has_next, int has_prev) {
    if (has_next && depth[k + step] > 0.0f) return k + step;
    if (has_prev && depth[k - step] > 0.0f) return k - step;
    return k;
}

/* Summed squared normal differences |du|² + |dv|² of the SIMD pixels from
 * `first` on (one lane per pixel, scalar neighbour lookups). */
INLINE real normal_difference2(uint first, uint npix, uint width, __global const float* depth,
                               __global const GB3* normal, uint plane, vec3 n) {
    uint height = npix / width;
    real_lanes qx[3], qy[3];
    for (int j = 0; j < SIMD; ++j) {
        uint k = min(first + (uint)j, npix - 1u);
        uint y = k / width, x = k - y * width;
        uint kx = aa_neighbour(depth, k, 1u, x + 1u < width, x > 0u);
        uint ky = aa_neighbour(depth, k, width, y + 1u < height, y > 0u);
        for (int c = 0; c < 3; ++c) {
            qx[c].s[j] = GB3_AT(normal + c * plane, kx);
            qy[c].s[j] = GB3_AT(normal + c * plane, ky);
        }
    }
    vec3 du = v3sub(unit_or(v3(qx[0].v, qx[1].v, qx[2].v), n), n);
    vec3 dv = v3sub(unit_or(v3(qy[0].v, qy[1].v, qy[2].v), n), n);
    return v3dot(du, du) + v3dot(dv, dv);
}

/* The Surface with its specular roughness (α and the Phong exponent) widened. */
INLINE Surface specular_aa(Surface s, real difference2) {
    real widen = fmin(2.0f * SPECULAR_AA_VARIANCE * difference2, SPECULAR_AA_THRESHOLD);
    real a2 = saturate(s.alpha * s.alpha + widen);
    s.alpha = fmax(sqrt(a2), MIN_ALPHA);
    real an2 = 2.0f / (s.shininess + 2.0f);
    s.shininess = fmax(2.0f / (an2 + widen) - 2.0f, 0.0f);
    return s;
}

#endif
