"""Loads and directions on S: vertices in a direction, the largest load a network carries.

One LP each, on the problem at <Fn> = 1 (:mod:`forcespace.space.lp`), answers in F0.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import InputError, NumericalError
from ..model.problem import StaticsProblem, full_problem
from .lp import bounds_list, solve_lp, unit_problem


def extreme_point(problem: StaticsProblem, c) -> np.ndarray:
    """A vertex of S maximising ``c @ x`` (c (2m,)), by one LP at <Fn> = 1 [F0].
    NumericalError if S is empty or unbounded in that direction."""
    P, s = unit_problem(problem)
    G, _, _ = P.inequalities()
    res = solve_lp(-np.asarray(c, float), G, np.zeros(G.shape[0]), P.A, P.b,
              bounds_list(*P.bounds()))
    if res.status != 0:
        raise NumericalError(f"extreme point of S: LP failed ({res.message})")
    return res.x * s


def max_load_factor(problem: StaticsProblem, d) -> float:
    """The largest lambda >= 0 for which S stays non-empty when the loads grow by
    lambda d: max lambda s.t. A x = b + lambda d, Coulomb, fn >= 0 (one LP at <Fn> = 1).

    d (3n,) is in the units of b: row 3i+1 = +1 adds a downward unit force on the
    centre of interior disk i (b holds minus the loads). Returns lambda [F0 per unit
    of d]; inf when every lambda is admissible (the network carries any such load);
    0 when S is already empty.
    """
    P, s = unit_problem(problem)
    G, _, _ = P.inequalities()
    m2 = P.n_columns
    c = np.zeros(m2 + 1)
    c[-1] = -1.0
    A_eq = sp.hstack([P.A, sp.csr_matrix(-np.asarray(d, float).reshape(-1, 1))]).tocsr()
    A_ub = sp.hstack([G, sp.csr_matrix((G.shape[0], 1))]).tocsr()
    res = solve_lp(c, A_ub, np.zeros(G.shape[0]), A_eq, P.b, bounds_list(*P.bounds()) + [(0, None)])
    if res.status == 3:
        return float("inf")
    if res.status == 2:
        return 0.0
    if res.status != 0:
        raise NumericalError(f"max load factor: LP failed ({res.message})")
    return float(res.x[-1] * s)


def max_point_force(packing, disk: int) -> float:
    """Largest downward force on ``disk``'s centre the frozen contact network of the
    whole ``packing`` can carry [F0]: max lambda with S non-empty under the extra load
    (inf: any force). Below it rigid disks need not move; above it they must."""
    prob = full_problem(packing)
    where = np.flatnonzero(prob.disks == disk)
    if where.size == 0:
        raise InputError("point force", "disk", "must be a load-bearing disk of the layer "
                         "(not a rattler)", got=disk)
    d = np.zeros(prob.A.shape[0])
    d[3 * int(where[0]) + 1] = 1.0
    return max_load_factor(prob, d)
