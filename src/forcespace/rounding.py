"""Rounding of a polytope by its maximum-volume inscribed ellipsoid (MVE).

For P = {y : H y <= s} (H (p, d), s (p,), full-dimensional, bounded) the MVE
{c + E u : |u| <= 1} is found by the primal-dual interior-point method of
Zhang & Gao (2003, "An interior-point algorithm for the maximum-volume
ellipsoid problem"; the algorithm of Y. Zhang's ``mve_solver`` that COBRA and
PolyRound use). Mapping y = c + E^{1/2} w makes the MVE the unit ball, and by
John's theorem the rounded polytope then lies within the ball of radius d:
a rounded polytope in which hit-and-run mixes in O(d^2) coordinate steps.

Plain linear algebra; the only output is an optional progress bar (stderr). Units: whatever the caller uses for y and s
(hit_and_run passes y in units of <Fn>).
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from .errors import InputError, NumericalError

ROW_TOL = 1e-10   # rows of {A x <= 1} below this x the largest row norm are round-off


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


def mve(H, s, y0, maxiter: int = 120, tol: float = 1e-7, minmu: float = 1e-8,
        callback=None):
    """Maximum-volume ellipsoid inscribed in {H y <= s}.

    H (p, d), s (p,), y0 (d,) a strictly interior point. Returns
    (c (d,) centre, E2 (d, d) SPD with the ellipsoid {c + E2^{1/2} u: |u| <= 1},
    converged: bool, iterations). The iterate is feasible throughout, so an
    unconverged result is still an inscribed ellipsoid (merely not the largest).
    Stops when the KKT residual is below ``tol`` (1 + sqrt(p)) and the
    centring parameter has reached ``minmu``. ``callback(it, res, gap)`` is
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
    # rows that are zero up to round-off (inequalities whose slack is constant on
    # the hull: contacts that do not vary in S) cannot bind; with them the
    # interior point stalls (their residual 1 - z never falls)
    nrm = np.linalg.norm(A, axis=1)
    A = A[nrm > ROW_TOL * nrm.max(initial=0.0)]
    p = A.shape[0]
    tau0 = 0.75
    bnrm = np.sqrt(p)
    x = np.zeros(d)
    y = np.ones(p)
    bmAx = np.ones(p)
    z = np.ones(p)
    astep, Adx = 0.0, np.zeros(p)
    ok = False
    it = 0
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
        dy = y * dyDy
        dz = R3Dy - z * dyDy
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


def mve_rounding(H, s, y0, max_rounds: int = 4, ratio: float = 6.0, progress: bool = False):
    """Iterated MVE rounding: (shift (d,), L (d, d), info dict).

    y = shift + L w maps {H y <= s} to {(H L) w <= s - H shift} whose MVE is
    (close to) the unit ball centred at w = 0. Repeats in the new frame until
    the MVE's axis ratio is below ``ratio`` (round-off in very thin polytopes
    needs a second pass). info: rounds, last axis ratio, converged flags,
    interior-point iterations per round. ``progress``: a bar on stderr counting
    interior-point iterations, with the round, KKT residual and duality gap.
    """
    from .progress import progress as progress_bar

    H = np.asarray(H, float)
    d = H.shape[1]
    shift = np.asarray(y0, float).copy()
    L = np.eye(d)
    info = {"rounds": 0, "axis_ratio": [], "converged": [], "iterations": []}
    bar = progress_bar(desc=f"MVE rounding (dim {d}, {H.shape[0]} rows)", unit="it",
                       disable=not progress)

    def show(it, res, gap):
        bar.set_postfix_str(f"round {info['rounds'] + 1}, residual {res:.1e}, gap {gap:.1e}",
                            refresh=False)
        bar.update(1)

    with bar:
        for _ in range(max_rounds):
            Hl = H @ L
            sl = s - H @ shift
            c, E2, ok, its = mve(Hl, sl, np.zeros(d), callback=show)
            info["iterations"].append(int(its) + 1)
            info, shift, L, r = _next_round(info, shift, L, c, E2, ok)
            if r < ratio:
                break
    return shift, L, info


def _next_round(info, shift, L, c, E2, ok):
    """Record one round's ellipsoid and compose the map: (info, shift, L, axis ratio)."""
    ev, V = np.linalg.eigh(E2)
    if ev.min() <= 0:
        raise NumericalError("MVE rounding: ellipsoid not positive definite")
    r = float(np.sqrt(ev.max() / ev.min()))
    info["rounds"] += 1
    info["axis_ratio"].append(r)
    info["converged"].append(bool(ok))
    return info, shift + L @ c, L @ (V * np.sqrt(ev)), r
