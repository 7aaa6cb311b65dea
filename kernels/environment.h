/* environment.h — light from the whole sky: an equirectangular radiance map, the rungs of
 * scenes/README.md's [environment]. Orientation (Mitsuba 3's envmap; clshade/render/environment.py):
 * +y up, u = atan2(d.x, −d.z)/2π wrapped to [0, 1), v = acos(d.y)/π (row 0 the zenith); the map is
 * looked up at R_y(−θ)·d, θ the sky's rotation. The sky is unoccluded: only the occlusion channel
 * (HAS_OCCLUSION) scales it.
 *
 * Defines (clshade/device/variants.py; each rung is compiled in only when the scene asks):
 *   HAS_ENVIRONMENT       1: the kernel takes the sky's arguments below
 *   ENV_DIFFUSE           the diffuse lobe's rung: ENV_CONSTANT (mean radiance × diffuse albedo,
 *                         the study's ambient), ENV_SH9 (irradiance from 9 SH coefficients,
 *                         Ramamoorthi & Hanrahan 2001, × albedo / π), ENV_SAMPLED, or ENV_NONE
 *                         (the model has no diffuse lobe)
 *   ENV_SPECULAR          the specular lobe's rung: ENV_SAMPLED, ENV_SPLIT_SUM (Karis 2013: a
 *                         prefiltered mip chain times a DFG table), ENV_SPLIT_SUM_MS (the same
 *                         with Fdez-Agüera 2019's multiple-scattering compensation) or ENV_NONE
 *   ENV_SPLIT_FAMILY      the split sum's lobe family (ENV_LOBE_*): its lookup coordinate t is the
 *                         roughness (GGX, Beckmann) or (2/(e + 2))^¼ of the exponent e (Phong,
 *                         Blinn–Phong); clshade/render/prefilter.py
 *   ENV_SPLIT_FRESNEL     1: the DFG table is Schlick's scale and bias of F0 (microfacet lobes);
 *                         0: the normalised empirical lobe's albedo, × ENV_SPLIT_NORM's factor
 *   ENV_SPLIT_NORM        0: none, 1: Phong's 2π/(e + 2), 2: Blinn–Phong's 8π/(e + 8)
 *   ENV_LEVELS, ENV_DFG_SIZE  the mip chain's levels and the DFG table's nodes per axis
 *   ENV_LOBE_SAMPLING     the distribution the sampled rung draws for the specular lobe:
 *                         ENV_LOBE_{NONE, GGX, BECKMANN, PHONG, BLINN_PHONG}
 *   ENV_COSINE_SAMPLING   1: the sampled rung also draws cosine-weighted directions
 *   ENV_MAP_SAMPLING      1: the sampled rung also draws from the map's luminance (0: a constant sky)
 *   ENV_BACKGROUND        1: uncovered pixels show the sky (bilinear: display only)
 *
 * Arguments (Environment.params, .texels, .cdf):
 *   env_params  float4 rows: (cos θ, sin θ, W, H), (mean radiance, 0), 9 × (SH coefficient × Â_l/π, 0)
 *   env_map     W·H float4: texel radiance RGB and the map strategy's pdf per steradian
 *   env_cdf     the marginal CDF over rows (H + 1 floats), then each row's CDF over its columns (W + 1)
 * and for the split-sum rungs (MipChain.table, .texels, prefilter.dfg_words):
 *   env_levels  ENV_LEVELS × (first texel, W, H, exponent bias) floats: the levels of env_mips
 *   env_mips    the levels' texels as RGB9E5 words (one gather a texel), level 0 the map itself
 *   env_dfg     ENV_DFG_SIZE² words, n·v the slow axis, t the fast one: A in the low half-float, B in
 *               the high one (one gather a node)
 *
 * The sampled rung: N samples per pixel shared round-robin among its strategies (cosine, the lobe's
 * distribution, the map), each strategy on its own Hammersley set of n_s points with a per-pixel
 * Cranley–Patterson rotation from an integer hash: the image is reproducible. Samples are combined by
 * Veach's balance heuristic for multi-sample MIS: Σ f·(n·l)·L / Σ_s n_s p_s(l).
 */
#ifndef CLSHADE_ENVIRONMENT_H
#define CLSHADE_ENVIRONMENT_H

#define ENV_NONE     0
#define ENV_CONSTANT 1
#define ENV_SH9      2
#define ENV_SAMPLED  3
#define ENV_SPLIT_SUM    4
#define ENV_SPLIT_SUM_MS 5

#define ENV_LOBE_NONE        0
#define ENV_LOBE_GGX         1
#define ENV_LOBE_BECKMANN    2
#define ENV_LOBE_PHONG       3
#define ENV_LOBE_BLINN_PHONG 4

#ifndef ENV_DIFFUSE
#define ENV_DIFFUSE ENV_NONE
#endif
#ifndef ENV_SPECULAR
#define ENV_SPECULAR ENV_NONE
#endif
#ifndef ENV_LOBE_SAMPLING
#define ENV_LOBE_SAMPLING ENV_LOBE_NONE
#endif
#ifndef ENV_COSINE_SAMPLING
#define ENV_COSINE_SAMPLING 0
#endif
#ifndef ENV_MAP_SAMPLING
#define ENV_MAP_SAMPLING 0
#endif
#ifndef ENV_BACKGROUND
#define ENV_BACKGROUND 0
#endif

#define ENV_SAMPLED_RUNG (ENV_DIFFUSE == ENV_SAMPLED || ENV_SPECULAR == ENV_SAMPLED)
#define ENV_SPLIT_SUM_RUNG (ENV_SPECULAR == ENV_SPLIT_SUM || ENV_SPECULAR == ENV_SPLIT_SUM_MS)

/* The split-sum rungs' extra arguments of shade.cl (none for the other rungs). */
#if ENV_SPLIT_SUM_RUNG
#define ENV_SPLIT_PARAMS , __global const float* env_levels, __global const uint* env_mips, \
                           __global const uint* env_dfg
#define ENV_SPLIT_ARGS , env_levels, env_mips, env_dfg
#else
#define ENV_SPLIT_PARAMS
#define ENV_SPLIT_ARGS
#endif

/* The real SH basis of bands 0–2, +y the polar axis (clshade/render/environment.py, SH_C*). */
#define ENV_SH_C0 0.282094792f
#define ENV_SH_C1 0.488602512f
#define ENV_SH_C2 1.092548431f
#define ENV_SH_C3 0.315391565f
#define ENV_SH_C4 0.546274215f

/* ---- the map ------------------------------------------------------------------ */

/* A world direction in the map's frame: R_y(−θ)·d, p0 = (cos θ, sin θ, W, H). */
INLINE vec3 env_to_map(vec3 d, float4 p0) {
    return v3(p0.x * d.x - p0.y * d.z, d.y, p0.y * d.x + p0.x * d.z);
}

/* A direction of the map's frame in the world: R_y(θ)·d. */
INLINE vec3 env_to_world(vec3 d, float4 p0) {
    return v3(p0.x * d.x + p0.y * d.z, d.y, p0.x * d.z - p0.y * d.x);
}

/* atan(a) for a in [0, 1]: a·P(a²), P of degree 7 fitted by least squares on Chebyshev nodes; its float32
 * error is < 1.4e-7 rad (about two float32 ulps at π/4; a texel spans ≥ 7.7e-4 rad). Cheaper than libm's
 * atan2 and acos on PoCL (docs/bench-notes.md). */
INLINE real env_atan01(real a) {
    real s = a * a;
    real p = fma(s, -0.004073120653629303f, 0.021945958957076073f);
    p = fma(s, p, -0.056062281131744385f);
    p = fma(s, p, 0.09656194597482681f);
    p = fma(s, p, -0.13915780186653137f);
    p = fma(s, p, 0.19948504865169525f);
    p = fma(s, p, -0.3333010673522949f);
    p = fma(s, p, 0.999999463558197f);
    return a * p;
}

/* atan2(y, x) in [−π, π] by octant reduction onto env_atan01 (error < 3.1e-7 rad: π − r rounds); (0, 0)
 * gives 0. */
INLINE real env_atan2(real y, real x) {
    real ax = fabs(x), ay = fabs(y);
    real r = env_atan01(fmin(ax, ay) / fmax(fmax(ax, ay), FLT_MIN));
    r = ay > ax ? 0.5f * CLSHADE_PI - r : r;
    r = x < 0.0f ? CLSHADE_PI - r : r;
    return copysign(r, y);
}

/* (u, v) of a unit direction of the map's frame, u in [0, 1] (a direction a hair left of the seam rounds
 * to 1: the lookups clamp or wrap it), v's polar angle as atan2 of (sin θ, cos θ), exact at the poles
 * where acos loses precision. */
INLINE void env_uv(vec3 d, real* u, real* v) {
    real a = env_atan2(d.x, -d.z) * (0.5f * CLSHADE_INV_PI);
    *u = a < 0.0f ? a + 1.0f : a;
    *v = env_atan2(sqrt(d.x * d.x + d.z * d.z), d.y) * CLSHADE_INV_PI;
}

/* The index of the texel holding a unit direction of the map's frame (nearest: the map is piecewise
 * constant); a direction with NaN reads some texel of the map (convert_mask_sat and the clamps), never
 * one outside it. */
INLINE mask env_texel_index(vec3 d, float4 p0) {
    int w = (int)p0.z, h = (int)p0.w;
    real u, v;
    env_uv(d, &u, &v);
    mask col = min(max(convert_mask_sat(floor(u * p0.z)), 0), w - 1);
    mask row = min(max(convert_mask_sat(floor(v * p0.w)), 0), h - 1);
    return row * w + col;
}

/* The mirror of v about unit h. */
INLINE vec3 env_reflect(vec3 v, vec3 h) { return v3sub(v3scale(h, 2.0f * v3dot(v, h)), v); }

typedef struct { vec3 L; real pdf; } EnvTexel;

/* Each lane's texel (a gather). */
#ifdef CLSHADE_HARDWARE_GATHER
INLINE EnvTexel env_fetch(__global const float4* map, mask index) {
    __global const float* m = (__global const float*)map;
    mask i = 4 * index;
    EnvTexel e;
    e.L = v3(gather(m, i), gather(m, i + 1), gather(m, i + 2));
    e.pdf = gather(m, i + 3);
    return e;
}
#else
INLINE EnvTexel env_fetch(__global const float4* map, mask index) {
    mask_lanes k = {index};
    real_lanes r, g, b, p;
    for (int j = 0; j < SIMD; ++j) {
        float4 t = map[k.s[j]];
        r.s[j] = t.x; g.s[j] = t.y; b.s[j] = t.z; p.s[j] = t.w;
    }
    EnvTexel e;
    e.L = v3(r.v, g.v, b.v);
    e.pdf = p.v;
    return e;
}
#endif

/* The sky's radiance and the map strategy's pdf in world direction d (unit). */
INLINE EnvTexel env_lookup(vec3 d, __constant float4* P, __global const float4* map) {
    float4 p0 = P[0];
    return env_fetch(map, env_texel_index(env_to_map(d, p0), p0));
}

/* A bilinear footprint between texel centres of a W×H level whose first texel is `base` (u wraps, v
 * clamps): the four texels' indices and the weights along u and v. */
typedef struct { mask i00, i01, i10, i11; real fx, fy; } EnvQuad;

INLINE EnvQuad env_quad(mask base, mask w, mask h, real wf, real hf, real u, real v) {
    real x = u * wf - 0.5f, y = v * hf - 0.5f;
    real x0 = floor(x), y0 = floor(y);
    mask c0 = convert_mask_sat(x0), r0 = convert_mask_sat(y0);
    mask c1 = c0 + 1;
    c0 = c0 < 0 ? c0 + w : c0;
    c1 = c1 >= w ? c1 - w : c1;
    mask r1 = min(max(r0 + 1, 0), h - 1);
    r0 = min(max(r0, 0), h - 1);
    EnvQuad q;
    q.i00 = base + r0 * w + c0;
    q.i01 = base + r0 * w + c1;
    q.i10 = base + r1 * w + c0;
    q.i11 = base + r1 * w + c1;
    q.fx = x - x0;
    q.fy = y - y0;
    return q;
}

/* The bilinear value of a footprint. With hardware gathers, channel by channel in lanes; else each lane's
 * four texels are read and blended as float4, one write back into lanes per channel instead of one per
 * texel and channel. */
typedef struct { mask_lanes i00, i01, i10, i11; real_lanes fx, fy; } EnvQuadLanes;

INLINE EnvQuadLanes env_quad_lanes(EnvQuad q) {
    EnvQuadLanes l = {{q.i00}, {q.i01}, {q.i10}, {q.i11}, {q.fx}, {q.fy}};
    return l;
}

INLINE float4 env_bilinear_lane(__global const float4* texels, EnvQuadLanes q, int j) {
    float4 top = mix(texels[q.i00.s[j]], texels[q.i01.s[j]], q.fx.s[j]);
    float4 bottom = mix(texels[q.i10.s[j]], texels[q.i11.s[j]], q.fx.s[j]);
    return mix(top, bottom, q.fy.s[j]);
}

INLINE vec3 env_bilinear(__global const float4* texels, EnvQuad q) {
#ifdef CLSHADE_HARDWARE_GATHER
    vec3 top = v3mix(env_fetch(texels, q.i00).L, env_fetch(texels, q.i01).L, q.fx);
    vec3 bottom = v3mix(env_fetch(texels, q.i10).L, env_fetch(texels, q.i11).L, q.fx);
    return v3mix(top, bottom, q.fy);
#else
    EnvQuadLanes l = env_quad_lanes(q);
    real_lanes r, g, b;
    for (int j = 0; j < SIMD; ++j) {
        float4 c = env_bilinear_lane(texels, l, j);
        r.s[j] = c.x; g.s[j] = c.y; b.s[j] = c.z;
    }
    return v3(r.v, g.v, b.v);
#endif
}

#if ENV_BACKGROUND
/* The sky behind the pixels SIMD·i … of the frame, bilinear between texel centres (u wraps, v
 * clamps): for display only, the lighting reads the texels as they are. The view ray is shade.cl's,
 * written per lane: fwd + right·(2(col + ½)/W − 1) + up·(1 − 2(row + ½)/H). */
INLINE vec3 env_background(uint first, uint width, float inv_width2, float inv_height2, float4 cam_fwd,
                           float4 cam_right, float4 cam_up, __constant float4* P, __global const float4* map) {
    uindex p = (uindex)(first) + LANE_IOTA;
    uindex row = p / width, col = p - row * width;
    real sx = (convert_real(col) + 0.5f) * inv_width2 - 1.0f;
    real sy = 1.0f - (convert_real(row) + 0.5f) * inv_height2;
    vec3 ray = v3add(v3c(cam_fwd.xyz), v3add(v3scale(v3c(cam_right.xyz), sx), v3scale(v3c(cam_up.xyz), sy)));
    float4 p0 = P[0];
    real u, v;
    env_uv(env_to_map(v3scale(ray, rsqrt(v3dot(ray, ray))), p0), &u, &v);
    return env_bilinear(map, env_quad((mask)(0), (mask)((int)p0.z), (mask)((int)p0.w), (real)(p0.z), (real)(p0.w),
                                      u, v));
}
#endif

/* ---- the diffuse rungs without samples ------------------------------------------ */

/* Radiance A reflected by the diffuse lobe as by a constant ambient of A (compose.h's ambient_term
 * with k_s = 0 and k_a = 1: k_d·diffuse colour, k_d = 1 − F0 in the metallic workflow). */
INLINE vec3 env_diffuse_reflected(vec3 A, Surface s) {
    s.ks = (real)(0.0f);
    s.ka = (real)(1.0f);
    return ambient_term(A, s);
}

#if ENV_DIFFUSE == ENV_SH9
/* E(n)/π from the 9 coefficients (env_params rows 2–10, already × Â_l/π), n in the world; negative
 * values (the ringing of 9 coefficients around a small bright source) are no light: 0. */
INLINE vec3 env_sh9(vec3 n, __constant float4* P) {
    vec3 d = env_to_map(n, P[0]);
    real x = d.x, y = d.y, z = d.z;
    real Y[9] = {(real)(ENV_SH_C0), ENV_SH_C1 * y, ENV_SH_C1 * z, ENV_SH_C1 * x, ENV_SH_C2 * (x * y),
                 ENV_SH_C2 * (y * z), ENV_SH_C3 * (3.0f * y * y - 1.0f), ENV_SH_C2 * (x * z),
                 ENV_SH_C4 * (x * x - z * z)};
    vec3 e = SUM_START;
    for (int k = 0; k < 9; ++k)
        e = v3add(e, v3scale(v3c(P[2 + k].xyz), Y[k]));
    return v3max(e, 0.0f);
}
#endif

/* ---- the sampled rung ----------------------------------------------------------- */

#if ENV_SAMPLED_RUNG

#define ENV_HAS_LOBE (ENV_LOBE_SAMPLING != ENV_LOBE_NONE)
#define ENV_STRATEGIES (ENV_COSINE_SAMPLING + ENV_HAS_LOBE + ENV_MAP_SAMPLING)
/* Each strategy's slot in the round robin (−1: absent). */
#define ENV_SLOT_COSINE (ENV_COSINE_SAMPLING ? 0 : -1)
#define ENV_SLOT_LOBE (ENV_HAS_LOBE ? ENV_COSINE_SAMPLING : -1)
#define ENV_SLOT_MAP (ENV_MAP_SAMPLING ? ENV_COSINE_SAMPLING + ENV_HAS_LOBE : -1)
#if ENV_STRATEGIES == 0
#error "the sampled rung needs a strategy"
#endif

/* The largest float below 1: a sample coordinate stays in [0, 1). */
#define ENV_ONE_MINUS 0.99999994f

/* Chris Wellons' lowbias32 integer hash (bias 0.17 % of the ideal's; "Prospecting for Hash
 * Functions", 2018): decorrelates neighbouring pixels' rotations. */
INLINE uindex env_hash(uindex x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

/* A hash's top 24 bits as a float in [0, 1) (× 2⁻²⁴: every value exact in float32). */
INLINE real env_unit(uindex h) { return convert_real(h >> 8) * 5.96046448e-8f; }

/* The base-2 radical inverse of i (its bits mirrored about the binary point), in [0, 1): its top 24
 * bits × 2⁻²⁴. */
INLINE float env_radical_inverse(uint i) {
    i = (i << 16) | (i >> 16);
    i = ((i & 0x00ff00ffu) << 8) | ((i & 0xff00ff00u) >> 8);
    i = ((i & 0x0f0f0f0fu) << 4) | ((i & 0xf0f0f0f0u) >> 4);
    i = ((i & 0x33333333u) << 2) | ((i & 0xccccccccu) >> 2);
    i = ((i & 0x55555555u) << 1) | ((i & 0xaaaaaaaau) >> 1);
    return (float)(i >> 8) * 5.96046448e-8f;
}

/* A point coordinate moved by a rotation and wrapped to [0, 1) (Cranley–Patterson). */
INLINE real env_rotate(float x, real shift) {
    real t = x + shift;
    return fmin(t >= 1.0f ? t - 1.0f : t, ENV_ONE_MINUS);
}

/* A tangent frame (x, y, n) of unit n: Duff et al. 2017, as surface.h's tangent_frame. */
INLINE void env_frame(vec3 n, vec3* x, vec3* y) {
    real sign = n.z >= 0.0f ? (real)(1.0f) : (real)(-1.0f);
    real a = -1.0f / (sign + n.z);
    real b = n.x * n.y * a;
    *x = v3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    *y = v3(b, sign + n.y * n.y * a, -n.y);
}

/* cos θ, sin θ · (cos φ, sin φ) in the frame (x, y, z). */
INLINE vec3 env_spherical(vec3 x, vec3 y, vec3 z, real cos_theta, real phi) {
    real sin_theta = safe_sqrt(1.0f - cos_theta * cos_theta);
    return v3add(v3add(v3scale(x, sin_theta * cos(phi)), v3scale(y, sin_theta * sin(phi))), v3scale(z, cos_theta));
}

/* Cosine-weighted about n: pdf (n·l)/π (Malley's method). */
INLINE vec3 env_sample_cosine(vec3 n, vec3 x, vec3 y, real a, real b) {
    return env_spherical(x, y, n, sqrt(1.0f - a), 2.0f * CLSHADE_PI * b);
}

#if ENV_HAS_LOBE
/* The lobe's distribution: GGX or Beckmann normals with density D(h)(n·h) (Walter et al. 2007,
 * eq. 35, 28), Blinn–Phong normals with density (e + 1)/2π (n·h)ᵉ, then l = the mirror of v about h;
 * Phong: l about the mirror direction of v with density (e + 1)/2π (r·l)ᵉ (Lafortune & Willems 1994). */
INLINE vec3 env_sample_lobe(vec3 n, vec3 x, vec3 y, vec3 v, const Surface s, real a, real b) {
    real phi = 2.0f * CLSHADE_PI * b;
#if ENV_LOBE_SAMPLING == ENV_LOBE_PHONG
    vec3 r = env_reflect(v, n);
    vec3 rx, ry;
    env_frame(r, &rx, &ry);
    return env_spherical(rx, ry, r, pow_runtime(a, 1.0f / (fmax(s.shininess, 0.0f) + 1.0f)), phi);
#else
#if ENV_LOBE_SAMPLING == ENV_LOBE_GGX
    real a2 = s.alpha * s.alpha;
    real cos_h = rsqrt(1.0f + a2 * a / (1.0f - a));
#elif ENV_LOBE_SAMPLING == ENV_LOBE_BECKMANN
    real cos_h = rsqrt(1.0f - s.alpha * s.alpha * (log2_lanes(1.0f - a) * 0.693147181f));
#else
    real cos_h = pow_runtime(a, 1.0f / (fmax(s.shininess, 0.0f) + 1.0f));
#endif
    return env_reflect(v, env_spherical(x, y, n, cos_h, phi));
#endif
}

/* The density of env_sample_lobe's l, per steradian (0 where it never draws l): the normal's
 * density p(h) over 4 (v·h) (the Jacobian of the mirror map), or Phong's about the mirror. */
INLINE real env_lobe_pdf(vec3 n, vec3 v, vec3 l, const Surface s) {
#if ENV_LOBE_SAMPLING == ENV_LOBE_PHONG
    real c = v3dot(env_reflect(v, n), l);
    real e = fmax(s.shininess, 0.0f);
    return c > 0.0f ? (e + 1.0f) * (0.5f * CLSHADE_INV_PI) * pow_runtime(fmin(c, 1.0f), e) : (real)(0.0f);
#else
    vec3 H = v3add(l, v);
    vec3 h = v3scale(H, rsqrt(fmax(v3dot(H, H), MIN_HALF_LEN2)));
    real nh = v3dot(n, h), vh = v3dot(v, h);
#if ENV_LOBE_SAMPLING == ENV_LOBE_BLINN_PHONG
    real e = fmax(s.shininess, 0.0f);
    real p = (e + 1.0f) * (0.5f * CLSHADE_INV_PI) * pow_runtime(saturate(nh), e);
#else
    vec3 c = v3cross(n, h);
    real sin2 = saturate(v3dot(c, c));
#if ENV_LOBE_SAMPLING == ENV_LOBE_GGX
    real p = D_GGX(saturate(nh), sin2, s.alpha) * nh;
#else
    real p = D_Beckmann(saturate(nh), sin2, s.alpha) * nh;
#endif
#endif
    return (nh > 0.0f) & (vh > 0.0f) ? p / (4.0f * vh) : (real)(0.0f);
#endif
}
#endif

#if ENV_MAP_SAMPLING
/* The largest index r in [0, count − 1] with c[base + r] ≤ x (c nondecreasing there, c[base] ≤ x):
 * binary lifting, the same steps in every lane (`base` may differ between lanes). */
INLINE mask env_search(__global const float* c, mask base, int count, real x) {
    int step = 1;
    while (2 * step <= count - 1)
        step *= 2;
    mask r = (mask)(0);
    for (; step > 0; step /= 2) {
        mask t = r + step;
        mask ok = (t <= count - 1) & (gather(c, base + min(t, count - 1)) <= x);
        r = ok ? t : r;
    }
    return r;
}

/* x's position in [c[base + r], c[base + r + 1]), in [0, 1]: uniform when x is. */
INLINE real env_residual(__global const float* c, mask index, real x) {
    real lo = gather(c, index), hi = gather(c, index + 1);
    return saturate((x - lo) / (hi - lo));
}

/* A direction drawn from the map: a row by the marginal CDF, a column by the row's CDF, then uniform
 * in the texel's solid angle (cos θ and φ uniform); its density is the texel's env_map pdf. */
INLINE vec3 env_sample_map(real a, real b, __constant float4* P, __global const float* cdf) {
    float4 p0 = P[0];
    int w = (int)p0.z, h = (int)p0.w;
    mask row = env_search(cdf, (mask)(0), h, a);
    mask base = (h + 1) + row * (w + 1);
    mask col = env_search(cdf, base, w, b);
    real top = cos(convert_real(row) * (CLSHADE_PI / p0.w));
    real bottom = cos(convert_real(row + 1) * (CLSHADE_PI / p0.w));
    real mu = top - env_residual(cdf, row, a) * (top - bottom);
    real phi = (convert_real(col) + env_residual(cdf, base + col, b)) * (2.0f * CLSHADE_PI / p0.z);
    real sin_theta = safe_sqrt(1.0f - mu * mu);
    return env_to_world(v3(sin_theta * sin(phi), mu, -sin_theta * cos(phi)), p0);
}
#endif

/* f of the lobes whose rung is sampled (the other lobe has its own rung): brdf() with the other's
 * weight at 0, so that compose.h stays the one place a model is assembled. */
INLINE vec3 env_brdf(const Geometry g, Surface s) {
#if ENV_SPECULAR != ENV_SAMPLED
    s.ks = (real)(0.0f);
#endif
#if ENV_DIFFUSE != ENV_SAMPLED
    s.diffuse_color = v3s((real)(0.0f));
#endif
    return brdf(g, s);
}

/* Σ over N samples of f·(n·l)·L / Σ_s n_s p_s(l): the sampled lobes' reflected sky radiance. */
INLINE vec3 env_sampled(vec3 n, vec3 v, const Surface s, uindex pixel, uint samples, __constant float4* P,
                        __global const float4* map, __global const float* cdf) {
    vec3 x, y;
    env_frame(n, &x, &y);
    float count[ENV_STRATEGIES];
    for (uint t = 0; t < ENV_STRATEGIES; ++t)
        count[t] = (float)((samples + ENV_STRATEGIES - 1 - t) / ENV_STRATEGIES);
    vec3 sum = v3s((real)(0.0f));
    for (uint k = 0; k < samples; ++k) {
        int t = (int)(k % ENV_STRATEGIES);
        uint i = k / ENV_STRATEGIES;
        uindex h1 = env_hash(pixel ^ (uindex)(0x9e3779b9u * (uint)(t + 1)));
        real a = env_rotate((float)i / count[t], env_unit(h1));
        real b = env_rotate(env_radical_inverse(i), env_unit(env_hash(h1)));
        vec3 l = n;
#if ENV_COSINE_SAMPLING
        if (t == ENV_SLOT_COSINE) l = env_sample_cosine(n, x, y, a, b);
#endif
#if ENV_HAS_LOBE
        if (t == ENV_SLOT_LOBE) l = env_sample_lobe(n, x, y, v, s, a, b);
#endif
#if ENV_MAP_SAMPLING
        if (t == ENV_SLOT_MAP) l = env_sample_map(a, b, P, cdf);
#endif
        real nl = v3dot(n, l);
        if (!ANY(nl > 0.0f))
            continue;
        EnvTexel e = env_lookup(l, P, map);
        real denom = (real)(0.0f);
#if ENV_COSINE_SAMPLING
        denom += count[ENV_SLOT_COSINE] * (fmax(nl, 0.0f) * CLSHADE_INV_PI);
#endif
#if ENV_HAS_LOBE
        denom += count[ENV_SLOT_LOBE] * env_lobe_pdf(n, v, l, s);
#endif
#if ENV_MAP_SAMPLING
        denom += count[ENV_SLOT_MAP] * e.pdf;
#endif
        mask ok = (nl > 0.0f) & (denom > 0.0f);
        Geometry g = make_geometry(n, l, v);
#ifdef GEOMETRY_TANGENTS
        surface_frame(&g, n, s);
#endif
        real w = ok ? nl / denom : (real)(0.0f);
        vec3 c = v3scale(v3mul(env_brdf(g, s), e.L), w);
        sum = v3add(sum, v3select(ok, c, v3s((real)(0.0f))));
    }
    return sum;
}
#endif

/* ---- the split-sum rungs ---------------------------------------------------------- */

#if ENV_SPLIT_SUM_RUNG

/* The smallest E = A + B the energy compensation divides by: GGX's albedo at α = 1 and grazing n·v
 * is ~0.02, so the floor acts only on a broken table (a bias of 0 above it). */
#define ENV_MIN_ALBEDO 1.0e-3f

INLINE real env_lerp(real a, real b, real t) { return a + (b - a) * t; }

/* Level k's bilinear footprint at map coordinates (u, v), k per lane (its row of env_levels): read once
 * where every lane is on one level (the lanes of one material, the usual case), else gathered. */
INLINE EnvQuad env_level_quad(__global const float* levels, mask k, real u, real v) {
    mask_lanes lanes = {k};
    int first = lanes.s[0];
    real base, wf, hf;
    if (ALL(k == first)) {
        base = (real)(levels[4 * first]);
        wf = (real)(levels[4 * first + 1]);
        hf = (real)(levels[4 * first + 2]);
    } else {
        base = gather(levels, 4 * k);
        wf = gather(levels, 4 * k + 1);
        hf = gather(levels, 4 * k + 2);
    }
    return env_quad(convert_mask_sat(base), convert_mask_sat(wf), convert_mask_sat(hf), wf, hf, u, v);
}

/* Each lane's word of p (a gather: the bits as they are). */
INLINE mask env_words(__global const uint* p, mask index) {
#ifdef CLSHADE_HARDWARE_GATHER
    return as_mask(gather((__global const float*)p, index));
#else
    mask_lanes k = {index}, w;
    for (int j = 0; j < SIMD; ++j)
        w.s[j] = (int)p[k.s[j]];
    return w.v;
#endif
}

/* The RGB of RGB9E5 words (clshade/render/prefilter.py, pack_rgb9e5): each 9-bit mantissa × 2 to the
 * 5-bit shared exponent + bias − 127, the float32 whose exponent field is e + bias (env_levels' bias:
 * 127 − 15 − 9 + the chain's scale exponent, so the field stays ≥ 103, a normal float). */
INLINE vec3 env_rgb9e5(mask w, mask bias) {
    real scale = as_real((((w >> 27) & 31) + bias) << 23);
    return v3(convert_real(w & 0x1ff) * scale, convert_real((w >> 9) & 0x1ff) * scale,
              convert_real((w >> 18) & 0x1ff) * scale);
}

/* The low and the high half-float of words (non-negative, finite: the DFG table's, prefilter.dfg_words) as
 * floats: a half's exponent and mantissa bits moved to a float's, times 2^(127 − 15) to rebias the exponent;
 * exact for every normal half (a subnormal half reads as 0 where the device flushes denormals). */
#define ENV_HALF_REBIAS 5.192296858534828e33f   /* 2¹¹² */
INLINE real env_half_lo(mask w) { return as_real((w & 0x7fff) << 13) * ENV_HALF_REBIAS; }
INLINE real env_half_hi(mask w) { return as_real((w >> 3) & 0x0fffe000) * ENV_HALF_REBIAS; }

/* The bilinear value of a footprint of the chain. */
INLINE vec3 env_level_bilinear(__global const uint* mips, EnvQuad q, mask bias) {
    vec3 top = v3mix(env_rgb9e5(env_words(mips, q.i00), bias), env_rgb9e5(env_words(mips, q.i01), bias), q.fx);
    vec3 bottom = v3mix(env_rgb9e5(env_words(mips, q.i10), bias), env_rgb9e5(env_words(mips, q.i11), bias), q.fx);
    return v3mix(top, bottom, q.fy);
}

/* The mip chain at map coordinates (u, v), linear between levels k and k + 1 (per lane) by `frac`, each
 * level bilinear (env_quad). */
INLINE vec3 env_prefiltered(__global const float* levels, __global const uint* mips, mask k, real frac, real u,
                            real v) {
    mask bias = (mask)((int)levels[3]);
    return v3mix(env_level_bilinear(mips, env_level_quad(levels, k, u, v), bias),
                 env_level_bilinear(mips, env_level_quad(levels, k + 1, u, v), bias), frac);
}

/* The lookup coordinate t in [0, 1] of the lobe (clshade/render/prefilter.py): the roughness, or
 * (2/(e + 2))^¼ for an exponent e (two square roots, no pow). */
INLINE real env_split_t(const Surface s) {
#if ENV_SPLIT_FAMILY == ENV_LOBE_GGX || ENV_SPLIT_FAMILY == ENV_LOBE_BECKMANN
    return saturate(s.roughness);
#else
    return saturate(sqrt(sqrt(2.0f / (fmax(s.shininess, 0.0f) + 2.0f))));
#endif
}

/* The specular lobe's reflected sky radiance by the split sum: the chain at the mirror direction r
 * of v (linear between the levels around t·(ENV_LEVELS − 1)) times the DFG table at (n·v, t),
 * bilinear between its nodes. */
INLINE vec3 env_split_sum(vec3 n, vec3 v, const Surface s, __constant float4* P, __global const float* levels,
                          __global const uint* mips, __global const uint* dfg) {
    real nv = saturate(fmax(v3dot(n, v), MIN_N_DOT_V));
    real t = env_split_t(s);
    real u, w;
    env_uv(env_to_map(env_reflect(v, n), P[0]), &u, &w);
    real lod = t * (real)(ENV_LEVELS - 1);
    real l0 = fmin(floor(lod), (real)(ENV_LEVELS - 2));
    mask k0 = convert_mask_sat(l0);
    vec3 pre = env_prefiltered(levels, mips, k0, lod - l0, u, w);
    real x = nv * (real)(ENV_DFG_SIZE - 1), y = t * (real)(ENV_DFG_SIZE - 1);
    real x0 = fmin(floor(x), (real)(ENV_DFG_SIZE - 2)), y0 = fmin(floor(y), (real)(ENV_DFG_SIZE - 2));
    real fx = x - x0, fy = y - y0;
    mask i = convert_mask_sat(x0) * ENV_DFG_SIZE + convert_mask_sat(y0);
    mask w00 = env_words(dfg, i), w01 = env_words(dfg, i + 1);
    mask w10 = env_words(dfg, i + ENV_DFG_SIZE), w11 = env_words(dfg, i + ENV_DFG_SIZE + 1);
    real A = env_lerp(env_lerp(env_half_lo(w00), env_half_lo(w01), fy),
                      env_lerp(env_half_lo(w10), env_half_lo(w11), fy), fx);
#if ENV_SPLIT_FRESNEL
    real B = env_lerp(env_lerp(env_half_hi(w00), env_half_hi(w01), fy),
                      env_lerp(env_half_hi(w10), env_half_hi(w11), fy), fx);
#if FRESNEL == FRESNEL_SCHLICK
    vec3 f0 = s.f0;
    real f90 = s.f90;
#else
    vec3 f0 = fresnel_cos((real)(1.0f), s);   /* the exact Fresnel's F0, Schlick's curve to 1 */
    real f90 = (real)(1.0f);
#endif
    vec3 spec = v3add(v3scale(f0, A), v3s(f90 * B));
#if ENV_SPECULAR == ENV_SPLIT_SUM_MS
    real k = 1.0f / fmax(A + B, ENV_MIN_ALBEDO) - 1.0f;
    spec = v3mul(spec, v3(1.0f + f0.x * k, 1.0f + f0.y * k, 1.0f + f0.z * k));
#endif
#else
    real e = fmax(s.shininess, 0.0f);
#if ENV_SPLIT_NORM == 1
    A = A * ((2.0f * CLSHADE_PI) / (e + 2.0f));
#elif ENV_SPLIT_NORM == 2
    A = A * ((8.0f * CLSHADE_PI) / (e + 8.0f));
#endif
    vec3 spec = v3s(A);
#endif
    return v3scale(v3mul(pre, spec), s.ks);
}
#endif

/* ---- the sky's light on one pixel ------------------------------------------------- */

/* Reflected sky radiance towards v: the diffuse rung plus the sampled lobes or the split sum. `pixel` is the lanes'
 * pixel index in the frame (the sampled rung's hash), `samples` the sample count N. */
INLINE vec3 environment_light(vec3 n, vec3 v, const Surface s, uindex pixel, uint samples, __constant float4* P,
                              __global const float4* map, __global const float* cdf ENV_SPLIT_PARAMS) {
    vec3 L = SUM_START;
#if ENV_DIFFUSE == ENV_CONSTANT
    L = v3add(L, env_diffuse_reflected(v3c(P[1].xyz), s));
#elif ENV_DIFFUSE == ENV_SH9
    L = v3add(L, env_diffuse_reflected(env_sh9(n, P), s));
#endif
#if ENV_SAMPLED_RUNG
    L = v3add(L, env_sampled(n, v, s, pixel, samples, P, map, cdf));
#endif
#if ENV_SPLIT_SUM_RUNG
    L = v3add(L, env_split_sum(n, v, s, P, env_levels, env_mips, env_dfg));
#endif
    return L;
}

#endif
