"""The reference engine that makes packings: rigid-disk contact dynamics (Moreau-Jean time
stepping, nonlinear Gauss-Seidel with Coulomb friction) in numba kernels, the jamming
protocol, the frozen-network relaxation and the point-force push."""
