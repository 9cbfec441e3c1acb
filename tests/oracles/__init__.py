"""Independent numpy/scipy oracles that the tests check rperc against, and that
``benchmarks/`` times rperc against in the same run: each is the same model written
out again in plain numpy (dense matrices, finite-difference Jacobians, brute force),
sharing no code with rperc."""
