"""Evidence of cost: frame timing and statistics, baselines, ladders."""
