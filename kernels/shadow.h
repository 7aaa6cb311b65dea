/* shadow.h — shadow-map lookup with percentage-closer filtering (PCF).
 *
 * Assembled only into variants with shadows (HAS_SHADOWS = 1) and into the
 * general kernel; a scene without shadows compiles no line of this file.
 * Maps and parameters come from clshade/render/shadows.py: per map SHADOW_ROWS float4
 *   rows 0–3  proj · view of the light (clip = M · (P, 1))
 *   row  4    light-view depth = dot(row.xyz, P) + row.w
 *   row  5    (texel, perspective, -, -): world size of one texel, at unit
 *             depth if perspective (spot) else everywhere (directional)
 * A map texel holds the light-view depth of the nearest surface; row 0 is the
 * top of the map (the rasterizer's convention).
 *
 * Written in lanes (simd.h): the projection is vector arithmetic, each PCF
 * tap one gather of SIMD map texels.
 */
#ifndef CLSHADE_SHADOW_H
#define CLSHADE_SHADOW_H

#define SHADOW_ROWS 6

/* Bias, normal offset plus a constant, in texels of the map at the receiver:
 * the lookup point is moved off the surface along its normal by
 * texel · (radius + SHADOW_NORMAL_OFFSET_TEXELS). A plane at angle θ to the
 * light then sits offset/cosθ nearer the light than its own map depth at the
 * looked-up texel, while texel quantisation (a stored depth up to √½ texel
 * away, PCF taps `radius` texels more) needs only (radius + √½) · tanθ texels:
 * SHADOW_NORMAL_OFFSET_TEXELS = 1 (> √½) keeps lit planes free of
 * self-shadowing ("acne") at every angle, grazing included, where a
 * slope-scaled depth bias must be capped. SHADOW_BIAS_TEXELS (a constant depth
 * bias) absorbs the interpolated shading normal differing from the faceted
 * geometry. Cost: shadows start up to ~(radius + 1.5) texels behind their
 * caster (peter-panning, 2.5 cm for a 10 m scene, 1024² map, PCF 3). */
#define SHADOW_NORMAL_OFFSET_TEXELS 1.0f
#define SHADOW_BIAS_TEXELS          0.5f

/* row · (q, 1): one row of a light matrix applied to lane points q. */
INLINE real shadow_row(float4 row, vec3 q) { return row.x * q.x + row.y * q.y + row.z * q.z + row.w; }

/* Fraction of PCF taps (a (2·radius + 1)² box of map texels) that see the
 * light from P, per lane. Receivers outside the map, or behind the light's
 * projection centre, are lit. n unit (the shading normal; the G-buffer keeps
 * no geometric normal). */
INLINE real shadow_factor(__global const float* maps, __constant float4* params, int slot, uint size,
                          vec3 P, vec3 n, int radius) {
    __constant float4* m = params + SHADOW_ROWS * slot;
    real texel = m[5].y > 0.5f ? m[5].x * shadow_row(m[4], P) : (real)(m[5].x);
    vec3 q = v3add(P, v3scale(n, texel * ((float)radius + SHADOW_NORMAL_OFFSET_TEXELS)));
    real cw = shadow_row(m[3], q);
    mask front = cw > 0.0f;
    real fx = (shadow_row(m[0], q) / cw * 0.5f + 0.5f) * (float)size;
    real fy = (0.5f - shadow_row(m[1], q) / cw * 0.5f) * (float)size;
    real ref = shadow_row(m[4], q) - texel * SHADOW_BIAS_TEXELS;
    /* Clamped to one PCF radius beyond the map, so that x ± radius and y·s + x
     * cannot overflow for a lane far outside (fx ≈ 1e30) and NaN (cw = 0, a
     * lane behind the light) lands on a bound. */
    float lo = -(float)(radius + 1), hi = (float)(size + radius);
    mask ix = convert_mask_sat(clamp(floor(fx), lo, hi)), iy = convert_mask_sat(clamp(floor(fy), lo, hi));
    int s = (int)size;
    __global const float* map = maps + (size_t)slot * size * size;
    real lit = (real)(0.0f);
    for (int dy = -radius; dy <= radius; ++dy) {
        for (int dx = -radius; dx <= radius; ++dx) {
            mask x = ix + dx, y = iy + dy;
            mask inside = (x >= 0) & (y >= 0) & (x < s) & (y < s);
            real d = gather(map, inside ? y * s + x : (mask)(0));
            lit += ((inside == 0) | (ref <= d)) ? (real)(1.0f) : (real)(0.0f);
        }
    }
    int w = 2 * radius + 1;
    return front ? lit / (float)(w * w) : (real)(1.0f);
}

#endif
