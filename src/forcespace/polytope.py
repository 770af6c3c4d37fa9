"""Exact analysis of the force ensemble S with linear programming (HiGHS).

S = {x : A x = b, x_fixed = 0, G x <= 0} (see statics.py for the columns and
rows). Every question here is answered by LPs solved with
``scipy.optimize.linprog(method="highs")``; the Euclidean projection onto S is a
convex QP solved exactly by least-distance programming (NNLS) and then
*polished and verified* by an exact active-set step (see :func:`distance_to_S`).

Tolerances are relative to ``problem.force_scale`` (<Fn>, the mean jammed
normal force over the unknown contacts): an inequality is "tight everywhere"
(an implicit equality) when no point of S has slack larger than
``tol * force_scale``; default tol = 1e-9.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.optimize import linprog

from .errors import InputError, NumericalError
from .statics import StaticsProblem

TOL = 1e-9
VARY_TOL = 1e-6   # a contact varies in S if its fn or ft can change by more than this x <Fn>


# ----------------------------------------------------------------------------
# LP helpers
# ----------------------------------------------------------------------------
# HiGHS set-ups tried in turn when one ends without an answer (status 1 or 4: iteration
# limit, numerical difficulties, or HiGHS's "model status unknown", seen on ill-conditioned
# slices at mu >= 0.4): the default, dual simplex without presolve, interior point.
LP_ATTEMPTS = (("highs", {}), ("highs-ds", {"presolve": False}), ("highs-ipm", {}))
# Large problems (n_columns >= SWEEP_MIN_COLUMNS) solve the feasibility, boundedness,
# implicit-equality and Chebyshev-centre LPs by interior point (with HiGHS' crossover to
# a basic solution) first: the simplex iteration count grows with the size, IPM's does
# not (measured 2x faster at 2000 disks, see studies/bench.py analysis). Then the chain
# above.
LP_ATTEMPTS_LARGE = (("highs-ipm", {}),) + LP_ATTEMPTS


def _attempts(problem: StaticsProblem):
    """The LP set-ups to try for the feasibility / boundedness / implicit LPs of problem."""
    return LP_ATTEMPTS_LARGE if problem.n_columns >= SWEEP_MIN_COLUMNS else LP_ATTEMPTS


def _lp(c, A_ub=None, b_ub=None, A_eq=None, b_eq=None, bounds=None, attempts=None):
    """scipy/HiGHS linprog; status 0 optimal, 2 infeasible, 3 unbounded are answers,
    anything else is retried with the next of ``attempts`` (default LP_ATTEMPTS; the
    last result is returned)."""
    for method, options in (LP_ATTEMPTS if attempts is None else attempts):
        res = linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq, bounds=bounds,
                      method=method, options=options)
        if res.status in (0, 2, 3):
            break
    return res


def _bounds_list(lo, hi):
    return list(zip([None if not np.isfinite(v) else v for v in lo],
                    [None if not np.isfinite(v) else v for v in hi]))


def _eq_system(problem: StaticsProblem, extra_rows=None):
    """Equality matrix [A; fixed columns; extra] as CSR and its rhs."""
    m2 = problem.n_columns
    fixed = problem.fixed_columns()
    F = sp.csr_matrix((np.ones(fixed.size), (np.arange(fixed.size), fixed)),
                      shape=(fixed.size, m2))
    blocks = [problem.A, F]
    rhs = [problem.b, np.zeros(fixed.size)]
    if extra_rows is not None and extra_rows.shape[0]:
        blocks.append(extra_rows)
        rhs.append(np.zeros(extra_rows.shape[0]))
    return sp.vstack(blocks).tocsr(), np.concatenate(rhs)


# Equality systems with at least this many columns are factorised by the frontier sweep
# of :mod:`forcespace.nullspace` (sparse, ~linear cost) instead of one dense SVD (cubic);
# smaller ones keep the dense SVD, so the paper-sized slices (~400 columns) give the
# same bits as before. A sweep whose rank decisions came within SWEEP_MARGIN of the
# threshold falls back to the dense SVD.
SWEEP_MIN_COLUMNS = 1500
SWEEP_MARGIN = 100.0


def _use_sweep(M) -> bool:
    return sp.issparse(M) and M.shape[1] >= SWEEP_MIN_COLUMNS and M.shape[0] > 0


def _sweep(M, rhs=None, tol_rel=1e-10, basis=True):
    """The frontier sweep of M (sparse), or None when a rank decision was close
    (within SWEEP_MARGIN of the threshold: the caller then uses the dense SVD)."""
    from .nullspace import sweep_null_space

    res = sweep_null_space(M, rhs, tol_rel=tol_rel, basis=basis)
    if res.kept_margin < SWEEP_MARGIN or res.dropped_margin > 1.0 / SWEEP_MARGIN:
        return None
    return res


def _rank(M, tol_rel=1e-10) -> int:
    if _use_sweep(M):
        res = _sweep(M, tol_rel=tol_rel, basis=False)
        if res is not None:
            return res.rank
    M = M.toarray() if sp.issparse(M) else np.asarray(M)
    if M.size == 0:
        return 0
    s = np.linalg.svd(M, compute_uv=False)
    return int((s > tol_rel * max(s[0], 1e-300) * max(M.shape)).sum()) if s.size else 0


def null_basis(M, tol_rel=1e-10, return_noise: bool = False):
    """Orthonormal basis N (ncol, d) of the null space of M (dense SVD).

    With ``return_noise``: also the round-off level of N's entries, eps times
    the condition number of M on its row space (s_max / s_rank); entries of N
    below a few hundred times that are indistinguishable from zero.
    """
    M = M.toarray() if sp.issparse(M) else np.asarray(M)
    eps = np.finfo(float).eps
    if M.shape[0] == 0:
        N, noise = np.eye(M.shape[1]), eps
    else:
        u, s, vt = np.linalg.svd(M, full_matrices=True)
        rank = int((s > tol_rel * max(s[0], 1e-300) * max(M.shape)).sum()) if s.size else 0
        N = vt[rank:].T.copy()
        noise = eps * s[0] / s[rank - 1] if rank else eps
    return (N, float(noise)) if return_noise else N


def _affine_hull(M, rhs, x0, tol_rel=1e-10):
    """(N, xa, rank): orthonormal null basis of M (as :func:`null_basis`), x0 moved
    onto {M x = rhs} by the minimum-norm step, and the rank of M, all from one dense
    SVD of M. The step uses only the singular values above the rank threshold: a
    least-squares solve that keeps the round-off ones (1e-16 s_max, dependent rows)
    moves x0 along null directions, i.e. out of S (seen: 2e-2 <Fn> on a slice).
    Large sparse M (>= SWEEP_MIN_COLUMNS columns): the same three from the
    frontier sweep (:mod:`forcespace.nullspace`), another orthonormal basis of
    the same null space."""
    if _use_sweep(M):
        x0 = np.asarray(x0, float)
        res = _sweep(M, M @ x0 - rhs, tol_rel=tol_rel)
        if res is not None:
            return res.basis, x0 - res.step, res.rank
    M = M.toarray() if sp.issparse(M) else np.asarray(M)
    if M.shape[0] == 0:
        return np.eye(M.shape[1]), np.asarray(x0, float).copy(), 0
    u, s, vt = np.linalg.svd(M, full_matrices=True)
    rank = int((s > tol_rel * max(s[0], 1e-300) * max(M.shape)).sum()) if s.size else 0
    r = M @ x0 - rhs
    step = vt[:rank].T @ ((u[:, :rank].T @ r) / s[:rank])
    return vt[rank:].T.copy(), x0 - step, rank


# ----------------------------------------------------------------------------
# Results
# ----------------------------------------------------------------------------
@dataclass
class PolytopeAnalysis:
    """Exact facts about S. Arrays indexed by problem contact j (0..m-1) unless stated.

    fn_range, ft_range: (m, 2) min and max of fn, ft over S [F0] (NaN if S is
    unbounded or infeasible, or ranges were not requested).
    implicit: list of (contact j, kind) inequalities tight on all of S; kind
    "slides+" (ft = +mu fn), "slides-" (ft = -mu fn), "zero" (fn = ft = 0).
    centre: Chebyshev centre of S inside its affine hull (2m,) [F0], with radius.
    affine_point, affine_basis: S lies in {affine_point + affine_basis @ y},
    affine_basis (2m, dim_S) orthonormal.
    varying: (m,) contacts whose force can change by more than VARY_TOL <Fn>
    within S (decided on forces, by bounds from the ball and the diameter of S
    and by LP where they do not decide; see :func:`_varying`).
    """

    feasible: bool
    bounded: bool | None
    n_interior: int
    n_contacts: int
    n_unknowns: int                 # free columns: 2m minus fixed ft of mu=0 contacts
    rank_A: int                     # rank of A over the unknown columns
    full_row_rank: bool
    degree_of_indeterminacy: int    # n_unknowns - rank([A; fixed])
    dim_S: int | None
    n_sliding: int | None
    n_zero: int | None
    implicit: list = field(default_factory=list)
    sliding_contacts: np.ndarray | None = None
    zero_contacts: np.ndarray | None = None
    fn_range: np.ndarray | None = None
    ft_range: np.ndarray | None = None
    centre: np.ndarray | None = None
    centre_radius: float | None = None
    max_sum_fn: float | None = None
    recession_direction: np.ndarray | None = None
    infeasibility: dict | None = None
    affine_point: np.ndarray | None = None
    affine_basis: np.ndarray | None = None
    implicit_rows: np.ndarray | None = None   # indices into problem.inequalities() rows
    force_scale: float = 1.0
    varying: np.ndarray | None = None         # (m,) bool: force can change by > VARY_TOL <Fn>

    def summary(self) -> dict:
        d = {"feasible": self.feasible, "bounded": self.bounded,
             "n_interior": self.n_interior, "n_contacts": self.n_contacts,
             "n_unknowns": self.n_unknowns, "rank_A": self.rank_A,
             "full_row_rank": self.full_row_rank,
             "degree_of_indeterminacy": self.degree_of_indeterminacy,
             "dim_S": self.dim_S, "n_sliding": self.n_sliding, "n_zero_force": self.n_zero,
             "max_sum_fn": self.max_sum_fn, "force_scale": self.force_scale,
             "centre_radius": self.centre_radius}
        if self.infeasibility is not None:
            d["infeasibility"] = self.infeasibility
        if self.recession_direction is not None:
            rd = self.recession_direction
            d["recession_direction_support"] = int((np.abs(rd) > 1e-9 * np.abs(rd).max()).sum())
        return d


@dataclass
class DistanceResult:
    """Euclidean distance from a force vector x to S.

    absolute = ||nearest - x||_2 [F0]; relative = absolute / (<Fn> sqrt(m)) with
    <Fn> = problem.force_scale and m the number of unknown contacts, i.e. the
    rms per-contact distance in units of the mean normal force.
    nearest (2m,) is the exact projection (verified KKT point); kkt_residual
    and max_violation (relative to <Fn>) report the verification.
    """

    absolute: float
    relative: float
    nearest: np.ndarray
    max_violation: float
    kkt_residual: float
    method: str


# ----------------------------------------------------------------------------
# Analysis
# ----------------------------------------------------------------------------
def _check_feasible(problem: StaticsProblem):
    """(feasible, x or None, diagnosis or None).

    When infeasible, an L1 relaxation of the equilibrium rows (minimum total
    imbalance) names the disks that cannot be balanced and by how much.
    """
    G, _, _ = problem.inequalities()
    lo, hi = problem.bounds()
    bnds = _bounds_list(lo, hi)
    m2 = problem.n_columns
    res = _lp(np.zeros(m2), G, np.zeros(G.shape[0]), problem.A, problem.b, bnds,
              attempts=_attempts(problem))
    if res.status == 0:
        return True, res.x, None
    if res.status != 2:
        raise NumericalError(f"feasibility LP failed: {res.message}")
    # relaxation: A x + s+ - s- = b, minimise sum s
    nr = problem.A.shape[0]
    I = sp.identity(nr, format="csr")
    Aeq = sp.hstack([problem.A, I, -I]).tocsr()
    Gr = sp.hstack([G, sp.csr_matrix((G.shape[0], 2 * nr))]).tocsr()
    c = np.concatenate([np.zeros(m2), np.ones(2 * nr)])
    r2 = _lp(c, Gr, np.zeros(G.shape[0]), Aeq, problem.b, bnds + [(0, None)] * (2 * nr))
    if r2.status != 0:
        raise NumericalError(f"infeasibility diagnosis LP failed: {r2.message}")
    s = r2.x[m2:m2 + nr] - r2.x[m2 + nr:]
    bad = np.flatnonzero(np.abs(s) > TOL * problem.force_scale)
    disks = sorted({int(problem.disks[i // 3]) for i in bad})
    comp = {0: "fx", 1: "fy", 2: "torque/r"}
    worst = [{"disk": int(problem.disks[i // 3]), "row": comp[i % 3],
              "imbalance": float(s[i])} for i in bad[np.argsort(-np.abs(s[bad]))][:10]]
    return False, None, {"min_total_imbalance": float(r2.fun),
                         "relative_to_mean_force": float(r2.fun / problem.force_scale),
                         "unbalanced_disks": disks, "worst_rows": worst,
                         "reason": "no force network satisfies equilibrium and Coulomb; the "
                                   "listed disks need the smallest extra loads"}


def _check_bounded(problem: StaticsProblem):
    """(bounded, max sum fn or inf, recession direction or None).

    S is bounded iff its recession cone {A d = 0, G d <= 0} is {0}; since the
    Coulomb cones are pointed, it suffices to maximise sum(d_fn) <= 1 over the
    cone: optimum 0 -> bounded, 1 -> unbounded with recession direction d.
    """
    G, _, _ = problem.inequalities()
    lo, hi = problem.bounds()
    m2 = problem.n_columns
    c = np.zeros(m2)
    c[0::2] = -1.0
    Aub = sp.vstack([G, sp.csr_matrix(-c)]).tocsr()
    bub = np.concatenate([np.zeros(G.shape[0]), [1.0]])
    res = _lp(c, Aub, bub, problem.A, np.zeros(problem.A.shape[0]), _bounds_list(lo, hi),
              attempts=_attempts(problem))
    if res.status != 0:
        raise NumericalError(f"recession-cone LP failed: {res.message}")
    if -res.fun > 1e-7:
        return False, np.inf, res.x / max(np.abs(res.x).max(), 1e-300)
    r2 = _lp(c, G, np.zeros(G.shape[0]), problem.A, problem.b, _bounds_list(lo, hi),
             attempts=_attempts(problem))
    if r2.status != 0:
        raise NumericalError(f"max sum fn LP failed: {r2.message}")
    return True, float(-r2.fun), None


def _implicit_equalities(problem: StaticsProblem, tol: float = TOL):
    """Indices of inequality rows of ``problem.inequalities()`` tight on all of S.

    Iterative slack LP (Fukuda's FAQ): maximise sum of slacks s_j in
    [0, <Fn>] over the undecided rows; rows with s_j > tol*<Fn> are proven
    strict somewhere; stop when the optimum is 0 (the rest are implicit).
    """
    G, _, _ = problem.inequalities()
    p = G.shape[0]
    lo, hi = problem.bounds()
    m2 = problem.n_columns
    scale = problem.force_scale
    undecided = np.ones(p, dtype=bool)
    thresh = tol * scale
    while undecided.any():
        idx = np.flatnonzero(undecided)
        q = idx.size
        S = sp.csr_matrix((np.ones(q), (idx, np.arange(q))), shape=(p, q))
        Aub = sp.hstack([G, S]).tocsr()
        c = np.concatenate([np.zeros(m2), -np.ones(q)])
        res = _lp(c, Aub, np.zeros(p), sp.hstack([problem.A, sp.csr_matrix((problem.A.shape[0], q))]),
                  problem.b, _bounds_list(lo, hi) + [(0.0, scale)] * q,
                  attempts=_attempts(problem))
        if res.status != 0:
            raise NumericalError(f"implicit-equality LP failed: {res.message}")
        slack = -(G @ res.x[:m2])
        strict = idx[slack[idx] > thresh]
        if strict.size == 0:
            break
        undecided[strict] = False
    return np.flatnonzero(undecided)


def _analyze(problem: StaticsProblem, ranges: bool = True, centre: bool = True,
            tol: float = TOL) -> PolytopeAnalysis:
    """Feasibility, boundedness, implicit equalities, dimensions, ranges, centre of S."""
    m = problem.n_contacts
    m2 = problem.n_columns
    n_fixed = problem.fixed_columns().size
    n_unknowns = m2 - n_fixed
    free_cols = np.setdiff1d(np.arange(m2), problem.fixed_columns())

    def set_rank(rank_A):
        # rank over the unknowns (not ft of mu=0 contacts). [A; fixed] is block
        # triangular in (free, fixed) columns with an identity on the fixed ones:
        # its rank is n_fixed + rank_A (no SVD of its own)
        out.rank_A, out.full_row_rank = rank_A, rank_A == problem.A.shape[0]
        out.degree_of_indeterminacy = m2 - (n_fixed + rank_A)

    out = PolytopeAnalysis(
        feasible=False, bounded=None, n_interior=problem.n_interior, n_contacts=m,
        n_unknowns=n_unknowns, rank_A=-1, full_row_rank=False,
        degree_of_indeterminacy=-1, dim_S=None, n_sliding=None, n_zero=None,
        force_scale=problem.force_scale)
    if m == 0:
        raise InputError(problem.source or "problem", "contacts", "no unknown contact in the problem")
    feas, x0, diag = _check_feasible(problem)
    if not feas:
        set_rank(_rank(problem.A[:, free_cols]))
        out.infeasibility = diag
        return out
    out.feasible = True
    bounded, msum, rdir = _check_bounded(problem)
    out.bounded, out.max_sum_fn, out.recession_direction = bounded, msum, rdir

    G, owner, kind = problem.inequalities()
    imp = _implicit_equalities(problem, tol)
    out.implicit_rows = imp
    Eq, rhs = _eq_system(problem, G[imp])
    # one point of S and the affine hull: x0 projected onto the hull (removes LP
    # round-off along the equalities), from the same SVD as the hull's basis
    N, xa, rank_eq = _affine_hull(Eq, rhs, x0)
    out.dim_S = int(N.shape[1])
    # without fixed columns and implicit rows Eq is A itself: same SVD, same rank
    set_rank(rank_eq if imp.size == 0 and n_fixed == 0 else _rank(problem.A[:, free_cols]))
    out.affine_point, out.affine_basis = xa, N
    # classify implicit equalities per contact
    imp_set = {}
    for r in imp:
        imp_set.setdefault(int(owner[r]), set()).add(int(kind[r]))
    sliding, zero = [], []
    for j, kinds in imp_set.items():
        if 2 in kinds or kinds == {0, 1}:
            zero.append(j)
            out.implicit.append((j, "zero"))
        else:
            sliding.append(j)
            out.implicit.append((j, "slides+" if 0 in kinds else "slides-"))
    out.sliding_contacts = np.array(sorted(sliding), dtype=np.int64)
    out.zero_contacts = np.array(sorted(zero), dtype=np.int64)
    out.n_sliding, out.n_zero = len(sliding), len(zero)

    if bounded and ranges:
        out.fn_range, out.ft_range = _column_ranges(problem, N, xa)
    if bounded and centre:
        out.centre, out.centre_radius = _chebyshev_centre(problem, N, imp)
    out.varying = _varying(problem, N, msum, out.centre_radius or 0.0, out)
    return out


def _varying(problem: StaticsProblem, N, max_sum_fn, radius, an=None) -> np.ndarray:
    """Mask (m,) of contacts whose force can change by more than VARY_TOL <Fn> within S
    (problem at <Fn> = 1).

    A contact's 2 x d block N_j of the hull basis bounds its force range: S
    holds a ball of radius ``radius`` in its hull, so the range is at least
    sqrt(2) radius ||N_j||; the diameter of S is at most 2 sqrt(1 + mu^2)
    max_sum_fn, so the range is at most that times ||N_j||. Contacts between
    the bounds are decided by LP (min and max of fn and ft). Entries of N_j
    at the 1e-9 level (couplings of the data's round-off) never make a
    contact vary: the decision is about forces, not about basis entries.
    """
    m = problem.n_contacts
    d = N.shape[1]
    if d == 0:
        return np.zeros(m, dtype=bool)
    blocks = N.reshape(m, 2, d)
    smax = np.linalg.norm(blocks, ord=2, axis=(1, 2))
    diam = 2.0 * np.sqrt(1.0 + float(problem.mu.max(initial=0.0)) ** 2) * max_sum_fn
    varying = np.sqrt(2.0) * radius * smax > VARY_TOL
    undecided = np.flatnonzero(~varying & (smax * diam > VARY_TOL))
    if undecided.size:
        rng_fn, rng_ft = (an.fn_range, an.ft_range) if an is not None and an.fn_range is not None \
            else (None, None)
        if rng_fn is None:
            cols = np.concatenate([2 * undecided, 2 * undecided + 1])
            rng = _column_ranges(problem, columns=cols)
            rng_fn, rng_ft = rng[0::2], rng[1::2]
        width = np.maximum(np.ptp(rng_fn[undecided], axis=1), np.ptp(rng_ft[undecided], axis=1))
        varying[undecided] = ~(width <= VARY_TOL)   # unbounded (inf) or NaN-free wide: varies
    return varying


def _column_ranges(problem: StaticsProblem, N=None, xa=None, columns=None):
    """Min and max of every column over S: (fn_range, ft_range), each (m, 2).

    Columns that do not move within the affine hull (zero rows of N) are
    constant and are not solved for. With ``columns``: only those columns are
    solved, and the (2m, 2) table is returned (other rows NaN); an unbounded
    side is +-inf.
    """
    G, _, _ = problem.inequalities()
    lo, hi = problem.bounds()
    bnds = _bounds_list(lo, hi)
    m2 = problem.n_columns
    rng = np.full((m2, 2), np.nan)
    moving = np.ones(m2, dtype=bool) if N is None else np.linalg.norm(N, axis=1) > 1e-10
    if xa is not None:
        rng[~moving] = xa[~moving, None]
    todo = np.flatnonzero(moving) if columns is None else np.asarray(columns, dtype=np.int64)
    for col in todo:
        if lo[col] == hi[col]:           # fixed column (ft of a frictionless contact)
            rng[col] = lo[col]
            continue
        for side, sgn in ((0, 1.0), (1, -1.0)):
            c = np.zeros(m2)
            c[col] = sgn
            res = _lp(c, G, np.zeros(G.shape[0]), problem.A, problem.b, bnds)
            if res.status == 3:          # unbounded in this direction
                rng[col, side] = -sgn * np.inf
                continue
            if res.status != 0:
                raise NumericalError(f"range LP for column {col} failed: {res.message}")
            rng[col, side] = res.x[col]
    if columns is not None:
        return rng
    return rng[0::2].copy(), rng[1::2].copy()


def _chebyshev_centre(problem: StaticsProblem, N=None, implicit_rows=None):
    """Centre of the largest ball inside S within its affine hull: (x (2m,), radius [F0]).

    Rows that are implicit equalities are kept as equalities; for the others
    g.x + r ||P g|| <= 0 with P the projector onto the affine hull's directions.
    """
    G, _, _ = problem.inequalities()
    if implicit_rows is None:
        implicit_rows = _implicit_equalities(problem)
    Eq, rhs = _eq_system(problem, G[implicit_rows])
    if N is None:
        N = null_basis(Eq)
    lo, hi = problem.bounds()
    m2 = problem.n_columns
    if N.shape[1] == 0:  # S is a single point: the centre is that point, radius 0
        x = sla.lstsq(Eq.toarray(), rhs)[0]
        return x, 0.0
    free = np.setdiff1d(np.arange(G.shape[0]), implicit_rows)
    Gf = G[free]
    w = np.linalg.norm((Gf @ N), axis=1) if N.shape[1] else np.zeros(free.size)
    Aub = sp.hstack([Gf, sp.csr_matrix(w[:, None])]).tocsr()
    Aeq = sp.hstack([Eq, sp.csr_matrix((Eq.shape[0], 1))]).tocsr()
    c = np.zeros(m2 + 1)
    c[-1] = -1.0
    # large problems: interior point first, as for the other LPs of the analysis (5000-disk
    # slice, dim S 1714: 11.3 s against 116 s for the default, same radius to 2.5e-7)
    res = _lp(c, Aub, np.zeros(free.size), Aeq, rhs,
              _bounds_list(lo, hi) + [(0.0, 10.0 * problem.force_scale * max(1, m2))],
              attempts=_attempts(problem))
    if res.status != 0:
        raise NumericalError(f"Chebyshev-centre LP failed: {res.message}")
    return res.x[:m2], float(res.x[-1])


# ----------------------------------------------------------------------------
# Euclidean projection
# ----------------------------------------------------------------------------
def _ldp_projection(problem: StaticsProblem, xhat):
    """Euclidean projection of xhat onto S by least-distance programming.

    Null-space coordinates x = xa + N y (N orthonormal basis of {A x = 0,
    fixed columns = 0}) turn the projection into: nearest point to
    y* = N^T (xhat - xa) of the polytope {M y <= u}, M = G N, u = -G xa.
    With z = y - y*: min ||z|| s.t. E z >= f, E = -M, f = M y* - u, solved by
    the Lawson-Hanson LDP algorithm: NNLS on [E^T; f^T] v ~ (0, ..., 0, 1),
    z = -r[:d] / r[d] with r the NNLS residual (a finite active-set method).

    Returns (x (2m,), active (k,) int, kkt): the projection, the rows of
    ``problem.inequalities()`` with a positive NNLS multiplier (the active set
    the polish starts from) and the KKT stationarity residual of the reduced
    problem (:func:`_reduced_kkt`), which needs no rank decision on the
    equalities.
    """
    from scipy.optimize import nnls

    G, _, _ = problem.inequalities()
    Eq, rhs = _eq_system(problem)
    Ed = Eq.toarray()
    xa = sla.lstsq(Ed, rhs, lapack_driver="gelsd")[0]
    N = null_basis(Ed)
    d = N.shape[1]
    if d == 0:
        return xa, np.zeros(0, dtype=np.int64), 0.0
    M = np.asarray(G @ N)
    u = -np.asarray(G @ xa)
    ystar = N.T @ (np.asarray(xhat, float) - xa)
    scale = max(problem.force_scale, 1e-300)
    E = -M
    f = (M @ ystar - u) / scale                       # work in units of <Fn>
    Ep = np.vstack([E.T, f[None, :]])
    e = np.zeros(d + 1)
    e[-1] = 1.0
    v, _ = nnls(Ep, e, maxiter=50 * Ep.shape[1])
    r = Ep @ v - e
    if abs(r[-1]) < 1e-14:
        raise NumericalError("projection: the constraints look infeasible (LDP)")
    z = -r[:d] / r[-1] * scale
    return xa + N @ (ystar + z), np.flatnonzero(v > 0), _reduced_kkt(M, u, ystar + z, z, scale)


def _reduced_kkt(M, u, y, z, scale) -> float:
    """KKT stationarity residual of min ||y - y*|| s.t. M y <= u at y = y* + z: with
    the rows tight to 1e-9 <Fn>, NNLS for lam >= 0 in z = -M_act^T lam; the residual
    relative to max(|z|, <Fn>). inf if y is infeasible by more than 1e-9 <Fn>."""
    from scipy.optimize import nnls

    slack = M @ y - u
    if slack.max(initial=0.0) > 1e-9 * scale:
        return float("inf")
    act = np.flatnonzero(slack > -1e-9 * scale)
    if act.size == 0:
        return float(np.linalg.norm(z)) / max(float(np.linalg.norm(z)), scale)
    Mt = M[act].T
    colscale = np.maximum(np.linalg.norm(Mt, axis=0), 1e-300)
    _, res = nnls(Mt / colscale, -z, maxiter=50 * act.size)
    return float(res) / max(float(np.linalg.norm(z)), scale)


def _range_basis(C, tol_rel=1e-11):
    """Orthonormal basis (ncol, r) of the row space of C (SVD, rank-revealing)."""
    if C.shape[0] == 0:
        return np.zeros((C.shape[1], 0))
    _, s, vt = np.linalg.svd(C, full_matrices=False)
    r = int((s > tol_rel * max(s[0], 1e-300) * max(C.shape)).sum()) if s.size else 0
    return vt[:r].T


def _eq_projection(xhat, Ceq, ceq, Gact):
    """Exact projection of xhat onto {Ceq x = ceq, Gact x = 0} (minimum-norm step), twice refined."""
    C = np.vstack([Ceq, Gact])
    c = np.concatenate([ceq, np.zeros(Gact.shape[0])])
    # cond: rows that are dependent up to round-off (e.g. both Coulomb rows and
    # a balance row through one contact) must not be amplified into big steps
    xn = xhat - sla.lstsq(C, C @ xhat - c, cond=1e-11, lapack_driver="gelsd")[0]
    return xn - sla.lstsq(C, C @ xn - c, cond=1e-11, lapack_driver="gelsd")[0]


def _multipliers(Q, Gact, rhs):
    """Inequality multipliers lam >= 0 with rhs = Ceq^T mu + Gact^T lam (mu free).

    Q (2m, r): orthonormal basis of range(Ceq^T); the equality part is removed
    by projecting onto its complement, then NNLS. Returns (lam (k,), residual
    norm, unconstrained least-squares lam (k,)).
    """
    from scipy.optimize import nnls

    P = lambda v: v - Q @ (Q.T @ v)  # noqa: E731
    Bt = P(Gact.T) if Gact.shape[0] else np.zeros((rhs.size, 0))
    br = P(rhs)
    if Bt.shape[1] == 0:
        return np.zeros(0), float(np.linalg.norm(br)), np.zeros(0)
    colscale = np.maximum(np.linalg.norm(Bt, axis=0), 1e-300)
    lam, res = nnls(Bt / colscale, br, maxiter=50 * Bt.shape[1])
    free = sla.lstsq(Bt / colscale, br, cond=1e-11, lapack_driver="gelsd")[0]
    return lam / colscale, float(res), free / colscale


def _polish(problem: StaticsProblem, xhat, x, max_iter: int = 60, active=None):
    """Exact active-set refinement and KKT verification of an approximate projection ``x``.

    Start from the active set ``active`` (rows of ``problem.inequalities()``;
    default: rows tight at x to 1e-7 <Fn>). Each round solves the
    equality-constrained projection exactly (SVD least squares), checks primal
    feasibility (adds violated rows) and then the multipliers: NNLS for
    lam >= 0 after projecting out the (free) equality multipliers; KKT
    stationarity residual <= 1e-9 (relative to max(|xhat - x|, <Fn>)) accepts.
    Otherwise the row with the most negative unconstrained multiplier is
    dropped. An empty active set has nothing to drop: the equality projection
    is then the answer iff its (equality-only) residual passes. Returns
    (x, kkt_residual, ok).
    """
    G, _, _ = problem.inequalities()
    Gd = G.toarray()
    Eq, ceq = _eq_system(problem)
    Ceq = Eq.toarray()
    Q = _range_basis(Ceq)
    scale = problem.force_scale
    if active is None:
        act = np.flatnonzero(G @ x > -1e-7 * scale)
    else:
        act = np.unique(np.asarray(active, dtype=np.int64))
    best = (x, np.inf, False)
    seen = set()
    for _ in range(max_iter):
        key = act.tobytes()
        if key in seen:                      # cycling: stop with the best verified so far
            break
        seen.add(key)
        xn = _eq_projection(xhat, Ceq, ceq, Gd[act])
        gx = Gd @ xn
        if gx.max(initial=0.0) > 1e-11 * scale:
            act = np.union1d(act, np.flatnonzero(gx > 1e-11 * scale))
            continue
        rhs = xhat - xn
        lam, res, free_lam = _multipliers(Q, Gd[act], rhs)
        kkt = res / max(np.linalg.norm(rhs), scale)
        if kkt < best[1]:
            best = (xn, kkt, False)
        if kkt <= 1e-9:
            return xn, kkt, True
        if act.size == 0:
            break
        act = np.delete(act, int(np.argmin(free_lam)))
    return best


def _distance_to_S(problem: StaticsProblem, x, analysis: PolytopeAnalysis | None = None
                   ) -> DistanceResult:
    """:func:`distance_to_S` on a problem at <Fn> = 1."""
    if analysis is not None and not analysis.feasible:
        raise InputError("distance_to_S", "S", "is empty (infeasible); no distance")
    xq, active, kkt_q = _ldp_projection(problem, x)
    method = "null-space LDP (Lawson-Hanson NNLS) + verified active-set polish"
    xn, kkt, ok = _polish(problem, x, xq, active=active)
    if not ok:       # retry from the rows tight at the LDP point
        xn2, kkt2, ok2 = _polish(problem, x, xq)
        if ok2 or kkt2 < kkt:
            xn, kkt, ok = xn2, kkt2, ok2
    if not ok and kkt_q <= 1e-9 and problem.violation(xq) <= 1e-9:
        # the full-space check failed on near-dependent equality rows (rank decision);
        # the LDP point's own KKT conditions, in null-space coordinates, hold
        xn, kkt, ok = xq, kkt_q, True
        method = "null-space LDP (Lawson-Hanson NNLS), KKT verified in null-space coordinates"
    viol = problem.violation(xn)
    if not ok or viol > 1e-9:
        raise NumericalError(f"projection onto S could not be verified (kkt={kkt:.2e}, "
                             f"violation={viol:.2e})")
    d = float(np.linalg.norm(xn - x))
    rel = d / (problem.force_scale * np.sqrt(problem.n_contacts))
    return DistanceResult(absolute=d, relative=rel, nearest=xn, max_violation=viol,
                          kkt_residual=kkt, method=method)


# ----------------------------------------------------------------------------
# Public entry points: every LP runs on the problem in units of <Fn>
# ----------------------------------------------------------------------------
# HiGHS' tolerances are absolute (primal/dual feasibility 1e-7): with forces of
# 1e-12 F0 every slack looks like zero, with 1e12 F0 nothing looks feasible.
# S scales exactly with the loads, so each entry point solves the problem
# scaled to <Fn> = 1 and scales its answers back to the caller's units.
def _unit(problem: StaticsProblem):
    """(problem scaled to force_scale 1, the scale s [F0])."""
    s = float(problem.force_scale)
    if not (np.isfinite(s) and s > 0):
        raise InputError(problem.source or "problem", "force_scale",
                         "must be a finite number > 0 (the mean normal force <Fn>)", got=s)
    return (problem if s == 1.0 else problem.scaled(1.0 / s)), s


def _scaled_diagnosis(diag, s):
    if diag is None:
        return None
    diag = dict(diag)
    diag["min_total_imbalance"] *= s
    diag["worst_rows"] = [dict(w, imbalance=w["imbalance"] * s) for w in diag["worst_rows"]]
    return diag


def check_feasible(problem: StaticsProblem):
    """(feasible, x (2m,) [F0] or None, diagnosis or None).

    When infeasible, an L1 relaxation of the equilibrium rows (minimum total
    imbalance) names the disks that cannot be balanced and by how much [F0].
    """
    P, s = _unit(problem)
    feas, x, diag = _check_feasible(P)
    return feas, (None if x is None else x * s), _scaled_diagnosis(diag, s)


def check_bounded(problem: StaticsProblem):
    """(bounded, max sum fn [F0] or inf, recession direction (2m,) or None).

    S is bounded iff its recession cone {A d = 0, G d <= 0} is {0}; since the
    Coulomb cones are pointed, it suffices to maximise sum(d_fn) <= 1 over the
    cone: optimum 0 -> bounded, 1 -> unbounded with recession direction d.
    """
    P, s = _unit(problem)
    bounded, msum, rdir = _check_bounded(P)
    return bounded, msum * s, rdir


def implicit_equalities(problem: StaticsProblem, tol: float = TOL):
    """Indices of inequality rows of ``problem.inequalities()`` tight on all of S
    (no point of S has slack above ``tol`` <Fn>)."""
    return _implicit_equalities(_unit(problem)[0], tol)


def analyze(problem: StaticsProblem, ranges: bool = True, centre: bool = True,
            tol: float = TOL) -> PolytopeAnalysis:
    """Feasibility, boundedness, implicit equalities, dimensions, ranges, centre of S.

    Invariant under scaling all forces: computed at <Fn> = 1, reported in F0.
    """
    P, s = _unit(problem)
    an = _analyze(P, ranges=ranges, centre=centre, tol=tol)
    for name in ("fn_range", "ft_range", "centre", "affine_point"):
        v = getattr(an, name)
        if v is not None:
            setattr(an, name, v * s)
    if an.centre_radius is not None:
        an.centre_radius *= s
    if an.max_sum_fn is not None:
        an.max_sum_fn *= s
    an.infeasibility = _scaled_diagnosis(an.infeasibility, s)
    an.force_scale = s
    return an


def column_ranges(problem: StaticsProblem, N=None, xa=None):
    """Min and max of every column over S [F0]: (fn_range, ft_range), each (m, 2)."""
    P, s = _unit(problem)
    fn, ft = _column_ranges(P, N, None if xa is None else np.asarray(xa, float) / s)
    return fn * s, ft * s


def chebyshev_centre(problem: StaticsProblem, N=None, implicit_rows=None):
    """Centre of the largest ball inside S within its affine hull: (x (2m,), radius) [F0].

    Rows that are implicit equalities are kept as equalities; for the others
    g.x + r ||P g|| <= 0 with P the projector onto the affine hull's directions.
    """
    P, s = _unit(problem)
    x, r = _chebyshev_centre(P, N, implicit_rows)
    return x * s, r * s


def extreme_point(problem: StaticsProblem, c) -> np.ndarray:
    """A vertex of S maximising ``c @ x`` (c (2m,)), by one LP at <Fn> = 1 [F0].
    NumericalError if S is empty or unbounded in that direction."""
    P, s = _unit(problem)
    G, _, _ = P.inequalities()
    res = _lp(-np.asarray(c, float), G, np.zeros(G.shape[0]), P.A, P.b,
              _bounds_list(*P.bounds()))
    if res.status != 0:
        raise NumericalError(f"extreme point of S: LP failed ({res.message})")
    return res.x * s


def l1_nearest(problem: StaticsProblem, x) -> np.ndarray:
    """The network of S nearest to x (2m,) in the L1 norm [F0]: one LP at <Fn> = 1
    (min sum t, -t <= y - x <= t, y in S), exact where the Euclidean projection's
    verification fails on ill-conditioned slices. NumericalError if S is empty."""
    P, s = _unit(problem)
    G, _, _ = P.inequalities()
    m2 = P.n_columns
    xs = np.asarray(x, float) / s
    eye = sp.identity(m2, format="csr")
    c = np.concatenate([np.zeros(m2), np.ones(m2)])
    A_ub = sp.vstack([sp.hstack([G, sp.csr_matrix((G.shape[0], m2))]),
                      sp.hstack([eye, -eye]), sp.hstack([-eye, -eye])]).tocsr()
    b_ub = np.concatenate([np.zeros(G.shape[0]), xs, -xs])
    A_eq = sp.hstack([P.A, sp.csr_matrix((P.A.shape[0], m2))]).tocsr()
    res = _lp(c, A_ub, b_ub, A_eq, P.b, _bounds_list(*P.bounds()) + [(0, None)] * m2)
    if res.status != 0:
        raise NumericalError(f"L1-nearest network of S: LP failed ({res.message})")
    # HiGHS is feasible to 1e-7 only: move exactly onto the equalities and the rows the
    # LP left tight (a minimum-norm step of that size; the other rows keep their slack)
    y = res.x[:m2]
    Eq, rhs = _eq_system(P)
    Gd = G.toarray()
    tight = np.flatnonzero(Gd @ y > -1e-6)
    return _eq_projection(y, Eq.toarray(), rhs, Gd[tight]) * s


def max_load_factor(problem: StaticsProblem, d) -> float:
    """The largest lambda >= 0 for which S stays non-empty when the loads grow by
    lambda d: max lambda s.t. A x = b + lambda d, Coulomb, fn >= 0 (one LP at <Fn> = 1).

    d (3n,) is in the units of b: row 3i+1 = +1 adds a downward unit force on the
    centre of interior disk i (b holds minus the loads). Returns lambda [F0 per unit
    of d]; inf when every lambda is admissible (the network carries any such load);
    0 when S is already empty.
    """
    P, s = _unit(problem)
    G, _, _ = P.inequalities()
    m2 = P.n_columns
    c = np.zeros(m2 + 1)
    c[-1] = -1.0
    A_eq = sp.hstack([P.A, sp.csr_matrix(-np.asarray(d, float).reshape(-1, 1))]).tocsr()
    A_ub = sp.hstack([G, sp.csr_matrix((G.shape[0], 1))]).tocsr()
    res = _lp(c, A_ub, np.zeros(G.shape[0]), A_eq, P.b, _bounds_list(*P.bounds()) + [(0, None)])
    if res.status == 3:
        return float("inf")
    if res.status == 2:
        return 0.0
    if res.status != 0:
        raise NumericalError(f"max load factor: LP failed ({res.message})")
    return float(res.x[-1] * s)


def distance_to_S(problem: StaticsProblem, x, analysis: PolytopeAnalysis | None = None
                  ) -> DistanceResult:
    """Exact Euclidean distance from ``x`` (2m,) [F0] to S (see :class:`DistanceResult`).

    Method: least-distance programming in the null space of the equalities
    (Lawson-Hanson via scipy's NNLS, a finite active-set method; HiGHS' QP
    solver cycled on the degenerate Coulomb apexes and was dropped), then an
    exact active-set polish whose KKT conditions are verified (feasibility to
    round-off, multipliers >= 0, stationarity residual <= 1e-9). Raises
    NumericalError if the verification fails, InputError for a wrong-shaped or
    non-finite x, and refuses an infeasible S.
    """
    x = np.asarray(x, float)
    if x.shape != (problem.n_columns,) or not np.all(np.isfinite(x)):
        raise InputError("distance_to_S", "x", f"must be a finite vector of shape "
                         f"({problem.n_columns},)", got=getattr(x, "shape", None))
    P, s = _unit(problem)
    r = _distance_to_S(P, x / s, analysis)
    return dataclasses.replace(r, absolute=r.absolute * s, nearest=r.nearest * s)
