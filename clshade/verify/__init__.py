"""Evidence of correctness: the float64 reference (the oracle), accuracy, plausibility, stability."""
