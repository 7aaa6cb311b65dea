"""clshade's benchmarks: result generators, publishing, experiments and mutation testing."""
