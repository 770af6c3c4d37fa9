"""Samples of S: uniform hit-and-run, the paper's perturb-and-relax walk, one driver for
both, their result (Ensemble) and convergence diagnostics."""
