"""Peers: the same shading model on the same G-buffer in another fast Python
stack, timed in the same rounds as clshade's kernels after their output is
checked against clshade's.

Models: Lambert, GGX height-correlated (Schlick F, metallic workflow with the
Fresnel-coupled diffuse of kernels/compose.h) and Phong (k_d + k_s workflow,
per-pixel material table), directional lights and a constant ambient — the
kernels' formulas, floors and conventions (kernels/brdf.h, surface.h,
compose.h, shade.cl), in float32.

Numba: `@njit(parallel=True, fastmath=True)`, a parallel loop over rows, one
compiled function per model (the model a compile-time constant), the G-buffer
in the planar float32 layout the OpenCL kernels read. A peer that cannot be
set up, or a model/scene it does not implement, is reported with a one-line
reason instead of a time. Dr.Jit: see drjit_peer.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from clshade.device.shade import camera_args
from clshade.models.lobe import builtin_lobes
from clshade.models.model import Model
from clshade.render.gbuffer import GBuffer
from clshade.render.scene import Camera, Scene
from clshade.resources import constant

VERIFY_RTOL = 1e-4           # peer vs clshade, relative to the pixel's largest channel (covered pixels)


@dataclass
class Peer:
    """A prepared peer: `run()` shades one frame into its own output array."""
    name: str
    version: str
    run: Callable[[], np.ndarray]
    timed: Callable[[], object] | None = None     # one frame as timed (default: run)


LAMBERT, GGX, PHONG = 0, 1, 2
PEER_MODELS = {"lambert": LAMBERT, "lambert+ggx_correlated": GGX, "lambert+phong": PHONG}
# kernels/brdf.h, surface.h, shade.cl constants, read from the headers (the peers follow the kernels'
# conventions: floors inside the lobes only, the irradiance with the true cosine E·max(n·l, 0)).
MIN_N_DOT_L, MIN_N_DOT_V, MIN_ALPHA = constant("MIN_N_DOT_L"), constant("MIN_N_DOT_V"), constant("MIN_ALPHA")
MIN_HALF_LEN2, MIN_UNIT_LEN2 = constant("MIN_HALF_LEN2"), constant("MIN_UNIT_LEN2")
MIN_POW_BASE, F0_DIELECTRIC, MAX_RADIANCE = constant("MIN_POW_BASE"), constant("F0_DIELECTRIC"), constant("MAX_RADIANCE")


def _numba_kernel(model: int, uniform: dict[str, float] | None = None, unit_normals: bool = False):
    """A Numba kernel for one model (the model is a compile-time constant), with the scene's
    uniform roughness / metallic (Features.uniform) compiled in as clshade's variants do, and
    with `unit_normals` (GBuffer.unit_normals) the normals only tested for zero, as UNIT_NORMALS."""
    import numba
    f32 = np.float32
    inv_pi = f32(1.0 / np.pi)
    uniform = uniform or {}
    rough_const, metal_const = "roughness" in uniform, "metallic" in uniform
    rough_value = f32(uniform.get("roughness", 0.0))     # in [0, 1]: uniform_channels saturates them
    metal_value = f32(uniform.get("metallic", 0.0))

    @numba.njit(inline="always", fastmath=True)
    def schlick(c, f0, f90):
        w = f32(1.0) - c
        w2 = w * w
        return f0 + (f90 - f0) * (w2 * w2 * w)

    @numba.njit(parallel=True, fastmath=True, cache=False)
    def shade(depth, nrm, base, rough, metal, mat_id, mats, width, height, cam, lights, ambient, background, out):
        n_l = lights.shape[0]
        for y in numba.prange(height):
            sy = f32(1.0) - (f32(y) + f32(0.5)) * f32(2.0 / height)
            for x in range(width):
                i = y * width + x
                z = depth[i]
                if z <= f32(0.0):
                    for c in range(4):
                        out[i, c] = background[c]
                    continue
                sx = (f32(x) + f32(0.5)) * f32(2.0 / width) - f32(1.0)
                rx = cam[1, 0] + sx * cam[2, 0] + sy * cam[3, 0]
                ry = cam[1, 1] + sx * cam[2, 1] + sy * cam[3, 1]
                rz = cam[1, 2] + sx * cam[2, 2] + sy * cam[3, 2]
                s = f32(-1.0) / np.sqrt(rx * rx + ry * ry + rz * rz)
                vx, vy, vz = rx * s, ry * s, rz * s
                nx, ny, nz = nrm[0, i], nrm[1, i], nrm[2, i]
                l2 = nx * nx + ny * ny + nz * nz
                if l2 > f32(MIN_UNIT_LEN2):
                    if not unit_normals:
                        s = f32(1.0) / np.sqrt(l2)
                        nx, ny, nz = nx * s, ny * s, nz * s
                else:                        # the kernels: a bad normal faces the viewer
                    nx, ny, nz = vx, vy, vz
                br = max(base[0, i], f32(0.0))
                bg = max(base[1, i], f32(0.0))
                bb = max(base[2, i], f32(0.0))
                r = rough_value if rough_const else min(max(rough[i], f32(0.0)), f32(1.0))
                m = metal_value if metal_const else min(max(metal[i], f32(0.0)), f32(1.0))
                row = mats[mat_id[i]]
                f90 = row[1, 1]
                if model == PHONG:           # k_d + k_s workflow
                    kd, ks, ka, shin = row[0, 0], row[0, 1], row[0, 2], row[0, 3]
                    r0 = (row[1, 0] - f32(1.0)) / (row[1, 0] + f32(1.0))
                    dr, dg, db = br, bg, bb
                    f0r = f0g = f0b = r0 * r0
                else:                        # metallic workflow
                    kd = ks = ka = f32(1.0)
                    shin = f32(0.0)
                    dr, dg, db = br * (f32(1.0) - m), bg * (f32(1.0) - m), bb * (f32(1.0) - m)
                    f0r = f32(F0_DIELECTRIC) + (br - f32(F0_DIELECTRIC)) * m
                    f0g = f32(F0_DIELECTRIC) + (bg - f32(F0_DIELECTRIC)) * m
                    f0b = f32(F0_DIELECTRIC) + (bb - f32(F0_DIELECTRIC)) * m
                alpha = max(r * r, f32(MIN_ALPHA))
                a2 = alpha * alpha
                nv_raw = nx * vx + ny * vy + nz * vz
                nv = max(nv_raw, f32(MIN_N_DOT_V))
                Lr = Lg = Lb = f32(0.0)
                for k in range(n_l):
                    lx, ly, lz = -lights[k, 0], -lights[k, 1], -lights[k, 2]
                    nl_raw = nx * lx + ny * ly + nz * lz
                    if nl_raw <= f32(0.0):
                        continue
                    nl = max(nl_raw, f32(MIN_N_DOT_L))
                    er, eg, eb = lights[k, 4] * nl_raw, lights[k, 5] * nl_raw, lights[k, 6] * nl_raw
                    if model == LAMBERT:
                        fr, fg, fb = dr * inv_pi, dg * inv_pi, db * inv_pi
                    elif model == GGX:
                        hx, hy, hz = lx + vx, ly + vy, lz + vz
                        h2 = hx * hx + hy * hy + hz * hz
                        s = f32(1.0) / np.sqrt(max(h2, f32(MIN_HALF_LEN2)))
                        hx, hy, hz = hx * s, hy * s, hz * s
                        nh = min(max(nx * hx + ny * hy + nz * hz, f32(0.0)), f32(1.0))
                        cx, cy, cz = ny * hz - nz * hy, nz * hx - nx * hz, nx * hy - ny * hx
                        sin2 = f32(1.0) if h2 < f32(MIN_HALF_LEN2) else min(max(cx * cx + cy * cy + cz * cz, f32(0.0)), f32(1.0))
                        vh = min(max(vx * hx + vy * hy + vz * hz, f32(0.0)), f32(1.0))
                        d = sin2 + nh * nh * a2
                        D = a2 / (f32(np.pi) * d * d)
                        gv = nl * np.sqrt(nv * nv * (f32(1.0) - a2) + a2)
                        gl = nv * np.sqrt(nl * nl * (f32(1.0) - a2) + a2)
                        DV = D * (f32(0.5) / (gv + gl))
                        fr = (f32(1.0) - schlick(nl, f0r, f90)) * (f32(1.0) - schlick(nv, f0r, f90)) * dr * inv_pi \
                            + schlick(vh, f0r, f90) * DV
                        fg = (f32(1.0) - schlick(nl, f0g, f90)) * (f32(1.0) - schlick(nv, f0g, f90)) * dg * inv_pi \
                            + schlick(vh, f0g, f90) * DV
                        fb = (f32(1.0) - schlick(nl, f0b, f90)) * (f32(1.0) - schlick(nv, f0b, f90)) * db * inv_pi \
                            + schlick(vh, f0b, f90) * DV
                    else:
                        lv = lx * vx + ly * vy + lz * vz
                        rv = f32(2.0) * nl_raw * nv_raw - lv
                        spec = ks * np.exp2(shin * np.log2(max(min(max(rv, f32(0.0)), f32(1.0)), f32(MIN_POW_BASE))))
                        fr, fg, fb = kd * dr * inv_pi + spec, kd * dg * inv_pi + spec, kd * db * inv_pi + spec
                    Lr += fr * er
                    Lg += fg * eg
                    Lb += fb * eb
                if model == GGX:
                    ar, ag, ab = (f32(1.0) - f0r) * dr + f0r, (f32(1.0) - f0g) * dg + f0g, (f32(1.0) - f0b) * db + f0b
                elif model == PHONG:
                    ar, ag, ab = dr * kd + f0r * ks, dg * kd + f0g * ks, db * kd + f0b * ks
                else:
                    ar, ag, ab = dr * kd, dg * kd, db * kd
                out[i, 0] = min(Lr + ambient[0] * ka * ar, f32(MAX_RADIANCE))
                out[i, 1] = min(Lg + ambient[1] * ka * ag, f32(MAX_RADIANCE))
                out[i, 2] = min(Lb + ambient[2] * ka * ab, f32(MAX_RADIANCE))
                out[i, 3] = f32(1.0)
    return shade, numba.__version__


def _check_supported(model: Model, scene: Scene, name: str) -> int:
    if model.id not in PEER_MODELS or model.fresnel != "schlick":
        raise RuntimeError(f"model {model.id}: the {name} peer implements {', '.join(PEER_MODELS)} (Schlick F)")
    if any(l.kind != "directional" for l in scene.lights) or scene.shadow_lights:
        raise RuntimeError(f"the {name} peer implements directional lights without shadows only")
    return PEER_MODELS[model.id]


def _planar_inputs(gb: GBuffer, scene: Scene, camera: Camera) -> dict[str, np.ndarray]:
    n = gb.pixels
    mats = gb.materials if len(gb.materials) else np.zeros((1, 4, 4), np.float32)
    return dict(
        depth=np.ascontiguousarray(gb.channels["depth"], np.float32),
        nrm=np.ascontiguousarray(gb.channels["normal"].reshape(n, 3).T, np.float32),
        base=np.ascontiguousarray(gb.channels["base"].reshape(n, 3).T, np.float32),
        rough=np.ascontiguousarray(gb.channels["roughness"], np.float32),
        metal=np.ascontiguousarray(gb.channels["metallic"], np.float32),
        mat_id=np.ascontiguousarray(gb.channels["material"], np.uint8),
        mats=np.ascontiguousarray(mats, np.float32),
        cam=np.stack([a[:3] for a in camera_args(camera)]).astype(np.float32),
        lights=np.array([[*l.direction, 0.0, *l.color, 0.0] for l in scene.lights], np.float32).reshape(-1, 8),
        ambient=np.array([*scene.ambient, 0.0], np.float32),
        background=np.array([*scene.background, 0.0], np.float32))


def numba_peer(model: Model, gb: GBuffer, scene: Scene, camera: Camera,
               uniform: dict[str, float] | None = None) -> Peer:
    """The Numba peer for `model` on `gb`; raises RuntimeError with the reason it cannot.
    `uniform`: the scene's one-value channels (Features.uniform), compiled in."""
    which = _check_supported(model, scene, "Numba")
    try:
        kernel, version = _numba_kernel(which, uniform, gb.unit_normals)
    except ImportError as exc:
        raise RuntimeError(f"numba not installed ({exc}); pip install 'clshade[peers]'") from exc
    a = _planar_inputs(gb, scene, camera)
    out = np.empty((gb.pixels, 4), np.float32)

    def run() -> np.ndarray:
        kernel(a["depth"], a["nrm"], a["base"], a["rough"], a["metal"], a["mat_id"], a["mats"], gb.width, gb.height,
               a["cam"], a["lights"], a["ambient"], a["background"], out)
        return out
    run()                                   # compile
    return Peer("numba", version, run)


LIBLLVM_CANDIDATES = ("/usr/lib/x86_64-linux-gnu/libLLVM-19.so", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
                      "/usr/lib/x86_64-linux-gnu/libLLVM-18.so", "/usr/lib/x86_64-linux-gnu/libLLVM-17.so",
                      "/usr/lib/x86_64-linux-gnu/libLLVM-16.so")


def drjit_libllvm() -> str | None:
    """The libLLVM Dr.Jit's LLVM backend will load: DRJIT_LIBLLVM_PATH, else the first
    libLLVM ≥ 16 found (Debian 12: `apt install libllvm19`; its libLLVM-15 aborts Dr.Jit)."""
    path = os.environ.get("DRJIT_LIBLLVM_PATH")
    if path:
        return path
    for cand in LIBLLVM_CANDIDATES:
        if os.path.exists(cand):
            os.environ["DRJIT_LIBLLVM_PATH"] = cand        # read when drjit initialises its backend
            return cand
    return None


def _drjit():
    lib = drjit_libllvm()
    if lib is None:
        raise RuntimeError("Dr.Jit's LLVM backend needs libLLVM ≥ 16 (Debian 12: apt install libllvm19, "
                           "or set DRJIT_LIBLLVM_PATH)")
    try:
        import drjit as dr
        import drjit.llvm as llvm
    except ImportError as exc:
        raise RuntimeError(f"drjit not installed ({exc}); pip install 'clshade[peers]'") from exc
    if not dr.has_backend(dr.JitBackend.LLVM):
        raise RuntimeError(f"Dr.Jit's LLVM backend did not initialise with {lib}")
    return dr, llvm, lib


def drjit_peer(model: Model, gb: GBuffer, scene: Scene, camera: Camera,
               uniform: dict[str, float] | None = None) -> Peer:
    """Dr.Jit's LLVM backend (`drjit.llvm`, its vectorised multi-threaded CPU JIT):
    dense — every pixel computed, then `dr.select` for the sky — and `@dr.freeze`
    so that a frame replays the recorded kernel without tracing Python again.
    Specialised as a JIT does it, with Python floats (literals in the traced kernel):
    the scene's uniform roughness / metallic (`uniform`, Features.uniform) and every
    material-table entry that is the same in all materials; the rest is read per pixel.
    Unit-or-zero normals (GBuffer.unit_normals) are only tested for zero, as UNIT_NORMALS."""
    which = _check_supported(model, scene, "Dr.Jit")
    dr, llvm, lib = _drjit()
    Float, UInt32 = llvm.Float, llvm.UInt32
    a = _planar_inputs(gb, scene, camera)
    n = gb.pixels
    f = {k: Float(a[k]) for k in ("depth", "rough", "metal")}
    nrm = [Float(a["nrm"][c]) for c in range(3)]
    base = [Float(a["base"][c]) for c in range(3)]
    mat_id = UInt32(a["mat_id"].astype(np.uint32))
    mats = Float(a["mats"].reshape(-1))
    uniform = uniform or {}
    table = a["mats"].reshape(-1, 16)
    same = np.all(table == table[0], axis=0)     # table entries with one value in every material
    # Python floats: a NumPy scalar would take over the arithmetic with Dr.Jit arrays.
    cam, lights = a["cam"].tolist(), a["lights"].tolist()
    amb, bgc = a["ambient"].tolist(), a["background"].tolist()
    px = UInt32(np.arange(n, dtype=np.uint32) % gb.width)
    py = UInt32(np.arange(n, dtype=np.uint32) // gb.width)
    inv_pi = 1.0 / np.pi

    def dot(a3, b3):
        return a3[0] * b3[0] + a3[1] * b3[1] + a3[2] * b3[2]

    def schlick(c, f0, f90):
        w = 1.0 - c
        w2 = w * w
        return f0 + (f90 - f0) * (w2 * w2 * w)

    @dr.freeze
    def frame(depth, n0, n1, n2, b0, b1, b2, rough, metal, mat_id, mats, px, py):
        sx = (Float(px) + 0.5) * (2.0 / gb.width) - 1.0
        sy = 1.0 - (Float(py) + 0.5) * (2.0 / gb.height)
        ray = [cam[1][c] + sx * cam[2][c] + sy * cam[3][c] for c in range(3)]
        s = -dr.rsqrt(dot(ray, ray))
        v = [r * s for r in ray]
        nn = [n0, n1, n2]
        l2 = dot(nn, nn)
        ok = l2 > MIN_UNIT_LEN2
        if gb.unit_normals:
            nn = [dr.select(ok, x, vc) for x, vc in zip(nn, v)]
        else:
            inv = dr.rsqrt(dr.select(ok, l2, 1.0))
            nn = [dr.select(ok, x * inv, vc) for x, vc in zip(nn, v)]
        b = [dr.maximum(x, 0.0) for x in (b0, b1, b2)]
        # Uniform values are in [0, 1] already (gbuffer.uniform_channels saturates them).
        r = uniform["roughness"] if "roughness" in uniform else dr.clip(rough, 0.0, 1.0)
        m = uniform["metallic"] if "metallic" in uniform else dr.clip(metal, 0.0, 1.0)
        row = mat_id * 16

        def entry(k: int):
            return float(table[0, k]) if same[k] else dr.gather(Float, mats, row + k)
        f90 = entry(5)
        if which == PHONG:
            kd, ks, ka, shin = (entry(k) for k in range(4))
            ior = entry(4)
            r0 = (ior - 1.0) / (ior + 1.0)
            dc, f0 = b, [r0 * r0] * 3
        else:
            kd = ks = ka = 1.0
            dc = [x * (1.0 - m) for x in b]
            f0 = [F0_DIELECTRIC + (x - F0_DIELECTRIC) * m for x in b]
        alpha = dr.maximum(r * r, MIN_ALPHA)
        a2 = alpha * alpha
        nv_raw = dot(nn, v)
        nv = dr.maximum(nv_raw, MIN_N_DOT_V)
        L = [Float(0.0), Float(0.0), Float(0.0)]
        for light in lights:
            l = [-light[c] for c in range(3)]
            nl_raw = dot(nn, l)
            nl = dr.maximum(nl_raw, MIN_N_DOT_L)
            E = [light[4 + c] * dr.maximum(nl_raw, 0.0) for c in range(3)]
            if which == LAMBERT:
                fr = [x * inv_pi for x in dc]
            elif which == GGX:
                h = [lc + vc for lc, vc in zip(l, v)]
                h2 = dot(h, h)
                hs = dr.rsqrt(dr.maximum(h2, MIN_HALF_LEN2))
                h = [x * hs for x in h]
                nh = dr.clip(dot(nn, h), 0.0, 1.0)
                cr = [nn[1] * h[2] - nn[2] * h[1], nn[2] * h[0] - nn[0] * h[2], nn[0] * h[1] - nn[1] * h[0]]
                sin2 = dr.select(h2 < MIN_HALF_LEN2, 1.0, dr.clip(dot(cr, cr), 0.0, 1.0))
                vh = dr.clip(dot(v, h), 0.0, 1.0)
                d = sin2 + nh * nh * a2
                D = a2 / (np.pi * d * d)
                gv = nl * dr.sqrt(nv * nv * (1.0 - a2) + a2)
                gl = nv * dr.sqrt(nl * nl * (1.0 - a2) + a2)
                DV = D * (0.5 / (gv + gl))
                fr = [(1.0 - schlick(nl, f0c, f90)) * (1.0 - schlick(nv, f0c, f90)) * dcc * inv_pi
                      + schlick(vh, f0c, f90) * DV for f0c, dcc in zip(f0, dc)]
            else:
                rv = 2.0 * nl_raw * nv_raw - dot(l, v)
                spec = ks * dr.exp2(shin * dr.log2(dr.maximum(dr.minimum(rv, 1.0), MIN_POW_BASE)))
                fr = [kd * dcc * inv_pi + spec for dcc in dc]
            lit = nl_raw > 0.0
            L = [Lc + dr.select(lit, fc * Ec, 0.0) for Lc, fc, Ec in zip(L, fr, E)]
        if which == GGX:
            amb_w = [(1.0 - f0c) * dcc + f0c for f0c, dcc in zip(f0, dc)]
        elif which == PHONG:
            amb_w = [dcc * kd + f0c * ks for f0c, dcc in zip(f0, dc)]
        else:
            amb_w = list(dc)
        cov = depth > 0.0
        out = [dr.select(cov, dr.minimum(Lc + amb[c] * ka * wc, MAX_RADIANCE), bgc[c])
               for c, (Lc, wc) in enumerate(zip(L, amb_w))]
        out.append(dr.select(cov, 1.0, bgc[3]))
        return out

    args = (f["depth"], *nrm, *base, f["rough"], f["metal"], mat_id, mats, px, py)
    result: list = []

    def run() -> np.ndarray:
        out = frame(*args)
        dr.eval(out)
        dr.sync_thread()
        result[:] = out
        return out

    def image() -> np.ndarray:
        run()
        return np.stack([np.asarray(c) for c in result], axis=1)

    for _ in range(3):                       # trace, compile, record the frozen function
        run()
    peer = Peer("drjit", f"{dr.__version__} (LLVM backend, {os.path.basename(lib)})", image)
    peer.timed = run
    return peer


PEERS: dict[str, Callable[..., Peer]] = {"numba": numba_peer, "drjit": drjit_peer}


# (r·v)ⁿ = exp2(n·log2(r·v)) in float32: r·v carries a few ulp of rounding and
# log2 ≤ 2 ulp (kernels/brdf.h log2_lanes), each multiplied by n in the result,
# so two correct float32 implementations differ by up to ~4·n·2⁻²³ relative:
# beyond 1e-4 once n > 1e-4·2²³/4 ≈ 210. Pixels with a larger exponent are
# checked separately (their difference is reported, not hidden).
WELL_CONDITIONED_EXPONENT = VERIFY_RTOL * 2.0 ** 23 / 4
# the lobes with a runtime exponent (r·v)ⁿ, (n·h)ⁿ: the empirical ones, normalised or not
POWER_LOBES = tuple(name for name, lobe in builtin_lobes().items() if lobe.family == "empirical")

# A microfacet D near its peak (GGX: α²/(π(sin²θh + cos²θh·α²)²)) is as steep as its
# width α: a direction error δ moves sin²θh by 2θh·δ, so D by up to 2δ/α relative (at
# θh = α). n, v and h carry a few ulp each (δ ≈ 2·2⁻²³), so two correct float32
# implementations differ by up to ~4·2⁻²³/α near the highlight: beyond 1e-4 once
# α < 4·2⁻²³/1e-4 ≈ 4.8e-3 (roughness below 0.069). sphere_grid's roughness-0 ball
# (α = MIN_ALPHA = 1e-4) has such a pixel. Its difference is reported, not hidden.
WELL_CONDITIONED_ALPHA = 4 * 2.0 ** -23 / VERIFY_RTOL


def _is_microfacet(model: Model) -> bool:
    return model.specular_lobe is not None and model.specular_lobe.family == "microfacet"


def ill_conditioned_note(model: Model) -> str:
    """Which pixels well_conditioned() leaves out for `model`, and why (for the results);
    "" for a model it never leaves a pixel out of."""
    if model.specular in POWER_LOBES:
        return (f"exponent n > {WELL_CONDITIONED_EXPONENT:.0f} (float32 (r·v)ⁿ differs by ~4·n·2⁻²³ between "
                "correct implementations)")
    if _is_microfacet(model):
        return (f"α < {WELL_CONDITIONED_ALPHA:.1e} (near its peak float32 D differs by ~4·2⁻²³/α between "
                "correct implementations)")
    return ""


def well_conditioned(model: Model, gb: GBuffer, covered: np.ndarray) -> np.ndarray:
    """Mask over `covered`: pixels where float32 peers can agree to VERIFY_RTOL (all,
    except empirical lobes whose exponent exceeds WELL_CONDITIONED_EXPONENT and microfacet
    lobes whose α = max(r², MIN_ALPHA) is below WELL_CONDITIONED_ALPHA)."""
    good = np.ones(len(covered), bool)
    if model.specular in POWER_LOBES and len(gb.materials):
        good &= gb.materials[:, 0, 3][gb.channels["material"][covered].astype(np.intp)] <= WELL_CONDITIONED_EXPONENT
    if _is_microfacet(model) and "roughness" in gb.channels:
        r = np.clip(gb.channels["roughness"][covered].astype(np.float64), 0.0, 1.0)
        good &= np.maximum(r * r, MIN_ALPHA) >= WELL_CONDITIONED_ALPHA
    return good


def verify(peer_image: np.ndarray, clshade_image: np.ndarray, covered: np.ndarray) -> float:
    """Largest relative difference over covered pixels, per pixel relative to the
    largest channel of clshade's value there."""
    a = peer_image.reshape(-1, 4)[covered, :3].astype(float)
    b = clshade_image.reshape(-1, 4)[covered, :3].astype(float)
    scale = np.maximum(np.abs(b).max(axis=1, keepdims=True), 1e-30)
    return float((np.abs(a - b) / scale).max()) if len(a) else 0.0


def time_once(peer: Peer) -> float:
    """One frame of the peer, in ms."""
    t0 = time.perf_counter()
    (peer.timed or peer.run)()
    return (time.perf_counter() - t0) * 1e3
