"""S as a compute object: the exact analysis of the force ensemble of a statics problem.

S = {x : A x = b, x_fixed = 0, G x <= 0} (columns and rows: :mod:`forcespace.model.problem`).
Every question is answered by LPs (HiGHS, :mod:`forcespace.space.lp`) on the problem
scaled to <Fn> = 1, and reported in F0. Tolerances are relative to <Fn>
(``problem.force_scale``, the mean jammed normal force over the unknown contacts):
an inequality is "tight everywhere" (an implicit equality) when no point of S has
slack larger than ``tol`` <Fn> (``config.IMPLICIT_TOL``).

>>> S = ForceSpace().compute(problem)
>>> S.dim, S.bounded, S.centre.shape, len(S.domains)
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .. import config
from ..errors import InputError, NumericalError
from ..linalg import affine_hull, null_basis, onto_affine_hull, rank
from ..model.problem import StaticsProblem
from ..progress import progress as progress_bar
from ..result import Computed
from .lp import (attempts_for, bounds_list, eq_system, inner_ball, solve_lp, solve_lp_interior,
                 unit_problem)


# ----------------------------------------------------------------------------
# the questions, each on a problem at <Fn> = 1
# ----------------------------------------------------------------------------
def _check_feasible(problem: StaticsProblem):
    """(feasible, x or None, diagnosis or None).

    When infeasible, an L1 relaxation of the equilibrium rows (minimum total
    imbalance) names the disks that cannot be balanced and by how much.
    """
    G, _, _ = problem.inequalities()
    lo, hi = problem.bounds()
    bnds = bounds_list(lo, hi)
    m2 = problem.n_columns
    res = solve_lp(np.zeros(m2), G, np.zeros(G.shape[0]), problem.A, problem.b, bnds,
              attempts=attempts_for(problem))
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
    r2 = solve_lp(c, Gr, np.zeros(G.shape[0]), Aeq, problem.b, bnds + [(0, None)] * (2 * nr))
    if r2.status != 0:
        raise NumericalError(f"infeasibility diagnosis LP failed: {r2.message}")
    s = r2.x[m2:m2 + nr] - r2.x[m2 + nr:]
    bad = np.flatnonzero(np.abs(s) > config.IMPLICIT_TOL * problem.force_scale)
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
    res = solve_lp(c, Aub, bub, problem.A, np.zeros(problem.A.shape[0]), bounds_list(lo, hi),
                   attempts=attempts_for(problem), known_feasible=True)   # d = 0 is feasible
    if res.status != 0:
        raise NumericalError(f"recession-cone LP failed: {res.message}")
    if -res.fun > config.UNBOUNDED_TOL:
        return False, np.inf, res.x / max(np.abs(res.x).max(), 1e-300)
    r2 = solve_lp(c, G, np.zeros(G.shape[0]), problem.A, problem.b, bounds_list(lo, hi),
                  attempts=attempts_for(problem), known_feasible=True)
    if r2.status != 0:
        raise NumericalError(f"max sum fn LP failed: {r2.message}")
    return True, float(-r2.fun), None


def _implicit_equalities(problem: StaticsProblem, tol: float, undecided=None):
    """Indices of inequality rows of ``problem.inequalities()`` tight on all of S.

    Iterative slack LP (Fukuda's FAQ): maximise sum of slacks s_j in
    [0, <Fn>] over the undecided rows (default all; a mask (p,) otherwise); rows
    with s_j > tol*<Fn> are proven strict somewhere; stop when the optimum is 0
    (the rest are implicit).
    """
    G, _, _ = problem.inequalities()
    p = G.shape[0]
    lo, hi = problem.bounds()
    m2 = problem.n_columns
    scale = problem.force_scale
    undecided = np.ones(p, dtype=bool) if undecided is None else np.array(undecided, bool)
    thresh = tol * scale
    while undecided.any():
        idx = np.flatnonzero(undecided)
        q = idx.size
        S = sp.csr_matrix((np.ones(q), (idx, np.arange(q))), shape=(p, q))
        Aub = sp.hstack([G, S]).tocsr()
        c = np.concatenate([np.zeros(m2), -np.ones(q)])
        res = solve_lp(c, Aub, np.zeros(p), sp.hstack([problem.A, sp.csr_matrix((problem.A.shape[0], q))]),
                  problem.b, bounds_list(lo, hi) + [(0.0, scale)] * q,
                  attempts=attempts_for(problem), known_feasible=True)
        if res.status != 0:
            raise NumericalError(f"implicit-equality LP failed: {res.message}")
        slack = -(G @ res.x[:m2])
        strict = idx[slack[idx] > thresh]
        if strict.size == 0:
            break
        undecided[strict] = False
    return np.flatnonzero(undecided)


def _interior_strict_rows(problem: StaticsProblem):
    """(x (2m,), strict (p,) bool), or None when the interior-point solve fails.

    One LP without crossover: max sum s_j, G x + s <= 0, 0 <= s <= INTERIOR_CAP <Fn>,
    x in S. If S has a point whose slack exceeds the cap on every row that is strict
    somewhere (true when the cap is below every such row's slack at one point), every
    optimum has all those rows at the cap, and the interior point (the relative interior
    of the optimal face) shows them all at once; rows it leaves below INTERIOR_STRICT
    are decided by the exact test. x is a point of S to INTERIOR_TOL <Fn>."""
    G, _, _ = problem.inequalities()
    p, m2, scale = G.shape[0], problem.n_columns, problem.force_scale
    lo, hi = problem.bounds()
    st, z = solve_lp_interior(
        np.concatenate([np.zeros(m2), -np.ones(p)]), sp.hstack([G, sp.identity(p)]).tocsr(),
        np.zeros(p), sp.hstack([problem.A, sp.csr_matrix((problem.A.shape[0], p))]).tocsr(),
        problem.b, np.concatenate([lo, np.zeros(p)]),
        np.concatenate([hi, np.full(p, config.INTERIOR_CAP * scale)]),
        tol=config.INTERIOR_TOL * scale)
    if st != 0:
        return None
    x = z[:m2]
    return x, -(G @ x) > config.INTERIOR_STRICT * scale


def _interior_max_sum_fn(problem: StaticsProblem):
    """max sum fn over S by one interior-point LP without crossover, or None (unbounded,
    or the solve failed: the caller then takes the exact recession-cone test)."""
    G, _, _ = problem.inequalities()
    lo, hi = problem.bounds()
    c = np.zeros(problem.n_columns)
    c[0::2] = -1.0
    st, x = solve_lp_interior(c, G, np.zeros(G.shape[0]), problem.A, problem.b, lo, hi,
                              tol=config.INTERIOR_TOL * problem.force_scale)
    return float(-c @ x) if st == 0 else None


def _varying(problem: StaticsProblem, N, max_sum_fn, radius, ranges=None,
             points=()) -> np.ndarray:
    """Mask (m,) of contacts whose force can change by more than VARY_TOL <Fn> within S
    (problem at <Fn> = 1).

    A contact's 2 x d block N_j of the hull basis bounds its force range: S
    holds a ball of radius ``radius`` in its hull, so the range is at least
    sqrt(2) radius ||N_j||; the diameter of S is at most 2 sqrt(1 + mu^2)
    max_sum_fn, so the range is at most that times ||N_j||. Contacts between
    the bounds are decided by LP (:func:`_lp_widths`; ``points``: known points of S
    that spare some of them; ``ranges``: the full range table when already computed).
    Entries of N_j at the 1e-9 level (couplings of the data's round-off) never make a
    contact vary: the decision is about forces, not about basis entries.
    """
    m = problem.n_contacts
    d = N.shape[1]
    if d == 0:
        return np.zeros(m, dtype=bool)
    blocks = N.reshape(m, 2, d)
    smax = np.linalg.norm(blocks, ord=2, axis=(1, 2))
    diam = 2.0 * np.sqrt(1.0 + float(problem.mu.max(initial=0.0)) ** 2) * max_sum_fn
    varying = np.sqrt(2.0) * radius * smax > config.VARY_TOL
    undecided = np.flatnonzero(~varying & (smax * diam > config.VARY_TOL))
    if undecided.size:
        if ranges is not None:
            rng_fn, rng_ft = ranges
            width = np.maximum(np.ptp(rng_fn[undecided], axis=1),
                               np.ptp(rng_ft[undecided], axis=1))
        else:
            width = _lp_widths(problem, undecided, config.VARY_TOL, points,
                               hull=N if points else None)
        varying[undecided] = ~(width <= config.VARY_TOL)   # unbounded (inf) or NaN-free wide: varies
    return varying




def _lp_widths(problem: StaticsProblem, contacts, tol: float, points=(),
               hull=None) -> np.ndarray:
    """Force range of each of ``contacts`` (k,) over S: max of its fn and ft ranges [F0],
    by LP, solving only what the decision "range > ``tol``" needs.

    Every LP optimum is a point of S, and so are ``points`` (e.g. the affine point and the
    Chebyshev centre): a contact whose fn or ft already differs by more than ``tol``
    between points found so far varies, and its own LPs (min and max of fn and ft) are
    skipped. Only points that violate S by at most ``config.TRUSTED_POINT * tol`` count: HiGHS'
    optima can miss S by 1e-6 <Fn> on ill-conditioned slices (mu = 10), and a point that
    far outside moved a contact constant in S (range 1e-8) by 1.3e-6.

    Returns (k,): the range for contacts whose LPs all ran (as in the full min/max table,
    to the trusted points' 1e-8), a lower bound above ``tol`` for the others, inf where S
    is unbounded along the contact. The decisions are those of the full table; at 2000
    disks with a thin S (most contacts undecided by the ball test) it replaced ~4000 LPs
    (hours) by a handful.

    ``hull``: N (2m, d), an orthonormal basis of S's affine hull through ``points[0]``.
    Where d <= ``config.REDUCED_LP_MAX_DIM`` the LPs are asked in the hull's coordinates
    (:class:`_HullLP`: d unknowns instead of 2m; S lies in its hull), which at mu = 1
    (thin S, few dimensions, most contacts undecided) is what the analysis spends its
    time on.
    """
    G, _, _ = problem.inequalities()
    lo, hi = problem.bounds()
    bnds = bounds_list(lo, hi)
    m2 = problem.n_columns
    extreme = (_HullLP(problem, hull, points).extreme
               if hull is not None and hull.shape[1] <= config.REDUCED_LP_MAX_DIM
               else lambda col, sgn: _column_extreme(problem, G, bnds, col, sgn))
    seen_lo, seen_hi = np.full(m2, np.inf), np.full(m2, -np.inf)
    trusted = config.TRUSTED_POINT * tol

    def see(x):
        nonlocal seen_lo, seen_hi
        if x is not None and problem.violation(x) <= trusted:
            seen_lo, seen_hi = np.minimum(seen_lo, x), np.maximum(seen_hi, x)

    for x in points:
        see(x)

    def spread(j):
        return max(seen_hi[2 * j] - seen_lo[2 * j], seen_hi[2 * j + 1] - seen_lo[2 * j + 1],
                   0.0)

    width = np.empty(len(contacts))
    for k, j in enumerate(contacts):
        unbounded = False
        for col in (2 * j, 2 * j + 1):
            if lo[col] == hi[col]:       # fixed column (ft of a frictionless contact)
                continue
            for sgn in (1.0, -1.0):
                if unbounded or spread(j) > tol:
                    break
                value, x = extreme(col, sgn)
                if x is None:            # unbounded in this direction
                    unbounded = True
                    break
                # the optimum of its own column counts as in the full table; the
                # rest of the point only if it is trusted
                seen_lo[col], seen_hi[col] = min(seen_lo[col], value), max(seen_hi[col], value)
                see(x)
        width[k] = np.inf if unbounded else spread(j)
    return width


class _HullLP:
    """min / max of one column over S as an LP in the coordinates y (d,) of S's affine
    hull, x = x0 + N y: the inequalities G x <= 0 become H y <= h (they imply fn >= 0:
    -2 mu fn <= 0 is the sum of a contact's two Coulomb rows, -fn <= 0 its row at
    mu = 0; the frame of the samplers uses them alone too); equilibrium, the fixed
    columns and the implicit equalities hold by construction.
    x0: of ``points`` (the first on the hull, the others projected onto it), the one
    that violates S least (the Chebyshev centre, where given). Its own violation (LP
    round-off: the affine point of an n = 800, mu = 1 slice misses S by 2e-7 <Fn>) is
    forgiven: h >= 0, so y = 0 is feasible and S is widened by at most that violation,
    the order of the 1e-7 tolerance HiGHS works to in the LPs in 2m unknowns. Rows
    constant on the hull (|row| <= FLAT_ROW) are dropped.
    ``extreme(col, sgn)`` is :func:`_column_extreme`'s contract."""

    def __init__(self, problem: StaticsProblem, N, points):
        G, _, _ = problem.inequalities()
        N = np.asarray(N, float)
        xa = np.asarray(points[0], float)
        on_hull = [xa] + [onto_affine_hull(x, xa, N) for x in points[1:] if x is not None]
        x0 = min(on_hull, key=problem.violation)
        H, h = np.asarray(G @ N), -(G @ x0)
        keep = np.linalg.norm(H, axis=1) > config.FLAT_ROW
        self.N, self.x0 = N, x0
        self.H, self.h = H[keep], np.maximum(h[keep], 0.0)

    def extreme(self, col: int, sgn: float):
        res = solve_lp(sgn * self.N[col], self.H, self.h, bounds=(None, None),
                       known_feasible=True)
        if res.status == 3:
            return -sgn * np.inf, None
        if res.status != 0:
            raise NumericalError(f"range LP for column {col} (hull coordinates) failed: "
                                 f"{res.message}")
        x = self.x0 + self.N @ res.x
        return x[col], x


def _column_extreme(problem: StaticsProblem, G, bnds, col: int, sgn: float):
    """min (sgn = 1) or max (sgn = -1) of column ``col`` over S by one LP: (value, x (2m,)
    the optimum), or (-sgn inf, None) where S is unbounded that way. ``G``, ``bnds``: the
    problem's inequalities and bounds_list. NumericalError if the LP fails."""
    c = np.zeros(problem.n_columns)
    c[col] = sgn
    res = solve_lp(c, G, np.zeros(G.shape[0]), problem.A, problem.b, bnds,
                   known_feasible=True)
    if res.status == 3:
        return -sgn * np.inf, None
    if res.status != 0:
        raise NumericalError(f"range LP for column {col} failed: {res.message}")
    return res.x[col], res.x


def _column_ranges(problem: StaticsProblem, N=None, xa=None, columns=None):
    """Min and max of every column over S: (fn_range, ft_range), each (m, 2).

    Columns that do not move within the affine hull (zero rows of N) are
    constant and are not solved for. With ``columns``: only those columns are
    solved, and the (2m, 2) table is returned (other rows NaN); an unbounded
    side is +-inf.
    """
    G, _, _ = problem.inequalities()
    lo, hi = problem.bounds()
    bnds = bounds_list(lo, hi)
    m2 = problem.n_columns
    rng = np.full((m2, 2), np.nan)
    moving = np.ones(m2, dtype=bool) if N is None else np.linalg.norm(N, axis=1) > config.MOVING_ROW_TOL
    if xa is not None:
        rng[~moving] = xa[~moving, None]
    todo = np.flatnonzero(moving) if columns is None else np.asarray(columns, dtype=np.int64)
    for col in todo:
        if lo[col] == hi[col]:           # fixed column (ft of a frictionless contact)
            rng[col] = lo[col]
            continue
        for side, sgn in ((0, 1.0), (1, -1.0)):
            rng[col, side] = _column_extreme(problem, G, bnds, col, sgn)[0]
    if columns is not None:
        return rng
    return rng[0::2].copy(), rng[1::2].copy()


def _chebyshev_centre(problem: StaticsProblem, N=None, implicit_rows=None,
                      interior: bool = False):
    """Centre of the largest ball inside S within its affine hull: (x (2m,), radius [F0]).

    Rows that are implicit equalities are kept as equalities; for the others
    g.x + r ||P g|| <= 0 with P the projector onto the affine hull's directions.
    """
    G, _, _ = problem.inequalities()
    if implicit_rows is None:
        implicit_rows = _implicit_equalities(problem, config.IMPLICIT_TOL)
    Eq, rhs = eq_system(problem, G[implicit_rows])
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
    r_max = 10.0 * problem.force_scale * max(1, m2)
    if interior:        # any optimal point will do: no crossover to a vertex
        st, z = solve_lp_interior(c, Aub, np.zeros(free.size), Aeq, rhs, np.append(lo, 0.0),
                                  np.append(hi, r_max),
                                  tol=config.INTERIOR_TOL * problem.force_scale)
        if st == 0:
            return z[:m2], float(z[-1])
    # large problems: interior point first, as for the other LPs of the analysis (5000-disk
    # slice, dim S 1714: 11.3 s against 116 s for the default, same radius to 2.5e-7)
    res = solve_lp(c, Aub, np.zeros(free.size), Aeq, rhs,
              bounds_list(lo, hi) + [(0.0, r_max)],
              attempts=attempts_for(problem), known_feasible=True)
    if res.status == 0:
        return res.x[:m2], float(res.x[-1])
    # a thin S (radius ~1e-10 <Fn>) can leave HiGHS "Unknown" on every attempt in the full
    # space (n = 400, mu = 1: dim S 2); in the hull's own coordinates the LP has d + 1
    # unknowns and no equalities
    hull = _hull_centre(Gf, Eq, rhs, N, lo, hi, r_max) if m2 <= config.HULL_CENTRE_MAX_COLUMNS \
        else None
    if hull is None:
        raise NumericalError(f"Chebyshev-centre LP failed: {res.message}")
    return hull




def _hull_centre(Gf, Eq, rhs, N, lo, hi, r_max):
    """(x, radius) of the Chebyshev centre found in the affine hull's coordinates
    x = x_p + N y (x_p a particular solution; the bounds lo <= x <= hi as rows), or None."""
    xp = sla.lstsq(Eq.toarray(), rhs)[0]
    rows, slack = [np.asarray(Gf @ N)], [-np.asarray(Gf @ xp)]
    for sign, bound in ((-1.0, lo), (1.0, hi)):
        k = np.isfinite(bound)
        rows.append(sign * N[k])
        slack.append(sign * (bound[k] - xp[k]))
    ball = inner_ball(np.vstack(rows), np.concatenate(slack), r_max)
    if ball is None:
        return None
    return xp + N @ ball[0], ball[1]


def _implicit_kinds(implicit_rows, owner, kind):
    """Per contact, which of its inequalities are tight on all of S: (implicit list of
    (contact, "slides+" | "slides-" | "zero"), sliding contacts, zero contacts)."""
    imp_set = {}
    for r in implicit_rows:
        imp_set.setdefault(int(owner[r]), set()).add(int(kind[r]))
    implicit, sliding, zero = [], [], []
    for j, kinds in imp_set.items():
        if 2 in kinds or kinds == {0, 1}:
            zero.append(j)
            implicit.append((j, "zero"))
        else:
            sliding.append(j)
            implicit.append((j, "slides+" if 0 in kinds else "slides-"))
    return (implicit, np.array(sorted(sliding), dtype=np.int64),
            np.array(sorted(zero), dtype=np.int64))


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
    P, s = unit_problem(problem)
    feas, x, diag = _check_feasible(P)
    return feas, (None if x is None else x * s), _scaled_diagnosis(diag, s)


def check_bounded(problem: StaticsProblem):
    """(bounded, max sum fn [F0] or inf, recession direction (2m,) or None).

    S is bounded iff its recession cone {A d = 0, G d <= 0} is {0}; since the
    Coulomb cones are pointed, it suffices to maximise sum(d_fn) <= 1 over the
    cone: optimum 0 -> bounded, 1 -> unbounded with recession direction d.
    """
    P, s = unit_problem(problem)
    bounded, msum, rdir = _check_bounded(P)
    return bounded, msum * s, rdir


_SCALED = ("fn_range", "ft_range", "centre", "affine_point", "radius", "max_sum_fn")


class ForceSpace(Computed):
    """The set S of admissible force networks of a statics problem, analysed exactly.

    ``ForceSpace(ranges=False, centre=True, tol=config.IMPLICIT_TOL).compute(problem)``
    runs the LPs: feasibility, boundedness, implicit equalities (contacts forced to
    slide or to carry nothing), the affine hull and dimension, the Chebyshev centre
    (``centre``) and, with ``ranges``, the min and max of every force (4 LPs per
    contact). Vectors are in problem column order: x[2j] = fn, x[2j+1] = ft of
    unknown contact j [F0]. Arrays indexed by problem contact j unless stated.
    An LP that fails ends ``compute`` with ``success = False`` (``message`` says
    which); results it did not reach then raise AttributeError.
    """

    def __init__(self, ranges: bool = False, centre: bool = True,
                 tol: float = config.IMPLICIT_TOL, progress: bool = False):
        self.ranges, self.centre_ball, self.tol = bool(ranges), bool(centre), float(tol)
        self.progress = bool(progress)
        self.problem: StaticsProblem | None = None
        self._domains = None

    def compute(self, problem: StaticsProblem) -> "ForceSpace":
        """Analyse S of ``problem`` (:class:`~forcespace.model.problem.StaticsProblem`)."""
        if problem.n_contacts == 0:
            raise InputError(problem.source or "problem", "contacts",
                             "no unknown contact in the problem")
        self._start()
        self.problem, self._domains = problem, None
        P, s = unit_problem(problem)
        r = self._results
        r["force_scale"] = s
        with progress_bar(total=100, desc="analysis of S", unit="%",
                          disable=not self.progress) as bar:
            done = []

            def stage(name):
                bar.update(round(100 * sum(STAGES[n] for n in done)) - bar.n)
                bar.set_postfix_str(name)
                done.append(name)
            try:
                _analyze(P, r, ranges=self.ranges, centre=self.centre_ball, tol=self.tol,
                         stage=stage)
            except NumericalError as exc:
                self._finish(2, str(exc))
            else:
                self._finish(0, "analysis complete")
                bar.update(100 - bar.n)
        for name in _SCALED:
            if r.get(name) is not None:
                r[name] = r[name] * s
        r["infeasibility"] = _scaled_diagnosis(r.get("infeasibility"), s)
        return self

    # ---- results ---------------------------------------------------------------
    @property
    def feasible(self) -> bool:
        """S is non-empty."""
        return self._get("feasible")

    @property
    def bounded(self) -> bool | None:
        """S is bounded (False: a wedged geometry admits arbitrarily large forces; None
        when S is empty)."""
        return self._get("bounded")

    @property
    def dim(self) -> int | None:
        """Dimension of S (0: the network is determined by the statics; None when S is
        empty)."""
        return self._get("dim")

    @property
    def n_interior(self) -> int:
        """Interior (non-rattler) disks of the problem."""
        return self.problem.n_interior

    @property
    def n_contacts(self) -> int:
        """Unknown contacts m."""
        return self.problem.n_contacts

    @property
    def n_unknowns(self) -> int:
        """Free columns: 2m minus the ft of frictionless contacts (fixed at 0)."""
        return self._get("n_unknowns")

    @property
    def rank_A(self) -> int:
        """Rank of the equilibrium matrix A over the unknown columns."""
        return self._get("rank_A")

    @property
    def full_row_rank(self) -> bool:
        """A has full row rank (every disk's three balance rows independent)."""
        return self._get("full_row_rank")

    @property
    def degree_of_indeterminacy(self) -> int:
        """Unknowns minus the rank of the equilibrium equations (an upper bound of dim)."""
        return self._get("degree_of_indeterminacy")

    @property
    def implicit_rows(self) -> np.ndarray:
        """Rows of ``problem.inequalities()`` tight on all of S (int, (k,))."""
        return self._get("implicit_rows")

    @property
    def implicit(self) -> list:
        """(contact j, kind) of every implicit equality: "slides+" (ft = +mu fn),
        "slides-" (ft = -mu fn) or "zero" (fn = ft = 0)."""
        return self._get("implicit")

    @property
    def sliding_contacts(self) -> np.ndarray:
        """Contacts at the Coulomb limit on all of S (int, sorted)."""
        return self._get("sliding_contacts")

    @property
    def zero_contacts(self) -> np.ndarray:
        """Contacts carrying no force on all of S (int, sorted)."""
        return self._get("zero_contacts")

    @property
    def n_sliding(self) -> int | None:
        """Number of contacts at the Coulomb limit on all of S (None when S is empty)."""
        c = self.sliding_contacts
        return None if c is None else int(c.size)

    @property
    def n_zero(self) -> int | None:
        """Number of contacts carrying no force on all of S (None when S is empty)."""
        c = self.zero_contacts
        return None if c is None else int(c.size)

    @property
    def fn_range(self) -> np.ndarray | None:
        """(m, 2) min and max of fn over S [F0] (``ranges=True``; else None)."""
        return self._get("fn_range")

    @property
    def ft_range(self) -> np.ndarray | None:
        """(m, 2) min and max of ft over S [F0] (``ranges=True``; else None)."""
        return self._get("ft_range")

    @property
    def centre(self) -> np.ndarray | None:
        """Chebyshev centre of S in its affine hull, (2m,) [F0] (None: not asked, or S
        unbounded)."""
        return self._get("centre")

    @property
    def radius(self) -> float | None:
        """Radius of the largest ball in S within its affine hull [F0]."""
        return self._get("radius")

    @property
    def max_sum_fn(self) -> float:
        """Largest total normal force over S [F0] (inf when S is unbounded)."""
        return self._get("max_sum_fn")

    @property
    def recession_direction(self) -> np.ndarray | None:
        """(2m,) a direction along which S is unbounded (max |entry| = 1), else None."""
        return self._get("recession_direction")

    @property
    def infeasibility(self) -> dict | None:
        """Why S is empty: the disks that need the smallest extra loads [F0], else None."""
        return self._get("infeasibility")

    @property
    def affine_point(self) -> np.ndarray:
        """A point of S, (2m,) [F0]; S lies in affine_point + affine_basis @ y."""
        return self._get("affine_point")

    @property
    def affine_basis(self) -> np.ndarray:
        """Orthonormal basis (2m, dim) of the directions of S."""
        return self._get("affine_basis")

    @property
    def varying(self) -> np.ndarray:
        """(m,) bool: the contact's force can change by more than ``config.VARY_TOL``
        <Fn> within S (decided on forces: bounds from the ball and the diameter of S,
        LPs where they do not decide)."""
        return self._get("varying")

    @property
    def varying_contacts(self) -> np.ndarray:
        """Problem contact indices whose force can change within S (none if S is empty)."""
        v = self.varying
        return np.zeros(0, np.int64) if v is None else np.flatnonzero(v)

    @property
    def force_scale(self) -> float:
        """<Fn> of the problem [F0]: the unit of every tolerance."""
        return self._get("force_scale")

    @property
    def domains(self) -> list:
        """Independent domains of indeterminacy (:class:`forcespace.space.structure.Domain`);
        the elementary clusters are the domains of dimension 1."""
        if self._domains is None:
            from .structure import domains
            self._domains = domains(self.problem, self) if self.feasible and self.dim else []
        return self._domains

    # ---- questions -------------------------------------------------------------
    def contains(self, x, tol: float = config.SAMPLE_VIOLATION) -> bool:
        """Whether x (2m,) [F0] is in S up to ``tol`` <Fn>."""
        return self.problem.violation(x) <= tol

    def distance(self, x):
        """Exact Euclidean distance from x (2m,) [F0] to S
        (:class:`forcespace.space.projection.DistanceResult`)."""
        from .projection import distance_to_S
        if not self.feasible:
            raise InputError("distance", "S", "is empty (infeasible); no distance")
        return distance_to_S(self.problem, x)

    def summary(self) -> dict:
        """The analysis as a JSON-able dict (what ``forcespace analyze`` prints)."""
        r = self._results or {}
        d = {"feasible": r.get("feasible"), "bounded": r.get("bounded"),
             "n_interior": self.problem.n_interior, "n_contacts": self.problem.n_contacts,
             "n_unknowns": r.get("n_unknowns"), "rank_A": r.get("rank_A"),
             "full_row_rank": r.get("full_row_rank"),
             "degree_of_indeterminacy": r.get("degree_of_indeterminacy"),
             "dim_S": r.get("dim"),
             "n_sliding": None if r.get("sliding_contacts") is None else self.n_sliding,
             "n_zero_force": None if r.get("zero_contacts") is None else self.n_zero,
             "max_sum_fn": r.get("max_sum_fn"), "force_scale": r.get("force_scale"),
             "centre_radius": r.get("radius")}
        if r.get("infeasibility") is not None:
            d["infeasibility"] = r["infeasibility"]
        rd = r.get("recession_direction")
        if rd is not None:
            d["recession_direction_support"] = int((np.abs(rd) > config.RECESSION_SUPPORT_TOL * np.abs(rd).max()).sum())
        if r.get("feasible") and r.get("dim") is not None and not self._status:
            doms = self.domains
            d.update({"n_domains": len(doms), "domain_dims": [g.dim for g in doms],
                      "n_elementary_clusters": int(sum(g.elementary for g in doms)),
                      "n_varying_contacts": int(self.varying_contacts.size),
                      # directions of S along which no contact force changes by more
                      # than config.VARY_TOL <Fn>
                      "n_thin_directions": int(r["dim"]) - sum(g.dim for g in doms)})
        if self._status:
            d["analysis_failed"] = self._message
        return d

    def plot(self, packing, ax=None, **kw):
        """The packing with the disks of each domain of indeterminacy outlined; returns
        the Axes."""
        from ..plot import plot_packing
        kw.setdefault("title", f"S: dim {self.dim}, {len(self.domains)} domain(s)")
        return plot_packing(packing, ax, highlight=[g.disks for g in self.domains], **kw)

    def __repr__(self) -> str:
        args = f"ranges={self.ranges}, centre={self.centre_ball}"
        if not self.computed:
            return f"ForceSpace({args})"
        r = self._results
        return (f"ForceSpace({args}): {self.problem.kind}, {self.problem.n_contacts} contacts, "
                f"feasible={r.get('feasible')}, bounded={r.get('bounded')}, dim={r.get('dim')}")


# the stages of an analysis and their share of its time (5000-disk slice, CPU), for the
# progress bar's estimate
STAGES = {"feasibility and implicit equalities": 0.45, "boundedness": 0.15,
          "affine hull": 0.1, "centre": 0.25, "ranges": 0.0, "varying contacts": 0.05}


def _analyze(problem: StaticsProblem, out: dict, ranges: bool, centre: bool, tol: float,
             stage=lambda name: None):
    """Fill ``out`` with the analysis of S of ``problem`` (at <Fn> = 1), in order:
    feasibility, boundedness, implicit equalities, affine hull, ranges, centre,
    varying contacts; ``stage(name)`` is called as each begins. Large problems
    (``config.SWEEP_MIN_COLUMNS`` columns and up) decide the strict rows, the largest
    total force and the centre by interior-point LPs without crossover (one each),
    then confirm the undecided rows by the exact test. An LP failure raises
    NumericalError with ``out`` holding what was reached."""
    m2 = problem.n_columns
    fixed = problem.fixed_columns()
    free_cols = np.setdiff1d(np.arange(m2), fixed)
    out["n_unknowns"] = m2 - fixed.size
    large = m2 >= config.SWEEP_MIN_COLUMNS

    def set_rank(rank_A):
        # rank over the unknowns (not ft of mu=0 contacts). [A; fixed] is block
        # triangular in (free, fixed) columns with an identity on the fixed ones:
        # its rank is n_fixed + rank_A (no SVD of its own)
        out["rank_A"], out["full_row_rank"] = rank_A, rank_A == problem.A.shape[0]
        out["degree_of_indeterminacy"] = m2 - (fixed.size + rank_A)

    out.update(bounded=None, dim=None, infeasibility=None, recession_direction=None,
               fn_range=None, ft_range=None, centre=None, radius=None, max_sum_fn=None,
               implicit_rows=None, implicit=[], sliding_contacts=None, zero_contacts=None,
               affine_point=None, affine_basis=None, varying=None)
    stage("feasibility and implicit equalities")
    interior = _interior_strict_rows(problem) if large else None
    if interior is not None:
        (x0, strict), feas = interior, True
    else:
        feas, x0, diag = _check_feasible(problem)
        strict = None
    out["feasible"] = feas
    if not feas:
        set_rank(rank(problem.A[:, free_cols]))
        out["infeasibility"] = diag
        return
    G, owner, kind = problem.inequalities()
    imp = _implicit_equalities(problem, tol, None if strict is None else ~strict)
    out["implicit_rows"] = imp
    stage("boundedness")
    msum = _interior_max_sum_fn(problem) if large else None
    bounded, msum, rdir = (True, msum, None) if msum is not None else _check_bounded(problem)
    out.update(bounded=bounded, max_sum_fn=msum, recession_direction=rdir)
    stage("affine hull")
    Eq, rhs = eq_system(problem, G[imp])
    # one point of S and the affine hull: x0 projected onto the hull (removes LP
    # round-off along the equalities), from the same SVD as the hull's basis
    N, xa, rank_eq = affine_hull(Eq, rhs, x0)
    out["dim"] = int(N.shape[1])
    # without fixed columns and implicit rows Eq is A itself: same SVD, same rank
    set_rank(rank_eq if imp.size == 0 and fixed.size == 0 else rank(problem.A[:, free_cols]))
    out["affine_point"], out["affine_basis"] = xa, N
    out["implicit"], out["sliding_contacts"], out["zero_contacts"] = \
        _implicit_kinds(imp, owner, kind)
    if bounded and ranges:
        stage("ranges")
        out["fn_range"], out["ft_range"] = _column_ranges(problem, N, xa)
    if bounded and centre:
        stage("centre")
        out["centre"], out["radius"] = _chebyshev_centre(problem, N, imp, interior=large)
    stage("varying contacts")
    rngs = (out["fn_range"], out["ft_range"]) if out["fn_range"] is not None else None
    out["varying"] = _varying(problem, N, msum, out["radius"] or 0.0, rngs,
                              points=(xa, out["centre"]))


def implicit_equalities(problem: StaticsProblem, tol: float = config.IMPLICIT_TOL):
    """Indices of inequality rows of ``problem.inequalities()`` tight on all of S
    (no point of S has slack above ``tol`` <Fn>)."""
    return _implicit_equalities(unit_problem(problem)[0], tol)


def chebyshev_centre(problem: StaticsProblem, N=None, implicit_rows=None):
    """Centre of the largest ball inside S within its affine hull: (x (2m,), radius) [F0]
    (without the rest of the analysis). Rows that are implicit equalities are kept as
    equalities; for the others g.x + r ||P g|| <= 0 with P the projector onto the
    affine hull's directions."""
    P, s = unit_problem(problem)
    x, r = _chebyshev_centre(P, N, implicit_rows)
    return x * s, r * s
