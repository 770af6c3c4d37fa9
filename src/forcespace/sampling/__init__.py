"""Samples of S: uniform hit-and-run (the reference), the uniform billiard walk (fast at
large dim S), the paper's perturb-and-relax walk, one driver for all, their result
(Ensemble) and convergence diagnostics."""
