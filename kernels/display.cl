/* display.cl — the display transform of clshade/render/image.py (exposure, tone map,
 * sRGB OETF, 8-bit rounding) on the device, bit for bit, for the live viewer.
 *
 * That transform maps each channel on its own, and it is monotone in the radiance:
 * the 8-bit level of a float32 value x is the number of thresholds t[k] ≤ x, where
 * t[k] is the least float32 that to_display maps to level k + 1 (k = 0 … 254).
 * clshade/device/display.py finds the thresholds by bisection over float32 bit
 * patterns with to_display itself and checks the steps around each one, so the
 * device compares floats and never evaluates a tone map: no rounding of its own.
 *
 * NaN and negative radiance show as 0 and +∞ as the largest float32, as image.tonemap
 * treats them.
 * Alpha is 255 (an opaque canvas); the background is in the radiance already.
 */
/* The count, per bucket of float32 values (the top 17 bits of a positive float: its
 * exponent and 8 mantissa bits, a 0.4 % wide range), is base[b] plus one when the value is
 * at or above the one threshold inside the bucket, cross[b] (+INFINITY when the bucket holds
 * none). display.py checks that no bucket holds two thresholds: the transform's steepest
 * level per log-radiance (the sRGB curve, 0.42 levels per bucket) keeps them apart. Two
 * table reads per channel instead of a search.
 *
 * The tables hold only the buckets from the first threshold's (`first`) to the last's
 * (`first + last`; 3–6 thousand for the tone maps): a value below them has no threshold at
 * or below it (level base[0] = 0), one above them has all (base[last] plus its crossing,
 * which it is past), so the bucket is clamped into them. Every read is then in range, for
 * negative and NaN inputs too: the lookup runs before the select that gives them 0, with no
 * branch, so that the compiler vectorises it. */
#define BUCKET_SHIFT 15

#ifdef DISPLAY_PACKED
/* Intel's CPU compiler (clshade/device/display.py, PACKED_RUNTIMES): float table reads and one
 * packed 32-bit store per pixel vectorise there; byte reads and uchar4 stores do not. The levels
 * are the same (a float holds every integer up to 255 exactly). */
inline uint packed_level(float x, __global const float* base, __global const float* cross, uint first, uint last)
{
    uint b = min(max(as_uint(x) >> BUCKET_SHIFT, first) - first, last);     /* +∞: the last bucket */
    uint level = (uint)base[b] + (x >= cross[b] ? 1u : 0u);
    return x > 0.0f ? level : 0u;       /* NaN, negatives and zeros: level 0 (no branch: vectorised) */
}

__kernel void display(const uint npix, __global const float4* radiance, __global const float* base,
                      __global const float* cross, const uint first, const uint last, __global uint* out)
{
    uint i = get_global_id(0);
    if (i >= npix) return;
    float4 c = radiance[i];
    out[i] = packed_level(c.x, base, cross, first, last) | packed_level(c.y, base, cross, first, last) << 8
             | packed_level(c.z, base, cross, first, last) << 16 | 0xFF000000u;   /* R, G, B, A in memory (little-endian) */
}
#else
inline uchar display_level(float x, __global const uchar* base, __global const float* cross, uint first, uint last)
{
    uint b = min(max(as_uint(x) >> BUCKET_SHIFT, first) - first, last);     /* +∞: the last bucket */
    uchar level = base[b] + (uchar)(x >= cross[b]);
    return x > 0.0f ? level : (uchar)0;     /* NaN, negatives and zeros: level 0 (no branch: vectorised) */
}

__kernel void display(const uint npix, __global const float4* radiance, __global const uchar* base,
                      __global const float* cross, const uint first, const uint last, __global uchar4* out)
{
    uint i = get_global_id(0);
    if (i >= npix) return;
    float4 c = radiance[i];
    out[i] = (uchar4)(display_level(c.x, base, cross, first, last), display_level(c.y, base, cross, first, last),
                      display_level(c.z, base, cross, first, last), (uchar)255);
}
#endif
