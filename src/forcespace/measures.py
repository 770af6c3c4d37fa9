"""Measures of the force ensemble: eta, indeterminacy structure, difference fields.

Samples are arrays (k, c m) in problem column order (:mod:`forcespace.model.problem`): columns
2j, 2j+1 are fn, ft of unknown contact j [F0] (disks, c = 2 ``per_contact``; spheres, c = 3:
3j, 3j+1, 3j+2 are fn, f1, f2, :mod:`forcespace.model.sphere_problem`).

eta (the paper's force ambiguity, Eq. 2), exactly:
    F_i = (fn_i, ft_i) the force vector of contact i ((fn_i, f1_i, f2_i) for spheres; the
    frame is fixed per contact, so |.| is the Euclidean vector norm),
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


def _check(samples, per_contact: int = 2):
    X = np.asarray(samples, float)
    if X.ndim != 2 or X.shape[1] % per_contact or X.shape[0] < 1:
        raise InputError("samples", "shape", f"must be (k >= 1, {per_contact}m)", got=X.shape)
    if not np.all(np.isfinite(X)):
        raise InputError("samples", "values", "must be finite (found NaN/inf)")
    return X


def contact_fluctuations(samples, per_contact: int = 2):
    """(dF (m,), mean |F| (m,)) as defined in the module docstring [F0]; ``per_contact``
    columns per contact (2 disks, 3 spheres)."""
    X = _check(samples, per_contact)
    k, mc = X.shape
    F = X.reshape(k, mc // per_contact, per_contact)
    # deviations from the first sample first, then from their mean: the same numbers,
    # but identical samples (a determinate S, dim S = 0) give exactly 0, where the mean
    # of k equal floats is not always that float (eta ~ 6e-16 from round-off)
    shifted = F - F[0]
    dev = shifted - shifted.mean(0)
    dF = np.sqrt((dev ** 2).sum(2).mean(0))
    mag = np.sqrt((F ** 2).sum(2)).mean(0)
    return dF, mag


def eta(samples, per_contact: int = 2) -> float:
    """The force ambiguity eta = <dF> / <|F|> (module docstring; ``per_contact`` columns
    per contact: 2 disks, 3 spheres)."""
    dF, mag = contact_fluctuations(samples, per_contact)
    den = mag.mean()
    if den == 0:
        raise InputError("samples", "forces", "all forces are zero; eta undefined")
    return float(dF.mean() / den)


def distance_from_centre(samples, x0):
    """Fig. 3 distances: the centre is the mean of the samples.

    Returns (l (k,), l0, lbar): distances of the samples and of x0 (the jammed
    state) from the centre [F0], and the mean sample distance lbar.
    """
    X = _check(samples, 1)      # any columns per contact
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


# ----------------------------------------------------------------------------
# observables of force-network ensembles (issue 47 item 11)
# ----------------------------------------------------------------------------
def force_pdf(fn, scale: float, edges) -> np.ndarray:
    """P(f): probability density (len(edges) - 1,) of f = fn / ``scale`` over the bins
    ``edges`` (ascending, in units of ``scale``); fn: any array of normal forces [F0]
    (e.g. all contacts of all samples), ``scale`` the mean normal force <Fn> [F0]. Forces
    beyond the last edge count in the normalisation (the density integrates to the
    fraction inside the bins)."""
    f = np.asarray(fn, float).ravel() / float(scale)
    e = require_array("force_pdf", "edges", edges, (None,), "bin edges in units of <Fn>")
    if f.size == 0 or e.size < 2 or np.any(np.diff(e) <= 0):
        raise InputError("force_pdf", "edges", "must be >= 2 ascending bin edges, with forces",
                         got=e.size)
    counts, _ = np.histogram(f, bins=e)
    return counts / (f.size * np.diff(e))


def stress_tensor(arms, forces, area: float) -> np.ndarray:
    """Cauchy stress (2, 2) [F0/R] of a set of disks: sigma = (1/V) sum_c a_c (x) f_c over
    every contact c of every disk, a_c (k, 2) [R] from the disk's centre to the contact
    point, f_c (k, 2) [F0] the force on that disk, V = ``area`` [R^2] of the region
    (2-D: force per length). Compression is negative; symmetric when every disk is in
    torque balance."""
    a = require_array("stress_tensor", "arms", arms, (None, 2), "[R]")
    f = require_array("stress_tensor", "forces", forces, (a.shape[0], 2), "[F0]")
    if not (np.isfinite(area) and area > 0):
        raise InputError("stress_tensor", "area", "must be a finite number > 0 [R^2]", got=area)
    return a.T @ f / float(area)


def fabric_tensor(normals, weights=None) -> np.ndarray:
    """Fabric tensor (2, 2) [1]: sum_c w_c n_c (x) n_c / sum_c w_c over contacts c with unit
    normals ``normals`` (k, 2); ``weights`` (k,) >= 0 (default 1: the geometric fabric;
    fn: the force-weighted one). Trace 1; isotropic: diag(1/2, 1/2)."""
    n = require_array("fabric_tensor", "normals", normals, (None, 2), "unit vectors")
    w = np.ones(n.shape[0]) if weights is None else \
        require_array("fabric_tensor", "weights", weights, (n.shape[0],), ">= 0")
    if n.shape[0] == 0 or w.min() < 0 or w.sum() <= 0:
        raise InputError("fabric_tensor", "weights", "must be >= 0 with a positive sum, "
                         "over at least one contact", got=n.shape[0])
    return (n * w[:, None]).T @ n / w.sum()


def network_arms_and_forces(packing, problem, x):
    """Per contact end on an interior disk of ``problem``: (arms (k, 2) [R], forces (k, 2)
    [F0] on the disk, normals (k, 2), fn (k,)) for the network x (2m,) [F0] (unknown
    contacts) with the loads at the packing's values: the input of
    :func:`stress_tensor`. Force on body b: fn n + ft t with t = (-n_y, n_x); on a: minus
    that. Periodic x: the arm is the minimum image of point - centre."""
    x = require_array("network_arms_and_forces", "x", x, (problem.n_columns,), "[F0]")
    fn, ft = np.array(packing.fn, float), np.array(packing.ft, float)
    fn[problem.contacts], ft[problem.contacts] = x[0::2], x[1::2]
    cs = np.concatenate([problem.contacts, problem.load_contacts]).astype(np.int64)
    n = np.asarray(packing.normal, float)[cs]
    F = fn[cs, None] * n + ft[cs, None] * np.stack([-n[:, 1], n[:, 0]], axis=1)
    inside = np.zeros(packing.n_disks, bool)
    inside[np.asarray(problem.disks, np.int64)] = True
    out = []
    for body, sign in ((np.asarray(packing.a)[cs], -1.0), (np.asarray(packing.b)[cs], 1.0)):
        k = (body >= 0) & inside[np.maximum(body, 0)]            # walls are negative codes
        arm = np.asarray(packing.point)[cs][k] - np.stack(
            [np.asarray(packing.x)[body[k]], np.asarray(packing.y)[body[k]]], axis=1)
        if packing.periodic_x:                  # the contact point is stored in [0, width)
            arm[:, 0] -= packing.width * np.round(arm[:, 0] / packing.width)
        out.append((arm, sign * F[k], n[k], fn[cs][k]))
    return tuple(np.concatenate(parts) for parts in zip(*out))


def region_area(packing, problem) -> float:
    """Area [R^2] of the region of ``problem``'s interior disks: the slice (width x
    height) or the box between the plates (the disks' extent where a plate is absent)."""
    if problem.height is not None:
        return float(packing.width * problem.height)
    y, r = np.asarray(packing.y, float), np.asarray(packing.r, float)
    lo = packing.y_bottom if np.isfinite(packing.y_bottom) else float((y - r).min())
    hi = packing.y_top if np.isfinite(packing.y_top) else float((y + r).max())
    return float(packing.width * (hi - lo))


def eta_interval(samples, chains, batches: int = 5, level: float = 0.95,
                 per_contact: int = 2) -> dict:
    """eta with its Monte-Carlo uncertainty from the chains: each chain cut into
    ``batches`` contiguous batches (long against the autocorrelation, the batch-means
    idea), the delete-one-batch jackknife over all of them (J = chains x batches):
    se = sqrt((J - 1) / J sum_j (eta_-j - mean)^2), and the Student-t interval at
    ``level``. {"eta", "se", "low", "high", "level", "batches"}; se None (no interval)
    with fewer than 2 draws per batch. ``per_contact``: as :func:`eta`."""
    from scipy import stats

    X = _check(samples, per_contact)
    c = np.asarray(chains)
    if c.shape != (X.shape[0],):
        raise InputError("eta_interval", "chains", f"must have shape ({X.shape[0]},)",
                         got=c.shape)
    value = eta(X, per_contact)
    groups = []
    for ch in np.unique(c):
        rows = np.flatnonzero(c == ch)
        groups += [g for g in np.array_split(rows, batches) if g.size]
    out = {"eta": value, "se": None, "low": None, "high": None, "level": level,
           "batches": len(groups)}
    if len(groups) < 2 or min(g.size for g in groups) < 2:
        return out
    label = np.empty(X.shape[0], np.int64)
    for j, g in enumerate(groups):
        label[g] = j
    loo = np.array([eta(X[label != j], per_contact) for j in range(len(groups))])
    J = len(groups)
    se = float(np.sqrt((J - 1) / J * ((loo - loo.mean()) ** 2).sum()))
    half = float(stats.t.ppf(0.5 + level / 2, J - 1)) * se
    out.update(se=se, low=value - half, high=value + half)
    return out
