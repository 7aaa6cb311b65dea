/* resolve.cl — the box filter of supersampling: each output pixel is the mean
 * of its N×N block of shaded samples (N = SAMPLES, a compile-time constant).
 *
 * The samples image is (N·H) × (N·W) float4 (RGB radiance, coverage) as the
 * shading kernel writes it, row 0 at the top; sample (a, b) of pixel (row y,
 * column x) is sample-image pixel (N·y + b, N·x + a), at the centre of cell
 * (a, b) of the pixel (clshade/render/samples.py, an ordered grid). Alpha
 * becomes the covered fraction of the pixel.
 *
 * A pixel's true value is the integral of radiance over its area (a box filter
 * of width 1 pixel); the mean of N² stratified samples converges to it as N grows
 * (clshade/bench/aa.py measures by how much).
 */
#ifndef SAMPLES
#error "resolve.cl needs -D SAMPLES=N"
#endif

__kernel void resolve(const uint width, const uint npix, __global const float4* samples, __global float4* out)
{
    uint i = get_global_id(0);
    if (i >= npix) return;
    uint y = i / width, x = i - y * width;
    uint row = SAMPLES * width;                  /* samples per sample-image row */
    __global const float4* p = samples + (size_t)(SAMPLES * y) * row + SAMPLES * x;
    /* Each sample is weighted before the sum: N² samples at the shading's ±MAX_RADIANCE clamp
     * would overflow a sum of the samples themselves to ±Inf. */
    const float weight = 1.0f / (float)(SAMPLES * SAMPLES);
    float4 sum = (float4)(0.0f);
    for (int b = 0; b < SAMPLES; ++b)
        for (int a = 0; a < SAMPLES; ++a)
            sum += p[b * row + a] * weight;
    out[i] = sum;
}

/* The MSAA-style resolve (clshade/render/samples.py, coverage_gbuffer): the pixel
 * was shaded once, for the surface sample nearest its centre; its N×N samples'
 * coverage c blends that radiance with the background: L·c + background·(1 − c).
 * Alpha becomes c. `image` is read and written in place. */
__kernel void blend_coverage(const uint npix, __global const float* coverage, const float4 background,
                             __global float4* image)
{
    uint i = get_global_id(0);
    if (i >= npix) return;
    float c = coverage[i];
    float4 L = image[i];
    image[i] = (float4)(L.xyz * c + background.xyz * (1.0f - c), c);
}
