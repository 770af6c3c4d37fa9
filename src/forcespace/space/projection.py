"""The Euclidean projection onto S (distance of a force network to S), verified.

The projection is a convex QP, solved exactly by least-distance programming in the
null space of the equalities (Lawson-Hanson via scipy's NNLS, a finite active-set
method; HiGHS' QP solver cycled on the degenerate Coulomb apexes and was dropped),
then *polished and verified* by an exact active-set step whose KKT conditions are
checked. Where that verification fails on ill-conditioned slices, the network of S
nearest in the L1 norm (one LP) is the fallback of the relax walk.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.optimize import nnls

from .. import config
from ..errors import InputError, NumericalError
from ..linalg import null_basis, range_basis
from ..model.problem import StaticsProblem, checked_problem
from .lp import bounds_list, eq_system, solve_lp, unit_problem


@dataclass
class DistanceResult:
    """Euclidean distance from a force vector x to S.

    absolute = ||nearest - x||_2 [F0]; relative = absolute / (<Fn> sqrt(m)) with
    <Fn> = problem.force_scale and m the number of unknown contacts, i.e. the
    rms per-contact distance in units of the mean normal force.
    nearest (2m,) is the exact projection (verified KKT point); kkt_residual
    and max_violation (relative to <Fn>) report the verification; allowed_violation
    is what it was verified to: ``config.SAMPLE_VIOLATION`` plus the equilibrium floor of
    the rank decision (as the billiard walk's): |Ceq N| |y| / <Fn>, the residual that
    directions counted as null (singular values below the rank cut) leave at the point's
    null-space coordinates y (0 where the null basis is exact).
    """

    absolute: float
    relative: float
    nearest: np.ndarray
    max_violation: float
    kkt_residual: float
    method: str
    allowed_violation: float = config.SAMPLE_VIOLATION

    def __repr__(self) -> str:        # the numbers, not the (2m,) nearest network
        return (f"DistanceResult(relative={self.relative:.3e} <Fn> rms per contact, "
                f"absolute={self.absolute:.3e} F0, max_violation={self.max_violation:.1e}, "
                f"kkt_residual={self.kkt_residual:.1e}, method={self.method!r}, "
                f"nearest=<{np.shape(self.nearest)[0]} forces>)")


@dataclass
class _Frame:
    """The problem-only linear algebra of the projection (one problem, many points).

    G (k, 2m) sparse and Gd dense: the inequality rows G x <= 0; Ceq (r, 2m) dense,
    ceq (r,): the equalities (:func:`eq_system`); xa (2m,): their least-squares
    solution; N (2m, d): orthonormal null basis of Ceq; Q (2m, rank): orthonormal
    basis of range(Ceq^T); M = G N, u = -G xa (the inequalities in null-space
    coordinates y, x = xa + N y: M y <= u)."""

    G: object
    Gd: np.ndarray
    Ceq: np.ndarray
    ceq: np.ndarray
    xa: np.ndarray
    N: np.ndarray
    Q: np.ndarray
    M: np.ndarray
    u: np.ndarray
    abs_CN: np.ndarray


def _frame(problem: StaticsProblem) -> _Frame:
    G, _, _ = problem.inequalities()
    Eq, ceq = eq_system(problem)
    Ceq = Eq.toarray()
    xa = sla.lstsq(Ceq, ceq, lapack_driver="gelsd")[0]
    N = null_basis(Ceq)
    return _Frame(G=G, Gd=G.toarray(), Ceq=Ceq, ceq=ceq, xa=xa, N=N, Q=range_basis(Ceq),
                  M=np.asarray(G @ N), u=-np.asarray(G @ xa), abs_CN=np.abs(Ceq @ N))


def _ldp_projection(problem: StaticsProblem, xhat, frame: _Frame):
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
    xa, N, M, u = frame.xa, frame.N, frame.M, frame.u
    d = N.shape[1]
    if d == 0:
        return xa, np.zeros(0, dtype=np.int64), 0.0
    ystar = N.T @ (np.asarray(xhat, float) - xa)
    scale = max(problem.force_scale, 1e-300)
    E = -M
    f = (M @ ystar - u) / scale                       # work in units of <Fn>
    Ep = np.vstack([E.T, f[None, :]])
    e = np.zeros(d + 1)
    e[-1] = 1.0
    v, _ = nnls(Ep, e, maxiter=50 * Ep.shape[1])
    r = Ep @ v - e
    if abs(r[-1]) < config.LDP_INFEASIBLE:
        raise NumericalError("projection: the constraints look infeasible (LDP)")
    z = -r[:d] / r[-1] * scale
    return xa + N @ (ystar + z), np.flatnonzero(v > 0), _reduced_kkt(M, u, ystar + z, z, scale)


def _reduced_kkt(M, u, y, z, scale) -> float:
    """KKT stationarity residual of min ||y - y*|| s.t. M y <= u at y = y* + z: with
    the rows tight to ``config.TIGHT_TOL`` <Fn>, NNLS for lam >= 0 in z = -M_act^T lam;
    the residual relative to max(|z|, <Fn>). inf if y is infeasible by more than that."""
    slack = M @ y - u
    if slack.max(initial=0.0) > config.TIGHT_TOL * scale:
        return float("inf")
    act = np.flatnonzero(slack > -config.TIGHT_TOL * scale)
    if act.size == 0:
        return float(np.linalg.norm(z)) / max(float(np.linalg.norm(z)), scale)
    Mt = M[act].T
    colscale = np.maximum(np.linalg.norm(Mt, axis=0), 1e-300)
    lam, res = nnls(Mt / colscale, -z, maxiter=50 * act.size)
    # complementarity: rows counted tight to 1e-9 <Fn> with huge multipliers (near-dependent
    # rows, far from S: 6e16 seen) certify nothing; 2 lam.slack bounds the error it leaves
    # in the squared distance
    comp = 2.0 * float((lam / colscale) @ np.abs(slack[act]))
    ref = max(float(np.linalg.norm(z)), scale)
    return max(float(res) / ref, comp / ref ** 2)


def eq_projection(xhat, Ceq, ceq, Gact):
    """Exact projection of xhat onto {Ceq x = ceq, Gact x = 0} (minimum-norm step), twice refined."""
    C = np.vstack([Ceq, Gact])
    c = np.concatenate([ceq, np.zeros(Gact.shape[0])])
    # cond: rows that are dependent up to round-off (e.g. both Coulomb rows and
    # a balance row through one contact) must not be amplified into big steps
    cond = config.RANGE_RANK_TOL
    xn = xhat - sla.lstsq(C, C @ xhat - c, cond=cond, lapack_driver="gelsd")[0]
    return xn - sla.lstsq(C, C @ xn - c, cond=cond, lapack_driver="gelsd")[0]


def _multipliers(Q, Gact, rhs):
    """Inequality multipliers lam >= 0 with rhs = Ceq^T mu + Gact^T lam (mu free).

    Q (2m, r): orthonormal basis of range(Ceq^T); the equality part is removed
    by projecting onto its complement, then NNLS. Returns (lam (k,), residual
    norm, unconstrained least-squares lam (k,)).
    """
    P = lambda v: v - Q @ (Q.T @ v)  # noqa: E731
    Bt = P(Gact.T) if Gact.shape[0] else np.zeros((rhs.size, 0))
    br = P(rhs)
    if Bt.shape[1] == 0:
        return np.zeros(0), float(np.linalg.norm(br)), np.zeros(0)
    colscale = np.maximum(np.linalg.norm(Bt, axis=0), 1e-300)
    lam, res = nnls(Bt / colscale, br, maxiter=50 * Bt.shape[1])
    free = sla.lstsq(Bt / colscale, br, cond=config.RANGE_RANK_TOL, lapack_driver="gelsd")[0]
    return lam / colscale, float(res), free / colscale


def _polish(problem: StaticsProblem, xhat, x, max_iter: int = 60, active=None,
            frame: _Frame | None = None):
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
    f = frame or _frame(problem)
    G, Gd, Ceq, ceq, Q = f.G, f.Gd, f.Ceq, f.ceq, f.Q
    scale = problem.force_scale
    if active is None:
        act = np.flatnonzero(G @ x > -config.ACTIVE_TOL * scale)
    else:
        act = np.unique(np.asarray(active, dtype=np.int64))
    best = (x, np.inf, False)
    seen = set()
    for _ in range(max_iter):
        key = act.tobytes()
        if key in seen:                      # cycling: stop with the best verified so far
            break
        seen.add(key)
        xn = eq_projection(xhat, Ceq, ceq, Gd[act])
        gx = Gd @ xn
        if gx.max(initial=0.0) > config.POLISH_FEASIBLE * scale:
            act = np.union1d(act, np.flatnonzero(gx > config.POLISH_FEASIBLE * scale))
            continue
        rhs = xhat - xn
        lam, res, free_lam = _multipliers(Q, Gd[act], rhs)
        kkt = res / max(np.linalg.norm(rhs), scale)
        if kkt < best[1]:
            best = (xn, kkt, False)
        if kkt <= config.KKT_TOL:
            return xn, kkt, True
        if act.size == 0:
            break
        act = np.delete(act, int(np.argmin(free_lam)))
    return best


def project(problem: StaticsProblem, x, frame: _Frame | None = None) -> DistanceResult:
    """The verified Euclidean projection of x (2m,) onto S of ``problem``, computed in
    the problem's own units (:func:`distance_to_S` calls it at <Fn> = 1; a caller that
    has already scaled its problem, as the selection's weighted one, calls it directly).
    ``frame``: the problem's :func:`_frame`, when it projects many points."""
    frame = frame or _frame(problem)
    xq, active, kkt_q = _ldp_projection(problem, x, frame)
    method = "null-space LDP (Lawson-Hanson NNLS) + verified active-set polish"
    xn, kkt, ok = _polish(problem, x, xq, active=active, frame=frame)
    if not ok:       # retry from the rows tight at the LDP point
        xn2, kkt2, ok2 = _polish(problem, x, xq, frame=frame)
        if ok2 or kkt2 < kkt:
            xn, kkt, ok = xn2, kkt2, ok2
    if not ok and kkt_q <= config.KKT_TOL and problem.violation(xq) <= (
            config.SAMPLE_VIOLATION + _null_floor(frame, xq, problem.force_scale)):
        # the full-space check failed on near-dependent equality rows (rank decision);
        # the LDP point's own KKT conditions, in null-space coordinates, hold
        xn, kkt, ok = xq, kkt_q, True
        method = "null-space LDP (Lawson-Hanson NNLS), KKT verified in null-space coordinates"
    # a point of S as the rank decision defines it may miss the equalities by the
    # residual its directions counted as null leave (0 where the null basis is exact)
    allowed = config.SAMPLE_VIOLATION + _null_floor(frame, xn, problem.force_scale)
    viol = problem.violation(xn)
    if not ok or viol > allowed:
        raise NumericalError(f"projection onto S could not be verified (kkt={kkt:.2e}, "
                             f"violation={viol:.2e})")
    d = float(np.linalg.norm(xn - x))
    rel = d / (problem.force_scale * np.sqrt(problem.n_contacts))
    return DistanceResult(absolute=d, relative=rel, nearest=xn, max_violation=viol,
                          kkt_residual=kkt, method=method, allowed_violation=allowed)


def _null_floor(frame: _Frame, x, scale: float) -> float:
    """Equilibrium floor |Ceq N| |N^T (x - xa)| / <Fn> of a point x of the frame's affine
    space: the largest equality residual the null directions' own residual (singular
    values of Ceq below the rank cut) can leave there (0 where the basis is exact)."""
    if frame.N.shape[1] == 0:
        return 0.0
    y = frame.N.T @ (np.asarray(x, float) - frame.xa)
    return float((frame.abs_CN @ np.abs(y)).max(initial=0.0) / max(scale, 1e-300))


def distance_to_S(problem: StaticsProblem, x) -> DistanceResult:
    """Exact Euclidean distance from ``x`` (2m,) [F0] to S (see :class:`DistanceResult`).

    Method: least-distance programming in the null space of the equalities
    (Lawson-Hanson via scipy's NNLS, a finite active-set method; HiGHS' QP
    solver cycled on the degenerate Coulomb apexes and was dropped), then an
    exact active-set polish whose KKT conditions are verified (feasibility to
    round-off, multipliers >= 0, stationarity residual <= 1e-9). Raises
    NumericalError if the verification fails, InputError for a wrong-shaped or
    non-finite x, and refuses an infeasible S. Many points of one problem:
    :class:`Projector`.
    """
    return Projector(problem)(x)


def qp_project(problem: StaticsProblem, xhat) -> DistanceResult:
    """The Euclidean projection of ``xhat`` (2m,) onto S of ``problem`` (at <Fn> = 1) by a
    sparse interior-point QP (Clarabel: sparse LDL^T, so it scales to 1000-particle frames
    where :func:`project`'s dense null-space method costs minutes), certified: the
    solver's own optimality (duality gap and feasibility to its tolerance), forcespace's
    check of the point (equilibrium and Coulomb to ``config.SAMPLE_VIOLATION`` <Fn>) and
    the KKT stationarity with the solver's multipliers (relative residual <=
    ``config.QP_KKT_TOL``); small problems (below ``config.SWEEP_MIN_COLUMNS`` columns) are
    finished exactly on the active rows (:func:`_polish`). Far from S, where
    :func:`project`'s multiplier certificate can be fooled by near-dependent rows
    (multipliers of 1e16), the interior-point multipliers stay bounded. Tolerances
    ``config.QP_TOLS`` are tried in turn (the tightest can end in "insufficient
    progress"). NumericalError when S is empty or no attempt verifies."""
    xhat = np.asarray(xhat, float)
    viol0 = problem.violation(xhat)
    if viol0 <= config.SAMPLE_VIOLATION:      # already in S at the project's resolution
        return DistanceResult(absolute=0.0, relative=0.0, nearest=xhat.copy(),
                              max_violation=viol0, kkt_residual=0.0,
                              method="the point is in S (violation <= SAMPLE_VIOLATION)")
    reason = ""
    for tol in config.QP_TOLS:
        status, x, kkt, active, iterations = _clarabel_projection(problem, xhat, tol)
        if status != "Solved":
            reason = f"the interior-point QP ended {status} at tolerance {tol:g}"
            continue
        method = f"sparse interior-point QP (Clarabel, tolerance {tol:g}, {iterations} " \
                 "iterations)"
        if problem.n_columns < config.SWEEP_MIN_COLUMNS:    # finish exactly
            xp, kkt_p, ok = _polish(problem, xhat, x, active=active, max_iter=8)
            if ok and problem.violation(xp) <= config.SAMPLE_VIOLATION and (
                    np.linalg.norm(xp - xhat) <= np.linalg.norm(x - xhat) + tol):
                x, kkt = xp, kkt_p
                method += " + exact active-set finish (KKT verified)"
        viol = problem.violation(x)
        if kkt > config.QP_KKT_TOL or viol > config.SAMPLE_VIOLATION:
            reason = f"not verified at tolerance {tol:g} (kkt={kkt:.2e}, violation={viol:.2e})"
            continue
        d = float(np.linalg.norm(x - xhat))
        return DistanceResult(absolute=d, relative=d / (problem.force_scale * np.sqrt(
            max(problem.n_contacts, 1))), nearest=x, max_violation=viol, kkt_residual=kkt,
            method=method + ", KKT and feasibility checked")
    raise NumericalError(f"projection onto S: {reason}")


def _clarabel_projection(problem: StaticsProblem, xhat, tol: float):
    """One Clarabel solve of min |x - xhat|^2 / 2 over S: (status: "Solved" (also for its
    "AlmostSolved"), "Infeasible" raises, or the solver's word; x (2m,); the relative KKT
    stationarity residual with its multipliers; the inequality rows with slack below
    ``config.ACTIVE_TOL``; iterations)."""
    import clarabel

    G, _, _ = problem.inequalities()
    Eq, ceq = eq_system(problem)
    C = sp.vstack([Eq, G]).tocsc()
    cones = [clarabel.ZeroConeT(Eq.shape[0])] + ([clarabel.NonnegativeConeT(G.shape[0])]
                                                 if G.shape[0] else [])
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = tol
    settings.max_iter = 400
    sol = clarabel.DefaultSolver(sp.identity(problem.n_columns, format="csc"), -xhat, C,
                                 np.concatenate([ceq, np.zeros(G.shape[0])]), cones,
                                 settings).solve()
    status = str(sol.status)
    if "Infeasible" in status and "Dual" not in status:
        raise NumericalError("projection onto S: S is empty (the QP is infeasible)")
    x = np.array(sol.x)
    if status not in ("Solved", "AlmostSolved"):
        return status, x, np.inf, None, sol.iterations
    kkt = float(np.linalg.norm((x - xhat) + C.T @ np.array(sol.z))
                / max(np.linalg.norm(x - xhat), 1.0))
    active = np.flatnonzero(np.array(sol.s)[Eq.shape[0]:] <= config.ACTIVE_TOL)
    return "Solved", x, kkt, active, sol.iterations


def weighted_problem(problem: StaticsProblem, kn, kt):
    """(problem in z = D^-1 x, d (2m,)): S of the weighted coordinates, in which the
    Euclidean projection minimises sum_j (fn_j^2 / kn_j + ft_j^2 / kt_j) (the elastic
    selection's complementary energy; with kn = sigma_fn^2, kt = sigma_ft^2 the
    uncertainty-weighted distance of a measured network).

    d[2j] = sqrt(kn_j / k0), d[2j+1] = sqrt(kt_j / k0), k0 = mean kn (so z is
    in force units); A -> A diag(d), mu_j -> mu_j sqrt(kn_j / kt_j). The
    complementary energy of x = d z is |z|^2 / (2 k0).
    """
    k0 = float(np.mean(kn))
    d = np.empty(problem.n_columns)
    d[0::2] = np.sqrt(kn / k0)
    d[1::2] = np.sqrt(kt / k0)
    A = (problem.A @ sp.diags(d)).tocsr()
    mu = problem.mu * np.sqrt(kn / kt)
    return dataclasses.replace(problem, A=A, mu=mu, x_jammed=problem.x_jammed / d), d


class Projector:
    """:func:`distance_to_S` for many points of one problem: ``Projector(problem)(x)``.

    The problem-only linear algebra (the equalities' particular solution, null and
    range bases: two SVDs of the 2m-column equality matrix) is done once, at the first
    call, instead of once per point; the results are those of :func:`distance_to_S`
    bit for bit. The relax walk projects every stalled sample of a slice with one.
    """

    def __init__(self, problem: StaticsProblem):
        self.problem = problem = checked_problem(problem, "distance")
        self._unit, self._scale = unit_problem(problem)
        self._frame: _Frame | None = None

    def __call__(self, x) -> DistanceResult:
        problem = self.problem
        x = np.asarray(x, float)
        if x.shape != (problem.n_columns,) or not np.all(np.isfinite(x)):
            raise InputError("distance_to_S", "x", f"must be a finite vector of shape "
                             f"({problem.n_columns},)", got=getattr(x, "shape", None))
        if self._frame is None:
            self._frame = _frame(self._unit)
        s = self._scale
        r = project(self._unit, x / s, self._frame)
        return dataclasses.replace(r, absolute=r.absolute * s, nearest=r.nearest * s)


def l1_nearest(problem: StaticsProblem, x) -> np.ndarray:
    """The network of S nearest to x (2m,) in the L1 norm [F0]: one LP at <Fn> = 1
    (min sum t, -t <= y - x <= t, y in S), exact where the Euclidean projection's
    verification fails on ill-conditioned slices. NumericalError if S is empty."""
    P, s = unit_problem(problem)
    G, _, _ = P.inequalities()
    m2 = P.n_columns
    xs = np.asarray(x, float) / s
    eye = sp.identity(m2, format="csr")
    c = np.concatenate([np.zeros(m2), np.ones(m2)])
    A_ub = sp.vstack([sp.hstack([G, sp.csr_matrix((G.shape[0], m2))]),
                      sp.hstack([eye, -eye]), sp.hstack([-eye, -eye])]).tocsr()
    b_ub = np.concatenate([np.zeros(G.shape[0]), xs, -xs])
    A_eq = sp.hstack([P.A, sp.csr_matrix((P.A.shape[0], m2))]).tocsr()
    res = solve_lp(c, A_ub, b_ub, A_eq, P.b, bounds_list(*P.bounds()) + [(0, None)] * m2)
    if res.status != 0:
        raise NumericalError(f"L1-nearest network of S: LP failed ({res.message})")
    # HiGHS is feasible to 1e-7 only: move exactly onto the equalities and the rows the
    # LP left tight (a minimum-norm step of that size; the other rows keep their slack)
    y = res.x[:m2]
    Eq, rhs = eq_system(P)
    Gd = G.toarray()
    tight = np.flatnonzero(Gd @ y > -1e-6)
    return eq_projection(y, Eq.toarray(), rhs, Gd[tight]) * s
