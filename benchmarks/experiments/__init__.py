"""A/B experiments: two versions of the code or two settings side by side, printed (host_ab's result
is published)."""
