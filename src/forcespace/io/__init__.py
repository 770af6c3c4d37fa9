"""Files at the edges: self-describing atomic HDF5 (packings, ensembles, checkpoints),
strict JSON, output checks and locks."""
