/* surface.h — what a lobe sees: the Geometry of one (n, l, v) triple and the
 * Surface of one pixel, built once per pixel by make_surface() following the
 * workflow (metallic-roughness or the study's k_d + k_s = 1 rule), and the
 * Fresnel dispatch chosen at compile time (-D FRESNEL=...).
 */
#ifndef CLSHADE_SURFACE_H
#define CLSHADE_SURFACE_H

#define FRESNEL_SCHLICK    0
#define FRESNEL_DIELECTRIC 1
#define FRESNEL_CONDUCTOR  2
#ifndef FRESNEL
#define FRESNEL FRESNEL_SCHLICK
#endif

#define WORKFLOW_METALLIC 0
#define WORKFLOW_KDKS     1
#ifndef WORKFLOW
#define WORKFLOW WORKFLOW_METALLIC
#endif

/* Reflectance at normal incidence of a common dielectric (IOR 1.5), the
 * metallic workflow's F0 for non-metals (Karis 2013; Filament). */
#define F0_DIELECTRIC 0.04f

/* Per-material constants, 4 float4 per material in the material table:
 *   m0 = (kd, ks, ka, shininess)   m1 = (ior, f90, -, -)
 *   m2 = (eta.rgb, -)              m3 = (k.rgb, -)                         */
#define MATERIAL_STRIDE 4

typedef struct {
    real nl;      /* n·l floored at MIN_N_DOT_L (the caller drops n·l ≤ 0)  */
    real nl_raw;  /* n·l as computed: > 0 when the light is above          */
    real nv;      /* n·v floored at MIN_N_DOT_V                             */
    real nh;      /* n·h in [0, 1]                                          */
    real sin2_nh; /* 1 − (n·h)² = |n × h|², precise near the peak          */
    real vh;      /* v·h = l·h in [0, 1]                                    */
    real lv;      /* l·v                                                    */
    real rv;      /* r·v, r = 2(n·l)n − l, the Phong mirror direction       */
#ifdef GEOMETRY_VECTORS
    vec3 n, l, v; /* the unit vectors themselves: lobes that declare `uses: vectors` */
#endif
#ifdef GEOMETRY_TANGENTS
    vec3 x, y;    /* tangent frame (x, y, n) right-handed: `uses: tangents`  */
#endif
} Geometry;

/* The per-material constants of one pixel (a row of the material table, or
 * the constants compiled in), unpacked from MATERIAL_STRIDE float4. */
typedef struct {
    real kd, ks, ka, shininess;
    real ior, f90;
    vec3 eta, k;
} Material;

typedef struct {
    vec3 base;           /* linear base colour                              */
    vec3 diffuse_color;  /* what the diffuse lobe multiplies                */
    vec3 f0;             /* Schlick reflectance at normal incidence         */
    vec3 eta, k;         /* conductor complex IOR                           */
    real roughness;      /* perceptual r                                    */
    real alpha;          /* r², floored at MIN_ALPHA                        */
    real kd, ks, ka;     /* lobe weights (1, 1, 1 in the metallic workflow) */
    real shininess;      /* Phong/Blinn–Phong exponent n ≥ 0                */
    real ior;            /* dielectric IOR (exact Fresnel)                  */
    real f90;            /* Schlick reflectance at grazing                  */
#ifdef GEOMETRY_TANGENTS
    vec3 tangent;        /* the mesh's tangent from the G-buffer, or 0      */
#endif
    COUNTERS_FIELD       /* the counting build's term counters (count.h)    */
} Surface;

/* One material, the same in every lane (a table row or the baked constants). */
INLINE Material material_uniform(float4 m0, float4 m1, float4 m2, float4 m3) {
    Material m;
    m.kd = (real)(m0.x); m.ks = (real)(m0.y); m.ka = (real)(m0.z); m.shininess = (real)(m0.w);
    m.ior = (real)(m1.x); m.f90 = (real)(m1.y);
    m.eta = v3c(m2.xyz); m.k = v3c(m3.xyz);
    return m;
}

/* Squared length below which a direction (a G-buffer normal, an evaluated
 * n, l or v) is treated as missing and replaced by a fallback: 1e-20 keeps
 * rsqrt ≤ 1e10 and the normalised vector unit to float32 precision; shorter
 * vectors come only from bad input (zero or denormal normals). */
#define MIN_UNIT_LEN2 1.0e-20f

/* *x normalised in the lanes where it has a usable direction (the returned mask);
 * the other lanes hold garbage (Inf, NaN) for the caller to replace. */
INLINE mask unit_in_place(vec3* x) {
    real len2 = v3dot(*x, *x);
    *x = v3scale(*x, rsqrt(len2));
    return len2 > MIN_UNIT_LEN2;
}

/* x normalised, or `fallback` where x has no usable direction (lane-wise). */
INLINE vec3 unit_or(vec3 x, vec3 fallback) {
    mask ok = unit_in_place(&x);
    return v3select(ok, x, fallback);
}

/* Lanes where the light is above the surface's horizon (n·l > 0). */
INLINE mask faces_light(vec3 n, vec3 l) { return v3dot(n, l) > 0.0f; }

#ifdef GEOMETRY_TANGENTS
/* A tangent frame of unit n, continuous except across n.z = 0's sign change:
 * Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 6(1), 2017
 * (the same as clshade.verify.reference._orthonormal_basis). Branch-free:
 * the sign is a lane-wise select. */
INLINE void tangent_frame(vec3 n, vec3* x, vec3* y) {
    real sign = n.z >= 0.0f ? (real)(1.0f) : (real)(-1.0f);
    real a = -1.0f / (sign + n.z);
    real b = n.x * n.y * a;
    *x = v3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    *y = v3(b, sign + n.y * n.y * a, -n.y);
}
#endif

/* n, l, v unit length. */
INLINE Geometry make_geometry(vec3 n, vec3 l, vec3 v) {
    Geometry g;
#ifdef GEOMETRY_VECTORS
    g.n = n; g.l = l; g.v = v;
#endif
#ifdef GEOMETRY_TANGENTS
    tangent_frame(n, &g.x, &g.y);
#endif
    real nv_raw = v3dot(n, v);
    g.nl_raw = v3dot(n, l);
    g.nl = fmax(g.nl_raw, MIN_N_DOT_L);
    g.nv = fmax(nv_raw, MIN_N_DOT_V);
    /* The half vector's dot products are taken with H = l + v before it is
     * normalised: they run beside the reciprocal length, which then scales three
     * scalars instead of H (fewer operations, and a shorter dependency chain:
     * the square root and division no longer precede the dot products). */
    vec3 H = v3add(l, v);
    real h_len2 = v3dot(H, H);
    real inv_len = rsqrt(fmax(h_len2, MIN_HALF_LEN2));
    real nH = v3dot(n, H);
    vec3 c = v3cross(n, H);
    g.nh = saturate(nH * inv_len);
    /* l = −v: no half vector. Treat h as perpendicular to n (n·h = 0 already,
     * sin² = 1) so that D_GGX sees 1, not the 0 that made α²/0 = Inf and,
     * times F = 0, NaN. So is a half vector below the surface (n·v < 0 at a
     * back-lit silhouette, l ≈ −v): n·h is clamped to 0, and sin² must agree with
     * it, or D's d = sin² + (n·h)²α² falls below α² (to 0 at l = −v exactly).
     * A select, not a branch. sin² = |n × H|² / |H|²: the two factors of inv_len
     * keep it finite (|n × H|² ≤ |H|², inv_len ≤ 1e15). */
    g.sin2_nh = ((h_len2 < MIN_HALF_LEN2) | (nH <= 0.0f)) ? (real)(1.0f)
              : saturate(v3dot(c, c) * inv_len * inv_len);
    g.vh = saturate(v3dot(v, H) * inv_len);
    g.lv = v3dot(l, v);
    g.rv = 2.0f * g.nl_raw * nv_raw - g.lv;
    return g;
}

/* Inputs are sanitised: base ≥ 0, roughness and metallic in [0, 1]. */
INLINE Surface make_surface(vec3 base, real roughness, real metallic, const Material m) {
    Surface s;
    s.base = base;
    s.roughness = roughness;
    s.alpha = fmax(roughness * roughness, MIN_ALPHA);
    s.shininess = m.shininess;
    s.ior = m.ior;
    s.f90 = m.f90;
#ifdef GEOMETRY_TANGENTS
    s.tangent = v3s((real)(0.0f));     /* none: surface_frame keeps the normal's frame */
#endif
    s.eta = m.eta;
    s.k = m.k;
#if WORKFLOW == WORKFLOW_METALLIC
#ifdef METALLIC_VALUE
    /* metallic is the scene's one value, compiled in (shade.cl; defined only for
     * the shading variants with a uniform channel). A dielectric scene (0) has the
     * base colour as diffuse colour and a grey F0, so every Fresnel term has one
     * value for the three channels and is computed once: the general formulas'
     * values for finite base colours. A compile-time choice, not a select. */
    const int dielectric = METALLIC_VALUE == 0.0f;
#else
    const int dielectric = 0;
#endif
    s.diffuse_color = dielectric ? base : v3scale(base, 1.0f - metallic);
    s.f0 = dielectric ? v3s((real)(F0_DIELECTRIC)) : v3mix(v3s((real)(F0_DIELECTRIC)), base, metallic);
    s.kd = (real)(1.0f); s.ks = (real)(1.0f); s.ka = (real)(1.0f);
#else
    real r0 = (s.ior - 1.0f) / (s.ior + 1.0f);
    s.diffuse_color = base;
    s.f0 = v3s(r0 * r0);
    s.kd = m.kd; s.ks = m.ks; s.ka = m.ka;
#endif
    return s;
}

#ifdef GEOMETRY_TANGENTS
/* The tangent frame a lobe sees: the surface's tangent made orthogonal to n
 * (Gram–Schmidt) and y = n × x, where it has one (the G-buffer's mesh tangent:
 * UVs); elsewhere (a zero tangent, or one along n) make_geometry's frame of n.
 * Lane-wise selects, no branch. */
INLINE void surface_frame(Geometry* g, vec3 n, const Surface s) {
    vec3 t = v3sub(s.tangent, v3scale(n, v3dot(n, s.tangent)));
    mask ok = unit_in_place(&t);
    g->x = v3select(ok, t, g->x);
    g->y = v3select(ok, v3cross(n, t), g->y);
}
#endif

/* The Fresnel term chosen at compile time, at incidence cosine c; the exact
 * Fresnels' raw value is counted before it is clamped to [0, 1]. */
INLINE vec3 fresnel_cos(real c, const Surface s) {
#if FRESNEL == FRESNEL_DIELECTRIC
    return v3s(saturate(RAW(s, TERM_F, F_Dielectric_unclamped(c, s.ior), 1.0f)));
#elif FRESNEL == FRESNEL_CONDUCTOR
    return v3saturate(RAW3(s, TERM_F, F_Conductor_unclamped(c, s.eta, s.k), 1.0f));
#else
    return RAW3(s, TERM_F, F_Schlick(c, s.f0, s.f90), 1.0f);
#endif
}

/* The microfacet lobes' F, at the microfacet incidence v·h. */
INLINE vec3 fresnel(const Geometry g, const Surface s) { return fresnel_cos(g.vh, s); }

#endif
