"""The exact questions about S, each answered by LPs (HiGHS, :mod:`forcespace.space.lp`).

S = {x : A x = b, x_fixed = 0, G x <= 0} (columns and rows: :mod:`forcespace.model.problem`).
The functions of the first part take a problem scaled to <Fn> = 1 (``lp.unit_problem``)
and answer one question each: a point of S (``feasibility``), ``boundedness``, the rows
tight on all of S (``tight_rows``, :func:`implicit_kinds`), which contacts can vary
(``varying_contacts``, by ``lp_widths``), the range of every force (``column_ranges``), the
Chebyshev centre (``centre_and_radius``), and the interior-point shortcuts of large
problems (``interior_strict_rows``, ``interior_max_sum_fn``). The last part asks them of
any problem and answers in F0 (``check_feasible``, ``check_bounded``,
``implicit_equalities``, ``chebyshev_centre``).
:class:`forcespace.space.force_space.ForceSpace` asks them in order.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .. import config
from ..errors import NumericalError
from ..linalg import null_basis, onto_affine_hull
from ..model.problem import NO_TENSION, SLIDES_MINUS, SLIDES_PLUS, StaticsProblem
from .lp import (HullRanges, attempts_for, bounds_list, eq_system, inner_ball, solve_lp,
                 solve_lp_interior, unit_problem)


# ----------------------------------------------------------------------------
# the questions, each on a problem at <Fn> = 1
# ----------------------------------------------------------------------------
def feasibility(problem: StaticsProblem):
    """(feasible, x or None, diagnosis or None).

    When infeasible, an L1 relaxation of the equilibrium rows (minimum total
    imbalance) names the disks that cannot be balanced and by how much; the diagnosis
    holds the relaxation's network (``least_violating`` (2m,): inside every cone, the
    least total imbalance) and its extra loads (``relaxation`` (rows of A,)).
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
                                   "listed disks need the smallest extra loads",
                         "least_violating": r2.x[:m2], "relaxation": s}


def boundedness(problem: StaticsProblem):
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


def tight_rows(problem: StaticsProblem, tol: float, undecided=None):
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


def interior_strict_rows(problem: StaticsProblem):
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
        tol=config.INTERIOR_TOL * scale, solver=config.INTERIOR_SOLVERS["strict_rows"])
    if st != 0:
        return None
    x = z[:m2]
    return x, -(G @ x) > config.INTERIOR_STRICT * scale


def interior_max_sum_fn(problem: StaticsProblem):
    """max sum fn over S by one interior-point LP without crossover, or None (unbounded,
    or the solve failed: the caller then takes the exact recession-cone test)."""
    G, _, _ = problem.inequalities()
    lo, hi = problem.bounds()
    c = np.zeros(problem.n_columns)
    c[0::2] = -1.0
    st, x = solve_lp_interior(c, G, np.zeros(G.shape[0]), problem.A, problem.b, lo, hi,
                              tol=config.INTERIOR_TOL * problem.force_scale,
                              solver=config.INTERIOR_SOLVERS["max_sum_fn"])
    return float(-c @ x) if st == 0 else None


def varying_contacts(problem: StaticsProblem, N, max_sum_fn, radius, ranges=None,
                     points=(), cert=None) -> np.ndarray:
    """Mask (m,) of contacts whose force can change by more than VARY_TOL <Fn> within S
    (problem at <Fn> = 1).

    A contact's 2 x d block N_j of the hull basis bounds its force range: S
    holds a ball of radius ``radius`` in its hull, so the range is at least
    sqrt(2) radius ||N_j||; the diameter of S is at most 2 sqrt(1 + mu^2)
    max_sum_fn, so the range is at most that times ||N_j||. Contacts between
    the bounds are decided by LP (:func:`lp_widths`; ``points``: known points of S
    that spare some of them; ``ranges``: the full range table when already computed;
    ``cert``: the :class:`RangeCertificate` its LPs are checked with).
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
            width = lp_widths(problem, undecided, config.VARY_TOL, points,
                              hull=N if points else None, cert=cert)
        varying[undecided] = ~(width <= config.VARY_TOL)   # unbounded (inf) or NaN-free wide: varies
    return varying




def lp_widths(problem: StaticsProblem, contacts, tol: float, points=(),
              hull=None, cert=None) -> np.ndarray:
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

    ``cert``: a :class:`RangeCertificate` every answer is checked with.
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
    extreme = (_HullLP(problem, hull, points, cert).extreme
               if hull is not None and hull.shape[1] <= config.REDUCED_LP_MAX_DIM
               else lambda col, sgn: _column_extreme(problem, G, bnds, col, sgn, cert))
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
    ``extreme(col, sgn)`` is :func:`_column_extreme`'s contract; with ``cert`` (a
    :class:`RangeCertificate`) an answer its multipliers do not prove is asked again in
    the 2m forces."""

    def __init__(self, problem: StaticsProblem, N, points, cert=None):
        G, _, _ = problem.inequalities()
        N = np.asarray(N, float)
        xa = np.asarray(points[0], float)
        on_hull = [xa] + [onto_affine_hull(x, xa, N) for x in points[1:] if x is not None]
        x0 = min(on_hull, key=problem.violation)
        H, h = np.asarray(G @ N), -(G @ x0)
        keep = np.linalg.norm(H, axis=1) > config.FLAT_ROW
        self.N, self.x0, self.cert = N, x0, cert
        self.H, self.h = H[keep], np.maximum(h[keep], 0.0)

    def extreme(self, col: int, sgn: float):
        c = sgn * self.N[col]
        res = solve_lp(c, self.H, self.h, bounds=(None, None), known_feasible=True)
        if res.status == 3:
            return -sgn * np.inf, None
        if res.status != 0:
            raise NumericalError(f"range LP for column {col} (hull coordinates) failed: "
                                 f"{res.message}")
        x = self.x0 + self.N @ res.x
        if self.cert is None or self.cert.hull_accepts(res.x, np.minimum(
                res.ineqlin.marginals, 0.0), c, self.H, self.h):
            return x[col], x
        return self.cert.in_full_space(col, sgn, (x[col], x))


class RangeCertificate:
    """Checks a range LP's "optimal" answer before it is reported (issue 47: on n = 800,
    mu = 1 slices HiGHS' simplex called optima that were 0.03-0.2 <Fn> short when the
    equilibrium rows were nearly dependent: its equality multipliers reached 1e11, and
    with them any point within 1e-9 of the equations looked optimal).

    S is taken as the analysis takes it: the points x = x_a + N y of its affine hull
    (``N`` (2m, d) the hull's orthonormal basis, the rank cut applied) with G x <= 0 and
    fn >= 0; |x - x_a| <= D = 2 sqrt(1 + mu_max^2) max_sum_fn (the diameter bound of S).
    In the 2m forces (:meth:`accepts`): for any nu <= 0 and r >= 0 on the fn columns,
    q = c - G^T nu - r gives, for every x of S, c.x = q.x + nu.(G x) + r.x >= q.x =
    q.x_a + (N^T q).y >= q.x_a - |N^T q| D. In the hull's coordinates, over {H y <= h}
    (:meth:`hull_accepts`): c.y >= nu.h - |c - H^T nu| D. With the LP's own multipliers
    (inequalities' nu, the lower bounds' reduced costs as r) the bound is tight at a true
    optimum; the equality multipliers never enter (huge ones leave a large |N^T q| and
    are refused). An answer is accepted when its point is in S (violation <=
    ``config.VARY_TOL``) and the bound is within ``config.RANGE_GAP_TOL`` of its value;
    otherwise the question is asked again in the 2m forces (:func:`_column_extreme`).
    ``stats``: lps (range questions), retried (first answer not proven), confirmed (no
    answer proven, two methods agree within RANGE_GAP_TOL), uncertified (neither), max_gap
    [<Fn>] of a proven answer."""

    def __init__(self, problem: StaticsProblem, N, xa, max_sum_fn: float):
        self.problem, self.N, self.xa = problem, np.asarray(N, float), np.asarray(xa, float)
        self.diam = 2.0 * np.sqrt(1.0 + float(problem.mu.max(initial=0.0)) ** 2) * max_sum_fn
        lo, hi = problem.bounds()
        self.fn = (lo == 0.0) & ~np.isfinite(hi)         # columns with fn >= 0 alone
        self.fn[1::2] = False
        self.stats = {"lps": 0, "retried": 0, "confirmed": 0, "uncertified": 0,
                      "max_gap": 0.0, "exact": 0, "polished": 0, "not_polished": 0}

    def _proven(self, gap: float, violation: float) -> bool:
        ok = bool(violation <= config.VARY_TOL and gap <= config.RANGE_GAP_TOL)
        if ok:
            self.stats["max_gap"] = max(self.stats["max_gap"], float(gap))
        return ok

    def accepts(self, res, c) -> bool:
        """Whether the answer ``res`` (scipy's, marked optimal) of min c.x over S is
        proven by its multipliers."""
        G, _, _ = self.problem.inequalities()
        try:
            nu = np.minimum(np.asarray(res.ineqlin.marginals, float), 0.0)
            r = np.where(self.fn, np.maximum(np.asarray(res.lower.marginals, float), 0.0),
                         0.0)
        except AttributeError:          # no multipliers: nothing proven
            return False
        q = c - G.T @ nu - r
        bound = q @ self.xa - np.linalg.norm(self.N.T @ q) * self.diam
        gap = res.fun - bound if np.isfinite(bound) else np.inf
        return self._proven(gap, self.problem.violation(res.x))

    def hull_accepts(self, y, nu, c, H, h) -> bool:
        """Whether y (d,), the answer of min c.y over {H y <= h} (hull coordinates about a
        point of S), is proven by the multipliers nu <= 0 of H's rows; counts the LP."""
        self.stats["lps"] += 1
        nz = np.flatnonzero(nu)
        bound = nu[nz] @ h[nz] - np.linalg.norm(c - H[nz].T @ nu[nz]) * self.diam
        gap = c @ y - bound if np.isfinite(bound) else np.inf
        return self._proven(gap, max(float(np.max(H @ y - h, initial=0.0)), 0.0))

    def in_full_space(self, col: int, sgn: float, found):
        """The question whose hull answer ``found`` (value, x (2m,)) was not proven, asked
        in the 2m forces (:func:`_column_extreme`): (value, x)."""
        self.stats["retried"] += 1
        G, _, _ = self.problem.inequalities()
        return _column_extreme(self.problem, G, bounds_list(*self.problem.bounds()), col,
                               sgn, self, found)


# a range LP whose answer is not proven is asked again this way, then that
RANGE_RETRIES = ((("highs-ipm", {}),), (("highs-ds", {"presolve": False}),))


def _column_extreme(problem: StaticsProblem, G, bnds, col: int, sgn: float,
                    cert: RangeCertificate | None = None, found=None):
    """min (sgn = 1) or max (sgn = -1) of column ``col`` over S by one LP: (value, x (2m,)
    the optimum), or (-sgn inf, None) where S is unbounded that way. ``G``, ``bnds``: the
    problem's inequalities and bounds_list. ``cert``: check each answer
    (:class:`RangeCertificate`) and, unless proven, ask again by interior point, then by
    dual simplex without presolve (``found``: an earlier answer (value, x) of the
    question, the hull's simplex, not proven: those two alone are asked); when no answer
    is proven, the most extreme point of S found (``found`` included) is
    reported, counted as confirmed when two methods found it within
    ``config.RANGE_GAP_TOL``, else as uncertified. NumericalError if the LP fails."""
    c = np.zeros(problem.n_columns)
    c[col] = sgn
    points = [] if found is None or problem.violation(found[1]) > config.VARY_TOL else [found]
    msg = ""
    if cert is not None and found is None:
        cert.stats["lps"] += 1
    # after a hull answer (a simplex's) the 2m forces are asked by the other methods
    chain = (RANGE_RETRIES if found is not None else (None,) + RANGE_RETRIES) \
        if cert is not None else (None,)
    for k, attempts in enumerate(chain):
        res = solve_lp(c, G, np.zeros(G.shape[0]), problem.A, problem.b, bnds,
                       attempts=attempts, known_feasible=True)
        if res.status == 3:
            return -sgn * np.inf, None
        if res.status != 0:
            msg = res.message
            continue
        if cert is None or cert.accepts(res, c):
            return res.x[col], res.x
        cert.stats["retried"] += k == 0 and found is None
        if problem.violation(res.x) <= config.VARY_TOL:
            points.append((res.x[col], res.x))
            if len(points) > 1 and abs(points[-1][0] - points[0][0]) <= config.RANGE_GAP_TOL:
                break                   # two methods agree: no third opinion needed
    if not points:
        raise NumericalError(f"range LP for column {col} failed: {msg or 'no point of S'}")
    value, x = min(points, key=lambda f: sgn * f[0])
    agree = sum(abs(v - value) <= config.RANGE_GAP_TOL for v, _ in points) > 1
    cert.stats["confirmed" if agree else "uncertified"] += 1
    return value, x


def column_ranges(problem: StaticsProblem, N=None, xa=None, columns=None, cert=None):
    """Min and max of every column over S: (fn_range, ft_range), each (m, 2).

    Columns that do not move within the affine hull (zero rows of N) are
    constant and are not solved for. With ``columns``: only those columns are
    solved, and the (2m, 2) table is returned (other rows NaN); an unbounded
    side is +-inf. ``cert``: every answer checked (:class:`RangeCertificate`),
    the hull's and the 2m forces' alike.
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
    fixed = lo[todo] == hi[todo]          # ft of a frictionless contact
    rng[todo[fixed]] = lo[todo[fixed], None]
    todo = todo[~fixed]
    extreme = None                        # without a hull: one LP each in the 2m forces
    if N is not None and xa is not None and N.shape[1] <= config.HULL_RANGES_MAX_DIM:
        extreme, order = _hull_extremes(G, N, xa, todo, cert)
        todo = todo[order]
    for side, sgn in ((0, 1.0), (1, -1.0)):     # all minima, then all maxima
        for col in todo:
            status, value = extreme(col, sgn) if extreme is not None else (1, None)
            if status == 0:
                rng[col, side] = value
            elif status == 3:
                rng[col, side] = -sgn * np.inf
            else:
                rng[col, side] = _column_extreme(problem, G, bnds, col, sgn, cert)[0]
    if columns is not None:
        return rng
    return rng[0::2].copy(), rng[1::2].copy()


def _hull_extremes(G, N, xa, cols, cert=None):
    """(``extreme(col, sgn)`` -> (status, min of sgn x[col] over S, times sgn), the order to
    ask them in): LPs in the affine hull's coordinates y (x = xa + N y; rows G N y <= -G xa
    as :class:`_HullLP`) by :class:`HullRanges`, warm-started, the columns ordered so
    that consecutive objectives are alike (few pivots between them). For large problems
    (a 1000-disk frame: 9 s where the LPs in the 2m forces took 14 min warm-started);
    exact up to the hull's own resolution (its implicit equalities are decided at
    ``config.IMPLICIT_TOL``, 1e-9 <Fn>); each optimum polished to the exact vertex of
    {H y <= h} (:func:`forcespace.space.lp.exact_vertex`, up to dim S =
    ``config.RANGE_EXACT_MAX_DIM``), so that bit-different data give the same ends to
    ~1e-13. Status as :meth:`HullRanges.minimum`. ``cert``:
    each optimum checked by its multipliers (:meth:`RangeCertificate.hull_accepts`), one
    not proven asked again in the 2m forces."""
    H, h = np.asarray(G @ N), -(G @ xa)
    keep = np.linalg.norm(H, axis=1) > config.RANGE_FLAT_ROW
    H, h = H[keep], h[keep]
    hull = HullRanges(H, h, tol=config.RANGE_LP_TOL)
    exact = N.shape[1] <= config.RANGE_EXACT_MAX_DIM

    def extreme(col, sgn):
        c = sgn * N[col]
        status, v = hull.minimum(c, exact=exact)
        if status != 0:
            return status, None
        if cert is not None and exact:
            cert.stats["polished" if hull.polished > 0 else "exact" if hull.polished == 0
                       else "not_polished"] += 1
        if cert is None or cert.hull_accepts(hull.y, -hull.mu, c, H, h):
            return 0, xa[col] + sgn * v
        x = xa + N @ hull.y
        return 0, cert.in_full_space(col, sgn, (x[col], x))[0]
    return extreme, similar_order(N[cols]) if cols.size else np.zeros(0, np.int64)


def similar_order(V) -> np.ndarray:
    """An order of the rows of V (k, d) in which consecutive rows point alike: greedy
    nearest neighbour by the cosine of their directions, from row 0 (O(k^2 d)); above
    ``config.SIMILAR_ORDER_MAX_WORK`` flops, the order of their projections on V's leading
    right singular vector (O(k d))."""
    U = V / np.maximum(np.linalg.norm(V, axis=1), 1e-300)[:, None]
    if float(U.shape[0]) ** 2 * U.shape[1] > config.SIMILAR_ORDER_MAX_WORK:
        v = np.ones(U.shape[1])
        for _ in range(20):                       # power iteration on U^T U
            v = U.T @ (U @ v)
            v /= max(np.linalg.norm(v), 1e-300)
        return np.argsort(U @ v, kind="stable")
    left = np.ones(U.shape[0], dtype=bool)
    order = np.empty(U.shape[0], np.int64)
    k = 0
    for i in range(U.shape[0]):
        order[i] = k
        left[k] = False
        if i + 1 < U.shape[0]:
            cos = U @ U[k]
            cos[~left] = -np.inf
            k = int(np.argmax(cos))
    return order


def centre_and_radius(problem: StaticsProblem, N=None, implicit_rows=None,
                      interior: bool = False):
    """Centre of the largest ball inside S within its affine hull: (x (2m,), radius [F0]).

    Rows that are implicit equalities are kept as equalities; for the others
    g.x + r ||P g|| <= 0 with P the projector onto the affine hull's directions.
    """
    G, _, _ = problem.inequalities()
    if implicit_rows is None:
        implicit_rows = tight_rows(problem, config.IMPLICIT_TOL)
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
                                  tol=config.INTERIOR_TOL * problem.force_scale,
                                  solver=config.INTERIOR_SOLVERS["centre"])
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


def implicit_kinds(implicit_rows, owner, kind):
    """Per contact, which of its inequalities are tight on all of S: (implicit list of
    (contact, "slides+" | "slides-" | "zero"), sliding contacts, zero contacts)."""
    imp_set = {}
    for r in implicit_rows:
        imp_set.setdefault(int(owner[r]), set()).add(int(kind[r]))
    implicit, sliding, zero = [], [], []
    for j, kinds in imp_set.items():
        if NO_TENSION in kinds or kinds == {SLIDES_PLUS, SLIDES_MINUS}:
            zero.append(j)
            implicit.append((j, "zero"))
        else:
            sliding.append(j)
            implicit.append((j, "slides+" if SLIDES_PLUS in kinds else "slides-"))
    return (implicit, np.array(sorted(sliding), dtype=np.int64),
            np.array(sorted(zero), dtype=np.int64))


def scaled_diagnosis(diag, s):
    if diag is None:
        return None
    diag = dict(diag)
    diag["min_total_imbalance"] *= s
    for key in ("least_violating", "relaxation"):
        diag[key] = diag[key] * s
    diag["worst_rows"] = [dict(w, imbalance=w["imbalance"] * s) for w in diag["worst_rows"]]
    return diag


def check_feasible(problem: StaticsProblem):
    """(feasible, x (2m,) [F0] or None, diagnosis or None).

    When infeasible, an L1 relaxation of the equilibrium rows (minimum total
    imbalance) names the disks that cannot be balanced and by how much [F0].
    """
    P, s = unit_problem(problem)
    feas, x, diag = feasibility(P)
    return feas, (None if x is None else x * s), scaled_diagnosis(diag, s)


def check_bounded(problem: StaticsProblem):
    """(bounded, max sum fn [F0] or inf, recession direction (2m,) or None).

    S is bounded iff its recession cone {A d = 0, G d <= 0} is {0}; since the
    Coulomb cones are pointed, it suffices to maximise sum(d_fn) <= 1 over the
    cone: optimum 0 -> bounded, 1 -> unbounded with recession direction d.
    """
    P, s = unit_problem(problem)
    bounded, msum, rdir = boundedness(P)
    return bounded, msum * s, rdir



def implicit_equalities(problem: StaticsProblem, tol: float = config.IMPLICIT_TOL):
    """Indices of inequality rows of ``problem.inequalities()`` tight on all of S
    (no point of S has slack above ``tol`` <Fn>)."""
    return tight_rows(unit_problem(problem)[0], tol)


def chebyshev_centre(problem: StaticsProblem, N=None, implicit_rows=None):
    """Centre of the largest ball inside S within its affine hull: (x (2m,), radius) [F0]
    (without the rest of the analysis). Rows that are implicit equalities are kept as
    equalities; for the others g.x + r ||P g|| <= 0 with P the projector onto the
    affine hull's directions."""
    P, s = unit_problem(problem)
    x, r = centre_and_radius(P, N, implicit_rows)
    return x * s, r * s
