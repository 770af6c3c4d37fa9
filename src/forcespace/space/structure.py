"""Domains of indeterminacy and elementary clusters: the structure of S (the paper's Fig. 2).

The directions in which a network can move inside S form the linear space
L = span(N), N = ``analysis.affine_basis`` (2m, d) [columns in problem order:
x[2j] = fn, x[2j+1] = ft of contact j]. A self-stress of the free directions is
a vector v of L; its support is the set of columns where it is non-zero. A
*circuit* is a v whose support is minimal (no v' of L has a strictly smaller
support): statically indeterminate, one degree of freedom, irreducible — the
paper's elementary cluster, on the level of force components (science.md §3).

Decomposition. L splits into independent domains (:func:`domains`);
inside each domain of dimension k we look for k circuits that span it, the
sparsest we can find: one L1-minimal vector through each pivot column of a
well-conditioned basis of the domain (an LP whose basic optimal solutions are
circuits), then a greedy choice by support size that keeps the chosen vectors
independent (the greedy algorithm is exact for the
minimum-weight basis among the candidates; the globally sparsest circuit basis
is NP-hard, so the candidates are the LP circuits and the fundamental circuits).

On the level of contacts a cluster is the set of contacts its circuit touches;
``dof`` is the dimension of L restricted to those contacts' columns. ``dof == 1``
is the paper's elementary cluster (deleting any one of its contacts cancels the
indeterminacy); ``dof > 1`` means the circuit needs contacts that also carry
another degree of freedom (overlapping clusters).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.optimize import linprog
from scipy.sparse.csgraph import connected_components

from .. import config
from ..streams import direction_generator
from .loads import extreme_point



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


def domains(problem, analysis, tol: float | None = None) -> list[Domain]:
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
    tol = config.CIRCUIT_TOL if tol is None else tol
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
    if Nv.shape[0] >= config.SWEEP_MIN_COLUMNS:
        circuits = _fundamental_supports_lu(Nv, vary, tol)
        if circuits is not None:
            return _group_domains(problem, m, circuits)
    # well-conditioned pivot columns (QR with column pivoting), then the
    # reduced form R = B^-1 N^T whose rows are the fundamental circuits
    _, rq, perm = sla.qr(Nv.T, mode="economic", pivoting=True)
    diag = np.abs(np.diag(rq))
    rank = int((diag > config.PIVOT_TOL * max(diag[0], 1e-300)).sum())
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
    if d == 0 or diag.min() <= config.PIVOT_TOL * max(diag.max(), 1e-300):
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



@dataclass(frozen=True)
class Cluster:
    """One circuit of the free directions of S.

    vector: (2m,) the self-stress, max |entry| = 1 [F0 per unit]; columns: its
    support (problem column indices); contacts: problem contacts it touches;
    disks: packing indices of the interior disks they touch; dof: dimension of
    L on the columns of those contacts; elementary: dof == 1; domain: index
    into :attr:`ClusterDecomposition.domains`.
    """

    vector: np.ndarray
    columns: np.ndarray
    contacts: np.ndarray
    disks: np.ndarray
    dof: int
    elementary: bool
    domain: int


@dataclass(frozen=True)
class ClusterDecomposition:
    """Clusters of a problem: ``clusters`` (sum of their count over a domain = its
    dim), ``domains`` (:class:`Domain`), and per-domain
    ``percolates`` (bool: its disks touch both the top and the bottom load of the
    slice; False where the problem has no such loads or no packing was given)."""

    clusters: list
    domains: list
    percolates: list
    n_interior: int

    @property
    def n_elementary(self) -> int:
        return sum(c.elementary for c in self.clusters)

    @property
    def density(self) -> float:
        """rho: elementary clusters per interior (non-rattler) disk."""
        return self.n_elementary / max(self.n_interior, 1)

    def summary(self) -> dict:
        sizes = [int(c.contacts.size) for c in self.clusters if c.elementary]
        dom = [int(g.contacts.size) for g in self.domains]
        return {"n_domains": len(self.domains), "domain_dims": [g.dim for g in self.domains],
                "n_clusters": len(self.clusters), "n_elementary": self.n_elementary,
                "elementary_sizes_contacts": sizes,
                "elementary_sizes_disks": [int(c.disks.size) for c in self.clusters
                                           if c.elementary],
                "density_rho": self.density,
                "largest_domain_contacts": max(dom, default=0),
                "percolating_domains": int(sum(self.percolates))}


def _least_directions(M, k: int) -> np.ndarray:
    """The k right singular vectors of M (r, d) with the smallest singular values, (d, k):
    the directions of L that vanish outside a domain of dimension k. Taken by count, not
    by a threshold: on ill-conditioned slices (mu = 10) a domain's vectors leak 1e-9 of
    their norm outside it, above a null space's round-off cut-off, and the domain then
    looked empty (0 clusters for domains of dimension 1)."""
    _, _, vt = np.linalg.svd(M, full_matrices=True)
    return vt[vt.shape[0] - k:].T


def _restricted_dim(N, cols) -> int:
    """dim of {v in span(N): v = 0 outside ``cols``} = d - rank(N[rest])."""
    rest = np.setdiff1d(np.arange(N.shape[0]), cols)
    if rest.size == 0:
        return N.shape[1]
    s = sla.svdvals(N[rest])
    # couplings below CIRCUIT_TOL are round-off, as in the domains (1e-9 leaks at mu = 10)
    return int(N.shape[1] - (s > config.CIRCUIT_TOL * max(s.max(initial=0.0), 1.0)).sum())


def _l1_circuit(B, k):
    """An L1-minimal vector of span(B) (q, d) with entry k equal to 1, or None."""
    q, d = B.shape
    # variables (y (d), t (q)): minimise sum t, -t <= B y <= t, (B y)_k = 1
    c = np.concatenate([np.zeros(d), np.ones(q)])
    eye = np.eye(q)
    A_ub = np.block([[B, -eye], [-B, -eye]])
    A_eq = np.concatenate([B[k], np.zeros(q)])[None]
    res = linprog(c, A_ub=A_ub, b_ub=np.zeros(2 * q), A_eq=A_eq, b_eq=[1.0],
                  bounds=[(None, None)] * d + [(0, None)] * q, method="highs-ds")
    return B @ res.x[:d] if res.status == 0 else None


def _support(v) -> np.ndarray:
    return np.flatnonzero(np.abs(v) > config.SUPPORT_TOL * np.abs(v).max())


def decompose(problem, analysis, packing=None, tol: float | None = None) -> ClusterDecomposition:
    """Elementary clusters of S (module docstring). ``analysis``: of ``problem``,
    from :class:`forcespace.space.force_space.ForceSpace` (feasible, with its affine basis);
    ``packing``: the packing of ``problem``, needed for percolation only."""
    doms = domains(problem, analysis, tol) if analysis.feasible and analysis.dim else []
    N = analysis.affine_basis
    vary = varying_mask(analysis) if doms else None
    clusters = []
    for gi, g in enumerate(doms):
        cols = np.sort(np.concatenate([2 * g.contacts, 2 * g.contacts + 1]))
        # basis of the domain's part of L: the vectors of L supported on its columns
        outside = np.setdiff1d(np.arange(N.shape[0]), cols)
        Nv = N.reshape(-1, 2, N.shape[1]).copy()
        Nv[~vary] = 0.0
        Nv = Nv.reshape(N.shape)
        null = _least_directions(Nv[outside], g.dim) if outside.size else np.eye(N.shape[1])
        B = Nv[cols] @ null                                 # (q, k) spans the domain
        B = sla.orth(B, rcond=config.PIVOT_TOL)[:, :g.dim] if B.shape[1] > g.dim else B
        # pivot columns of a well-conditioned basis: one L1-minimal circuit through
        # each, plus the fundamental circuits (which always span the domain)
        _, _, perm = sla.qr(B.T, mode="economic", pivoting=True)
        piv = np.sort(perm[:B.shape[1]])
        candidates = [v for v in (_l1_circuit(B, k) for k in piv) if v is not None]
        candidates += list((B @ np.linalg.solve(B[piv], np.eye(B.shape[1]))).T)
        candidates.sort(key=lambda v: (_support(v).size, -np.abs(v).min()))
        chosen, Q = [], np.zeros((B.shape[0], 0))
        for v in candidates:                      # greedy: keep what adds a direction
            r = v - Q @ (Q.T @ v)
            if np.linalg.norm(r) > config.NEW_DIRECTION_TOL * np.linalg.norm(v):
                chosen.append(v)
                Q = np.column_stack([Q, r / np.linalg.norm(r)])
            if len(chosen) == g.dim:
                break
        for v in chosen:
            full = np.zeros(N.shape[0])
            full[cols] = v / np.abs(v).max()
            sup = _support(full)
            contacts = np.unique(sup // 2)
            ccols = np.sort(np.concatenate([2 * contacts, 2 * contacts + 1]))
            dof = _restricted_dim(Nv, ccols)
            clusters.append(Cluster(vector=full, columns=sup, contacts=contacts,
                                    disks=problem.contact_disks(contacts), dof=int(dof),
                                    elementary=dof == 1, domain=gi))
    return ClusterDecomposition(clusters=clusters, domains=doms,
                                percolates=[packing is not None and
                                            percolates(problem, packing, g) for g in doms],
                                n_interior=problem.n_interior)


def boundary_disks(problem, packing):
    """(top, bottom): packing indices of interior disks carrying a fixed load from a
    disk whose centre lies above / below theirs (the slice's boundary layers)."""
    interior = np.zeros(packing.n_disks, bool)
    interior[problem.disks] = True
    a = np.asarray(packing.a)[problem.load_contacts]
    b = np.asarray(packing.b)[problem.load_contacts]
    y = np.asarray(packing.y)
    top, bottom = [], []
    for mine, other in ((a, b), (b, a)):
        ok = (mine >= 0) & (other >= 0)
        mine, other = mine[ok], other[ok]
        keep = interior[mine]
        mine, other = mine[keep], other[keep]
        top += mine[y[other] > y[mine]].tolist()
        bottom += mine[y[other] < y[mine]].tolist()
    return np.unique(np.array(top, np.int64)), np.unique(np.array(bottom, np.int64))


def percolates(problem, packing, domain) -> bool:
    """Whether a domain's disks reach both the top and the bottom load of the slice."""
    top, bottom = boundary_disks(problem, packing)
    return bool(np.intersect1d(domain.disks, top).size and
                np.intersect1d(domain.disks, bottom).size)


def extreme_pair(problem, analysis, seed: int = 0):
    """Two admissible networks (x1, x2) (2m,) [F0] far apart: the vertices of S that
    minimise and maximise a random direction of its affine hull (seeded). Their
    difference is generically non-zero on every varying contact (the paper's Fig. 2)."""

    N = analysis.affine_basis
    c = N @ direction_generator(seed).normal(size=N.shape[1])
    return extreme_point(problem, -c), extreme_point(problem, c)
