"""Mutation testing: does the test suite catch small semantic bugs?

Each mutant of the catalogue is (file, exact original snippet, replacement, description). For every mutant
the script copies the repository (its committed HEAD) to a temporary folder, applies the one edit (a snippet that is not found
exactly once is an error: the catalogue must track the code), and runs the whole test suite there (no fail-fast:
every failing test is listed), with PYTHONPATH pointing at the copy: the copy's Python code and the copy's kernels
are the ones used (the run checks that clshade.resources.kernels_dir() lies inside the copy; PoCL caches binaries
by source, so a mutated kernel is compiled afresh).

Each kill is classified (KILL_CLASSES) from its failing tests (benchmarks/mutant_plugin.py records them with
their markers): *behavioural* when some failing test checks behaviour; else *compile error* (the mutated kernel
does not build), *collection error*, *snapshot* (only tests marked `snapshot`: output compared with a committed
file the same code wrote), *text* (only tests marked `text`: a string searched in source, docs or binaries) or
*needs extra* (only tests marked `extra`, which run only where an optional package is installed). The headline
counts behavioural kills only. The unmutated snapshot runs first (the baseline): a test failing there kills
nothing, and is listed apart in each mutant's row.

    python benchmarks/mutants.py [--jobs 2] [--only NAME,...] [--json benchmarks/results/mutants.json]
    python benchmarks/mutants.py --resume --impact-from MAP    # go on with a run stopped part way, same commit

Writes JSON only; `python benchmarks/publish.py` renders benchmarks/results/mutants.md from it.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from clshade.provenance import stamp  # noqa: E402
sys.path.insert(0, str(ROOT / "benchmarks"))
import freshness  # noqa: E402
import impact  # noqa: E402
OUT = ROOT / "benchmarks" / "results" / "mutants.json"
COPY_IGNORE = shutil.ignore_patterns(".venv", ".git", "__pycache__", "*.egg-info", "build", "dist",
                                     ".pytest_cache", ".hypothesis", "out")
TEST_TIMEOUT_S = 1800     # the whole suite (no fail-fast), 2 at a time on 2 shared cores


@dataclass(frozen=True)
class Mutant:
    name: str
    file: str
    original: str
    replacement: str
    description: str


M = Mutant
CATALOGUE: list[Mutant] = [
    # ---- term functions (kernels/brdf.h)
    M("ggx_d_square", "kernels/brdf.h", "quotient q = {a2, CLSHADE_PI * d * d};", "quotient q = {a2, CLSHADE_PI * d};",
      "GGX D: denominator not squared"),
    M("beckmann_exp_sign", "kernels/brdf.h", "return exp_lanes(-sin2_nh * t)", "return exp_lanes(-0.5f * sin2_nh * t)",
      "Beckmann D: exponent halved"),
    M("v_correlated_half", "kernels/brdf.h", "quotient q = {(real)(0.5f), gv + gl};", "quotient q = {(real)(0.25f), gv + gl};",
      "height-correlated Smith V: 0.5 → 0.25"),
    M("v_separable_swap", "kernels/brdf.h", "real sv = nv + sqrt(a2 + (1.0f - a2) * nv * nv);",
      "real sv = nv + sqrt(a2 + (1.0f - a2) * nl * nl);", "separable Smith V: G1(v) uses n·l"),
    M("v_schlick_k", "kernels/brdf.h", "real k = 0.5f * alpha;", "real k = alpha;",
      "Smith–Schlick V: k = α instead of α/2"),
    M("v_cook_torrance_2", "kernels/brdf.h", "return fmin(2.0f * nh * fmin(nv, nl), b) / (4.0f * nl * nv * b);",
      "return fmin(nh * fmin(nv, nl), b) / (4.0f * nl * nv * b);", "V-cavity G: factor 2 dropped"),
    M("schlick_pow4", "kernels/brdf.h", "real w = pow5(1.0f - vh);", "real w = sq(sq(1.0f - vh));",
      "Schlick Fresnel: (1 − v·h)⁴ instead of ⁵"),
    M("schlick_f90", "kernels/brdf.h", "f0.x + (f90 - f0.x) * w", "f0.x + (1.0f - f0.x) * w",
      "Schlick Fresnel: red channel ignores f90"),
    M("dielectric_half", "kernels/brdf.h", "real f = 0.5f * a * a * (1.0f + b * b);",
      "real f = 0.5f * a * a * (1.0f + b);", "exact dielectric Fresnel: b² → b"),
    M("dielectric_tir", "kernels/brdf.h", "return g2 < 0.0f ? (real)(1.0f) : f;",
      "return g2 < 0.0f ? (real)(0.0f) : f;", "dielectric: total internal reflection gives 0"),
    M("conductor_rp", "kernels/brdf.h", "real rp = rs * (t3 - t4) / (t3 + t4);", "real rp = rs * (t3 + t4) / (t3 + t4);",
      "conductor Fresnel: R_p = R_s"),
    M("conductor_channel", "kernels/brdf.h",
      "fresnel_conductor_channel_unclamped(c, eta.z, k.z)", "fresnel_conductor_channel_unclamped(c, eta.y, k.y)",
      "conductor Fresnel: blue channel uses green's η, k"),
    M("lambert_pi", "kernels/brdf.h", "INLINE real Fd_Lambert(void) { return (real)(CLSHADE_INV_PI); }",
      "INLINE real Fd_Lambert(void) { return (real)(0.5f * CLSHADE_INV_PI); }", "Lambert: 1/(2π)"),
    M("burley_f90", "kernels/brdf.h", "real f90 = 0.5f + 2.0f * alpha * lh * lh;", "real f90 = 0.5f + alpha * lh * lh;",
      "Burley: F90 = 0.5 + α(l·h)²"),
    M("burley_view", "kernels/brdf.h", "real view = 1.0f + (f90 - 1.0f) * pow5(1.0f - nv);",
      "real view = 1.0f + (f90 - 1.0f) * pow5(1.0f - nl);", "Burley: view factor uses n·l"),
    M("oren_nayar_b", "kernels/brdf.h", "real B = 0.45f * s2 / (s2 + 0.09f);", "real B = 0.45f * s2 / (s2 + 0.9f);",
      "Oren–Nayar: B denominator 0.09 → 0.9"),
    M("oren_nayar_a", "kernels/brdf.h", "real A = 1.0f - 0.5f * s2 / (s2 + 0.33f);", "real A = 1.0f - 0.5f * s2 / (s2 + 0.033f);",
      "Oren–Nayar: A denominator 0.33 → 0.033"),
    M("phong_clamp", "kernels/brdf.h", "return rv > 0.0f ? pow_runtime(fmin(rv, 1.0f), n) : zero_pow;",
      "return pow_runtime(fabs(rv), n);", "Phong: |r·v| instead of the clamped r·v (a lobe behind the mirror horizon)"),
    M("phong_zero_pow", "kernels/brdf.h", "return rv > 0.0f ? pow_runtime(fmin(rv, 1.0f), n) : zero_pow;",
      "return pow_runtime(clamp(rv, MIN_POW_BASE, 1.0f), n);",
      "Phong: r·v ≤ 0 floored to MIN_POW_BASE (MIN_POW_BASEⁿ, 1e-3 at n = 0.1) instead of 0ⁿ"),
    M("phong_skip_all", "kernels/brdf.h", "return ALL((!(rv > 0.0f) & !shininess_is_zero(n)) | power_underflows(rv, n));",
      "return ANY((!(rv > 0.0f) & !shininess_is_zero(n)) | power_underflows(rv, n));",
      "Phong: the power skipped when any lane (not every lane) has r·v ≤ 0"),
    M("log2_poly", "kernels/brdf.h", "real c45 = 1.4249322787e-1f - 1.2420140846e-1f * f;",
      "real c45 = 1.4249322787e-1f + 1.2420140846e-1f * f;", "log2_lanes: a polynomial coefficient's sign"),
    M("exp_reduction", "kernels/brdf.h", "real r = (c - kf * 0.693359375f) + kf * 2.12194440e-4f;",
      "real r = (c - kf * 0.693359375f);", "exp_lanes: Cody–Waite low part dropped"),
    M("exp2_poly", "kernels/brdf.h", "+ (5.550332471162809e-2f + 9.618437357674640e-3f * r) * z",
      "+ (5.550332471162809e-2f - 9.618437357674640e-3f * r) * z", "exp2_lanes: a polynomial coefficient's sign"),
    M("exp2_scale", "kernels/brdf.h", "return x < MIN_EXP2_ARG ? (real)(0.0f) : y * as_real((k + 127) << 23);",
      "return x < MIN_EXP2_ARG ? (real)(0.0f) : y * as_real((k + 126) << 23);",
      "exp2_lanes: 2ᵏ off by one (halved)"),
    M("exp2_underflow", "kernels/brdf.h", "return x < MIN_EXP2_ARG ? (real)(0.0f) : y", "return x < MIN_EXP2_ARG ? (real)(FLT_MIN) : y",
      "exp2_lanes: below 2⁻¹²⁶ returns FLT_MIN instead of 0"),
    # ---- model lobes (kernels/models)
    M("blinn_norm", "kernels/models/blinn_phong_normalized.cl", "(s.shininess + 8.0f) * (0.125f * CLSHADE_INV_PI)",
      "(s.shininess + 2.0f) * (0.125f * CLSHADE_INV_PI)", "normalized Blinn–Phong: (n+2)/8π"),
    M("phong_norm", "kernels/models/phong_normalized.cl", "(s.shininess + 2.0f) * (0.5f * CLSHADE_INV_PI)",
      "(s.shininess + 1.0f) * (0.5f * CLSHADE_INV_PI)", "normalized Phong: (n+1)/2π"),
    M("ggx_lobe_no_f", "kernels/models/ggx_correlated.cl", "return v3scale(fresnel(g, s), dv_product(D, V));",
      "return v3s(dv_product(D, V));", "GGX height-correlated: Fresnel dropped"),
    # ---- geometry (kernels/surface.h)
    M("rv_sign", "kernels/surface.h", "g.rv = 2.0f * g.nl_raw * nv_raw - g.lv;", "g.rv = 2.0f * g.nl_raw * nv_raw + g.lv;",
      "Phong mirror: r·v = 2(n·l)(n·v) + l·v"),
    M("vh_uses_l", "kernels/surface.h", "g.vh = saturate(v3dot(v, H) * inv_len);", "g.vh = saturate(v3dot(n, H) * inv_len);",
      "v·h computed as n·h"),
    M("f0_dielectric", "kernels/surface.h", ": v3mix(v3s((real)(F0_DIELECTRIC)), base, metallic);",
      ": v3mix(v3s((real)(0.08f)), base, metallic);", "metallic workflow: dielectric F0 = 0.08"),
    M("diffuse_metallic", "kernels/surface.h", ": v3scale(base, 1.0f - metallic);",
      ": base;", "metallic workflow: metals keep a diffuse colour"),
    M("kdks_r0", "kernels/surface.h", "real r0 = (s.ior - 1.0f) / (s.ior + 1.0f);", "real r0 = (s.ior - 1.0f) / (s.ior + 2.0f);",
      "k_d + k_s workflow: F0 from IOR wrong"),
    M("material_f90", "kernels/surface.h", "    s.f90 = m.f90;", "    s.f90 = (real)(1.0f);",
      "the material's Schlick f90 ignored (f90 = 1)"),
    M("alpha_floor_square", "kernels/surface.h", "s.alpha = fmax(roughness * roughness, MIN_ALPHA);",
      "s.alpha = fmax(roughness, MIN_ALPHA);", "α = r instead of r²"),
    # ---- composition and workflows (kernels/compose.h)
    M("kd_one_sided", "kernels/compose.h", "(1.0f - fl.x) * (1.0f - fv.x)", "(1.0f - fl.x)",
      "metallic k_d: red channel drops (1 − F(n·v))"),
    M("ks_ignored", "kernels/compose.h", "v3scale(RAW3(s, TERM_SPECULAR, specular_lobe(g, s), UNBOUNDED), s.ks)",
      "RAW3(s, TERM_SPECULAR, specular_lobe(g, s), UNBOUNDED)", "k_s weight ignored"),
    M("irradiance_floor", "kernels/compose.h", "vec3 e = v3scale(E, fmax(g.nl_raw, 0.0f));",
      "vec3 e = v3scale(E, g.nl);", "irradiance uses the floored n·l (the bug of issue 13)"),
    M("horizon_select", "kernels/compose.h",
      "    vec3 e = v3scale(E, fmax(g.nl_raw, 0.0f));\n    vec3 lo = RAW3(s, TERM_LIGHT, v3mul(brdf(g, s), e), UNBOUNDED);\n"
      "    return v3select(g.nl_raw > 0.0f, lo, v3s((real)(0.0f)));",
      "    vec3 e = v3scale(E, fabs(g.nl_raw));\n    vec3 lo = v3mul(brdf(g, s), e);\n    return lo;",
      "light below the horizon lights the surface (|n·l|, no horizon select)"),
    M("ambient_ka", "kernels/compose.h", "v3mul(v3scale(A, s.ka), r)", "v3mul(A, r)",
      "ambient ignores k_a"),
    M("ambient_spec", "kernels/compose.h", "r = v3add(r, v3scale(s.f0, s.ks));", "r = v3add(r, v3scale(s.f0, 0.8f * s.ks));",
      "ambient specular term × 0.8 (issue 13)"),
    M("ambient_metal_kd", "kernels/compose.h",
      "r = v3add(r, v3mul(v3sub(v3s((real)(1.0f)), s.f0), s.diffuse_color));",
      "r = v3add(r, s.diffuse_color);", "ambient metallic workflow: k_d = 1 instead of 1 − F0"),
    # ---- light kinds (kernels/shade.cl, specialised path)
    M("point_falloff", "kernels/shade.cl", "v3scale(v3c(lights[o + 1].xyz), 1.0f / d2), s));",
      "v3scale(v3c(lights[o + 1].xyz), rsqrt(d2)), s));", "point light falloff 1/d² → 1/d (issue 13)"),
    M("spot_cone_square", "kernels/shade.cl", "    return t * t;\n}",
      "    return t;\n}", "spot cone falloff t² → t (issue 13; spot_cone, both kernel paths)"),
    M("spot_axis_sign", "kernels/shade.cl", "real t = saturate((v3dot(v3neg(l), v3c(axis.xyz)) - cos_outer)",
      "real t = saturate((v3dot(l, v3c(axis.xyz)) - cos_outer)", "spot: axis sign flipped"),
    M("dir_light_sign", "kernels/shade.cl", "vec3 l = v3c(-lights[2 * k].xyz);", "vec3 l = v3c(lights[2 * k].xyz);",
      "directional light: l points along the light's travel"),
    M("pixel_centre_x", "kernels/shade.cl", "+ ((float)col + 0.5f) * step", "+ ((float)col) * step",
      "shade.cl: view ray through the pixel corner"),
    M("pixel_centre_y", "kernels/shade.cl", "(1.0f - ((float)row + 0.5f) * inv_height2)",
      "(1.0f - ((float)row) * inv_height2)", "shade.cl: view ray through the pixel's top edge"),
    M("lane_step", "kernels/shade.cl", "v3scale(v3c(step), convert_real(as_mask(LANE_IOTA)))",
      "v3scale(v3c(step), convert_real(as_mask(LANE_IOTA)) * 0.5f)", "shade.cl: lanes half a pixel apart"),
    M("ambient_dropped", "kernels/shade.cl", "#if HAS_AMBIENT\n        L = v3add(L, AMBIENT(ambient));",
      "#if HAS_AMBIENT\n        L = v3add(L, v3s((real)(0.0f)));", "specialised kernel: ambient dropped"),
    M("lane_wrap", "kernels/shade.cl", "v3c(-(float)width * step - inv_height2 * cam_up.xyz)",
      "v3c(-(float)width * step)", "SIMD lanes wrapping to the next row keep the row"),
    M("lane_wrap_once", "kernels/shade.cl", "real k = floor((convert_real(as_mask(LANE_IOTA + (uindex)(col))) + 0.5f) * (0.5f * inv_width2));",
      "real k = fmin(floor((convert_real(as_mask(LANE_IOTA + (uindex)(col))) + 0.5f) * (0.5f * inv_width2)), 1.0f);",
      "a frame narrower than SIMD: lanes two or more rows on stay one row down"),
    M("lane_wrap_column", "kernels/shade.cl", "v3c(-(float)width * step - inv_height2 * cam_up.xyz)",
      "v3c(-inv_height2 * cam_up.xyz)", "SIMD lanes wrapping to the next row keep counting columns past its end"),
    M("bad_normal_branch", "kernels/shade.cl", "        if (!ALL(n_ok))\n", "        if (0)\n",
      "shade.cl: bad normals not replaced by the view direction (the fallback branch never taken)"),
    # ---- shadows (kernels/shadow.h)
    M("shadow_compare", "kernels/shadow.h", "lit += ((inside == 0) | (ref <= d)) ? (real)(1.0f) : (real)(0.0f);",
      "lit += ((inside == 0) | (ref >= d)) ? (real)(1.0f) : (real)(0.0f);", "shadow compare reversed"),
    M("shadow_bias", "kernels/shadow.h", "#define SHADOW_NORMAL_OFFSET_TEXELS 1.0f", "#define SHADOW_NORMAL_OFFSET_TEXELS 0.0f",
      "shadow normal offset removed (acne)"),
    M("shadow_pcf_norm", "kernels/shadow.h", "return front ? lit / (float)(w * w) : (real)(1.0f);",
      "return front ? lit / (float)(w * w + 1) : (real)(1.0f);", "PCF average over w² + 1 taps"),
    # ---- SIMD lane / tail and storage (kernels/simd.h, gbuffer.h)
    M("simd_iota", "kernels/simd.h", "#define LANE_IOTA ((uint8)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u))",
      "#define LANE_IOTA ((uint8)(0u, 1u, 2u, 3u, 4u, 5u, 7u, 6u))", "SIMD-8: lanes 6 and 7 swapped"),
    M("store_lane", "kernels/gbuffer.h", "float8 t1 = __builtin_shufflevector(x, y, 2, 10, 3, 11, 6, 14, 7, 15);",
      "float8 t1 = __builtin_shufflevector(x, y, 2, 10, 3, 11, 6, 14, 6, 15);",
      "SIMD-8/16 store: lane 7 red written from lane 6"),
    M("store_row_order", "kernels/gbuffer.h", "STORE_ROW8(__builtin_shufflevector(u0, u1, 4, 5, 6, 7, 12, 13, 14, 15), 2, o);",
      "STORE_ROW8(__builtin_shufflevector(u1, u0, 4, 5, 6, 7, 12, 13, 14, 15), 2, o);",
      "SIMD-8/16 store: pixels 4 and 5 swapped"),
    M("any_is_all", "kernels/simd.h", "#define ANY(m) (MASK_BITS(m) != 0)", "#define ANY(m) (MASK_BITS(m) == MASK_FULL)",
      "x86 any(): true only when every lane is set"),
    M("inline_floor", "kernels/simd.h", "__builtin_ia32_roundps256(x.hi, 9)", "__builtin_ia32_roundps256(x.hi, 10)",
      "inline floor (SIMD 16, lanes 8–15) rounds up: shadow-map taps one texel off"),
    M("inline_fabs", "kernels/simd.h", "(x) & 0x7fffffff); }", "(x) & 0x3fffffff); }",
      "inline fabs clears the exponent's top bit (|x| ≥ 2 comes out below 1)"),
    M("inline_half_hi", "kernels/simd.h", "CLSHADE_HALF8(2 * (i) + 1, (p))", "CLSHADE_HALF8(2 * (i), (p))",
      "inline vload_half16: lanes 8–15 load lanes 0–7"),
    M("all_is_any", "kernels/simd.h", "#define ALL(m) (MASK_BITS(m) == MASK_FULL)", "#define ALL(m) (MASK_BITS(m) != 0)",
      "x86 all(): true when one lane is set (material fast path)"),
    M("half_plane", "kernels/gbuffer.h", "#define LOAD_PLANE(i, p) VLOAD_HALF((i), (p))",
      "#define LOAD_PLANE(i, p) VLOAD_HALF((i), (p)) * 0.999f", "half-float G-buffer: loads scaled"),
    M("tail_pad", "clshade/render/gbuffer.py", "planes[:, :self.pixels] = data.T", "planes[:, :self.pixels - 1] = data.T[:, :-1]",
      "channels to planes: drops the last pixel (tail)"),
    M("gbuffer_tail", "clshade/render/gbuffer.py", "            put(depth, fragments.face_depth[part])\n",
      "            depth[lo:hi - 1][mask[:-1]] = fragments.face_depth[part][:-1]\n",
      "G-buffer: depth of each chunk's last pixel dropped"),
    # ---- benchmark measurements (clshade/bench)
    M("stream_triad_bytes", "clshade/bench/bandwidth.py", 'STREAM_BYTES = {"copy": 2 * 4, "triad": 3 * 4}',
      'STREAM_BYTES = {"copy": 2 * 4, "triad": 2 * 4}', "STREAM triad counted as 2 × 4 B per element"),
    M("opencl_triad", "clshade/bench/bandwidth.py", "a[i] = b[i] + s * c[i];   /* STREAM triad */",
      "a[i] = b[i] + c[i];   /* STREAM triad */", "OpenCL STREAM triad without the scalar"),
    M("opencl_triad_streaming", "clshade/bench/bandwidth.py", "STREAMING_STORE(b[i] + s * c[i], a + i);",
      "STREAMING_STORE(b[i] + c[i], a + i);", "OpenCL STREAM triad with streaming stores without the scalar"),
    M("uniform_metallic_value", "kernels/shade.cl", "        real m = saturate((real)(METALLIC_VALUE));",
      "        real m = (real)(0.0f);", "uniform channels: the scene's one metallic value ignored (0 compiled in)"),
    M("uniform_gltf_factor", "clshade/render/gbuffer.py",
      "            values = np.where(textured, factors[np.where(textured, tex, 0)], values)\n", "",
      "uniform channels: glTF faces judged by their scene material, not their texture set's factor"),
    M("peer_drjit_table_const", "clshade/bench/peers.py",
      "return float(table[0, k]) if same[k] else dr.gather(Float, mats, row + k)",
      "return float(table[0, k]) if True else dr.gather(Float, mats, row + k)",
      "Dr.Jit peer: every material-table entry taken from the first material"),
    M("peer_numba_uniform", "clshade/bench/peers.py", "m = metal_value if metal_const else",
      "m = f32(0.0) if metal_const else", "Numba peer: the scene's uniform metallic compiled in as 0"),
    M("unit_normals_default", "clshade/render/gbuffer.py", "    unit_normals: bool = False\n",
      "    unit_normals: bool = True\n", "G-buffers made by hand promise unit normals: the kernel skips normalising them"),
    M("gbuffer_normalise", "clshade/render/gbuffer.py", "                nd *= inv\n",
      "", "G-buffer: interpolated normals not normalised (the kernel trusts UNIT_NORMALS)"),
    M("kernel_unit_normals_always", "kernels/shade.cl", "#ifdef UNIT_NORMALS\n        mask n_ok",
      "#ifndef HALF_GBUFFER\n        mask n_ok", "shade.cl: normals never normalised (UNIT_NORMALS assumed for every G-buffer)"),
    M("peer_numba_unit_normals", "clshade/bench/peers.py", "                    if not unit_normals:\n",
      "                    if unit_normals:\n", "Numba peer: normals normalised only where the G-buffer promises unit ones"),
    M("store_row_offset", "kernels/simd.h",
      "__builtin_nontemporal_store((v), (__global float8*)((p) + 8 * (size_t)(k)))",
      "__builtin_nontemporal_store((v), (__global float8*)((p) + 8 * (size_t)((k) ^ 1)))",
      "streaming image stores: rows 0/1 and 2/3 of each work-item swapped"),
    M("store_two_sites", "kernels/copy.cl", "    real w = VLOAD(i, depth);\n",
      "    real w = VLOAD(i, depth);\n    if (all_empty(w)) {\n        store4(i, out, v3s((real)(0.0f)), w);\n"
      "        return;\n    }\n",
      "copy kernel: a second store4 site for the sky (LLVM merges the sites' last stores and drops the streaming mark)"),
    M("whole_frame_runtimes", "clshade/bench/perf.py", "    for wf in doc.get(\"whole_frames\", []):\n",
      "    for wf in doc.get(\"whole_frames\", [])[:1]:\n", "perf: the whole-frame target judged on the first runtime only"),
    M("frame_blocks_merge", "clshade/bench/frame.py", '        timed = [f for r in per_runtime for f in r["frames_s"]]\n',
      '        timed = list(per_runtime[0]["frames_s"])\n', "whole frames: only the first block's frames counted"),
    M("cache_band_densest", "clshade/bench/perf.py", "best = starts[int(np.argmax(counts[starts + items] - counts[starts]))]",
      "best = starts[int(np.argmin(counts[starts + items] - counts[starts]))]", "in-cache band: the least covered window"),
    # ---- Python stages
    M("raster_top_left", "clshade/render/raster/triangles.py", "owns = (ea > 0.0) | ((ea == 0.0) & (eb > 0.0))",
      "owns = (ea >= 0.0)", "raster: top-left rule broken (ties owned twice)"),
    M("raster_centre", "clshade/render/raster/tiles.py", "    xc = xabs + 0.5\n", "    xc = xabs + 0.0\n",
      "raster: pixel centres at the corner"),
    M("near_clip", "clshade/render/raster/triangles.py", "    dist = z + w  # near plane: dist >= 0 is visible\n",
      "    dist = z + 0.9 * w  # near plane: dist >= 0 is visible\n", "near clipping at the wrong plane"),
    M("clip_fold", "clshade/render/raster/triangles.py", '"cvm,mvj->cjm"', '"cvm,mjv->cjm"',
      "raster: clipped triangles' barycentric map folded in transposed"),
    M("raster_key_merge", "clshade/render/raster/resolve.py", "np.minimum(keys[r], other[r], out=keys[r])",
      "np.maximum(keys[r], other[r], out=keys[r])", "raster: worker key arrays merged by maximum (farthest wins)"),
    M("winner_row", "clshade/render/raster/resolve.py", "    np.floor(py, out=py)\n", "    np.round(py, out=py)\n",
      "raster: winners' pixel row rounded instead of floored (right half of each row one row down)"),
    M("gbuffer_finite", "clshade/render/gbuffer.py", "            finite[part] = ok\n", "            finite[part] = True\n",
      "G-buffer: non-finite pixels not replaced"),
    M("plane_align", "clshade/render/arrays.py", "PLANE_ALIGN: int = 128", "PLANE_ALIGN: int = 64",
      "G-buffer planes not aligned for the device: copied at every launch instead of shared"),
    M("key_reset", "clshade/render/raster/resolve.py", "        keys[r][mask] = EMPTY_KEY\n", "",
      "raster: key array not reset after a batch (stale depths in the next call, which reuses it)"),
    M("worker_key_reset", "clshade/render/raster/resolve.py", "            other[r] = EMPTY_KEY\n", "",
      "raster: a worker's key array not reset after the merge"),
    # ---- rasterizer speed (RasterMesh pre-cull, 8 px tiles, depth-range shortcut, merged classes; in-place
    # winners and G-buffer; issue 27)
    M("raster_precull_sign", "clshade/render/raster/mesh.py", "            back = s < -bound\n",
      "            back = s > bound\n", "raster pre-cull: front faces dropped instead of back faces"),
    M("raster_precull_margin", "clshade/render/raster/mesh.py", "            back = s < -bound\n",
      "            back = s < bound\n", "raster pre-cull: faces within the margin of edge-on (front ones too) dropped"),
    M("raster_precull_double_sided", "clshade/render/raster/mesh.py", "        back &= self.cull[f0:f1]\n", "",
      "raster pre-cull: double-sided faces (cull False) pre-culled as well"),
    M("raster_camera_centre_sign", "clshade/render/raster/mesh.py",
      "    return minors * np.array([1.0, -1.0, 1.0, -1.0])", "    return minors * np.array([1.0, 1.0, 1.0, 1.0])",
      "raster pre-cull: camera centre's cofactor signs dropped (wrong eye)"),
    M("view_raster_mesh_stale", "clshade/view/session.py", '        if kept.get("mesh_of") is not geometry:\n',
      '        if "mesh" not in kept:\n', "viewer: the first geometry's RasterMesh kept after the geometry changed"),
    M("raster_depth_unit_or", "clshade/render/raster/tiles.py", "    return (lo >= -1.0) & (hi <= 1.0)\n",
      "    return (lo >= -1.0) | (hi <= 1.0)\n", "raster: a box reaching past the far plane skips the depth test"),
    M("raster_depth_unit_corner", "clshade/render/raster/tiles.py",
      "    x0, x1 = t.z_a * (t.col0 + 0.5), t.z_a * (t.col1 + 0.5)\n",
      "    x0, x1 = t.z_a * (t.col0 + 0.5), t.z_a * (t.col0 + 0.5)\n",
      "raster: depth range of a box judged from its left corners only"),
    M("raster_merge_class_shape", "clshade/render/raster/tiles.py", "        remap[rare] = side * (n_cls + 1)\n",
      "        remap[rare] = side * n_cls\n", "raster: rare size classes merged into a grid one column wide"),
    M("winners_reused_buffer", "clshade/render/raster/resolve.py", "        by += np.take(t.persp_c[j], tri)\n",
      "        by += np.take(t.persp_c[0], tri)\n", "raster winners: the reused row buffer adds vertex 0's constant"),
    M("gbuffer_reused_term", "clshade/render/gbuffer.py", 'np.take(face[f"n{c}{d}"], tri, out=term, mode="clip")',
      'np.take(face[f"n1{d}"], tri, out=term, mode="clip")',
      "G-buffer: the reused term buffer gathers corner 1's normal for corner 2"),
    M("gbuffer_span_end", "clshade/render/gbuffer.py",
      "            lo, hi = int(pix[part.start]), int(pix[part.stop - 1]) + 1\n",
      "            lo, hi = int(pix[part.start]), int(pix[part.stop - 1])\n",
      "G-buffer: a chunk's span of pixels one short (its last pixel outside the mask)"),
    M("gbuffer_zero_normal", "clshade/render/gbuffer.py", "                inv[~(len2 > 0)] = 0.0\n", "",
      "G-buffer: a zero normal divided by its zero length (NaN, the pixel dropped as non-finite)"),
    M("view_scene_camera_only", "clshade/view/session.py",
      '    return a.keys() == b.keys() and all(a[k] == b[k] for k in a if k != "camera")\n',
      "    return a.keys() == b.keys()\n", "viewer: any change taken for a camera move (the last scene kept, its edits lost)"),
    M("view_finish_kept_raster", "clshade/view/session.py",
      "        gbuffer = self._gbuffer_for(scene, geometry, p.geometry_key, p.fragments, camera, timings)\n",
      "        gbuffer = self._gbuffer_for(scene, geometry, p.geometry_key, self._raster.value, camera, timings)\n",
      "viewer pipeline: a frame shaded on the newest raster (the next state's camera), not its own"),
    M("view_prepared_oldest_kept", "clshade/view/server.py",
      "                        prepared = (seq, result, received, (time.perf_counter() - started) * 1e3)\n",
      "                        prepared = prepared or (seq, result, received, (time.perf_counter() - started) * 1e3)\n",
      "viewer pipeline: a prepared state waiting for the render thread is not replaced by a newer one"),
    M("label_slots", "clshade/report/formats.py", "        for k in range(40):\n", "        for k in range(1):\n",
      "plots: labels of clustered points never moved off each other"),
    M("srgb_decode", "clshade/render/image.py", "((c + 0.055) / 1.055) ** 2.4", "((c + 0.055) / 1.055) ** 2.2",
      "texture sRGB decode: exponent 2.2"),
    M("uv_orientation", "clshade/render/textures.py", "y = (1.0 - uv[:, 1]) * h - 0.5", "y = uv[:, 1] * h - 0.5",
      "texture V axis flipped"),
    M("normal_map_sign", "clshade/render/gbuffer.py",
      "mapped = m[:, 0:1] * T + m[:, 1:2] * B + m[:, 2:3] * normal", "mapped = m[:, 0:1] * T - m[:, 1:2] * B + m[:, 2:3] * normal",
      "normal map: green channel sign"),
    M("mr_channels", "clshade/render/gbuffer.py", "        rough *= mr[:, 1]\n        metal *= mr[:, 2]\n",
      "        rough *= mr[:, 2]\n        metal *= mr[:, 1]\n", "glTF metallic-roughness: G/B swapped"),
    M("gltf_factor", "clshade/render/meshes.py", "tuple(float(c) / 255.0 for c in np.asarray(factor)[:3])",
      "tuple(float(c) / 256.0 for c in np.asarray(factor)[:3])", "glTF baseColorFactor / 256"),
    M("gbuffer_roughness", "clshade/render/gbuffer.py", "rough = np.full(k, t.roughness_factor, np.float32)",
      "rough = np.full(k, t.metallic_factor, np.float32)", "textured G-buffer: roughness channel from metallic factor"),
    M("scene_default_roughness", "clshade/render/scene.py", 'roughness=r.number("roughness", 0.5, 0.0, 1.0),',
      'roughness=r.number("roughness", 0.4, 0.0, 1.0),', "scene default roughness 0.4"),
    M("scene_default_ks", "clshade/render/scene.py", 'ks=r.number("ks", 0.3, 0.0, 1.0),',
      'ks=r.number("ks", 0.25, 0.0, 1.0),', "scene default k_s 0.25"),
    M("tonemap_exposure", "clshade/render/image.py", "scale = 2.0 ** exposure\n", "scale = 2.0 ** (0.5 * exposure)\n",
      "exposure halved"),
    M("tonemap_reinhard", "clshade/render/image.py", "x /= x + 1.0\n", "x /= 0.5 * x + 1.0\n",
      "Reinhard x/(1 + x/2)"),
    M("srgb_encode", "clshade/render/image.py", "np.power(c, 1 / 2.4, out=", "np.power(c, 1 / 2.2, out=",
      "sRGB encode exponent 1/2.2"),
    M("grey_f0_value", "kernels/surface.h", "s.f0 = dielectric ? v3s((real)(F0_DIELECTRIC)) :",
      "s.f0 = dielectric ? v3s((real)(0.05f)) :", "dielectric scenes with metallic compiled in: F0 0.05 instead of 0.04"),
    M("grey_f0_diffuse", "kernels/surface.h", "s.diffuse_color = dielectric ? base :",
      "s.diffuse_color = dielectric ? v3s(base.x) :", "dielectric scenes with metallic compiled in: red base colour on every channel"),
    M("dv_product_den", "kernels/brdf.h", "return (d.num * v.num) / (d.den * v.den);",
      "return (d.num * v.num) / (d.den + v.den);", "GGX lobes: D·V divided by the sum of the denominators"),
    M("power_zero_bound", "kernels/brdf.h", "#define POW_ZERO_BOUND (MIN_EXP2_ARG - 2.0f)",
      "#define POW_ZERO_BOUND (-20.0f)", "Phong/Blinn–Phong powers above FLT_MIN skipped as zero"),
    M("power_zero_log2e", "kernels/brdf.h", "(fmin(fmax(x, MIN_POW_BASE), 1.0f) - 1.0f) * 1.44269504089f <",
      "(fmin(fmax(x, MIN_POW_BASE), 1.0f) - 1.0f) * 4.0f <", "power underflow bound without ln x ≤ x − 1 (too eager)"),
    M("blinn_phong_skip", "kernels/models/blinn_phong.cl", "    if (blinn_phong_lobe_is_zero(g.nh, s.shininess))",
      "    if (!ANY(g.nh > 0.9f))", "Blinn–Phong lobe skipped wherever n·h ≤ 0.9 in every lane"),
    M("power_zero_margin", "kernels/brdf.h", "#define POW_ZERO_BOUND (MIN_EXP2_ARG - 2.0f)",
      "#define POW_ZERO_BOUND (MIN_EXP2_ARG + 3.0f)", "Phong powers just above FLT_MIN (2⁻¹²³) skipped as zero"),
    M("half_vector_below", "kernels/surface.h", "((h_len2 < MIN_HALF_LEN2) | (nH <= 0.0f))",
      "(h_len2 < MIN_HALF_LEN2)", "a half vector below the surface: n·h clamped to 0, sin²θh left at |n × h|²"),
    M("sin2_half_scaled", "kernels/surface.h", ": saturate(v3dot(c, c) * inv_len * inv_len);",
      ": saturate(v3dot(c, c) * inv_len);", "sin²θh = |n × H|²/|H| instead of /|H|² (H = l + v unnormalised)"),
    M("nh_unscaled", "kernels/surface.h", "g.nh = saturate(nH * inv_len);", "g.nh = saturate(nH);",
      "n·h taken with H = l + v not divided by |H|"),
    M("directional_unlit_skip", "kernels/shade.cl", "            if (fmax(fmax(c.x, c.y), c.z) > 0.0f)\n",
      "            if (fmax(fmax(c.x, c.y), c.z) > 1.0f)\n", "directional lights up to irradiance 1 skipped as unlit"),
    M("peer_alpha_bound", "clshade/bench/peers.py", "good &= np.maximum(r * r, MIN_ALPHA) >= WELL_CONDITIONED_ALPHA",
      "good &= np.maximum(r, MIN_ALPHA) >= WELL_CONDITIONED_ALPHA", "peer check: α taken as r, not r²"),
    M("prefetch_dropped", "kernels/shade.cl", "    PREFETCH_AHEAD(i, z);   /* gbuffer.h: the lines of the work-items ahead */",
      "    /* no prefetch */", "the shading kernel no longer prefetches the G-buffer ahead"),
    M("copy_prefetch_dropped", "kernels/copy.cl", "    PREFETCH_AHEAD(i, w);", "    /* no prefetch */",
      "the copy kernel (the floor) no longer prefetches what the shading kernel does"),
    M("prefetch_noop", "kernels/simd.h", "#define PREFETCH(p) __builtin_prefetch((p))", "#define PREFETCH(p) ((void)(p))",
      "PREFETCH a no-op on x86 although CLSHADE_PREFETCH says it prefetches"),
    M("copy_sky_zeros", "kernels/copy.cl", "    vec3 color = v3c(background.xyz);", "    vec3 color = v3s((real)(0.0f));",
      "the copy kernel writes 0 over the sky, where the shading kernel writes the background"),
    M("copy_sky_lanes_zeros", "kernels/copy.cl", "        color = v3select(covered, acc, color);", "        color = acc;",
      "the copy kernel writes the loaded sums (0) in the sky lanes of covered work-items"),
    M("fill_value_unused", "clshade/bench/bandwidth.py", "    STREAMING_STORE((float16)(v), c + i);",
      "    STREAMING_STORE((float16)(1.0f), c + i);", "the fill kernel ignores its value: zeros are never timed"),
    M("fill_line_swapped", "clshade/report/formats.py", "f\"{short(d)} {v['zeros_median_gbs']:.1f} vs {v['ones_median_gbs']:.1f} \"",
      "f\"{short(d)} {v['ones_median_gbs']:.1f} vs {v['zeros_median_gbs']:.1f} \"",
      "perf's fill line quotes the fill of 1.0 as the fill of zeros"),
    M("timed_first_run", "clshade/bench/perf.py", "    timed()\n    return timed()", "    return timed()",
      "perf times each item after whatever the round's order put before it"),
    # ---- device health and runtimes (issue 24: clshade/device/health.py, icd.py, runtime.py)
    M("default_ignores_health", "clshade/device/runtime.py",
      "            if state.ok:\n                return Selection(info, device, tuple(skipped))",
      "            if True:\n                return Selection(info, device, tuple(skipped))",
      "default device: the first in preference order even when its probe failed"),
    M("explicit_broken_allowed", "clshade/device/runtime.py",
      "    if not state.ok:\n        raise ClshadeError(f\"device {info.spec}",
      "    if False:\n        raise ClshadeError(f\"device {info.spec}",
      "an explicitly chosen broken device is used instead of refused"),
    M("preference_gpu_first", "clshade/device/runtime.py", "    return (\"cpu\" not in info.kind, rank,",
      "    return (\"cpu\" in info.kind, rank,", "default order: non-CPU devices before CPU devices"),
    M("health_key_without_env", "clshade/device/health.py", "cl.VERSION_TEXT, PROBE_SOURCE, build_environment()]",
      "cl.VERSION_TEXT, PROBE_SOURCE]", "health cache: key ignores the build environment (POCL_EXTRA_BUILD_FLAGS)"),
    M("probe_output_unchecked", "clshade/device/health.py",
      "    if not abs(float(out[0]) - PROBE_EXPECTED) <= PROBE_TOLERANCE:", "    if False:",
      "health probe: a device that builds but computes wrong values counts as healthy"),
    M("first_line_not_error", "clshade/errors.py",
      "    return next((line for line in useful if \"error\" in line.lower()), useful[0] if useful else \"\")",
      "    return useful[0] if useful else \"\"", "compiler's reason: the first log line, not the first error"),
    M("icd_without_intel", "clshade/device/icd.py", "            out[rt.icd_name] = f\"{lib}\\n\"", "            pass",
      "pip's Intel runtime not registered with the ICD loader"),
    M("icd_overrides_user", "clshade/device/icd.py",
      "    if os.environ.get(ENV_VENDORS, \"\").strip() or os.environ", "    if os.environ",
      "a user's own OCL_ICD_VENDORS replaced by clshade's folder"),
    # ---- hostile inputs (issue 29): the budget, the output checks, the one-line stderr
    M("texture_budget_after_decode", "clshade/render/textures.py", "            budget.texture_pixels(width, height, channels)",
      "            budget.texture_pixels(1, 1, channels)", "a texture's header size is not checked before decoding"),
    M("shadow_budget_2x", "clshade/budget.py", "    if texels > MAX_SHADOW_TEXELS:",
      "    if texels > 2 * MAX_SHADOW_TEXELS:", "the shadow maps' total allowed twice its ceiling"),
    M("scene_lights_unbounded", "clshade/render/scene.py", "    if len(lights_raw) > MAX_LIGHTS:",
      "    if len(lights_raw) > MAX_LIGHTS + 1:", "a scene with one light over the ceiling accepted"),
    M("sweep_columns_unbounded", "clshade/cli.py", "    if len(values) > budget.MAX_SWEEP_COLUMNS:",
      "    if len(values) > 1000 * budget.MAX_SWEEP_COLUMNS:", "sweep columns bounded only by the sheet's size"),
    M("bench_frames_unbounded", "clshade/cli.py",
      'budget.check_count("--frames", args.frames, budget.MAX_FRAMES, low=1)\n    budget.check_count("--warmup"',
      'budget.check_count("--frames", args.frames, 10 ** 30, low=1)\n    budget.check_count("--warmup"',
      "bench --frames without a ceiling"),
    M("special_files_accepted", "clshade/budget.py", "    if not stat.S_ISREG(mode):", "    if stat.S_ISDIR(mode):",
      "devices and FIFOs taken for regular files (only folders refused)"),
    M("coordinates_unbounded", "clshade/budget.py", "MAX_COORDINATE = 1e12", "MAX_COORDINATE = 1.7e308",
      "camera coordinates allowed up to float64's largest (the view matrix overflows)"),
    M("unit_not_prescaled", "clshade/render/transforms.py", "    w = v / largest\n", "    w = v\n",
      "a direction normalised by its Euclidean norm alone (over- and underflows)"),
    M("face_index_off_by_one", "clshade/render/meshes.py", "if f.size and (f.min() < 0 or f.max() >= len(v)):",
      "if f.size and (f.min() < 0 or f.max() > len(v)):", "a face index one past the last vertex accepted"),
    M("obj_zero_unchecked", "clshade/render/meshes.py", '    if path.suffix.lower() == ".obj":\n        _check_obj',
      '    if path.suffix.lower() == ".objx":\n        _check_obj', "OBJ face index 0 not checked"),
    M("model_empty_lobe", "clshade/models.py", "        if not all(names):", "        if not any(names):",
      "'lambert+' accepted (only a spec of '+' alone refused)"),
    M("fresnel_on_diffuse", "clshade/models.py", '    if "@" in spec and not model.uses_fresnel:',
      '    if "@" in text and not model.uses_fresnel:', "the Fresnel suffix looked for after it was split off"),
    M("outputs_may_share", "clshade/cli.py", '    check_distinct([("--json", args.json), ("--csv", args.csv),',
      '    check_distinct([("--json", args.json), ("--csv", None),', "bench --csv may share --json's or --plot's path"),
    M("bench_json_over_input", "clshade/cli.py", 'check_output_file(args.json, "--json", protected=protected)',
      'check_output_file(args.json, "--json")', "bench --json may be the scene"),
    M("long_name_unchecked", "clshade/outputs.py", "    if len(os.fsencode(resolved.name)) > name_max:",
      "    if len(os.fsencode(resolved.name)) > name_max + 64:", "output names up to 64 bytes over the limit pass the check"),
    M("libpng_on_stderr", "clshade/diagnostics.py", "        os.dup2(tmp.fileno(), 2)\n", "        pass\n",
      "what C libraries print while a texture is read reaches stderr"),
    M("freeze_after_error", "clshade/cli.py", "        if status != 2:\n            # Not after a reported error",
      "        if True:\n            # Not after a reported error", "gc.freeze after an error: nanobind's leak report on stderr"),
    M("warnings_uncaptured", "clshade/diagnostics.py", '        warnings.simplefilter("always")\n        try:',
      '        warnings.simplefilter("default")\n        caught = []\n        try:',
      "Python warnings dropped instead of kept for --debug"),
    M("bench_oracle_unchecked", "clshade/bench/run.py",
      "    for m in models:\n        reference.check_model(m)\n    bench = Bench.prepare(", "    bench = Bench.prepare(",
      "bench starts a model the float64 oracle cannot evaluate (a ValueError at the end of the run)"),
    # ---- the live viewer (clshade view): the server's checks, the split, the frames
    M("view_json_nan", "clshade/view/controls.py", "value = json.loads(text, parse_constant=no_constant)",
      "value = json.loads(text)", "viewer: NaN / Infinity in a message read as numbers"),
    M("view_no_upper_bound", "clshade/view/controls.py",
      "if not math.isfinite(value) or not low <= value <= high:", "if not math.isfinite(value) or not low <= value:",
      "viewer: control values above their range accepted"),
    M("view_bool_from_int", "clshade/view/controls.py", "    if not isinstance(value, bool):\n",
      "    if not isinstance(value, (bool, int)):\n", "viewer: 0 / 1 accepted for a switch"),
    M("view_light_index", "clshade/view/controls.py", "int(index_text) >= len(limits.light_kinds)",
      "int(index_text) > len(limits.light_kinds)", "viewer: light index one past the last accepted"),
    M("view_material_name", "clshade/view/controls.py", "        if name not in limits.materials:\n",
      "        if False:\n", "viewer: a material the scene does not have accepted"),
    M("view_save_name", "clshade/view/session.py", "if not isinstance(name, str) or not SAVE_NAME.match(name):",
      "if not isinstance(name, str) or not name:", "viewer: save names with a path (../x) accepted"),
    M("view_split_hides_b", "clshade/view/session.py", "        if controls.split or controls.diff:\n",
      "        if controls.diff:\n", "viewer: the split renders no model B"),
    M("view_patch_uncovered", "clshade/view/session.py", "    material = gbuffer.plane(\"material\")[0][pixels]\n",
      "    material = gbuffer.plane(\"material\")[0]\n    pixels = np.arange(len(material))\n",
      "viewer: a roughness edit also written into uncovered pixels (material id 0 there)"),
    M("view_host_unchecked", "clshade/view/server.py", "if self.token is None and not is_loopback(host):",
      "if False:", "viewer: any Host header answered (DNS rebinding)"),
    M("view_origin_unchecked", "clshade/view/server.py",
      'if origin is not None and origin != f"{request.scheme}://{request.host}":', "if False:",
      "viewer: WebSockets from another origin's page accepted"),
    M("view_any_token", "clshade/view/server.py",
      'not secrets.compare_digest(request.query.get("token", ""), self.token)', 'not request.query.get("token")',
      "viewer: any token accepted on a non-loopback address"),
    M("view_stale_not_counted", "clshade/view/server.py",
      "                    self.skipped += 1               # superseded before it was rendered",
      "                    pass", "viewer: superseded states not counted as skipped"),
    M("view_split_whole_b", "clshade/view/static/view.js", "ctx.putImageData(views.b, 0, 0, x, 0, w - x, h);",
      "ctx.putImageData(views.b, 0, 0);", "viewer page: model B drawn over the whole frame, not right of the divider"),
    M("view_cost_stale", "clshade/view/static/view.js", "  costHeader = header;\n  if (costTimer !== null) return;",
      "  if (costTimer !== null) return;\n  costHeader = header;",
      "viewer page: a throttled cost readout shows an older frame's figures, not the newest"),
    M("code_commit_is_head", "benchmarks/mutants.py", '"HEAD", "--", *freshness.PRODUCERS' '["mutants.json"]) or head',  # split: see above
      '"HEAD") or head', "mutants.py names HEAD (a results-only commit) instead of the last commit of the code"),
    M("provenance_kernels_rendered", "clshade/provenance.py", '"REPORT.md", "docs")', '"REPORT.md", "docs", "kernels")',
      "provenance: a kernel edited in the checkout does not make a measurement dirty"),
    M("numpy_dot_channel", "clshade/bench/numpy_baseline.py", "    out += a[:, 2] * l[2]\n", "    out += a[:, 2] * l[1]\n",
      "NumPy baseline: n·l takes the light's y for its z"),
    M("minimal_lambert_no_z", "clshade/bench/numpy_baseline.py", "        nl += normal[:, 2] * l[2]\n", "",
      "straw-man guard: the minimal Lambert drops n_z l_z (a cheaper yardstick than a Lambert)"),
    M("plugin_assertion_is_build_failure", "benchmarks/mutant_plugin.py",
      'BUILD_FAILED in text and not _crash(report).startswith("AssertionError")', "BUILD_FAILED in text",
      "mutant plugin: a test that checks a build error's message counts as a compile-error kill"),
    M("view_cost_no_trailing", "clshade/view/static/view.js", "if (wait <= 0) show(); else costTimer = setTimeout(show, wait);",
      "if (wait <= 0) show();", "viewer page: the cost readout skips the last frames of a burst (no trailing update)"),
    # ---- the live viewer's speed (issue 27): kept Shader, runtime material, patched base colour, pooled planes
    M("view_rebind_camera", "clshade/device/shade.py",
      "old, self.gb, self.scene, self.camera = self.gb, gbuffer, scene, camera or scene.camera",
      "old, self.gb, self.scene = self.gb, gbuffer, scene",
      "viewer: a rebound Shader keeps the previous frame's camera (orbit shades with stale view rays)"),
    M("view_runtime_bakes", "clshade/device/variants.py",
      "if len(table) and not features.runtime_material and np.all(table[:, mask] == table[0][mask]):",
      "if len(table) and np.all(table[:, mask] == table[0][mask]):",
      "viewer: one-material scenes compile the material constants in (a ks slider builds a program)"),
    M("view_runtime_uniform", "clshade/device/variants.py", "            features = replace(features, uniform=())\n",
      "            pass\n", "viewer: uniform roughness / metallic compiled in (a roughness slider builds a program)"),
    M("view_patch_base_channel", "clshade/view/session.py", "                plane[c][rows] = new[index, columns.start + c]",
      "                plane[0][rows] = new[index, columns.start + c]",
      "viewer: a base colour edit writes all three channels into the red plane"),
    M("view_face_key_base", "clshade/view/session.py",
      "return tuple((tuple(m.base_color), m.roughness, m.metallic, tuple(m.emissive)) for m in mats)",
      "return tuple((m.roughness, m.metallic, tuple(m.emissive)) for m in mats)",
      "viewer: face tables kept across a base colour edit (the next orbit shows the old colour)"),
    M("view_pool_in_use", "clshade/render/arrays.py", "sys.getrefcount(self._blocks[i]) == 2:",
      "sys.getrefcount(self._blocks[i]) <= 3:", "plane pool: a block still referenced by one array handed out again"),
    M("display_cross_strict", "kernels/display.cl", "return base[b] + (uchar)(x >= cross[b]);",
      "return base[b] + (uchar)(x > cross[b]);", "device display: a value exactly at a level's threshold one level low"),
    # ---- the visibility buffer on the device (kernels/visibility.cl, clshade/device/visibility.py; issue 27)
    M("visibility_key_reset", "kernels/visibility.cl",
      "    VSTORE((lvec)(EMPTY_KEY), i, keys);    /* empty again for the next frame's cover */\n", "",
      "device visibility buffer: keys not reset after a frame (the last frame's nearer fragments win the next)"),
    M("cover_box_columns", "kernels/visibility.cl", "const lvec in_box = convert_lvec(LANE_IOTA < bw - h);",
      "const lvec in_box = convert_lvec(LANE_IOTA < TILE - h);",
      "device cover: a tile's columns past the triangle's box tested (past the image's right edge: the next row)"),
    M("cover_depth_range", "kernels/visibility.cl", "                              & ((ax2 + byc2) >= thr[2]) & (z >= z_lo) & (z <= z_hi);",
      "                              & ((ax2 + byc2) >= thr[2]);", "device cover: fragments beyond the near and far planes kept"),
    M("visibility_w_is_depth", "kernels/visibility.cl", "    if (!w_is_depth || any(bad & hitl)) {",
      "    if (any(bad & hitl)) {", "device G-buffer: an orthographic depth taken as area2 / s (perspective only)"),
    M("visibility_corner_row", "kernels/visibility.cl", "    ny = ny + GF(corner_normal + 4 * nface, f) * b1;",
      "    ny = ny + GF(corner_normal + 7 * nface, f) * b1;",
      "device G-buffer: the second corner's normal y read from the third corner"),
    M("visibility_nonfinite_cover", "kernels/visibility.cl",
      "select(select((ivec)(0), (ivec)(2), hit), (ivec)(1), ok)", "select(select((ivec)(0), (ivec)(1), hit), (ivec)(1), ok)",
      "device G-buffer: pixels with non-finite inputs counted as covered"),
    M("visibility_sky_depth", "kernels/visibility.cl", "        VSTORE(fzero, i, depth);\n", "",
      "device G-buffer: sky pixels keep the depth a recycled plane held"),
    M("device_gbuffer_textures", "clshade/device/visibility.py",
      "    return geometry.face_texture is None and all(e in extensions for e in EXTENSIONS)",
      "    return all(e in extensions for e in EXTENSIONS)",
      "device G-buffer: used for textured scenes too (their textures never sampled)"),
    M("cover_lane_chunk", "kernels/visibility.cl", "__global long* row = keys + (size_t)(y0 + r) * width + x0 + h;",
      "__global long* row = keys + (size_t)(y0 + r) * width + x0;",
      "device cover at 4 lanes: a tile row's second half written over its first"),
    M("double_lanes_narrow", "clshade/device/runtime.py", "return 8 if native >= 8 and not self.narrow_target else 4",
      "return 8 if native >= 8 else 4",
      "device G-buffer: double8 on pip's PoCL 3.0 on an AVX-512 host (its cached program lists no kernels)"),
    M("verify_planes", "clshade/device/visibility.py", "        if differ:\n", "        if differ and name == 'depth':\n",
      "viewer's device check: only the depth plane compared"),
    M("verify_cover", "clshade/device/visibility.py", "    if not np.array_equal(np.flatnonzero(cover), fragments.pixels):",
      "    if False:", "viewer's device check: the coverage not compared"),
    M("view_unverified_device", "clshade/view/session.py", "        if reason is None:\n            return device",
      "        if device is not None:\n            return device",
      "viewer: a device whose check frame differs from the host's used all the same"),
    M("view_fallback_cover", "clshade/view/session.py", "                    cover[host.pixels] = 1\n", "",
      "viewer: the frame that turns the device path off keeps no coverage (the next slider patches no pixel)"),
    M("pool_empty_fills", "clshade/render/arrays.py", "        return self.empty(shape, dtype, align, fill=True)",
      "        return self.empty(shape, dtype, align)", "plane pool: zeros() hands out a recycled block unfilled"),
    # ---- user lobes: the GLSL translator (clshade/glsl.py), .brdf parameters, the tangent frame, the fp64 build
    M("glsl_precedence", "clshade/glsl.py", '''("<", ">", "<=", ">="), ("+", "-"), ("*", "/", "%"))''',
      '''("<", ">", "<=", ">="), ("*", "/", "%"), ("+", "-"))''', "GLSL: + and - bind tighter than * and /"),
    M("glsl_swizzle", "clshade/glsl.py", '''return ["xyzw"[i] for i in idx]''', '''return ["xyzw"[i] for i in sorted(idx)]''',
      "GLSL: a swizzle's components in xyz order (.zyx reads as .xyz)"),
    M("glsl_int_division", "clshade/glsl.py", '''        if kind == "int":
            lit = None''', '''        if kind == "int" and op != "/":
            lit = None''', "GLSL: int / int divides as floats (7 / 2 = 3.5, not 3)"),
    M("glsl_int_literal", "clshade/glsl.py", '''                return Value("float", f"G_LIT({_float_text(v.literal)})", v.literal)''',
      '''                return Value("float", f"G_LIT({_float_text(str(int(v.literal) + 0.5))})", v.literal)''',
      "GLSL: an int literal converted to float is off by one half"),
    M("glsl_else_mask", "clshade/glsl.py", '''self.out.append(f"{pad}mask x_else{k} = {outer}!({cond.code});")''',
      '''self.out.append(f"{pad}mask x_else{k} = {outer}({cond.code});")''', "GLSL: the else branch acts where the if did"),
    M("glsl_return_not_done", "clshade/glsl.py", '''self.out.append(f"{pad}x_done = x_done || {p};")''',
      '''self.out.append(f"{pad}x_done = x_done;")''', "GLSL: an early return does not stop later statements"),
    M("glsl_ternary_swapped", "clshade/glsl.py", '''            return Value(kind, self.select(kind, c.code, self.coerce(a, kind, n.line).code,
                                           self.coerce(b, kind, n.line).code))''', '''            return Value(kind, self.select(kind, c.code, self.coerce(b, kind, n.line).code,
                                           self.coerce(a, kind, n.line).code))''', "GLSL: ?: returns the other branch"),
    M("glsl_pow_products", "clshade/glsl.py", '''{1: f"({code[0]})", 2: f"sq({code[0]})", 3: f"g1_pow3({code[0]})",''',
      '''{1: f"({code[0]})", 2: f"sq({code[0]})", 3: f"sq({code[0]})",''', "GLSL: pow(x, 3.0) expanded as x²"),
    M("glsl_mix_order", "kernels/glsl.h", "INLINE real g1_mix(real a, real b, real t) { return a + (b - a) * t; }",
      "INLINE real g1_mix(real a, real b, real t) { return b + (a - b) * t; }", "GLSL mix(a, b, t) weights t on a"),
    M("tangent_frame_sign", "kernels/surface.h", "    *y = v3(b, sign + n.y * n.y * a, -n.y);",
      "    *y = v3(b, sign + n.y * n.y * a, n.y);", "tangent frame: the bitangent's z flipped (not orthonormal)"),
    M("brdf_param_ignored", "clshade/brdf_explorer.py",
      '''            value = float(parse_value("float", values[name], f"--param {name}")) if name in values else default''',
      '''            value = default''', "--param NAME=VALUE ignored for float parameters"),
    M("surface_frame_crossed", "kernels/surface.h", "    g->x = v3select(ok, t, g->x);",
      "    g->x = v3select(ok, v3cross(n, t), g->x);", "G-buffer tangent frame: x = y = n × t"),
    M("tangent_channel_dropped", "clshade/device/variants.py",
      '''        extra += ("tangent",) if tangents and "tangents" in model.uses else ()''',
      '''        extra += ()''', "the G-buffer's tangents never reach a lobe that reads the frame"),
    M("double_build_float", "kernels/simd.h", "#ifdef REAL_DOUBLE\ntypedef double real;",
      "#ifdef REAL_DOUBLE\ntypedef float real;", "the double-precision build computes in float32"),
    # ---- the counting build and the stability verdict (kernels/count.h, clshade/verify/stability.py)
    M("count_nan_missed", "kernels/count.h", "    if (bits > 0x7f800000u)\n", "    if (bits > 0xffffffffu)\n",
      "count.h: a raw NaN term is never counted"),
    M("count_inf_missed", "kernels/count.h", "    else if (bits == 0x7f800000u)\n", "    else if (bits == 0u && 0)\n",
      "count.h: a raw ±Inf term is never counted"),
    M("count_negative_missed", "kernels/count.h", "    else if ((as_uint(x) >> 31) && bits != 0u)\n",
      "    else if ((as_uint(x) >> 31) && bits == 0u)\n", "count.h: a negative raw term is never counted"),
    M("fresnel_counted_after_clamp", "kernels/surface.h",
      "v3s(saturate(RAW(s, TERM_F, F_Dielectric_unclamped(c, s.ior), 1.0f)))",
      "v3s(RAW(s, TERM_F, F_Dielectric(c, s.ior), 1.0f))",
      "the dielectric Fresnel counted after its saturate (which turns NaN into 0)"),
    M("stability_deviation_ignored", "clshade/verify/stability.py",
      "if not r.fast_math and not deviation <= PRECISE_TOLERANCE:", "if False:",
      "check stability ignores the deviation from float64"),
    M("stability_raw_inf_ignored", "clshade/verify/stability.py",
      "sum(r.nonfinite for r in self.results) + sum(s.nonfinite for s in self.shading)",
      "sum(r.nonfinite for r in self.results) + sum(s.nan for s in self.shading)",
      "check stability counts a raw +Inf pixel as saturation, not as a failure"),
    M("fast_above_fails_precise_too", "clshade/verify/stability.py",
      'bad = {k: v for k, v in bad.items() if not (r.fast_math and k == "above")}',
      'bad = {k: v for k, v in bad.items() if not k == "above"}',
      "check stability: a term above its bound no longer fails the precise build"),
    M("stability_term_counts_ignored", "clshade/verify/stability.py",
      "for term, bad in counts.failures(r.terms).items():", "for term, bad in {}.items():",
      "check stability ignores the counting build's raw-term counts"),
    M("shade_grid_ior_one", "clshade/verify/stability.py", "for ior, f90 in ((1.5, 1.0), (3.0, 0.0))",
      "for ior, f90 in ((1.0, 0.0), (1.0, 0.0))", "the shaded grid's IOR back at 1 (dielectric F = 0: the Fresnel path unexercised)"),
    M("kdks_ior_unread", "clshade/models.py", "            if self.specular != NONE:   # F0",
      "            if self.fresnel == \"schlick\" and self.specular != NONE:   # F0",
      "kdks: the IOR counted as read only under Schlick (a conductor variant bakes the first material's)"),
    # ---- the oracle stands alone (clshade/verify/reference/constants.py states its constants; kernels differ → a test fails)
    M("kernel_light_floor", "kernels/shade.cl", "#define MIN_LIGHT_DIST2 1.0e-8f", "#define MIN_LIGHT_DIST2 1.0e-6f",
      "shade.cl: the light-distance floor 100× larger (the oracle used to inherit it)"),
    M("kernel_shadow_bias", "kernels/shadow.h", "#define SHADOW_BIAS_TEXELS          0.5f",
      "#define SHADOW_BIAS_TEXELS          1.5f", "shadow.h: depth bias 3× larger (the oracle used to inherit it)"),
    M("oracle_fresnel_lobes", "clshade/verify/reference/constants.py", "FRESNEL_LOBES: frozenset[str] = frozenset(MICROFACET_MODELS)",
      "FRESNEL_LOBES: frozenset[str] = frozenset(MICROFACET_MODELS[1:])",
      "oracle: Cook–Torrance's k_d no longer takes F's share"),
    # ---- evidence tied to its code (benchmarks/freshness.py, publish.py, the kill classes above)
    M("freshness_range_reversed", "benchmarks/freshness.py", 'out = git(root, "rev-list", f"{commit}..HEAD", "--", *code)',
      'out = git(root, "rev-list", f"HEAD..{commit}", "--", *code)', "freshness: a later change to the code is not seen"),
    M("publish_aa_unrendered", "benchmarks/publish.py",
      '        out[RESULTS / "aa.md"] = lambda text: aa_markdown(load(RESULTS / "aa.json"))',
      "        pass", "publish: aa.md left out of the renderings (a hand edit there goes unseen)"),
    M("snapshot_kill_behavioural", "benchmarks/mutants.py",       # split: the catalogue must not contain it
      '(("snap' 'shot", "snapshot"), ("text", "text"), ("extra", "needs extra"))',
      '(("text", "text"), ("extra", "needs extra"))', "mutation score: a kill by a snapshot test counted as behavioural"),
    # ---- the NumPy baseline and its straw-man guard (clshade/bench/numpy_baseline.py, run.py, publish.py)
    M("numpy_lambert_pi", "clshade/bench/numpy_baseline.py", "INV_PI = f32(1.0 / math.pi)", "INV_PI = f32(0.5 / math.pi)",
      "NumPy baseline: diffuse lobes use 1/(2π)"),
    M("numpy_schlick_pow4", "clshade/bench/numpy_baseline.py", "return f0 + (f90 - f0) * pow5(1 - c)",
      "return f0 + (f90 - f0) * (1 - c) ** 4", "NumPy baseline: Schlick's Fresnel with (1 − c)⁴"),
    M("numpy_ggx_v_half", "clshade/bench/numpy_baseline.py", "return (a2 * f32(0.5)) / (d_ggx_den(g, a2) * (gv + gl))",
      "return (a2 * f32(0.25)) / (d_ggx_den(g, a2) * (gv + gl))", "NumPy baseline: height-correlated V with 0.25"),
    M("numpy_oren_nayar_b", "clshade/bench/numpy_baseline.py", "f32(0.45) * s2 / (s2 + f32(0.09))",
      "f32(0.45) * s2 / (s2 + f32(0.9))", "NumPy baseline: Oren–Nayar B denominator 0.09 → 0.9"),
    M("numpy_ambient_kd", "clshade/bench/numpy_baseline.py",
      "wd = add(wd, s.ka * ambient * ((1 - s.f0) if fresnel and metallic_wf else s.kd))",
      "wd = add(wd, s.ka * ambient * s.kd)", "NumPy baseline: ambient diffuse weight ignores F0 (k_d = 1)"),
    M("numpy_zero_normal", "clshade/bench/numpy_baseline.py",
      "            n[bad] = v[bad] if v is not None else view(bad if idx is None else idx[bad])",
      "            pass", "NumPy baseline: a zero normal stays zero instead of facing the viewer"),
    M("numpy_background", "clshade/bench/numpy_baseline.py", "            L[depth <= 0] = background\n",
      "            L[depth <= 0] = 0\n", "NumPy baseline (every-pixel layout): empty pixels black, not the background"),
    M("numpy_unverified", "clshade/bench/run.py", "    if c.numpy_check <= VERIFY_RTOL:", "    if True:",
      "bench: the NumPy baseline is timed even when it differs from the kernel's image"),
    M("numpy_guard_limit", "clshade/bench/numpy_baseline.py", "return ratio, ratio > SUSPECT_RATIO",
      "return ratio, ratio >= SUSPECT_RATIO", "straw-man guard: a ratio of exactly 1.5 marked suspect"),
    M("numpy_guard_mean", "clshade/bench/numpy_baseline.py", "ratio = float(np.median([a / b for a, b in pairs]))",
      "ratio = float(np.mean([a / b for a, b in pairs]))", "straw-man guard: the mean of the pairs' ratios (one loaded pair moves it)"),
    M("numpy_suspect_unmarked", "benchmarks/publish.py",
      'return " (suspect)" if (doc.get("numpy_guard") or {}).get("suspect") else ""', 'return ""',
      "published tables: a suspect NumPy column is not marked"),
    # ---- the mutation runner's own test selection (benchmarks/impact.py)
    M("impact_reads_ignored", "benchmarks/impact.py", "elif file in got.whole or file in got.read:",
      "elif file in got.whole:", "impact: a kernel source read by a test file does not select that file"),
    M("impact_statement_first_line", "benchmarks/impact.py",
      "out.update(range(inner.lineno, (inner.end_lineno or inner.lineno) + 1))", "out.add(line)",
      "impact: a mutated continuation line is looked up alone (coverage names a statement by its first line)"),
    M("impact_failed_recording_trusted", "benchmarks/impact.py",
      "if got.returncode not in RECORDED_OK or not got.lines:", "if got.returncode not in RECORDED_OK and not got.lines:",
      "impact: a test file whose recording failed is trusted (left out of mutants it may reach)"),
    M("impact_children_unsaved", "benchmarks/impact.py", "    atexit.register(save)\n", "\n",
      "impact: no process saves its coverage (every open counts whole: a selection wider than needed)"),
    M("resume_reruns_done", "benchmarks/mutants.py", 'if commit and r.get("commit") ' '== commit',  # split: see above
      'if commit and r.get("commit") ' '!= commit', "--resume: runs the rows already measured on this commit, skips the rest"),
    M("known_stale_in_producers", "benchmarks/freshness.py", '"mutants.json": ("benchmarks/mutants.py", ',
      '"mutants.json": ("benchmarks", ', "the known-stale list inside mutants.json's producers (off the list = stale again)"),
    # ---- portability: what the NVIDIA H100 run found (/work/notes/gpu/REPORT.md, 2026-11-26)
    M("buildlog_not_relocated", "clshade/device/runtime.py", "log = relocate(str(exc).strip(), source)",
      "log = str(exc).strip()", "build errors of a compiler that ignores #line (NVIDIA) keep <kernel>:N, not file:line"),
    M("buildlog_marker_counted", "clshade/device/buildlog.py", 'line = int(marker.group("line"))',
      'line = int(marker.group("line")) + 1', "#line N read as numbering itself N (every mapped line one too far)"),
    M("buildlog_rewrites_honoured", "clshade/device/buildlog.py",
      'if not files or re.search("(?:" + "|".join(map(re.escape, sorted(files))) + r"):\\d+:", log):',
      "if not files:", "a log that already names our files (PoCL) is relocated again as if it counted program lines"),
    M("shininess_exact_zero", "kernels/brdf.h", "{ return fabs(n) < MIN_SHININESS; }", "{ return n == 0.0f; }",
      "Phong's 0ⁿ: a denormal n is 0 only where the build flushes denormals (NVIDIA fast math: 1 vs 0)"),
    M("phong_skip_denormal", "kernels/brdf.h", "(!(rv > 0.0f) & !shininess_is_zero(n))", "(!(rv > 0.0f) & (n != 0.0f))",
      "Phong's skip test claims 0 behind the mirror for a denormal n that Fs_Phong reads as 0 (0⁰ = 1)"),
    M("oracle_shininess_as_given", "clshade/verify/reference/frame.py", "shininess=kernel_shininess(m[:, 0, 3])",
      "shininess=m[:, 0, 3]", "float64 oracle: a denormal shininess is not read as 0 as the kernels read it"),
    M("numpy_shininess_exact_zero", "clshade/bench/numpy_baseline.py", "np.abs(s.shininess) < MIN_SHININESS",
      "s.shininess == 0", "NumPy baseline: Phong's 0ⁿ with a denormal n differs from the kernel's"),
    M("runtime_label_opencl_version", "clshade/device/runtime.py", "version.group(2) or version.group(1)",
      "version.group(1)", "runtime label: NVIDIA's runtime named by its OpenCL version (NVIDIA CUDA 3.0)"),
    M("stability_zero_rule_dropped", "clshade/verify/stability.py", 'if getattr(r, "nonzero_where_zero", 0):',
      "if False:", "check stability: a fast build non-zero where the reference is exactly 0 passes (NVIDIA's 1000)"),
    M("devices_footnote_always_cpu", "clshade/cli.py", '    if "cpu" in default.kind:\n', "    if True:\n",
      "clshade devices: the footnote says a CPU device is the default when a GPU is"),
]


def apply(root: Path, mutant: Mutant) -> None:
    """Apply one mutant in the tree at `root`; the original must occur exactly once."""
    path = root / mutant.file
    text = path.read_text(encoding="utf-8")
    count = text.count(mutant.original)
    if count != 1:
        raise SystemExit(f"mutant {mutant.name}: snippet found {count} times in {mutant.file} "
                         f"(the catalogue must track the code): {mutant.original!r}")
    path.write_text(text.replace(mutant.original, mutant.replacement), encoding="utf-8")


def check_catalogue(root: Path = ROOT) -> None:
    """Every snippet occurs exactly once and names are unique (no tests run)."""
    names = [m.name for m in CATALOGUE]
    dupes = {n for n in names if names.count(n) > 1}
    if dupes:
        raise SystemExit(f"duplicate mutant names: {sorted(dupes)}")
    for mutant in CATALOGUE:
        text = (root / mutant.file).read_text(encoding="utf-8")
        if text.count(mutant.original) != 1:
            raise SystemExit(f"mutant {mutant.name}: snippet found {text.count(mutant.original)} times in "
                             f"{mutant.file}: {mutant.original!r}")


def head_commit() -> str | None:
    return freshness.git(ROOT, "rev-parse", "HEAD")


def code_commit(root: Path = ROOT) -> str | None:
    """The commit the results name: the last one up to HEAD that changed the catalogue's code
    (freshness.PRODUCERS["mutants.json"]). HEAD's tree holds that code as it was there, so a run
    resumed after commits of results only names the same commit (and goes on where it stopped)."""
    head = freshness.git(root, "rev-parse", "HEAD")
    if not head:
        return None
    return freshness.git(root, "log", "-1", "--format=%H", "HEAD", "--", *freshness.PRODUCERS["mutants.json"]) or head


def snapshot(dest: Path) -> None:
    """The tree under test: the committed HEAD (git archive), so that edits made while the catalogue runs
    cannot leak into a mutant; a plain copy of the working tree where there is no git checkout."""
    if head_commit():
        dest.mkdir(parents=True)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", "HEAD"], capture_output=True,
                                 check=True)
        subprocess.run(["tar", "-x", "-C", str(dest)], input=archive.stdout, check=True)
    else:
        shutil.copytree(ROOT, dest, ignore=COPY_IGNORE)


def test_order(root: Path, mutant: Mutant) -> list[str]:
    """Every test file, those that name the mutated module (or kernel file: `glsl.h`) first (the likeliest
    to fail), then the rest in the usual order."""
    files = sorted((root / "tests").glob("test_*.py"))
    module = mutant.file.removesuffix(".py").replace("/", ".")       # clshade.render.image
    if mutant.file.startswith("kernels/"):
        module = mutant.file.removeprefix("kernels/")                 # glsl.h, models/phong.cl
    first = [f for f in files if module in f.read_text(encoding="utf-8")]
    return [str(f.relative_to(root)) for f in first + [f for f in files if f not in first]]


KILL_CLASSES = ("behavioural", "compile error", "collection error", "snapshot", "text", "needs extra")


def classify(failures: list[dict], returncode: int | None) -> str:
    """The kill class of one mutant from its failing tests (mutant_plugin records), or
    'survived' / 'timeout'."""
    if returncode == -1:
        return "timeout"
    if not failures:
        return "survived" if returncode in (0, 5) else "collection error"
    def one(f: dict) -> str:
        if f["when"] == "collect":
            return "collection error"
        if f["build_failed"]:
            return "compile error"
        for marker, cls in (("snapshot", "snapshot"), ("text", "text"), ("extra", "needs extra")):
            if marker in f["markers"]:
                return cls
        return "behavioural"
    found = {one(f) for f in failures}
    return next(c for c in KILL_CLASSES if c in found)


def installed_extras(python: str) -> dict[str, bool]:
    """Which optional packages the suite's interpreter has (tests marked `extra` need them)."""
    code = ("import importlib.util, json; print(json.dumps({m: importlib.util.find_spec(m) is not None "
            "for m in ('matplotlib', 'numba', 'drjit')}))")
    proc = subprocess.run([python, "-c", code], capture_output=True, text=True)
    return json.loads(proc.stdout) if proc.returncode == 0 else {}


# The unmutated tree, run once like a mutant: tests failing there kill nothing.
BASELINE = Mutant("(baseline)", "", "", "", "the snapshot itself, unmutated")


def suite_env(copy: Path) -> dict[str, str]:
    """The environment of a suite run in `copy`: the copy's Python code and kernels are the ones used."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(copy), str(copy / "benchmarks")]),
               PYTHONDONTWRITEBYTECODE="1",
               CLSHADE_TEST_ONE_RUNTIME="1",          # tests/conftest.py: device_runtime tests on the default device
               CLSHADE_TEST_NO_LOCAL_CONSTANTS="1")   # and Hypothesis's examples independent of other modules
    env.pop("CLSHADE_EXPECT_INSTALLED", None)
    return env


def run_one(mutant: Mutant, python: str, base: Path, baseline: frozenset[str] = frozenset(),
            files: list[str] | None = None) -> dict:
    """Copy the snapshot `base`, apply the mutant, run the suite there — the test files `files` that the
    mutant can change (benchmarks/impact.py), or the whole suite where `files` is None; every failing test
    is recorded, and the kill classified on the tests that pass on the unmutated tree (`baseline`:
    the tests failing there, listed apart)."""
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix=f"mutant-{mutant.name}-") as tmp:
        copy = Path(tmp) / "repo"
        shutil.copytree(base, copy)
        if mutant is not BASELINE:
            apply(copy, mutant)
        report = Path(tmp) / "failures.json"
        env = dict(suite_env(copy), CLSHADE_MUTANT=mutant.name, CLSHADE_MUTANT_REPORT=str(report))
        where = subprocess.run([python, "-c", "import clshade.resources as r; print(r.kernels_dir())"],
                               cwd=copy, env=env, capture_output=True, text=True)
        kernels = where.stdout.strip()
        if where.returncode or not Path(kernels).resolve().is_relative_to(copy.resolve()):
            raise SystemExit(f"mutant {mutant.name}: the copy's kernels are not the ones used ({kernels!r} "
                             f"{where.stderr.strip()})")
        every = test_order(copy, mutant)
        order = [f for f in every if files is None or f in files]
        if not order:          # no test file reaches the mutated code: nothing can fail
            rc, tail = 5, ["no test file reaches the mutated code"]
        else:
            try:
                proc = subprocess.run([python, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "mutant_plugin",
                                       *order], cwd=copy, env=env, capture_output=True, text=True,
                                      timeout=TEST_TIMEOUT_S)
                rc, tail = proc.returncode, proc.stdout.strip().splitlines()
            except subprocess.TimeoutExpired:
                rc, tail = -1, ["timeout"]
        failures = json.loads(report.read_text(encoding="utf-8")) if report.exists() else []
    new = [f for f in failures if f["test"] not in baseline]
    kill = classify(new, 0 if failures and not new else rc)
    return dict(name=mutant.name, file=mutant.file, description=mutant.description,
                status="killed" if kill not in ("survived", "timeout") else kill, kill_class=kill, returncode=rc,
                failing_tests=[dict(test=f["test"], kind=classify([f], 1)) for f in new],
                failing_on_baseline_too=sorted({f["test"] for f in failures} - {f["test"] for f in new}),
                seconds=round(time.perf_counter() - start, 1), summary=tail[-1] if tail else "",
                test_files_run=len(order), test_files_total=len(every))


def record_impact(base: Path, commit: str | None, keep: str | None = None) -> dict[str, impact.FileImpact]:
    """Record, on an unmutated copy of the snapshot, what each test file reaches (benchmarks/impact.py)."""
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="mutants-impact-") as tmp:
        copy = Path(tmp) / "repo"
        shutil.copytree(base, copy)
        got = impact.record(copy, sys.executable, suite_env(copy))
    if keep:
        Path(keep).write_text(json.dumps(dict(commit=commit, files=impact.to_json(got))) + "\n", encoding="utf-8")
    print(f"impact recorded for {len(got)} test files in {time.perf_counter() - start:.0f} s", flush=True)
    return got


MAX_IMPACT_BYTES = 256 << 20     # a kept map is a few MB; a larger file is not one


def _seconds(text: str) -> float:
    """--budget-s: a positive, finite number of seconds."""
    value = float(text)
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: not a positive, finite number of seconds")
    return value


def load_impact(path: str, commit: str | None) -> dict[str, impact.FileImpact]:
    """A map kept by --impact-json; it must name the commit the mutants run on."""
    file = Path(path)
    if not file.is_file() or file.stat().st_size > MAX_IMPACT_BYTES:
        raise SystemExit(f"{path}: --impact-from needs a map kept by --impact-json (a regular file of at most "
                         f"{MAX_IMPACT_BYTES >> 20} MB)")
    doc = json.loads(file.read_text(encoding="utf-8"))
    if not commit or doc.get("commit") != commit:
        raise SystemExit(f"{path}: impact map recorded on {doc.get('commit')!r}, the mutants run on {commit!r}; "
                         "record it again (--impact-json)")
    return impact.from_json(doc["files"])


def _run_within(chosen: list[Mutant], run, jobs: int, deadline: float | None):
    """Yield run(m) for the mutants in order, `jobs` at a time, starting none after `deadline` (perf_counter)."""
    from concurrent.futures import FIRST_COMPLETED, wait
    todo = list(chosen)
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        running = set()
        while todo or running:
            while todo and len(running) < jobs and (deadline is None or time.perf_counter() < deadline):
                running.add(pool.submit(run, todo.pop(0)))
            if not running:
                print(f"budget spent: {len(todo)} mutants not started", flush=True)
                return
            done, running = wait(running, return_when=FIRST_COMPLETED)
            for future in done:
                yield future.result()


def still_to_run(chosen: list[Mutant], previous: dict, commit: str | None) -> list[Mutant]:
    """--resume: the mutants without a measured row on `commit` in the previous results."""
    done = {r["name"] for r in previous["mutants"] if commit and r.get("commit") == commit
            and r["status"] != "not run"}
    return [m for m in chosen if m.name not in done]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2, help="mutants run at the same time (≤ 2 on the shared machine)")
    parser.add_argument("--only", default="", help="comma-separated mutant names")
    parser.add_argument("--json", default=str(OUT))
    parser.add_argument("--check", action="store_true", help="only check that every snippet is found once")
    parser.add_argument("--whole-suite", action="store_true",
                        help="run every test file for every mutant (default: the files that can fail, "
                             "benchmarks/impact.py)")
    parser.add_argument("--impact-json", help="keep the recorded impact map here")
    parser.add_argument("--budget-s", type=_seconds, help="start no mutant after this many seconds (baseline and "
                        "recording included); the rows not reached keep the results file's previous rows")
    parser.add_argument("--impact-from", help="use a map kept by --impact-json on this same commit instead of "
                                              "recording one")
    parser.add_argument("--resume", action="store_true", help="run only the mutants whose row in the results file "
                        "was not measured on this commit (a run stopped part way goes on; rows of this commit are kept)")
    args = parser.parse_args(argv)
    commit = code_commit()
    holder = tempfile.TemporaryDirectory(prefix="mutants-base-")
    base = Path(holder.name) / "repo"
    snapshot(base)                      # one snapshot for the whole run: later commits cannot leak in
    check_catalogue(base)               # the catalogue must match the tree the mutants run on
    if args.check:
        print(f"{len(CATALOGUE)} mutants, every snippet found once")
        return 0
    only = set(args.only.split(",")) if args.only else set()
    unknown = only - {m.name for m in CATALOGUE}
    if unknown:
        raise SystemExit(f"--only: no mutant named {', '.join(sorted(unknown))} in the catalogue")
    kept = load_impact(args.impact_from, commit) if args.impact_from else None    # refused before hours of work
    chosen = [m for m in CATALOGUE if not only or m.name in only]
    out = Path(args.json)
    previous = json.loads(out.read_text(encoding="utf-8")) if out.exists() and \
        (args.only or args.budget_s or args.resume) else None
    if args.resume and previous:
        chosen = still_to_run(chosen, previous, commit)
        print(f"resume: {len(chosen)} mutants to run; the others were measured on {commit}", flush=True)
    start = time.perf_counter()
    results: list[dict] = []
    base_run = run_one(BASELINE, sys.executable, base)
    baseline = frozenset(f["test"] for f in base_run["failing_tests"])
    print(f"baseline (unmutated): {len(baseline)} failing {sorted(baseline)}", flush=True)
    selection = None if args.whole_suite else \
        kept if kept is not None else record_impact(base, commit, args.impact_json)
    selected = {m.name: impact.select(selection, m.file, (base / m.file).read_text(encoding="utf-8"), m.original)
                for m in chosen} if selection is not None else {}
    def files(m: Mutant) -> list[str] | None:
        return selected[m.name] if selection is not None else None
    if selection is not None:      # the cheapest first (recorded seconds of the files each runs): a budget reaches most
        cost = {m.name: sum(selection[f].seconds for f in files(m)) for m in chosen}
        chosen = sorted(chosen, key=lambda m: cost[m.name])
        print(f"selected test files: {sum(len(files(m)) for m in chosen)} runs for {len(chosen)} mutants "
              f"(of {len(selection) * len(chosen)} in whole suites)", flush=True)
    for res in _run_within(chosen, lambda m: run_one(m, sys.executable, base, baseline, files(m)),
                           jobs=max(1, min(args.jobs, 2)), deadline=start + args.budget_s if args.budget_s else None):
        res["commit"] = commit
        results.append(res)
        first = res["failing_tests"][0]["test"] if res["failing_tests"] else ""
        print(f"{res['kill_class']:16s} {res['name']:28s} {res['seconds']:6.1f} s  "
              f"{len(res['failing_tests'])} failing  {first}", flush=True)
        write_results(out, results, chosen, previous, commit, time.perf_counter() - start, sorted(baseline))
    doc = write_results(out, results, chosen, previous, commit, time.perf_counter() - start, sorted(baseline))
    print(f"{doc['behavioural']}/{doc['total']} killed by a behavioural test ({doc['killed']} killed in all: "
          f"{doc['kill_classes']}); wrote {out}")
    return 0


def write_results(out: Path, results: list[dict], chosen: list[Mutant], previous: dict | None, commit: str | None,
                  seconds: float, baseline: list[str] | None = None) -> dict:
    """Write the results so far (after every mutant: a stopped run leaves what it measured); mutants of the
    run not measured yet are listed as 'not run'. A partial --only run updates its rows of the previous file."""
    done = {r["name"] for r in results}
    not_run = lambda m: dict(name=m.name, file=m.file, description=m.description, status="not run",  # noqa: E731
                             returncode=None, kill_class="not run", failing_tests=[], seconds=0.0, summary="",
                             commit=None)
    rows = results + [not_run(m) for m in chosen if m.name not in done]
    if previous:   # each row keeps its commit; a mutant new to the catalogue is listed as not run
        by_name = {r["name"]: {"commit": previous.get("commit"), **r} for r in previous["mutants"]}
        by_name.update({r["name"]: r for r in rows if r["status"] != "not run" or r["name"] not in by_name})
        rows = [by_name.get(m.name) or not_run(m) for m in CATALOGUE]
    else:
        order = {m.name: i for i, m in enumerate(CATALOGUE)}
        rows.sort(key=lambda r: order[r["name"]])
    doc = dict(schema=2, created=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
               machine=f"{platform.node()} {platform.machine()}", command="python benchmarks/mutants.py",
               commit=commit, commits=sorted({r.get("commit") or "" for r in rows if r.get("commit")}),
               seconds=round(seconds, 1), total=len(rows),
               killed=sum(r["status"] == "killed" for r in rows),
               survived=sum(r["status"] == "survived" for r in rows),
               timeouts=sum(r["status"] == "timeout" for r in rows),
               not_run=sum(r["status"] == "not run" for r in rows),
               # the headline: kills by a test of behaviour; rows of schema-1 runs (first failing test only,
               # no class) are counted apart as unclassified
               behavioural=sum(r.get("kill_class") == "behavioural" for r in rows),
               kill_classes={c: sum(r.get("kill_class") == c for r in rows) for c in KILL_CLASSES},
               unclassified=sum(r["status"] == "killed" and "kill_class" not in r for r in rows),
               extras=installed_extras(sys.executable), baseline_failures=baseline, mutants=rows)
    # Provenance: the commit the suites ran on where every row ran there; else the previous file's, when rows of it are kept
    # (a partial run does not make the whole catalogue fresh); the snapshot is a clean `git archive`.
    on_commit = all(r.get("commit") == commit for r in rows)      # every row measured on this commit
    measured = commit if on_commit or not previous else \
        ((previous.get("provenance") or {}).get("commit") or previous.get("commit"))
    doc = stamp(doc, commit=measured)   # the suites ran on the host (PoCL CPU)
    out.write_text(json.dumps(doc, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    return doc


if __name__ == "__main__":
    sys.exit(main())
