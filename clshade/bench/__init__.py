"""Evidence of cost: frame timing and statistics, baselines, ladders."""

NUMPY_FRAMES = 9             # NumPy frames per model (median), spread over the timed rounds; here so that
                             # the CLI's parser reads the default without importing the benchmark modules
