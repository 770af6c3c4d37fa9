"""Linear programs over S with HiGHS (scipy's ``linprog``): retries, bounds, scaling.

S = {x : A x = b, x_fixed = 0, G x <= 0} (see :mod:`forcespace.model.problem` for the
columns and rows). HiGHS' tolerances are absolute (primal/dual feasibility 1e-7):
with forces of 1e-12 F0 every slack looks like zero, with 1e12 F0 nothing looks
feasible. S scales exactly with the loads, so every question is asked of the
problem scaled to <Fn> = 1 (:func:`unit_problem`) and its answers scaled back.
"""
from __future__ import annotations

import os
import sys

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog

from .. import config
from ..errors import InputError
from ..model.problem import StaticsProblem

# HiGHS set-ups tried in turn when one ends without an answer (status 1 or 4: iteration
# limit, numerical difficulties, or HiGHS's "model status unknown", seen on ill-conditioned
# slices at mu >= 0.4): the default, dual simplex without presolve, interior point.
LP_ATTEMPTS = (("highs", {}), ("highs-ds", {"presolve": False}), ("highs-ipm", {}))
# Large problems (n_columns >= config.SWEEP_MIN_COLUMNS) solve the feasibility, boundedness,
# implicit-equality and Chebyshev-centre LPs by interior point (with HiGHS' crossover to
# a basic solution) first: the simplex iteration count grows with the size, IPM's does
# not (measured 2x faster at 2000 disks, see studies/bench.py analysis). Then the chain
# above.
LP_ATTEMPTS_LARGE = (("highs-ipm", {}),) + LP_ATTEMPTS


def attempts_for(problem: StaticsProblem):
    """The LP set-ups to try for the feasibility / boundedness / implicit LPs of problem."""
    return LP_ATTEMPTS_LARGE if problem.n_columns >= config.SWEEP_MIN_COLUMNS else LP_ATTEMPTS


def solve_lp(c, A_ub=None, b_ub=None, A_eq=None, b_eq=None, bounds=None, attempts=None,
             known_feasible: bool = False):
    """scipy/HiGHS linprog; status 0 optimal, 2 infeasible, 3 unbounded are answers,
    anything else is retried with the next of ``attempts`` (default LP_ATTEMPTS; the
    last result is returned). "Infeasible" is confirmed by dual simplex without
    presolve before it is believed: HiGHS' presolve called feasible slices infeasible
    at mu = 1e-9, whose Coulomb cones are 1e-9 wide. ``known_feasible``: the caller
    holds a feasible point (a point of S with zero slacks), so "infeasible" is never an
    answer and every attempt is tried."""
    answers = (0, 3) if known_feasible else (0, 2, 3)
    for method, options in (LP_ATTEMPTS if attempts is None else attempts):
        res = linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq, bounds=bounds,
                      method=method, options=options)
        if res.status == 2 and options.get("presolve", True):
            check = linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq, bounds=bounds,
                            method="highs-ds", options={"presolve": False})
            if check.status in (0, 3):
                res = check
        if res.status in answers:
            break
    return res


def inner_ball(H, s, r_max: float):
    """The largest ball inside {H y <= s}: (centre y (d,), radius t), the solution of
    max t s.t. H y + t |H_i| <= s, 0 <= t <= r_max (rows with |H_i| <= config.FLAT_ROW
    are constant and dropped); None when the LP has no optimum (no point inside)."""
    H, s = np.asarray(H, float), np.asarray(s, float)
    norms = np.linalg.norm(H, axis=1)
    live = norms > config.FLAT_ROW
    d = H.shape[1]
    c = np.zeros(d + 1)
    c[-1] = -1.0
    res = solve_lp(c, np.column_stack([H[live], norms[live]]), s[live],
                   bounds=[(None, None)] * d + [(0.0, r_max)], known_feasible=True)
    if res.status != 0:
        return None
    return res.x[:d], float(res.x[-1])


def bounds_list(lo, hi):
    return list(zip([None if not np.isfinite(v) else v for v in lo],
                    [None if not np.isfinite(v) else v for v in hi]))


def eq_system(problem: StaticsProblem, extra_rows=None):
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


def unit_problem(problem: StaticsProblem):
    """(problem scaled to force_scale 1, the scale s [F0])."""
    s = float(problem.force_scale)
    if not (np.isfinite(s) and s > 0):
        raise InputError(problem.source or "problem", "force_scale",
                         "must be a finite number > 0 (the mean normal force <Fn>)", got=s)
    return (problem if s == 1.0 else problem.scaled(1.0 / s)), s


_BANNER_SILENCED = False


def _quiet_highs():
    """A ``highspy.Highs`` without its banner. highspy (>= 1.12) prints "Running HiGHS ...
    Copyright ..." to the process's standard output when the first ``Highs`` is built,
    before any option can be set (ERGO-Code/HiGHS#1702, #2749): that first construction
    runs with file descriptor 1 pointed at the null device. Later ones print nothing."""
    import highspy

    global _BANNER_SILENCED
    if _BANNER_SILENCED:
        return highspy.Highs()
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            h = highspy.Highs()
            h.setOptionValue("output_flag", False)
    finally:
        os.dup2(saved, 1)
        os.close(saved)
    _BANNER_SILENCED = True
    return h


class HullRanges:
    """min c.y over the polytope {H y <= h} (y (d,): coordinates in S's affine hull) for
    many objectives c, by the dual LP

        max -h.mu  s.t.  H^T mu = -c,  mu >= 0

    (equal optima by LP duality): its d rows are the only thing an objective changes (their
    right-hand side), so HiGHS' dual simplex restarts from the previous optimal basis, of
    size d instead of the primal's number of rows (1000-particle frame, d = 41, 2004 rows:
    2.2 ms and 12 pivots per objective, against 4.8 ms and 17 pivots by warm primal simplex
    on the primal and 21 ms by warm dual simplex). ``minimum(c)`` -> (status, value): 0
    optimal, 3 unbounded below (the dual is infeasible), 1 anything else; after an optimum,
    ``y`` (d,) is its vertex and ``mu`` (p,) >= 0 its multipliers (the dual's solution:
    H^T mu = -c, the certificate of :class:`forcespace.space.questions.RangeCertificate`).

    ``minimum(c, exact=True)`` polishes the answer (:func:`exact_vertex`): HiGHS stops at a
    basis optimal to its tolerances (1e-10, its smallest), which may be a neighbour of the
    optimal one; its value then differs from the optimum by ~1e-9 <Fn>, and by a different
    amount on bit-different data (a packing written and read back). The polish pivots to
    the basis whose multipliers are >= 0 and whose vertex is feasible to round-off, so the
    value is the optimum's to ~1e-13. ``polished``: pivots the last polish made (0: HiGHS'
    basis was optimal), -1 where it was not polished (the basis not square, or no exact
    optimum reached within ``EXACT_MAX_PIVOTS``: HiGHS' answer stands)."""

    def __init__(self, H, h, tol: float = 1e-10):
        import highspy

        H = np.asarray(H, float)
        p, d = H.shape
        A = sp.csc_matrix(H.T)
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = p, d
        lp.col_cost_ = np.asarray(h, float)
        lp.col_lower_ = np.zeros(p)
        lp.col_upper_ = np.full(p, highspy.kHighsInf)
        lp.row_lower_ = lp.row_upper_ = np.zeros(d)
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = A.indptr
        lp.a_matrix_.index_ = A.indices
        lp.a_matrix_.value_ = A.data
        self.h = _quiet_highs()
        for key, value in (("output_flag", False), ("solver", "simplex"), ("presolve", "off"),
                           ("simplex_strategy", 1), ("threads", 1),
                           ("primal_feasibility_tolerance", tol),
                           ("dual_feasibility_tolerance", tol)):
            self.h.setOptionValue(key, value)
        self.h.passModel(lp)
        self.rows = np.arange(d, dtype=np.int32)
        self.codes, self.basic = highspy.HighsModelStatus, highspy.HighsBasisStatus.kBasic
        self.H, self.rhs = H, np.asarray(h, float)
        self.y = self.mu = None
        self.polished = -1

    def minimum(self, c, exact: bool = False):
        c = np.asarray(c, float)
        h, M = self.h, self.codes
        h.changeRowsBounds(self.rows.size, self.rows, -c, -c)
        h.run()
        status = h.getModelStatus()
        if status == M.kOptimal:
            # the primal vertex y is the dual LP's row dual (B^-T h_B from the final basis:
            # it solves its d active rows to round-off); c.y there, not the dual objective,
            # which carries the tolerance of every mu_i >= 0 (1e-10 x 2000 slacks: 1e-9 <Fn>)
            sol = h.getSolution()
            self.y = np.array(sol.row_dual)
            self.mu = np.maximum(np.array(sol.col_value), 0.0)
            self.polished = -1
            if exact:
                B = np.flatnonzero(np.array(h.getBasis().col_status) == self.basic)
                done = exact_vertex(self.H, self.rhs, c, B, self.y, self.mu)
                if done is not None:
                    self.y, self.mu, self.polished = done
            return 0, float(c @ self.y)
        if status == M.kInfeasible:
            return 3, -np.inf
        return 1, None


EXACT_MAX_PIVOTS = 200      # pivots of exact_vertex before it gives up (HiGHS' answer stands)
EXACT_ROUNDOFF = 1e-13      # [1] x the scale: a multiplier above -this, a row violated by less than
                            # this, counts as >= 0, as satisfied (round-off of a d x d solve)


def exact_vertex(H, h, c, B, y=None, mu=None):
    """The optimum of min c.y over {H y <= h} (H (p, d)) from a basis B (d rows, e.g.
    HiGHS' final one) by dense active-set pivots with round-off tolerances: at the vertex
    H_B y = h_B, the multipliers lam of H_B^T lam = -c; while some lam_i < 0, row i leaves
    (the objective falls along H_B dy = -e_i) and the first row reached enters (ratio test).
    ``y``, ``mu`` (HiGHS' vertex and multipliers): when they are already exact (mu_B >= 0,
    H y <= h, both to ``EXACT_ROUNDOFF``) nothing is solved. Returns (y (d,), mu (p,),
    pivots), or None: B not square or singular, no optimum within ``EXACT_MAX_PIVOTS``, or
    the optimum's vertex violating a row (a dual step would be needed)."""
    p, d = H.shape
    B = np.asarray(B, np.int64)
    if B.size != d:
        return None
    scale = max(1.0, float(np.abs(c).max(initial=0.0)))
    if y is not None and mu is not None and _exact(H, h, y, mu[B], scale):
        return y, mu, 0
    import scipy.linalg as sla

    for k in range(EXACT_MAX_PIVOTS + 1):
        try:
            lu = sla.lu_factor(H[B], check_finite=False)
        except (ValueError, np.linalg.LinAlgError):
            return None
        y = sla.lu_solve(lu, h[B])
        y += sla.lu_solve(lu, h[B] - H[B] @ y)          # one step of refinement
        lam = sla.lu_solve(lu, -c, trans=1)
        if not np.all(np.isfinite(lam)) or not np.all(np.isfinite(y)):
            return None
        i = int(np.argmin(lam))
        if lam[i] >= -EXACT_ROUNDOFF * scale:
            if not _exact(H, h, y, lam, scale):
                return None
            out = np.zeros(p)
            out[B] = np.maximum(lam, 0.0)
            return y, out, k
        e = np.zeros(d)
        e[i] = -1.0
        r = H @ sla.lu_solve(lu, e)                      # the rows' rates along dy
        r[B] = 0.0
        cand = np.flatnonzero(r > EXACT_ROUNDOFF * max(1.0, float(np.abs(r).max())))
        if cand.size == 0:
            return None                                  # unbounded: not a range's case
        t = np.maximum(h[cand] - H[cand] @ y, 0.0) / r[cand]
        B[i] = cand[int(np.argmin(t))]
    return None


def _exact(H, h, y, lam, scale) -> bool:
    """Multipliers lam >= 0 and H y <= h, both to EXACT_ROUNDOFF x scale."""
    return bool(lam.min(initial=0.0) >= -EXACT_ROUNDOFF * scale
                and np.max(H @ y - h, initial=0.0) <= EXACT_ROUNDOFF * max(1.0, float(
                    np.abs(h).max(initial=0.0))))


def solve_lp_interior(c, A_ub, b_ub, A_eq, b_eq, lo, hi, tol: float = 1e-9,
                      solver: str = "highs-ipm"):
    """min c.x s.t. A_ub x <= b_ub, A_eq x = b_eq, lo <= x <= hi by an interior point
    **without crossover**: the solution lies in the relative interior of the optimal face
    (strict complementarity), not at a vertex. Feasible and optimal to ``tol`` (call on a
    problem at <Fn> = 1). Returns (status, x): status 0 optimal, 2 infeasible, 3
    unbounded, 1 anything else (x None). ``solver``: "highs-ipm" (HiGHS' IPX, highspy;
    ``tol`` absolute) or "clarabel" (:func:`solve_lp_clarabel`); the analysis takes the
    faster measured for each of its LPs (config.INTERIOR_SOLVERS)."""
    if solver == "clarabel":
        return solve_lp_clarabel(c, A_ub, b_ub, A_eq, b_eq, lo, hi, tol)
    import highspy

    A = sp.vstack([sp.csr_matrix(A_ub), sp.csr_matrix(A_eq)]).tocsc()
    inf = highspy.kHighsInf
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = A.shape[1], A.shape[0]
    lp.col_cost_ = np.asarray(c, float)
    lp.col_lower_ = np.where(np.isfinite(lo), lo, -inf)
    lp.col_upper_ = np.where(np.isfinite(hi), hi, inf)
    lp.row_lower_ = np.concatenate([np.full(A_ub.shape[0], -inf), b_eq])
    lp.row_upper_ = np.concatenate([b_ub, b_eq])
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_ = A.indptr
    lp.a_matrix_.index_ = A.indices
    lp.a_matrix_.value_ = A.data
    h = _quiet_highs()
    for key, value in (("output_flag", False), ("solver", "ipm"), ("run_crossover", "off"),
                       ("threads", 1), ("primal_feasibility_tolerance", tol),
                       ("dual_feasibility_tolerance", tol), ("ipm_optimality_tolerance", tol)):
        h.setOptionValue(key, value)
    h.passModel(lp)
    h.run()
    status = h.getModelStatus()
    M = highspy.HighsModelStatus
    if status == M.kOptimal:
        return 0, np.array(h.getSolution().col_value)
    if status == M.kInfeasible:
        return 2, None
    if status in (M.kUnbounded, M.kUnboundedOrInfeasible):
        return 3, None
    return 1, None


def solve_lp_clarabel(c, A_ub, b_ub, A_eq, b_eq, lo, hi, tol: float = 1e-9):
    """:func:`solve_lp_interior` by Clarabel (a primal-dual interior point on the
    homogeneous embedding, sparse LDL^T: its iterates follow the central path, so the
    solution is in the relative interior of the optimal face). ``tol``: its feasibility
    and gap tolerances (relative to max(1, |b|): call on a problem at <Fn> = 1). The
    bounds become rows (b - A x in the non-negative cone). Measured on the 5000-disk
    slice's strict-rows LP (21 568 unknowns): 0.49 CPU s, 13 iterations, against 6.7-7.1
    for HiGHS' IPX, the same strict rows (studies/sampler_cost.md)."""
    import clarabel

    n = len(c)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    fl, fh = np.flatnonzero(np.isfinite(lo)), np.flatnonzero(np.isfinite(hi))
    eye = sp.identity(n, format="csr")
    A = sp.vstack([sp.csr_matrix(A_eq), sp.csr_matrix(A_ub), -eye[fl], eye[fh]]).tocsc()
    b = np.concatenate([b_eq, b_ub, -lo[fl], hi[fh]])
    cones = [clarabel.ZeroConeT(A_eq.shape[0]),
             clarabel.NonnegativeConeT(A.shape[0] - A_eq.shape[0])]
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    for name in ("tol_feas", "tol_gap_abs", "tol_gap_rel"):
        setattr(settings, name, tol)
    sol = clarabel.DefaultSolver(sp.csc_matrix((n, n)), np.asarray(c, float), A, b, cones,
                                 settings).solve()
    status = str(sol.status).split(".")[-1]
    if status in ("Solved", "AlmostSolved"):
        x = np.clip(np.asarray(sol.x, float), lo, hi)
        if _clarabel_accepts(x, sol, c, A_ub, b_ub, A_eq, b_eq, tol):
            return 0, x
    return {"PrimalInfeasible": 2, "DualInfeasible": 3}.get(status, 1), None


def _clarabel_accepts(x, sol, c, A_ub, b_ub, A_eq, b_eq, tol: float) -> bool:
    """Whether Clarabel's x (clipped to its bounds) is an answer to ``tol``: equalities and
    inequalities met to 10 tol max(1, |b|) (absolute at <Fn> = 1, as HiGHS' tolerances),
    duality gap below 1e3 tol max(1, |c.x|). Its "AlmostSolved" (it stalls a step short
    of its own 1e-10: the 5000-disk slice's strict-rows LP, primal residual 2e-15) is
    taken only so."""
    scale = max(1.0, float(np.abs(b_eq).max(initial=0.0)), float(np.abs(b_ub).max(initial=0.0)))
    primal = max(float(np.abs(A_eq @ x - b_eq).max(initial=0.0)),
                 float((A_ub @ x - b_ub).max(initial=0.0)))
    value = float(np.dot(c, x))
    gap = abs(float(sol.obj_val) - float(sol.obj_val_dual))
    return primal <= 10 * tol * scale and gap <= 1e3 * tol * max(1.0, abs(value))
