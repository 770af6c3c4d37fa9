"""Rounding of a polytope by an inscribed ellipsoid: the exact maximum-volume one
(MVE, interior point, cost O(p^3) per iteration) or a John-ellipsoid
approximation by Lewis-weight fixed point (cost O(p d^2) per iteration).

For P = {y : H y <= s} (H (p, d), s (p,), full-dimensional, bounded) the MVE
{c + E u : |u| <= 1} is found by the primal-dual interior-point method of
Zhang & Gao (2003, "An interior-point algorithm for the maximum-volume
ellipsoid problem"; the algorithm of Y. Zhang's ``mve_solver`` that COBRA and
PolyRound use). Mapping y = c + E^{1/2} w makes the MVE the unit ball, and by
John's theorem the rounded polytope then lies within the ball of radius d:
a rounded polytope in which hit-and-run mixes in O(d^2) coordinate steps.

For p rows much larger than d (the slices of big packings: p ~ 3 Nc, d ~ 0.3 Nc)
the interior point's p x p factorisations dominate everything (a 2000-disk slice,
p ~ 4900-7400, took 1000-2700 s), so :func:`john_ellipsoid` replaces it there: the
fixed point w_i <- w_i a_i^T (A^T W A)^{-1} a_i of Cohen, Cousins, Lee & Yang
(2019, "A near-optimal algorithm for approximating the John ellipsoid"), whose
fixed point is John's condition, interleaved with Newton steps towards the
w-weighted analytic centre (the centre the weights balance). Its ellipsoid is
scaled to be inscribed exactly; it is the MVE for a simplex or a box, and close
to it otherwise (tests compare the two).

:func:`lewis_rounding` is the cheap rounding of the billiard walk (billiard.py): the
same Lewis-weight fixed point, but centred by Newton steps with an *exact* line search
(where :func:`john_ellipsoid` damps its steps to 1 / (1 + decrement): from the Chebyshev
centre of the 5000-disk slice, decrement ~16, ~100 damped steps against ~10-15) and
stopped after a few weight updates: the walk needs a round body, not John's exact
ellipsoid (studies/sampler_cost.md: its cost per effective sample changes by tens of
per cent between 0 and 20 updates, the rounding's by 7x at dim 1714).

Plain linear algebra; the only output is an optional progress bar (stderr).
Units: whatever the caller uses for y and s
(hit_and_run passes y in units of <Fn>).
"""
from __future__ import annotations

import time
from functools import partial

import numpy as np
import scipy.linalg as sla

from .. import config
from ..errors import InputError, NumericalError


def _live_start(H, s, y0, who: str):
    """(H, s, y, r, keep): the rows that can bind (mask ``keep`` of the given rows) at the
    start y = y0, with r = s - H y their slacks there; InputError unless y0 is strictly
    inside {H y <= s}."""
    H, s = np.asarray(H, float), np.asarray(s, float)
    y = np.asarray(y0, float).copy()
    r = s - H @ y
    if not np.all(r > 0):
        raise InputError(who, "y0", "must be strictly inside the polytope", got=float(r.min()))
    keep = _live_rows(H / r[:, None])
    if keep.all():                  # no copy of H (p x d) when every row can bind
        return H, s, y, r, keep
    return H[keep], s[keep], y, r[keep], keep


def _live_rows(A):
    """Mask (p,) of the rows of the slack-scaled {A x <= 1} that can bind: rows that are
    zero up to round-off (inequalities whose slack is constant on the hull: contacts
    that do not vary in S) never bind, and with them an iteration stalls (their
    residual never falls)."""
    nrm = np.linalg.norm(A, axis=1)
    return nrm > config.ROUNDING_ROW_TOL * nrm.max(initial=0.0)


def _spd_factor(M):
    """Cholesky factor of the SPD matrix M (LU fallback if round-off makes it indefinite)."""
    try:
        return ("chol", sla.cho_factor(M, lower=False, check_finite=False))
    except np.linalg.LinAlgError:
        return ("lu", sla.lu_factor(M, check_finite=False))


def _spd_solve(fac, b):
    kind, f = fac
    return sla.cho_solve(f, b, check_finite=False) if kind == "chol" else \
        sla.lu_solve(f, b, check_finite=False)


MVE_STALL = 5   # [iterations] without a 1e-6 relative fall of the KKT residual: stop


def mve(H, s, y0, maxiter: int = 120, tol: float = 1e-7, minmu: float = 1e-8,
        callback=None):
    """Maximum-volume ellipsoid inscribed in {H y <= s}.

    H (p, d), s (p,), y0 (d,) a strictly interior point. Returns
    (c (d,) centre, E2 (d, d) SPD with the ellipsoid {c + E2^{1/2} u: |u| <= 1},
    converged: bool, iterations). The iterate is feasible throughout, so an
    unconverged result is still an inscribed ellipsoid (merely not the largest).
    Stops when the KKT residual is below ``tol`` (1 + sqrt(p)) and the
    centring parameter has reached ``minmu``, or unconverged when the residual has not
    fallen for MVE_STALL iterations. ``callback(it, res, gap)`` is
    called once per interior-point iteration (progress display).

    Cost per iteration: one Cholesky factorisation of the p x p matrix Gm
    (symmetric positive definite), reused for both of its solves.
    """
    A = np.asarray(H, float)
    s = np.asarray(s, float)
    p, d = A.shape
    slack0 = s - A @ y0
    if not np.all(slack0 > 0):
        raise InputError("mve", "y0", "must be strictly inside the polytope",
                         got=float(slack0.min()))
    A = A / slack0[:, None]          # now {A x <= 1}, x = y - y0
    A = A[_live_rows(A)]
    p = A.shape[0]
    tau0, bnrm = 0.75, np.sqrt(p)
    x, y, bmAx, z = np.zeros(d), np.ones(p), np.ones(p), np.ones(p)
    astep, Adx = 0.0, np.zeros(p)
    ok, it, stalled, last_res = False, 0, 0, np.inf
    for it in range(maxiter):
        if it > 0:
            bmAx = bmAx - astep * Adx
        try:
            E2 = np.linalg.inv(A.T @ (y[:, None] * A))
        except np.linalg.LinAlgError as exc:
            raise NumericalError(f"MVE rounding: singular system ({exc}); S is flat "
                                 "in a direction the analysis kept") from exc
        Q = A @ E2 @ A.T
        h = np.sqrt(np.maximum(np.diag(Q), 0.0))
        if it == 0:
            t = np.min(bmAx / h)
            y = y / t ** 2
            h = t * h
            z = np.maximum(0.1, bmAx - h)
            Q = t ** 2 * Q
        yz = y * z
        yh = y * h
        gap = yz.sum() / p
        rmu = max(min(0.5, gap) * gap, minmu)
        R1 = -A.T @ yh
        R2 = bmAx - h - z
        R3 = rmu - yz
        res = max(np.abs(R1).max(), np.abs(R2).max(), np.abs(R3).max())
        if callback is not None:
            callback(it, res, gap)
        if res < tol * (1 + bnrm) and rmu <= minmu:
            ok = True
            break
        stalled = stalled + 1 if res >= (1 - 1e-6) * last_res else 0
        if stalled >= MVE_STALL:
            break      # the iterate no longer moves (its centre on a facet: the n = 400
                       # slice's residual stayed at 311 from iteration 15 to 119)
        last_res = res
        dx, Adx, dy, dyDy, dz = _mve_direction(A, Q, y, z, h, yh, R1, R2, R3)
        ax = -1.0 / min(np.min(-Adx / bmAx), -0.5)
        ay = -1.0 / min(np.min(dyDy), -0.5)
        az = -1.0 / min(np.min(dz / z), -0.5)
        tau = max(tau0, 1 - res)
        astep = tau * min(1.0, ax, ay, az)
        x = x + astep * dx
        y = y + astep * dy
        z = z + astep * dz
    E2 = np.linalg.inv(A.T @ (y[:, None] * A))
    E2 = 0.5 * (E2 + E2.T)
    return x + y0, E2, ok, it


def _mve_direction(A, Q, y, z, h, yh, R1, R2, R3):
    """The primal-dual Newton direction (dx, A dx, dy, dy / y, dz) of Zhang & Gao's MVE
    iteration: one Cholesky factorisation of the p x p matrix Gm, used for both solves."""
    p = A.shape[0]
    YQ = y[:, None] * Q
    Gm = YQ * YQ.T
    y2h = 2 * yh
    Gm[np.diag_indices(p)] += np.maximum(1e-12, y2h * z)
    YA = y[:, None] * A
    fac = _spd_factor(Gm)
    T = _spd_solve(fac, (h + z)[:, None] * YA)
    ATP = (y2h[:, None] * T - YA).T
    R3Dy = R3 / y
    R23 = R2 - R3Dy
    dx = np.linalg.solve(ATP @ A, R1 + ATP @ R23)
    Adx = A @ dx
    dyDy = _spd_solve(fac, y2h * (Adx - R23))
    return dx, Adx, y * dyDy, dyDy, R3Dy - z * dyDy


def john_ellipsoid(H, s, y0, maxiter: int = 300, tol: float = 0.05, callback=None,
                   warm: dict | None = None):
    """Approximate John (max-volume inscribed) ellipsoid of {H y <= s}, O(p d^2) per iteration.

    H (p, d), s (p,), y0 (d,) strictly interior. Returns (c (d,), E2 (d, d) SPD,
    converged, iterations) like :func:`mve`; the ellipsoid {c + E2^{1/2} u : |u| <= 1}
    is inside the polytope (exactly: E2 is scaled by 1 / max_i a_i^T E2 a_i in the
    slack-scaled rows a_i = H_i / (s_i - H_i c)).

    Alternates Newton steps to the w-weighted analytic centre (until the Newton
    decrement is below ``config.ROUNDING_CENTRED``) with one Lewis-weight update w_i <- w_i
    a_i^T M^{-1} a_i, M = sum w_i a_i a_i^T (weights renormalised to sum d and
    floored at 1e-6 d/p: weights left to vanish let the centre drift onto their
    rows and the iteration oscillates). Converged: John's condition
    max_i a_i^T M^{-1} a_i <= 1 + ``tol`` at a centred point, i.e. the axes are within
    a factor (1 + tol)^{1/2} of the fixed point's, which is the MVE. Each
    iteration (Newton step or weight update) costs one d x d Cholesky factorisation
    of M. ``callback(it, john_excess, newton_decrement)`` once per iteration.
    ``warm``: a dict carrying the weights (p,) from one call to the next; weights
    and centre are affine invariant, so a second call on the polytope mapped by the
    first one's ellipsoid starts at its fixed point (the check round of
    :func:`mve_rounding` then costs a few iterations, not a second solve).
    """
    H, s, y, r, keep = _live_start(H, s, y0, "john_ellipsoid")
    p, d = H.shape
    w = np.full(p, d / p)
    if warm is not None and np.shape(warm.get("w")) == keep.shape:
        w = np.maximum(warm["w"][keep], 1e-6 * d / p)
    ok = False
    excess = np.inf
    it = 0
    for it in range(maxiter):
        At = H / r[:, None]
        M = At.T @ (w[:, None] * At)
        try:
            cf = sla.cho_factor(M, lower=True, check_finite=False)
        except np.linalg.LinAlgError as exc:
            raise NumericalError(f"John rounding: singular system ({exc}); S is flat in a "
                                 "direction the analysis kept") from exc
        g = At.T @ w                                  # gradient of -sum w log r
        dy = -sla.cho_solve(cf, g, check_finite=False)
        dec = float(np.sqrt(max(-g @ dy, 0.0)))
        if callback is not None:
            callback(it, excess, dec)
        if dec > config.ROUNDING_CENTRED:             # centre first: a Newton step
            y = _damped_step(H, r, y, w, g, dy, dec)
            r = s - H @ y
            continue
        X = sla.solve_triangular(cf[0], At.T, lower=True, check_finite=False)
        lev = np.einsum("ij,ij->j", X, X)            # a_i^T M^-1 a_i, (p,)
        excess = float(lev.max() - 1.0)
        if excess <= tol:
            ok = True
            break
        w = w * lev                                   # Lewis-weight fixed point
        w = np.maximum(w * (d / w.sum()), 1e-6 * d / p)
    if warm is not None:
        warm["w"] = np.zeros(keep.shape)
        warm["w"][keep] = w
    At = H / r[:, None]
    E2 = np.linalg.inv(At.T @ (w[:, None] * At))
    E2 = 0.5 * (E2 + E2.T)
    E2 /= max(float(((At @ E2) * At).sum(1).max()), 1e-300)
    return y, E2, ok, it


def _damped_step(H, r, y, w, g, dy, dec):
    """y + a dy: a Newton step towards the w-weighted analytic centre of {H y <= s}
    (slacks r), damped outside the quadratic region (a = 1 / (1 + dec) for a Newton
    decrement dec > 1/4), kept strictly inside, backtracked on sum w log r."""
    Hdy = H @ dy
    pos = Hdy > 0
    amax = float(np.min(r[pos] / Hdy[pos])) if pos.any() else np.inf
    a = min(1.0 / (1.0 + dec) if dec > 0.25 else 1.0, 0.9 * amax)
    phi0 = -w @ np.log(r)
    while a > 1e-12:
        rt = r - a * Hdy
        if np.all(rt > 0) and -w @ np.log(rt) <= phi0 + 1e-4 * a * (g @ dy):
            break
        a *= 0.5
    return y + a * dy


ROUNDING_METHODS = ("mve", "john")


def mve_rounding(H, s, y0, max_rounds: int = 4, ratio: float = 6.0, progress: bool = False,
                 method: str = "mve"):
    """Iterated MVE rounding: (shift (d,), L (d, d), info dict).

    y = shift + L w maps {H y <= s} to {(H L) w <= s - H shift} whose MVE is
    (close to) the unit ball centred at w = 0. Repeats in the new frame until
    the MVE's axis ratio is below ``ratio`` (round-off in very thin polytopes
    needs a second pass). info: rounds, last axis ratio, converged flags,
    interior-point iterations per round. ``progress``: a bar on stderr counting
    interior-point iterations, with the round, KKT residual and duality gap.
    ``method``: "mve" (exact, :func:`mve`) or "john" (:func:`john_ellipsoid`). A round
    whose centre is not strictly inside is rejected (``info["rejected_round"]``); when it
    is the first MVE round, the rounding is John's (``info["fallback_from"]``: the MVE's).
    """
    from ..progress import progress as progress_bar

    H = np.asarray(H, float)
    d = H.shape[1]
    shift = np.asarray(y0, float).copy()
    L = np.eye(d)
    if method not in ROUNDING_METHODS:
        raise InputError("rounding", "method", f"must be one of {ROUNDING_METHODS}", got=method)
    warm: dict = {}
    solve, labels = (mve, ("residual", "gap")) if method == "mve" else \
        (partial(john_ellipsoid, warm=warm), ("John excess", "Newton decrement"))
    info = {"method": method, "rounds": 0, "axis_ratio": [], "converged": [],
            "iterations": []}
    bar = progress_bar(desc=f"{method.upper()} rounding (dim {d}, {H.shape[0]} rows)",
                       unit="it", disable=not progress)

    def show(it, a, b):
        bar.set_postfix_str(f"round {info['rounds'] + 1}, {labels[0]} {a:.1e}, "
                            f"{labels[1]} {b:.1e}", refresh=False)
        bar.update(1)

    with bar:
        for _ in range(max_rounds):
            Hl = H @ L
            sl = s - H @ shift
            c, E2, ok, its = _round(solve, Hl, sl, show)
            info["iterations"].append(int(its) + 1)
            ev, V = _eigen(E2)
            clear = clearance(Hl, sl, c, E2, ev)
            if not clear >= config.ROUNDING_MIN_CLEARANCE:
                # an unconverged interior point whose centre drifted onto a facet (size
                # study, n = 400, mu = 0.01, seed 3, dim 189: 119 iterations, slack -3e-19
                # or +3e-19 with the BLAS thread count; accepted at +3e-19, the next round
                # started on the facet and its ellipsoid was indefinite): keep the rounds
                # before it; a first round is redone by John's ellipsoid
                info["rejected_round"] = info["rounds"] + 1
                info["rejected_clearance"] = float(clear)
                if info["rounds"] == 0 and method == "mve":
                    bar.close()
                    shift, L, john = mve_rounding(H, s, y0, max_rounds, ratio, progress, "john")
                    return shift, L, {**john, "fallback_from": info}
                break
            r = float(np.sqrt(ev.max() / ev.min()))
            info["rounds"] += 1
            info["axis_ratio"].append(r)
            info["converged"].append(bool(ok))
            shift, L = shift + L @ c, L @ (V * np.sqrt(ev))
            if r < ratio or (method == "john" and not ok):
                break      # round; or John's iteration used its budget: another round
                           # would continue the same iteration (warm weights), not fix it
    return shift, L, info


def _round(solve, Hl, sl, show):
    """One round's ellipsoid (c, E2, converged, iterations); a round whose linear algebra
    broke down (a singular or non-finite system) comes back as E2 = NaN, i.e. rejected."""
    d = Hl.shape[1]
    try:
        c, E2, ok, its = solve(Hl, sl, np.zeros(d), callback=show)
    except (np.linalg.LinAlgError, NumericalError, FloatingPointError):
        return np.zeros(d), np.full((d, d), np.nan), False, 0
    return c, 0.5 * (E2 + E2.T), ok, its


def _eigen(E2):
    """Eigenvalues (ascending) and vectors of the symmetric E2; NaN values when E2 is not
    finite."""
    if not np.all(np.isfinite(E2)):
        return np.full(E2.shape[0], np.nan), np.eye(E2.shape[0])
    return np.linalg.eigh(E2)


def clearance(H, s, c, E2, ev=None) -> float:
    """The largest t with the ellipsoid {c + t E2^{1/2} u : |u| <= 1} inside {H y <= s}:
    min_i (s_i - H_i c) / |E2^{1/2} H_i|. 1 for an inscribed ellipsoid that touches a facet
    (the MVE at convergence), 0 when the centre is not strictly inside or E2 is not
    positive definite (``ev``: its eigenvalues, if known; relative floor d eps)."""
    ev = np.linalg.eigvalsh(E2) if ev is None else ev
    if not (np.all(np.isfinite(ev)) and np.all(np.isfinite(c))) or \
            ev.min() <= E2.shape[0] * np.finfo(float).eps * ev.max():
        return 0.0
    slack = s - H @ c
    h = np.sqrt(np.maximum(((H @ E2) * H).sum(1), 0.0))
    if not np.all(slack > 0):
        return 0.0
    return float(np.min(slack / np.maximum(h, np.finfo(float).tiny)))


# ----------------------------------------------------------------------------
# cheap Lewis-weight rounding (the billiard walk's)
# ----------------------------------------------------------------------------
def _weighted_gram(At, u):
    """M = At^T diag(u) At (d x d, SPD) by BLAS syrk (half the flops of a product)."""
    from scipy.linalg.blas import dsyrk

    B = np.sqrt(u)[:, None] * At
    M = dsyrk(1.0, B, trans=1, lower=1)      # B^T B, lower triangle
    return np.tril(M) + np.tril(M, -1).T


def _cholesky(M):
    try:
        return sla.cholesky(M, lower=True, check_finite=False)
    except np.linalg.LinAlgError as exc:
        raise NumericalError(f"rounding: singular system ({exc}); the polytope is flat in "
                             "a direction the analysis kept") from exc


def _line_search(r, Hdy, u, amax):
    """The step a in (0, amax) minimising phi(a) = -sum u_i log(r_i - a Hdy_i) (convex,
    infinite at amax; phi'(0) < 0): Newton in a, bisection when it leaves the bracket.
    O(p) per evaluation."""
    lo, hi = 0.0, amax
    a = min(1.0, 0.9 * amax)
    for _ in range(60):
        q = Hdy / (r - a * Hdy)
        g = float(u @ q)                       # phi'(a)
        h = float(u @ (q * q))                 # phi''(a) > 0
        if g < 0.0:
            lo = a
        else:
            hi = a
        if h <= 0.0 or g * g <= 1e-12 * h:
            break
        an = a - g / h
        if not lo < an < hi:
            an = 0.5 * (lo + hi)
        a = an
    return a


def _centre(H, s, y, u, st, max_newton, callback, centred):
    """Newton with exact line search to the u-weighted analytic centre of {H y <= s}
    (minimiser of -sum u log(s - H y)), from y strictly inside, until half the squared
    Newton decrement is below ``centred``; st counts "newton" steps (shared with the
    caller's budget). Returns (y, slacks, (At, Lm)): the slack-scaled rows and the Cholesky
    factor of M at y when the last step found the centre (the caller's M, one p x d^2 syrk
    saved), else None; st["dec2"]: the squared Newton decrement at that centre. A
    direction that meets no facet (the polytope is unbounded) is a NumericalError."""
    r = s - H @ y
    while st["newton"] < max_newton:
        At = H / r[:, None]
        Lm = _cholesky(_weighted_gram(At, u))
        g = At.T @ u
        dy = -sla.cho_solve((Lm, True), g, check_finite=False)
        dec2 = float(-g @ dy)
        st["newton"] += 1
        if callback is not None:
            callback("centre", st["newton"], st["updates"], st["excess"])
        if dec2 / 2 < centred:
            st["dec2"] = dec2
            return y, r, (At, Lm)
        Hdy = H @ dy
        pos = Hdy > 0
        if not pos.any():                      # H dy <= 0: dy is a recession direction
            raise NumericalError("rounding: the polytope is unbounded (a Newton direction "
                                 "meets no facet)")
        amax = float(np.min(r[pos] / Hdy[pos]))
        y = y + _line_search(r, Hdy, u, amax) * dy
        r = s - H @ y
        if not np.all(r > 0):
            raise NumericalError("rounding: the centring left the polytope")
    return y, r, None


def lewis_rounding(H, s, y0, max_updates: int = 5, tol: float = 0.05, max_newton: int = 200,
                   callback=None, centred: float | None = None, mapped: bool = False):
    """Cheap rounding ellipsoid of {H y <= s}: (c (d,), Lc (d, d) upper triangular, info),
    with ``mapped`` also H Lc (p, d), the rows of the rounded polytope (from the leverage
    pass's triangular solve, not a second p x d^2 product: equal to round-off).

    The ellipsoid {c + Lc z : |z| <= 1} is inscribed in the polytope and touches it, so
    w -> y = c + Lc w maps the polytope to {(H Lc) w <= s - H c} with the unit ball
    inside. H (p, d), s (p,), y0 (d,) strictly interior. For weights u (p,) summing to d
    and slack-scaled rows a_i = H_i / (s_i - H_i y): M = sum u_i a_i a_i^T at the
    u-weighted analytic centre; u = d/p first (the Dikin ellipsoid at the analytic
    centre), then at most ``max_updates`` Lewis-weight updates u_i <- u_i a_i^T M^-1 a_i
    (Cohen, Cousins, Lee & Yang 2019), each followed by re-centring; stops earlier when
    John's condition max_i a_i^T M^-1 a_i <= 1 + ``tol`` holds. Whatever the iteration
    count the ellipsoid is scaled to be inscribed: the rounding is never wrong, only
    more or less round. ``centred``: half the squared Newton decrement at which a centre
    counts as found (default config.LEWIS_CENTRED). ``callback(stage, newton_steps,
    updates, excess)`` after every Newton step and weight update. info: method,
    newton_steps, weight_updates, john_excess, converged, cpu_s, bounded.

    info["bounded"] is True when the last centring proves the polytope bounded, else None
    (not decided). F = -sum (u_i / u_min) log r_i is a standard self-concordant barrier
    (a sum of -log r_i with coefficients >= 1), non-degenerate (M has a Cholesky factor);
    its Newton decrement squared is dec^2 / u_min, dec^2 = g^T M^-1 g that of -sum u_i log
    r_i. Where it is < 1, F has a minimiser (Nesterov, Introductory Lectures on Convex
    Optimization, 2004, Thm 4.1.11), which no unbounded polytope has (F falls without
    bound along a recession direction). The test asks dec^2 < u_min / 2 (a factor 2 for
    round-off); at the large path's centring (dec^2 / 2 < 1e-2, u = d / p ~ 1/6) it
    holds with a margin of ~4. A Newton direction that meets no facet proves the
    polytope unbounded: NumericalError.
    """
    t0 = time.process_time()
    H_all = H
    H, s, y, _, keep = _live_start(H, s, y0, "lewis_rounding")
    p, d = H.shape
    u = np.full(p, d / p)
    st = {"newton": 0, "updates": 0, "excess": np.inf, "dec2": np.inf, "certified": False}
    ok = False
    while True:
        y, r, found = _centre(H, s, y, u, st, max_newton, callback,
                              config.LEWIS_CENTRED if centred is None else centred)
        st["certified"] = found is not None and st["dec2"] < 0.5 * float(u.min())
        if found is None:                     # the Newton budget ran out before the centre
            At = H / r[:, None]
            found = At, _cholesky(_weighted_gram(At, u))
        At, Lm = found
        # X = Lm^-1 At^T (d, p) in At's own memory (At.T is Fortran-ordered; At is not
        # used again): one p x d array less at the rounding's peak, the same numbers
        X = sla.solve_triangular(Lm, At.T, lower=True, check_finite=False, overwrite_b=True)
        At = found = None
        lev = np.einsum("ij,ij->j", X, X)      # a_i^T M^-1 a_i
        st["excess"] = float(lev.max() - 1.0)
        if st["excess"] <= tol:
            ok = True
            break
        if st["updates"] >= max_updates or st["newton"] >= max_newton:
            break
        u = u * lev
        u = np.maximum(u * (d / u.sum()), 1e-6 * d / p)
        st["updates"] += 1
        if callback is not None:
            callback("weights", st["newton"], st["updates"], st["excess"])
    # E = M^-1 / max lev (a_i^T E a_i <= 1 for all i): Lc = Lm^-T / sqrt(max lev)
    scale = 1.0 / np.sqrt(max(float(lev.max()), 1e-300))
    Lc = sla.solve_triangular(Lm.T, np.eye(d), lower=False, check_finite=False) * scale
    info = {"method": "lewis", "newton_steps": st["newton"], "weight_updates": st["updates"],
            "john_excess": st["excess"], "converged": ok, "cpu_s": time.process_time() - t0,
            "bounded": True if st["certified"] else None}
    if not mapped:
        return y, Lc, info
    return y, Lc, info, _mapped_rows(H_all, keep, X, r * scale, Lc)


def _mapped_rows(H_all, keep, X, rs, Lc):
    """H_all Lc (p, d), C-ordered: the kept rows from X = Lm^-1 (H / r)^T (d, p_keep) as
    rs X^T (rs = r / sqrt(max lev): Lc = Lm^-T / sqrt(max lev)), the others (rows zero to
    round-off) by a product."""
    HL = np.empty((keep.size, X.shape[0]))
    if keep.all():                  # in place: no p x d temporary
        return np.multiply(X.T, rs[:, None], out=HL)
    HL[keep] = X.T * rs[:, None]
    HL[~keep] = np.asarray(H_all, float)[~keep] @ Lc
    return HL


def lewis_rounding_with_progress(H, s, y0, max_updates: int = 5, progress: bool = False,
                                 centred: float | None = None, mapped: bool = False):
    """:func:`lewis_rounding` with a bar on stderr: one step per Newton step or weight
    update. Its total is unknown until the first centring is done; then it is estimated
    from the Newton steps the re-centrings have taken so far (5 per update until one is
    measured), so the bar's ETA is honest after the first update. ``centred``, ``mapped``:
    as for :func:`lewis_rounding`."""
    from ..progress import progress as progress_bar

    first = {}
    bar = progress_bar(total=None, desc=f"Lewis rounding (dim {H.shape[1]}, {H.shape[0]} "
                       "rows)", unit="it", disable=not progress)

    def show(stage, newton, updates, excess):
        bar.update(1)
        if stage == "weights":
            first.setdefault("newton", newton)
            per = (newton - first["newton"]) / (updates - 1) if updates > 1 else 5.0
            bar.total = bar.n + int(round((max_updates - updates) * (per + 1) + per))
        bar.set_postfix_str(f"{stage}: {newton} Newton steps, {updates} weight updates, "
                            f"John excess {excess:.2g}", refresh=False)

    with bar:
        return lewis_rounding(H, s, y0, max_updates=max_updates, callback=show,
                              centred=centred, mapped=mapped)
