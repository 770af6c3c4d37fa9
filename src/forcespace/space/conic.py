"""Second-order-cone programs over S of a sphere packing, with Clarabel (interior point).

S = {x : A x = b, f1 = f2 = 0 and fn >= 0 where mu = 0, ||(f1, f2)|| <= mu fn elsewhere}
(columns and rows: :mod:`forcespace.model.sphere_problem`). The Coulomb cone of a sphere
contact is a second-order (Lorentz) cone, which no LP takes; Clarabel (sparse LDL^T,
homogeneous embedding) decides feasibility exactly to its tolerances and certifies
infeasibility. As with the LPs of :mod:`forcespace.space.lp`, every question is asked of
the problem scaled to <Fn> = 1 and answered back in F0.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..model.sphere_problem import SphereStaticsProblem

SOLVER_TOLERANCE = 1e-10     # [1] Clarabel's feasibility and gap tolerances (<Fn> = 1)


@dataclass(frozen=True)
class ConicResult:
    """The answer of :func:`nearest_admissible`: ``feasible`` (S is not empty), ``x``
    (3m,) [F0] the point found (None if infeasible), ``status`` (Clarabel's),
    ``iterations``, ``seconds`` (CPU), ``violation`` (:meth:`SphereStaticsProblem.violation`
    of x, in <Fn>; inf if none)."""

    feasible: bool
    x: np.ndarray | None
    status: str
    iterations: int
    seconds: float
    violation: float


def cone_constraints(problem: SphereStaticsProblem):
    """Clarabel's data ``(A, b, cones)`` for S: rows ``A x + s = b`` with s in the zero
    cone (equilibrium, fixed columns), the non-negative cone (fn of frictionless
    contacts) and one 3-D second-order cone (mu fn, f1, f2) per frictional contact."""
    import clarabel

    m = problem.n_columns
    fixed = problem.fixed_columns()
    eye = sp.identity(m, format="csr")
    free = np.flatnonzero(problem.mu == 0.0)
    cone = np.flatnonzero(problem.mu > 0.0)
    soc_rows = []
    for j in cone:
        soc_rows.append(sp.csr_matrix(([-problem.mu[j], -1.0, -1.0],
                                       ([0, 1, 2], [3 * j, 3 * j + 1, 3 * j + 2])),
                                      shape=(3, m)))
    blocks = [problem.A, eye[fixed], -eye[3 * free]] + soc_rows
    A = sp.vstack(blocks).tocsc()
    b = np.concatenate([problem.b, np.zeros(fixed.size + free.size + 3 * cone.size)])
    cones = [clarabel.ZeroConeT(problem.A.shape[0] + fixed.size)]
    if free.size:
        cones.append(clarabel.NonnegativeConeT(int(free.size)))
    cones += [clarabel.SecondOrderConeT(3) for _ in cone]
    return A, b, cones


def nearest_admissible(problem: SphereStaticsProblem, target=None,
                       tol: float = SOLVER_TOLERANCE) -> ConicResult:
    """A point of S: the one nearest (Euclidean, in F0) to ``target`` (3m,) when given,
    e.g. the dynamics' last forces, else a central point of S (zero objective: the
    interior point method ends in the relative interior). Solved on the problem scaled
    to <Fn> = 1; ``tol`` Clarabel's feasibility and gap tolerances there."""
    import clarabel

    scale = problem.force_scale if problem.force_scale > 0 else 1.0
    unit = problem.scaled(1.0 / scale)
    m = unit.n_columns
    A, b, cones = cone_constraints(unit)
    if target is None:
        P, q = sp.csc_matrix((m, m)), np.zeros(m)
    else:
        P, q = sp.identity(m, format="csc"), -np.asarray(target, float) / scale
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    for name in ("tol_feas", "tol_gap_abs", "tol_gap_rel", "tol_infeas_abs",
                 "tol_infeas_rel"):
        setattr(settings, name, tol)
    t0 = time.process_time()
    sol = clarabel.DefaultSolver(P, q, A, b, cones, settings).solve()
    seconds = time.process_time() - t0
    status = str(sol.status).split(".")[-1]
    if status not in ("Solved", "AlmostSolved"):
        return ConicResult(False, None, status, int(sol.iterations), seconds, float("inf"))
    x = np.asarray(sol.x, float) * scale
    x[problem.fixed_columns()] = 0.0
    return ConicResult(True, x, status, int(sol.iterations), seconds, problem.violation(x))
