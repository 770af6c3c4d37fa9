"""Measures of the force ensemble: eta, indeterminacy structure, difference fields.

Samples are arrays (k, 2m) in problem column order (:mod:`forcespace.model.problem`): columns
2j, 2j+1 are fn, ft of unknown contact j [F0].

eta (the paper's force ambiguity, Eq. 2), exactly:
    F_i = (fn_i, ft_i) the force vector of contact i (the frame is fixed per
    contact, so |.| is the Euclidean vector norm),
    dF_i^2 = mean over samples of |F_i - mean_samples(F_i)|^2,
    |F_i|  = mean over samples of |F_i|,
    eta = mean_i dF_i / mean_i |F_i|,
with i running over all unknown contacts of the problem (the contacts of the
slice whose forces are sampled; fixed boundary loads are not included).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import config
from .errors import InputError, require_array


def _check(samples):
    X = np.asarray(samples, float)
    if X.ndim != 2 or X.shape[1] % 2 or X.shape[0] < 1:
        raise InputError("samples", "shape", "must be (k >= 1, 2m)", got=X.shape)
    if not np.all(np.isfinite(X)):
        raise InputError("samples", "values", "must be finite (found NaN/inf)")
    return X


def contact_fluctuations(samples):
    """(dF (m,), mean |F| (m,)) as defined in the module docstring [F0]."""
    X = _check(samples)
    k, m2 = X.shape
    F = X.reshape(k, m2 // 2, 2)
    # deviations from the first sample first, then from their mean: the same numbers,
    # but identical samples (a determinate S, dim S = 0) give exactly 0, where the mean
    # of k equal floats is not always that float (eta ~ 6e-16 from round-off)
    shifted = F - F[0]
    dev = shifted - shifted.mean(0)
    dF = np.sqrt((dev ** 2).sum(2).mean(0))
    mag = np.sqrt((F ** 2).sum(2)).mean(0)
    return dF, mag


def eta(samples) -> float:
    """The force ambiguity eta = <dF> / <|F|> (module docstring)."""
    dF, mag = contact_fluctuations(samples)
    den = mag.mean()
    if den == 0:
        raise InputError("samples", "forces", "all forces are zero; eta undefined")
    return float(dF.mean() / den)


def distance_from_centre(samples, x0):
    """Fig. 3 distances: the centre is the mean of the samples.

    Returns (l (k,), l0, lbar): distances of the samples and of x0 (the jammed
    state) from the centre [F0], and the mean sample distance lbar.
    """
    X = _check(samples)
    x0 = require_array("distance_from_centre", "x0", x0, (X.shape[1],),
                       "a network in the samples' columns [F0]")
    c = X.mean(0)
    ell = np.linalg.norm(X - c, axis=1)
    l0 = float(np.linalg.norm(x0 - c))
    return ell, l0, float(ell.mean())


def difference_field(packing, problem, x1, x2) -> dict:
    """The difference of two admissible networks as a drawable field.

    Returns arrays per unknown contact j: ``segments`` (m, 2, 2) the line from
    the centre of body a to the centre of body b (periodic image applied;
    walls: the contact point) [R], ``point`` (m, 2) contact point [R],
    ``dfn``, ``dft`` (m,) the differences x2 - x1 [F0] and ``dF`` (m, 2) the
    force difference vector on b [F0].
    """
    k = problem.contacts
    x1, x2 = (require_array("difference_field", name, x, (problem.n_columns,),
                            "a network of the problem [F0]")
              for name, x in (("x1", x1), ("x2", x2)))
    dx = x2 - x1
    dfn, dft = dx[0::2], dx[1::2]
    n = packing.normal[k]
    t = np.stack([-n[:, 1], n[:, 0]], axis=1)
    pt = packing.point[k]
    seg = np.empty((k.size, 2, 2))
    for q, c in enumerate(k):
        a, b = packing.a[c], packing.b[c]
        pa = np.array([packing.x[a], packing.y[a]]) if a >= 0 else pt[q]
        pb = np.array([packing.x[b] + packing.image[c] * packing.width, packing.y[b]]) \
            if b >= 0 else pt[q]
        seg[q] = (pa, pb)
    return {"segments": seg, "point": pt, "dfn": dfn, "dft": dft,
            "dF": dfn[:, None] * n + dft[:, None] * t}


def surface_disk(packing) -> int:
    """The disk whose top (y + r) is highest: a disk of the free surface."""
    return int(np.argmax(np.asarray(packing.y) + np.asarray(packing.r)))


@dataclass(frozen=True)
class Rearrangement:
    """The rearrangement a push caused (:func:`rearrangement_depth`).

    region: indices of its disks (sorted); depth [R]: from the pushed disk's centre down
    to the lowest centre of the region (0 when the region is empty or lies above it);
    floor_gap [R]: the lowest point of the region's lowest-reaching disk above the floor
    (nan without a floor or a region); reaches_floor: floor_gap < ``config.FLOOR_LAYER``
    (the region reaches the bottom layer: the floor cut it off, its depth is censored);
    displaced: disks displaced by more than the threshold anywhere (the region's and
    others, e.g. a disk creeping elsewhere in the layer)."""

    region: np.ndarray
    depth: float
    floor_gap: float
    reaches_floor: bool
    displaced: int

    @property
    def size(self) -> int:
        """Disks in the region."""
        return int(self.region.size)


def displaced_region(packing, disk: int, displacement, threshold: float | None = None
                     ) -> np.ndarray:
    """The connected displaced region around ``disk``: the disks displaced by more than
    ``threshold`` R (default ``config.DISPLACED``) that are joined to ``disk`` through
    disk-disk contacts of ``packing`` (its settled state; near-contacts within its gap
    tolerance included, walls are not bodies here) via displaced disks only. ``disk``
    itself and its contact neighbours seed the region (those of them that are displaced);
    a displaced disk with no such path (a disk creeping elsewhere) is not part of it.
    Returns the sorted indices (empty when no seed is displaced)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    threshold = config.DISPLACED if threshold is None else threshold
    moved = np.asarray(displacement, float) > threshold
    n = packing.n_disks
    if moved.shape != (n,):
        raise InputError("rearrangement", "displacement", f"must have shape "
                         f"({n},), one value per disk", got=moved.shape)
    a, b = np.asarray(packing.a), np.asarray(packing.b)
    a, b = a[(a >= 0) & (b >= 0)], b[(a >= 0) & (b >= 0)]
    seeds = np.concatenate([[disk], b[a == disk], a[b == disk]])
    seeds = seeds[moved[seeds]]
    if seeds.size == 0:
        return np.zeros(0, np.int64)
    both = moved[a] & moved[b]          # edges between displaced disks only
    graph = coo_matrix((np.ones(int(both.sum())), (a[both], b[both])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    return np.flatnonzero(moved & np.isin(label, label[seeds]))


def rearrangement_depth(packing, disk: int, displacement, threshold: float | None = None,
                        floor_layer: float | None = None) -> Rearrangement:
    """The rearrangement around a push on ``disk`` (:class:`Rearrangement`): the
    connected displaced region (:func:`displaced_region`, threshold default
    ``config.DISPLACED`` R), its depth below ``disk``'s centre, and whether it reaches
    the bottom layer (lowest point less than ``floor_layer``, default
    ``config.FLOOR_LAYER`` R, above the floor ``packing.y_bottom``). Positions are
    ``packing``'s (the state before the push)."""
    threshold = config.DISPLACED if threshold is None else threshold
    floor_layer = config.FLOOR_LAYER if floor_layer is None else floor_layer
    region = displaced_region(packing, disk, displacement, threshold)
    displaced = int((np.asarray(displacement, float) > threshold).sum())
    if region.size == 0:
        return Rearrangement(region, 0.0, float("nan"), False, displaced)
    y, r = np.asarray(packing.y, float), np.asarray(packing.r, float)
    depth = float(max(y[disk] - y[region].min(), 0.0))
    gap = float((y[region] - r[region]).min() - packing.y_bottom) \
        if np.isfinite(packing.y_bottom) else float("nan")
    return Rearrangement(region, depth, gap, bool(gap < floor_layer), displaced)
