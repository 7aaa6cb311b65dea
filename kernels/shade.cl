/* shade.cl — the deferred shading pass: one work-item per pixel.
 *
 * Reads the G-buffer channels the variant needs, builds the pixel's Surface,
 * adds every light (counts are compile-time constants, so the loops unroll and
 * PoCL vectorises across work-items) and the optional ambient term, and writes
 * linear RGB radiance with coverage in alpha.
 *
 * Variant defines (set by clshade/variants.py, see `clshade render --explain`):
 *   NUM_DIR, NUM_POINT, NUM_SPOT   light counts by kind
 *   HAS_ROUGHNESS, HAS_METALLIC    per-pixel channels present
 *   HAS_MATERIAL                   per-pixel material id + material table
 *   MAT_M0..MAT_M3                 the material constants when HAS_MATERIAL is 0
 *   HAS_AMBIENT                    constant ambient radiance
 *   HALF_GBUFFER                   normal and base colour stored as half floats
 *   HAS_SHADOWS, SHADOW_PCF        shadow-map lookup (shadow.h), PCF kernel width
 *   GENERAL                        the general kernel: every channel read, the
 *                                  light count, ambient and shadows runtime
 *                                  switches; the reference every specialised
 *                                  variant must match (tests/test_specialisation.py)
 *
 * Channel layout (struct of arrays, one entry per pixel, row 0 at the top):
 *   depth     float   view-space depth along the camera axis, ≤ 0 = empty
 *   normal    3×float world-space shading normal (or 3×half)
 *   base      3×float linear base colour (or 3×half)
 *   roughness float   perceptual roughness
 *   metallic  float
 *   material  uchar   index into the material table (MATERIAL_STRIDE float4)
 * Lights (__constant float4, directional first, then point, then spot):
 *   directional: (direction of travel, 0), (irradiance RGB, 0)
 *   point:       (position, 0), (intensity RGB [W/sr], 0)
 *   spot:        (position, cos outer), (intensity RGB, cos inner), (axis, shadow slot)
 *   The shadow slot (index of the light's shadow map, −1 = none) sits in the
 *   .w of the colour row of directional lights and of the axis row of spots.
 * General kernel lights (num_lights × 4 float4, any order):
 *   (position or direction of travel, kind), (colour, shadow slot),
 *   (axis, cos outer), (cos inner, 0, 0, 0); kind: LIGHT_* below.
 */

#define LIGHT_DIRECTIONAL 0
#define LIGHT_POINT       1
#define LIGHT_SPOT        2

#ifndef GENERAL
#define GENERAL 0
#endif
#ifndef HAS_SHADOWS
#define HAS_SHADOWS 0
#endif
#if GENERAL
/* The general kernel reads every channel; its switches are runtime arguments. */
#undef HAS_ROUGHNESS
#undef HAS_METALLIC
#undef HAS_MATERIAL
#define HAS_ROUGHNESS 1
#define HAS_METALLIC 1
#define HAS_MATERIAL 1
#endif

/* Smallest squared light distance: keeps I/r² finite when a point light sits
 * on a surface. Bias: none beyond 1e-4 scene units. */
#define MIN_LIGHT_DIST2 1.0e-8f

/* Largest radiance written: finite by contract even for 1e30 lights. */
#define MAX_RADIANCE 3.0e38f

#ifdef HALF_GBUFFER
#define LOAD3(i, p) vload_half3((i), (p))
#define GB3 half
#else
#define LOAD3(i, p) vload3((i), (p))
#define GB3 float
#endif

inline float3 safe_normal(float3 n, float3 fallback) {
    float len2 = dot(n, n);
    /* A zero-length (bad) normal shades as if it faced the viewer. */
    return len2 > 1.0e-20f ? n * rsqrt(len2) : fallback;
}

__kernel void shade(
    const uint npix, const uint width, const float inv_width2, const float inv_height2,
    const float4 cam_pos, const float4 cam_fwd, const float4 cam_right, const float4 cam_up,
    __global const float* depth,
    __global const GB3* normal,
    __global const GB3* base
#if HAS_ROUGHNESS
    , __global const float* roughness
#endif
#if HAS_METALLIC
    , __global const float* metallic
#endif
#if HAS_MATERIAL
    , __global const uchar* material, __constant float4* materials
#endif
#if GENERAL
    , const uint num_lights, __constant float4* lights
    , const uint has_ambient, const float4 ambient
    , const uint has_shadows, const int pcf_radius, const uint shadow_size
    , __global const float* shadow_maps, __constant float4* shadow_params
#else
#if NUM_DIR + NUM_POINT + NUM_SPOT > 0
    , __constant float4* lights
#endif
#if HAS_SHADOWS
    , const uint shadow_size, __global const float* shadow_maps, __constant float4* shadow_params
#endif
#if HAS_AMBIENT
    , const float4 ambient
#endif
#endif
    , const float4 background,
    __global float4* out)
{
    uint i = get_global_id(0);
    if (i >= npix) return;

    /* Camera ray through the pixel centre; cam_right/cam_up are pre-scaled by
     * tan(fov/2)·aspect and tan(fov/2), so P = cam_pos + depth · ray. */
    uint px = i % width, py = i / width;
    float sx = ((float)px + 0.5f) * inv_width2 - 1.0f;
    float sy = 1.0f - ((float)py + 0.5f) * inv_height2;
    float3 ray = cam_fwd.xyz + sx * cam_right.xyz + sy * cam_up.xyz;
    float3 v = -normalize(ray);
    float z = depth[i];

    float3 n = safe_normal(LOAD3(i, normal), v);
    float3 b = fmax(LOAD3(i, base), 0.0f);
#if HAS_ROUGHNESS
    float r = saturate(roughness[i]);
#else
    float r = 1.0f;
#endif
#if HAS_METALLIC
    float m = saturate(metallic[i]);
#else
    float m = 0.0f;
#endif
#if HAS_MATERIAL
    uint mi = (uint)material[i] * MATERIAL_STRIDE;
    Surface s = make_surface(b, r, m, materials[mi], materials[mi + 1],
                             materials[mi + 2], materials[mi + 3]);
#else
    Surface s = make_surface(b, r, m, MAT_M0, MAT_M1, MAT_M2, MAT_M3);
#endif

    float3 L = (float3)(0.0f);
#if GENERAL || NUM_POINT + NUM_SPOT > 0 || HAS_SHADOWS
    float3 P = cam_pos.xyz + z * ray;
#endif
#if GENERAL
    for (uint k = 0; k < num_lights; ++k) {
        float4 a = lights[4 * k], c = lights[4 * k + 1];
        int kind = (int)a.w;
        float3 l, E;
        if (kind == LIGHT_DIRECTIONAL) {
            l = -a.xyz;
            E = c.xyz;
        } else {
            float3 d = a.xyz - P;
            float d2 = fmax(dot(d, d), MIN_LIGHT_DIST2);
            l = d * rsqrt(d2);
            if (kind == LIGHT_SPOT) {
                float4 e = lights[4 * k + 2];
                float cos_inner = lights[4 * k + 3].x;
                float t = saturate((dot(-l, e.xyz) - e.w) / fmax(cos_inner - e.w, 1.0e-6f));
                E = c.xyz * (t * t / d2);
            } else {
                E = c.xyz / d2;
            }
        }
        if (has_shadows && c.w >= 0.0f)
            E *= shadow_factor(shadow_maps, shadow_params, (int)c.w, shadow_size, P, n, pcf_radius);
        L += shade_light(n, v, l, E, s);
    }
    if (has_ambient)
        L += ambient_term(ambient.xyz, s);
#else
#if HAS_SHADOWS
#define SHADOW(E, slot) \
    if ((slot) >= 0.0f) (E) *= shadow_factor(shadow_maps, shadow_params, (int)(slot), shadow_size, P, n, SHADOW_PCF / 2)
#else
#define SHADOW(E, slot)
#endif
#if NUM_DIR > 0
    for (int k = 0; k < NUM_DIR; ++k) {
        float3 l = -lights[2 * k].xyz;
        float4 c = lights[2 * k + 1];
        float3 E = c.xyz;
        SHADOW(E, c.w);
        L += shade_light(n, v, l, E, s);
    }
#endif
#if NUM_POINT > 0
    for (int k = 0; k < NUM_POINT; ++k) {
        int o = 2 * NUM_DIR + 2 * k;
        float3 d = lights[o].xyz - P;
        float d2 = fmax(dot(d, d), MIN_LIGHT_DIST2);
        float3 l = d * rsqrt(d2);
        L += shade_light(n, v, l, lights[o + 1].xyz / d2, s);
    }
#endif
#if NUM_SPOT > 0
    for (int k = 0; k < NUM_SPOT; ++k) {
        int o = 2 * NUM_DIR + 2 * NUM_POINT + 3 * k;
        float4 p = lights[o], e = lights[o + 1], a = lights[o + 2];
        float3 d = p.xyz - P;
        float d2 = fmax(dot(d, d), MIN_LIGHT_DIST2);
        float3 l = d * rsqrt(d2);
        /* Smooth cone: 0 outside the outer cone, 1 inside the inner, t² between. */
        float t = saturate((dot(-l, a.xyz) - p.w) / fmax(e.w - p.w, 1.0e-6f));
        float3 E = e.xyz * (t * t / d2);
        SHADOW(E, a.w);
        L += shade_light(n, v, l, E, s);
    }
#endif
#if HAS_AMBIENT
    L += ambient_term(ambient.xyz, s);
#endif
#endif
    L = fmin(L, MAX_RADIANCE);
    out[i] = z > 0.0f ? (float4)(L, 1.0f) : background;
}
