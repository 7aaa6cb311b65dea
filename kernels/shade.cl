/* shade.cl — the deferred shading pass: one work-item per SIMD adjacent
 * pixels, one pixel per lane (simd.h).
 *
 * Reads the G-buffer channels the variant needs, builds the pixels' Surface,
 * adds every light (counts are compile-time constants, so the loops unroll)
 * and the optional ambient term, and writes linear RGB radiance with coverage
 * in alpha. Buffers hold a multiple of SIMD pixels (the host pads them).
 *
 * Variant defines (set by clshade/device/variants.py, see `clshade render --explain`):
 *   NUM_DIR, NUM_POINT, NUM_SPOT   light counts by kind
 *   HAS_ROUGHNESS, HAS_METALLIC    per-pixel channels present
 *   ROUGHNESS_VALUE, METALLIC_VALUE  the channel's one value in the whole scene when it
 *                                  is not read per pixel (defaults: 1, 0 — a model that
 *                                  does not use the channel never sees it)
 *   HAS_MATERIAL                   per-pixel material id + material table
 *   MAT_M0..MAT_M3                 the material constants when HAS_MATERIAL is 0
 *   HAS_AMBIENT                    constant ambient radiance
 *   HAS_EMISSIVE                   per-pixel emitted radiance, added unlit
 *   HAS_TANGENT                    per-pixel mesh tangent, for a lobe that reads the tangent
 *                                  frame (GEOMETRY_TANGENTS, surface.h); without it the frame
 *                                  is built from the normal
 *   HAS_OCCLUSION                  per-pixel ambient occlusion multiplying the ambient term
 *                                  (both compile-time in the general kernel too)
 *   HALF_GBUFFER                   normal and base colour stored as half floats
 *   UNIT_NORMALS                   the G-buffer's normals are unit or zero (clshade's own
 *                                  G-buffers): not normalised again, only the zero ones replaced
 *   HAS_SHADOWS, SHADOW_PCF        shadow-map lookup (shadow.h), PCF kernel width
 *   HAS_ENVIRONMENT, ENV_*         light from the sky and the sky behind the scene
 *                                  (environment.h; compile-time in the general kernel too)
 *   SIMD                           pixels per work-item (1, 4, 8 or 16)
 *   SPECULAR_AA                    specular lobe widened by the normal's screen-space
 *                                  variance (specular_aa.h); absent unless the scene asks
 *   RAW_RADIANCE                   no MAX_RADIANCE clamp: the radiance as summed,
 *                                  NaN/Inf included (`clshade check stability`
 *                                  counts them before any clamp)
 *   GENERAL                        the general kernel: every channel read, the
 *                                  light count, ambient and shadows runtime
 *                                  switches; the reference every specialised
 *                                  variant must match (tests/device/test_specialisation.py)
 *
 * Channel layout (struct of arrays, one entry per pixel, row 0 at the top;
 * `plane` = npix padded to a multiple of 16 (render/arrays.py PIXEL_PAD) ≥ SIMD, see
 * gbuffer.h):
 *   depth     float   view-space depth along the camera axis, ≤ 0 = empty
 *   normal    3 planes of float: world-space shading normal (or half)
 *   base      3 planes of float: linear base colour (or half)
 *   roughness float   perceptual roughness
 *   metallic  float
 *   emissive  3 planes of float: emitted radiance (HAS_EMISSIVE)
 *   occlusion float   ambient occlusion in [0, 1] (HAS_OCCLUSION)
 *   tangent   3 planes of float: the interpolated mesh tangent (HAS_TANGENT)
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
#ifndef HAS_EMISSIVE
#define HAS_EMISSIVE 0
#endif
#ifndef HAS_OCCLUSION
#define HAS_OCCLUSION 0
#endif
#ifndef HAS_TANGENT
#define HAS_TANGENT 0
#endif
#ifndef HAS_ENVIRONMENT
#define HAS_ENVIRONMENT 0
#endif
#ifndef ROUGHNESS_VALUE
#define ROUGHNESS_VALUE 1.0f
#endif
#ifndef METALLIC_VALUE
#define METALLIC_VALUE 0.0f
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

/* Largest magnitude of radiance written: finite by contract even for 1e30 lights (and, below, for
 * a user's lobe whose value runs to −∞). */
#define MAX_RADIANCE 3.0e38f

/* The one copy of the light formulas, shared by the specialised and the general
 * paths (scenes/README.md): a point or spot light of intensity I at `pos` gives
 * E = I / r² at P; a spot also its cone. */

/* Unit direction from P towards `pos`; *d2 = squared distance, floored at MIN_LIGHT_DIST2. */
INLINE vec3 towards_light(float4 pos, vec3 P, real* d2) {
    vec3 d = v3sub(v3c(pos.xyz), P);
    *d2 = fmax(v3dot(d, d), MIN_LIGHT_DIST2);
    return v3scale(d, rsqrt(*d2));
}

/* Smooth cone: 0 outside the outer cone, 1 inside the inner, t² between; l towards
 * the light, `axis` the direction the light travels. */
INLINE real spot_cone(vec3 l, float4 axis, float cos_outer, float cos_inner) {
    real t = saturate((v3dot(v3neg(l), v3c(axis.xyz)) - cos_outer) / fmax(cos_inner - cos_outer, 1.0e-6f));
    return t * t;
}

#if HAS_MATERIAL
/* Each lane's row of the material table (a gather: lanes may differ). */
INLINE Material material_gather(uindex id, mask covered, __constant float4* materials) {
    uindex_lanes ids = {id};
    /* Sky lanes (id 0, their shading discarded) take the first covered lane's id, so that a
     * work-item on one object's silhouette stays on the one-row path below. Some lane is
     * covered: the caller skips all-sky work-items. */
    mask_lanes cov = {covered};
    uint first = ids.s[0];
    for (int j = 0; j < SIMD; ++j)
        if (cov.s[j]) { first = ids.s[j]; break; }
    id = covered ? id : (uindex)(first);
    ids.v = id;
    /* Fast path: neighbouring pixels mostly share a material. A branch per
     * work-item, not per lane (nothing vectorises across work-items here). */
    if (ALL(id == (uindex)(first))) {
        uint mi = first * MATERIAL_STRIDE;
        return material_uniform(materials[mi], materials[mi + 1], materials[mi + 2], materials[mi + 3]);
    }
    real_lanes t[12];
    for (int j = 0; j < SIMD; ++j) {
        uint mi = ids.s[j] * MATERIAL_STRIDE;
        float4 m0 = materials[mi], m1 = materials[mi + 1], m2 = materials[mi + 2], m3 = materials[mi + 3];
        t[0].s[j] = m0.x; t[1].s[j] = m0.y; t[2].s[j] = m0.z; t[3].s[j] = m0.w;
        t[4].s[j] = m1.x; t[5].s[j] = m1.y;
        t[6].s[j] = m2.x; t[7].s[j] = m2.y; t[8].s[j] = m2.z;
        t[9].s[j] = m3.x; t[10].s[j] = m3.y; t[11].s[j] = m3.z;
    }
    Material m;
    m.kd = t[0].v; m.ks = t[1].v; m.ka = t[2].v; m.shininess = t[3].v;
    m.ior = t[4].v; m.f90 = t[5].v;
    m.eta = v3(t[6].v, t[7].v, t[8].v); m.k = v3(t[9].v, t[10].v, t[11].v);
    return m;
}
#endif


__kernel void shade(
    const uint npix, const uint plane, const uint width, const float inv_width2, const float inv_height2,
    const float4 cam_pos, const float4 cam_fwd, const float4 cam_right, const float4 cam_up,
    GBUFFER_PARAMS      /* gbuffer.h: depth, normal, base and the variant's channels */
#if HAS_MATERIAL
    , __constant float4* materials
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
#if HAS_ENVIRONMENT
    , __constant float4* env_params, __global const float4* env_map, __global const float* env_cdf
    , const uint env_samples, const uint env_first_pixel   /* N; the band's first pixel in the frame */
    ENV_SPLIT_PARAMS                                     /* the split-sum rungs' tables */
#endif
    , const float4 background,
    __global float4* out
#ifdef COUNT_TERMS
    , __global uint* term_counts   /* count.h: TERMS × CHECKS counters */
#endif
    )
{
    size_t i = get_global_id(0);
    if (SIMD * i >= npix) return;

    real z = VLOAD(i, depth);
    mask covered = z > 0.0f;
    PREFETCH_AHEAD(i, z);   /* gbuffer.h: the lines of the work-items ahead */
    /* Sky: a work-item with no covered pixel reads nothing else and writes the
     * background (copy.cl skips the same reads, so the floor stays fair). Both
     * paths end in the one store4 below: gbuffer.h says why there is one site. */
    vec3 color = v3c(background.xyz);
    real alpha = (real)(background.w);
#if HAS_ENVIRONMENT && ENV_BACKGROUND
    if (!ALL(covered))
        color = env_background(SIMD * i, width, inv_width2, inv_height2, cam_fwd, cam_right, cam_up,
                               env_params, env_map);
#endif
    if (!all_empty(z)) {
        /* Camera rays through the pixel centres; cam_right/cam_up are pre-scaled by
         * tan(fov/2)·aspect and tan(fov/2), so P = cam_pos + depth · ray. */
        /* Lane j is pixel SIMD·i + j: one division per work-item. The first pixel's ray
         * is scalar arithmetic, and each lane steps cam_right·inv_width2 from it (a
         * vector of lane offsets the same in every work-item). Lanes past the row's end
         * (only where width is not a multiple of SIMD) move back k row widths and down
         * k rows, k = (col + j) div width: 1, or more in a frame narrower than SIMD. */
        uint first = (uint)(SIMD * i), row = first / width, col = first - row * width;
        float3 step = cam_right.xyz * inv_width2;
        float3 ray0 = cam_fwd.xyz - cam_right.xyz + ((float)col + 0.5f) * step
                    + (1.0f - ((float)row + 0.5f) * inv_height2) * cam_up.xyz;
        vec3 ray = v3add(v3c(ray0), v3scale(v3c(step), convert_real(as_mask(LANE_IOTA))));
        if (col + SIMD > width) {
            /* k in float: exact, as (col + j + ½)/width stays ≥ ½/width from every integer. */
            real k = floor((convert_real(as_mask(LANE_IOTA + (uindex)(col))) + 0.5f) * (0.5f * inv_width2));
            vec3 back = v3c(-(float)width * step - inv_height2 * cam_up.xyz);
            ray = v3add(ray, v3scale(back, k));
        }
        vec3 v = v3scale(ray, -rsqrt(v3dot(ray, ray)));

        /* A bad normal (zero, NaN, Inf) shades as if facing the viewer. The fallback is a
         * branch taken only where some lane has one, so a model that reads v nowhere else
         * (Lambert) computes it only there (LLVM sinks v into the branch). */
        vec3 n = load3(i, normal, plane);
#ifdef UNIT_NORMALS
        mask n_ok = v3dot(n, n) > MIN_UNIT_LEN2;   /* unit or zero already (GBuffer.unit_normals) */
#else
        mask n_ok = unit_in_place(&n);
#endif
        if (!ALL(n_ok))
            n = v3select(n_ok, n, v);
        vec3 b = v3max(load3(i, base, plane), 0.0f);
#if HAS_ROUGHNESS
        real r = saturate(VLOAD(i, roughness));
#else
        real r = saturate((real)(ROUGHNESS_VALUE));
#endif
#if HAS_METALLIC
        real m = saturate(VLOAD(i, metallic));
#else
        real m = saturate((real)(METALLIC_VALUE));
#endif
#if HAS_MATERIAL
        Surface s = make_surface(b, r, m, material_gather(VLOAD_UCHAR(i, material), covered, materials));
#else
        Surface s = make_surface(b, r, m, material_uniform(MAT_M0, MAT_M1, MAT_M2, MAT_M3));
#endif
        COUNT_INTO(s, term_counts);

#if HAS_TANGENT
        s.tangent = load3f(i, tangent, plane);     /* the mesh's tangent (surface_frame orthonormalises it) */
#endif

#ifdef SPECULAR_AA
        s = specular_aa(s, normal_difference2(first, npix, width, depth, normal, plane, n));   /* specular_aa.h */
#endif

        vec3 L = SUM_START;
#if HAS_OCCLUSION
#define AMBIENT(A) v3scale(ambient_term(v3c((A).xyz), s), saturate(VLOAD(i, occlusion)))
#else
#define AMBIENT(A) ambient_term(v3c((A).xyz), s)
#endif
#if GENERAL || NUM_POINT + NUM_SPOT > 0 || HAS_SHADOWS
        vec3 P = v3add(v3c(cam_pos.xyz), v3scale(ray, z));
#endif
#if GENERAL
        for (uint k = 0; k < num_lights; ++k) {
            float4 a = lights[4 * k], c = lights[4 * k + 1];
            int kind = (int)a.w;
            vec3 l, E;
            if (kind == LIGHT_DIRECTIONAL) {
                l = v3c(-a.xyz);
                E = v3c(c.xyz);
            } else {
                real d2;
                l = towards_light(a, P, &d2);
                if (kind == LIGHT_SPOT) {
                    float4 e = lights[4 * k + 2];
                    E = v3scale(v3c(c.xyz), spot_cone(l, e, e.w, lights[4 * k + 3].x) / d2);
                } else {
                    E = v3scale(v3c(c.xyz), 1.0f / d2);
                }
            }
            if (has_shadows && c.w >= 0.0f && ANY(faces_light(n, l)))
                E = v3scale(E, shadow_factor(shadow_maps, shadow_params, (int)c.w, shadow_size, P, n, pcf_radius));
            L = v3add(L, shade_light(n, v, l, E, s));
        }
        if (has_ambient)
            L = v3add(L, AMBIENT(ambient));
#else
#if HAS_SHADOWS
    /* Only where some lane faces the light: shade_light() adds nothing otherwise. */
#define SHADOW(E, slot) \
        if ((slot) >= 0.0f && ANY(faces_light(n, l))) \
            (E) = v3scale((E), shadow_factor(shadow_maps, shadow_params, (int)(slot), shadow_size, P, n, SHADOW_PCF / 2))
#else
#define SHADOW(E, slot)
#endif
#if NUM_DIR > 0
        for (int k = 0; k < NUM_DIR; ++k) {
            vec3 l = v3c(-lights[2 * k].xyz);
            float4 c = lights[2 * k + 1];
            vec3 E = v3c(c.xyz);
#if HAS_SHADOWS
            SHADOW(E, c.w);
            L = v3add(L, shade_light(n, v, l, E, s));
#else
            /* One irradiance for every lane: whether it is 0 is a scalar test
             * (compose.h, shade_light). */
            if (fmax(fmax(c.x, c.y), c.z) > 0.0f)
                L = v3add(L, shade_light_lit(n, v, l, E, s));
#endif
        }
#endif
#if NUM_POINT > 0
        for (int k = 0; k < NUM_POINT; ++k) {
            int o = 2 * NUM_DIR + 2 * k;
            real d2;
            vec3 l = towards_light(lights[o], P, &d2);
            L = v3add(L, shade_light(n, v, l, v3scale(v3c(lights[o + 1].xyz), 1.0f / d2), s));
        }
#endif
#if NUM_SPOT > 0
        for (int k = 0; k < NUM_SPOT; ++k) {
            int o = 2 * NUM_DIR + 2 * NUM_POINT + 3 * k;
            float4 p = lights[o], e = lights[o + 1], a = lights[o + 2];
            real d2;
            vec3 l = towards_light(p, P, &d2);
            vec3 E = v3scale(v3c(e.xyz), spot_cone(l, a, p.w, e.w) / d2);
            SHADOW(E, a.w);
            L = v3add(L, shade_light(n, v, l, E, s));
        }
#endif
#if HAS_AMBIENT
        L = v3add(L, AMBIENT(ambient));
#endif
#endif
#if HAS_ENVIRONMENT
        vec3 sky = environment_light(n, v, s, (uindex)(first + env_first_pixel) + LANE_IOTA, env_samples,
                                     env_params, env_map, env_cdf ENV_SPLIT_ARGS);
#if HAS_OCCLUSION
        sky = v3scale(sky, saturate(VLOAD(i, occlusion)));   /* the sky is unoccluded but for AO */
#endif
        L = v3add(L, sky);
#endif
#if HAS_EMISSIVE
        L = v3add(L, v3max(load3f(i, emissive, plane), 0.0f));
#endif
        L = RAW3(s, TERM_RADIANCE, L, UNBOUNDED);   /* count.h: before the clamp */
#ifndef RAW_RADIANCE
        L = v3max(v3min(L, MAX_RADIANCE), -MAX_RADIANCE);   /* fmin first: a NaN becomes MAX_RADIANCE */
#endif
        color = v3select(covered, L, color);
        alpha = covered ? (real)(1.0f) : alpha;
    }
    store4(i, out, color, alpha);
}
