"""Evidence of cost: frame timing and statistics, baselines, ladders."""

NUMPY_FRAMES = 9             # NumPy frames per model (median), spread over the timed rounds; here so that
                             # the CLI's parser reads the default without importing the benchmark modules

# Defaults of the anti-aliasing ladder (clshade/bench/aa.py), here for the same reason.
TRUTH_SAMPLES = 16          # ground truth: 16×16 ordered-grid samples per pixel, float64
CHECK_SAMPLES = 24          # denser truth, to show the 16×16 one has converged
TEMPORAL_FRAMES = 16        # frames of the sub-pixel pan
DEFAULT_MODELS = "ggx_correlated,blinn_phong_normalized"
