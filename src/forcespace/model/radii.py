"""Radius distributions of a scene (``disks.distribution`` and its parameters).

* ``"uniform"`` (default): radii uniform in [radius_min, radius_max]; drawn with
  ``rng.uniform(radius_min, radius_max, n)``, the same call (and so the same radii, and
  the same random stream afterwards) as every packing made before distributions existed.
* ``"bidisperse"``: round(small_fraction * n) disks of radius_min, the rest of
  radius_max (the usual 50:50 mixture with a size ratio of 1.4 is ``radius_max = 1.4``);
  no random numbers are drawn.
* ``"lognormal"``: ln r normal with median ``lognormal_median`` (0: the geometric mean
  sqrt(radius_min * radius_max)) and standard deviation ``lognormal_sigma``, truncated to
  [radius_min, radius_max] (so lengths stay in units of R = radius_min and the solver's
  contact margins keep their meaning); drawn exactly by the inverse CDF, one uniform
  number per disk.

All radii are in R, shape (n,).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtr, ndtri

from ..errors import InputError

DISTRIBUTIONS = ("uniform", "bidisperse", "lognormal")


def draw_radii(grains, rng) -> np.ndarray:
    """Radii (n,) [R] of :class:`~forcespace.model.setup.Grains` (a scene's ``disks.*``
    keys), drawn from ``rng`` (a ``numpy.random.Generator``) by its distribution."""
    g = grains
    return radii(g.distribution, g.n, g.radius_min, g.radius_max, rng,
                 small_fraction=g.small_fraction, lognormal_sigma=g.lognormal_sigma,
                 lognormal_median=g.lognormal_median)


def radii(distribution: str, n: int, radius_min: float, radius_max: float, rng=None, *,
          small_fraction: float = 0.5, lognormal_sigma: float = 0.25,
          lognormal_median: float = 0.0) -> np.ndarray:
    """n radii [R] in [radius_min, radius_max] from ``distribution`` (module docstring).

    ``rng``: a ``numpy.random.Generator`` (needed by "uniform" and "lognormal")."""
    lo, hi = float(radius_min), float(radius_max)
    if distribution == "uniform":
        return rng.uniform(lo, hi, n)
    if distribution == "bidisperse":
        n_small = int(round(small_fraction * n))
        return np.concatenate([np.full(n_small, lo), np.full(n - n_small, hi)])
    if distribution == "lognormal":
        if hi == lo:
            return np.full(n, lo)
        med = lognormal_median if lognormal_median > 0 else math.sqrt(lo * hi)
        a = (math.log(lo) - math.log(med)) / lognormal_sigma
        b = (math.log(hi) - math.log(med)) / lognormal_sigma
        u = rng.uniform(ndtr(a), ndtr(b), n)
        return np.clip(med * np.exp(lognormal_sigma * ndtri(u)), lo, hi)
    raise InputError("disks.distribution", "distribution", "must be one of "
                     + ", ".join(DISTRIBUTIONS), got=distribution)


def moments(r) -> dict:
    """Size statistics of radii r (n,) [R]: mean, standard deviation, polydispersity
    (std / mean), size ratio max / min."""
    r = np.asarray(r, float)
    return {"mean": float(r.mean()), "std": float(r.std()),
            "polydispersity": float(r.std() / r.mean()), "size_ratio": float(r.max() / r.min())}
