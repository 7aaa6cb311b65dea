/* shadow.h — shadow-map lookup with percentage-closer filtering (PCF).
 *
 * Assembled only into variants with shadows (HAS_SHADOWS = 1) and into the
 * general kernel; a scene without shadows compiles no line of this file.
 * Maps and parameters come from clshade/shadows.py: per map SHADOW_ROWS float4
 *   rows 0–3  proj · view of the light (clip = M · (P, 1))
 *   row  4    light-view depth = dot(row.xyz, P) + row.w
 *   row  5    (texel, perspective, -, -): world size of one texel, at unit
 *             depth if perspective (spot) else everywhere (directional)
 * A map texel holds the light-view depth of the nearest surface; row 0 is the
 * top of the map (the rasterizer's convention).
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

/* Fraction of PCF taps (a (2·radius + 1)² box of map texels) that see the
 * light from P. Receivers outside the map are lit. n unit (the shading normal;
 * the G-buffer keeps no geometric normal). */
inline float shadow_factor(__global const float* maps, __constant float4* params, int slot, uint size,
                           float3 P, float3 n, int radius) {
    __constant float4* m = params + SHADOW_ROWS * slot;
    float texel = m[5].y > 0.5f ? m[5].x * (dot(m[4].xyz, P) + m[4].w) : m[5].x;
    float4 p4 = (float4)(P + n * (texel * ((float)radius + SHADOW_NORMAL_OFFSET_TEXELS)), 1.0f);
    float cw = dot(m[3], p4);
    if (cw <= 0.0f) return 1.0f;
    float fx = (dot(m[0], p4) / cw * 0.5f + 0.5f) * (float)size;
    float fy = (0.5f - dot(m[1], p4) / cw * 0.5f) * (float)size;
    float ref = dot(m[4], p4) - texel * SHADOW_BIAS_TEXELS;
    int ix = (int)floor(fx), iy = (int)floor(fy);
    float lit = 0.0f;
    __global const float* map = maps + (size_t)slot * size * size;
    for (int dy = -radius; dy <= radius; ++dy) {
        for (int dx = -radius; dx <= radius; ++dx) {
            int x = ix + dx, y = iy + dy;
            bool inside = x >= 0 && y >= 0 && x < (int)size && y < (int)size;
            lit += (!inside || ref <= map[inside ? y * (int)size + x : 0]) ? 1.0f : 0.0f;
        }
    }
    int w = 2 * radius + 1;
    return lit / (float)(w * w);
}

#endif
