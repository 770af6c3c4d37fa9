"""Measures of the force ensemble: eta, indeterminacy structure, difference fields.

Samples are arrays (k, 2m) in problem column order (statics.py): columns
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
import scipy.linalg as sla
import scipy.sparse as sp

from .errors import InputError


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
    dev = F - F.mean(0)
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
    c = X.mean(0)
    ell = np.linalg.norm(X - c, axis=1)
    l0 = float(np.linalg.norm(np.asarray(x0, float) - c))
    return ell, l0, float(ell.mean())


def coordination(packing, problem=None, rel_threshold: float = 1e-9) -> float:
    """z (Packing.coordination convention: 2 Nc / n over non-rattlers, walls count)."""
    return float(packing.coordination(rel_threshold))


# ----------------------------------------------------------------------------
# indeterminacy structure
# ----------------------------------------------------------------------------
@dataclass
class Domain:
    """An independent domain of indeterminacy.

    contacts: problem contact indices whose force varies in it; disks: packing
    disk indices touched (interior ones); dim: its number of degrees of
    freedom; elementary: dim == 1 (a single circuit: irreducible).
    """

    contacts: np.ndarray
    disks: np.ndarray
    dim: int
    elementary: bool


def _rref_pivots(M, tol):
    """Pivot columns and the reduced row echelon form of M (d, q) (partial pivoting)."""
    R = np.array(M, float)
    d, q = R.shape
    piv = []
    row = 0
    for col in range(q):
        if row >= d:
            break
        best = row + int(np.argmax(np.abs(R[row:, col])))
        if abs(R[best, col]) <= tol:
            continue
        R[[row, best]] = R[[best, row]]
        R[row] /= R[row, col]
        others = np.arange(d) != row
        R[others] -= np.outer(R[others, col], R[row])
        piv.append(col)
        row += 1
    return np.array(piv, dtype=np.int64), R[:row]


# null bases with at least this many rows take the LU path of domains (see
# _fundamental_supports_lu); smaller ones keep the QR one (as polytope.SWEEP_MIN_COLUMNS)
SWEEP_MIN_COLUMNS = 1500
CIRCUIT_TOL = 1e-6   # entries of a fundamental circuit below this x its largest are round-off


def domains(problem, analysis, tol: float = CIRCUIT_TOL) -> list[Domain]:
    """Independent domains of indeterminacy of S and their dimensions.

    The directions in which a force network can move inside S form the null
    space of the equality system of the affine hull of S (equilibrium, fixed
    columns and the implicit equalities: sliding and zero contacts). Its
    minimal supports are the circuits of a matroid on the columns; the
    matroid's connected components are read from the fundamental circuits
    (rows of the RREF of the null basis): two contacts are connected if they
    share a fundamental circuit. A domain's dimension is the number of
    fundamental circuits it holds; domains of dimension 1 are single
    circuits, i.e. supports of a minimal self-stress: the paper's elementary
    clusters.

    Only the varying contacts (``analysis.varying``: force can change by more
    than VARY_TOL <Fn>) take part; basis entries of the others are round-off
    couplings and are removed first. So the domains' contacts are exactly the
    varying contacts, and the dimensions add up to the number of independent
    directions among them (dim S unless S is thinner than VARY_TOL <Fn> in
    some direction).
    """
    N = analysis.affine_basis
    if N is None or N.shape[1] == 0:
        return []
    m = problem.n_contacts
    d = N.shape[1]
    vary = varying_mask(analysis)
    if not vary.any():
        return []
    Nv = N.reshape(m, 2, d).copy()
    Nv[~vary] = 0.0
    Nv = Nv.reshape(2 * m, d)
    if Nv.shape[0] >= SWEEP_MIN_COLUMNS:
        circuits = _fundamental_supports_lu(Nv, vary, tol)
        if circuits is not None:
            return _group_domains(problem, m, circuits)
    # well-conditioned pivot columns (QR with column pivoting), then the
    # reduced form R = B^-1 N^T whose rows are the fundamental circuits
    _, rq, perm = sla.qr(Nv.T, mode="economic", pivoting=True)
    diag = np.abs(np.diag(rq))
    rank = int((diag > 1e-9 * max(diag[0], 1e-300)).sum())
    piv = np.sort(perm[:rank])
    R = sla.lstsq(Nv.T[:, piv], Nv.T)[0]                   # (rank, 2m)
    Rc = np.sqrt(R[:, 0::2] ** 2 + R[:, 1::2] ** 2)        # per contact (rank, m)
    support = Rc > tol * Rc.max(axis=1, keepdims=True)
    support[:, ~vary] = False
    support[np.arange(rank), piv // 2] = True
    lonely = np.flatnonzero(vary & ~support.any(axis=0))  # every varying contact in a circuit
    support[np.argmax(Rc[:, lonely], axis=0), lonely] = True
    # union-find over contacts
    parent = np.arange(m)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    row_contacts = []
    for r in range(rank):
        cs = np.flatnonzero(support[r])
        row_contacts.append(cs)
        for c in cs[1:]:
            ra, rb = find(cs[0]), find(c)
            if ra != rb:
                parent[rb] = ra
    groups = {}
    for r, cs in enumerate(row_contacts):
        root = find(cs[0])
        g = groups.setdefault(root, [set(), 0])
        g[0].update(cs.tolist())
        g[1] += 1
    out = []
    for root, (cs, dim) in groups.items():
        cs = np.array(sorted(cs), dtype=np.int64)
        out.append(Domain(contacts=cs, disks=problem.contact_disks(cs), dim=int(dim),
                          elementary=dim == 1))
    out.sort(key=lambda g: (-g.dim, -g.contacts.size))
    return out


def _fundamental_supports_lu(Nv, vary, tol):
    """Supports of the fundamental circuits of the null basis Nv (2m, d), per contact:
    a bool (d, m) matrix, or None when Nv is not of full column rank d (the caller
    then takes the rank-revealing QR path).

    The pivot columns come from an LU factorisation with partial (row) pivoting,
    Nv = P L U (a well-conditioned column basis B = rows piv of Nv when U's diagonal
    stays above 1e-9 of its largest): then B^-1-reduced form R = L1^-T L^T, whose
    rows are the fundamental circuits ([I | L1^-T L2^T] in pivot order), costs one
    triangular solve instead of a QR with column pivoting and a least-squares solve
    (dense O(m d^2) BLAS-3 both, several times cheaper). The matroid's connected
    components and the dimensions do not depend on the choice of basis.
    """
    n2, d = Nv.shape
    p, L, U = sla.lu(Nv, p_indices=True)                   # Nv = L[p] U, L (2m, d)
    P = np.argsort(p)                                      # Nv[P] = L U
    diag = np.abs(np.diag(U))
    if d == 0 or diag.min() <= 1e-9 * max(diag.max(), 1e-300):
        return None
    # rows P[:d] of Nv form the basis B = L1 U; R = B^-T-reduced = L1^-T L^T (permuted)
    L1 = L[:d]
    X = sla.solve_triangular(L1, L[d:].T, trans="T", lower=True, unit_diagonal=True,
                             check_finite=False)           # L1^-T L2^T (d, 2m - d)
    R = np.empty((d, n2))
    R[:, P[:d]] = np.eye(d)
    R[:, P[d:]] = X
    Rc = np.sqrt(R[:, 0::2] ** 2 + R[:, 1::2] ** 2)        # per contact (d, m)
    support = Rc > tol * Rc.max(axis=1, keepdims=True)
    support[:, ~vary] = False
    support[np.arange(d), P[:d] // 2] = True
    lonely = np.flatnonzero(vary & ~support.any(axis=0))  # every varying contact in a circuit
    support[np.argmax(Rc[:, lonely], axis=0), lonely] = True
    return support


def _group_domains(problem, m, support):
    """Domains from circuit supports (d, m) bool: connected components of the
    bipartite graph circuits - contacts (the matroid's components); a domain's
    dim is its number of circuits. Sorted by (-dim, -size, first contact)."""
    from scipy.sparse.csgraph import connected_components

    rows, cols = np.nonzero(support)
    k = support.shape[0]
    g = sp.coo_matrix((np.ones(rows.size), (rows, k + cols)), shape=(k + m, k + m))
    _, lab = connected_components(g, directed=False)
    in_circuit = np.flatnonzero(support.any(axis=0))       # contacts, ascending
    clab = lab[k + in_circuit]
    dims = np.bincount(lab[:k], minlength=lab.max() + 1)
    order = np.argsort(clab, kind="stable")
    labs, starts = np.unique(clab[order], return_index=True)
    out = []
    for c, cs in zip(labs, np.split(in_circuit[order], starts[1:])):
        out.append(Domain(contacts=cs.astype(np.int64), disks=problem.contact_disks(cs),
                          dim=int(dims[c]), elementary=bool(dims[c] == 1)))
    out.sort(key=lambda g: (-g.dim, -g.contacts.size, int(g.contacts[0])))
    return out


def varying_mask(analysis) -> np.ndarray:
    """Mask (m,) of contacts whose force can change within S (``analysis.varying``)."""
    if analysis.varying is not None:
        return np.asarray(analysis.varying, bool)
    return np.zeros(analysis.n_contacts, dtype=bool)


def varying_contacts(analysis) -> np.ndarray:
    """Problem contact indices whose force can change within S by more than
    VARY_TOL <Fn> (see :func:`forcespace.polytope.analyze`)."""
    return np.flatnonzero(varying_mask(analysis))


def difference_field(packing, problem, x1, x2) -> dict:
    """The difference of two admissible networks as a drawable field.

    Returns arrays per unknown contact j: ``segments`` (m, 2, 2) the line from
    the centre of body a to the centre of body b (periodic image applied;
    walls: the contact point) [R], ``point`` (m, 2) contact point [R],
    ``dfn``, ``dft`` (m,) the differences x2 - x1 [F0] and ``dF`` (m, 2) the
    force difference vector on b [F0].
    """
    x1 = np.asarray(x1, float)
    x2 = np.asarray(x2, float)
    k = problem.contacts
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


def summary(problem, analysis, samples=None, packing=None) -> dict:
    """Numbers for reports: dims, sliding, domains, eta and Fig.-3 distance."""
    doms = domains(problem, analysis) if analysis.feasible and analysis.dim_S else []
    out = {"n_interior": problem.n_interior, "n_contacts": problem.n_contacts,
           "degree_of_indeterminacy": analysis.degree_of_indeterminacy,
           "dim_S": analysis.dim_S, "bounded": analysis.bounded, "feasible": analysis.feasible,
           "n_sliding": analysis.n_sliding, "n_zero_force": analysis.n_zero,
           "n_domains": len(doms), "domain_dims": [g.dim for g in doms],
           "n_elementary_clusters": int(sum(g.elementary for g in doms)),
           "n_varying_contacts": int(varying_contacts(analysis).size) if analysis.feasible else 0}
    # directions of S along which no contact force changes by more than VARY_TOL <Fn>
    out["n_thin_directions"] = (int(analysis.dim_S) - sum(g.dim for g in doms)
                                if analysis.dim_S is not None else None)
    if packing is not None:
        out["z"] = coordination(packing)
    if samples is not None and len(samples):
        out["eta"] = eta(samples)
        ell, l0, lbar = distance_from_centre(samples, problem.x_jammed)
        out["jammed_distance_from_centre"] = l0
        out["mean_sample_distance_from_centre"] = lbar
    return out
