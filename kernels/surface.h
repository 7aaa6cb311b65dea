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
    float nl;      /* n·l floored at MIN_N_DOT_L (the caller drops n·l ≤ 0)  */
    float nl_raw;  /* n·l as computed: > 0 when the light is above          */
    float nv;      /* n·v floored at MIN_N_DOT_V                             */
    float nh;      /* n·h in [0, 1]                                          */
    float sin2_nh; /* 1 − (n·h)² = |n × h|², precise near the peak          */
    float vh;      /* v·h = l·h in [0, 1]                                    */
    float lv;      /* l·v                                                    */
    float rv;      /* r·v, r = 2(n·l)n − l, the Phong mirror direction       */
} Geometry;

typedef struct {
    float3 base;           /* linear base colour                              */
    float3 diffuse_color;  /* what the diffuse lobe multiplies                */
    float3 f0;             /* Schlick reflectance at normal incidence         */
    float3 eta, k;         /* conductor complex IOR                           */
    float roughness;       /* perceptual r                                    */
    float alpha;           /* r², floored at MIN_ALPHA                        */
    float kd, ks, ka;      /* lobe weights (1, 1, 1 in the metallic workflow) */
    float shininess;       /* Phong/Blinn–Phong exponent n ≥ 0                */
    float ior;             /* dielectric IOR (exact Fresnel)                  */
    float f90;             /* Schlick reflectance at grazing                  */
} Surface;

/* n, l, v unit length. */
inline Geometry make_geometry(float3 n, float3 l, float3 v) {
    Geometry g;
    float nv_raw = dot(n, v);
    g.nl_raw = dot(n, l);
    g.nl = fmax(g.nl_raw, MIN_N_DOT_L);
    g.nv = fmax(nv_raw, MIN_N_DOT_V);
    float3 h = l + v;
    float h_len2 = dot(h, h);
    h = h * rsqrt(fmax(h_len2, MIN_HALF_LEN2));
    g.nh = saturate(dot(n, h));
    float3 c = cross(n, h);
    /* l = −v: no half vector. Treat h as perpendicular to n (n·h = 0 already,
     * sin² = 1) so that D_GGX sees 1, not the 0 that made α²/0 = Inf and,
     * times F = 0, NaN. A select, not a branch. */
    g.sin2_nh = h_len2 < MIN_HALF_LEN2 ? 1.0f : saturate(dot(c, c));
    g.vh = saturate(dot(v, h));
    g.lv = dot(l, v);
    g.rv = 2.0f * g.nl_raw * nv_raw - g.lv;
    return g;
}

/* Inputs are sanitised: base ≥ 0, roughness and metallic in [0, 1]. */
inline Surface make_surface(float3 base, float roughness, float metallic,
                            float4 m0, float4 m1, float4 m2, float4 m3) {
    Surface s;
    s.base = base;
    s.roughness = roughness;
    s.alpha = fmax(roughness * roughness, MIN_ALPHA);
    s.shininess = m0.w;
    s.ior = m1.x;
    s.f90 = m1.y;
    s.eta = m2.xyz;
    s.k = m3.xyz;
#if WORKFLOW == WORKFLOW_METALLIC
    s.diffuse_color = base * (1.0f - metallic);
    s.f0 = mix((float3)(F0_DIELECTRIC), base, metallic);
    s.kd = 1.0f; s.ks = 1.0f; s.ka = 1.0f;
#else
    float r0 = (s.ior - 1.0f) / (s.ior + 1.0f);
    s.diffuse_color = base;
    s.f0 = (float3)(r0 * r0);
    s.kd = m0.x; s.ks = m0.y; s.ka = m0.z;
#endif
    return s;
}

/* The Fresnel term chosen at compile time, at incidence cosine c. */
inline float3 fresnel_cos(float c, const Surface s) {
#if FRESNEL == FRESNEL_DIELECTRIC
    return (float3)(F_Dielectric(c, s.ior));
#elif FRESNEL == FRESNEL_CONDUCTOR
    return F_Conductor(c, s.eta, s.k);
#else
    return F_Schlick(c, s.f0, s.f90);
#endif
}

/* The microfacet lobes' F, at the microfacet incidence v·h. */
inline float3 fresnel(const Geometry g, const Surface s) { return fresnel_cos(g.vh, s); }

#endif
