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
 * none; NaN in the buckets of +∞ and NaN). display.py checks that no bucket holds two
 * thresholds: the transform's steepest level per log-radiance (the sRGB curve, 0.42 levels
 * per bucket) keeps them apart. Two table reads per channel instead of a search. */
#define BUCKET_SHIFT 15

inline uchar display_level(float x, __global const uchar* base, __global const float* cross)
{
    if (!(x > 0.0f))                    /* NaN, negatives and zeros: level 0 */
        return 0;
    uint b = as_uint(x) >> BUCKET_SHIFT;
    return base[b] + (uchar)(x >= cross[b]);
}

__kernel void display(const uint npix, __global const float4* radiance, __global const uchar* base,
                      __global const float* cross, __global uchar4* out)
{
    uint i = get_global_id(0);
    if (i >= npix) return;
    float4 c = radiance[i];
    out[i] = (uchar4)(display_level(c.x, base, cross), display_level(c.y, base, cross),
                      display_level(c.z, base, cross), (uchar)255);
}
