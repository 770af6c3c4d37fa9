"""Rank, null space and minimum-norm solutions of the (sparse) equality systems of S.

Small systems (fewer than ``config.SWEEP_MIN_COLUMNS`` columns) use one dense SVD;
large sparse ones a frontier sweep (below), falling back to the dense SVD when a
rank decision came close (``config.SWEEP_MARGIN``). Pure functions of their arguments.

The frontier sweep.

The equality systems of S (equilibrium rows of the disks, fixed columns,
implicit Coulomb rows) are sparse and, after a bandwidth-reducing ordering of
the rows (reverse Cuthill-McKee), narrow: a row couples only the contacts of
one disk, and a packing is a quasi one-dimensional strip (or a small
square). The sweep below takes the rows in that order, a few at a time, and
keeps an orthonormal basis of the null space of the rows seen so far over the
columns seen so far. Only the *live* part of that basis (the vectors that
still touch a column of a row to come, the frontier) is transformed by later
rows; a vector with no weight on the frontier is final: every later row
annihilates it. Each step is one small dense SVD of (rows of the chunk) x
(live vectors + new columns), so the cost is O(n f^2) for the rank and
O(n d f) for the basis (n columns, f the frontier, d the nullity) instead of
the O(n^3) of a dense SVD of the whole matrix.

Rank decisions use the dense path's rule, singular value > tol_rel *
s_max(M) * max(M.shape), applied to the singular values of each step's small
matrix; the smallest kept and the largest dropped value (relative to that
threshold) are reported so a caller can fall back to the dense SVD when a
decision was close. Pure functions of their arguments.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee

from . import config


@dataclass
class SweepResult:
    """Null space of M (r, n) from :func:`sweep_null_space`.

    rank: rank of M; basis: (n, n - rank) orthonormal null basis (None if not
    asked for); step: (n,) minimum-norm truncated least-squares solution of
    M s = rhs (None without rhs); kept_margin: smallest kept singular value
    over the rank threshold (inf if none); dropped_margin: largest dropped
    singular value over the threshold (0 if none); threshold: the absolute
    threshold used.
    """

    rank: int
    basis: np.ndarray | None
    step: np.ndarray | None
    kept_margin: float
    dropped_margin: float
    threshold: float
    max_live: int = 0


def spectral_norm(M, iters: int = 60, rtol: float = 1e-6) -> float:
    """Largest singular value of a sparse or dense matrix M (r, n), by power
    iteration on M^T M from a fixed start (deterministic; a few percent is
    all the rank threshold needs)."""
    if M.shape[0] == 0 or M.shape[1] == 0:
        return 0.0
    v = np.ones(M.shape[1]) + np.linspace(0.0, 1.0, M.shape[1])
    v /= np.linalg.norm(v)
    s = 0.0
    for _ in range(iters):
        w = M.T @ (M @ v)
        nw = float(np.linalg.norm(w))
        if nw == 0.0:
            return 0.0
        s_new = np.sqrt(nw)
        v = w / nw
        if abs(s_new - s) <= rtol * s_new:
            s = s_new
            break
        s = s_new
    return float(s)


def row_order(M) -> np.ndarray:
    """Permutation (r,) of the rows of sparse M (r, n) that keeps the sweep's
    frontier small: reverse Cuthill-McKee on the row graph (two rows adjacent
    when they share a column)."""
    P = sp.csr_matrix(M, copy=True)
    P.data = np.ones_like(P.data)
    R = (P @ P.T).tocsr()
    return np.asarray(reverse_cuthill_mckee(R, symmetric_mode=True), dtype=np.int64)


def sweep_null_space(M, rhs=None, tol_rel: float = 1e-10, basis: bool = True,
                     chunk: int | None = None, s_max: float | None = None) -> SweepResult:
    """Rank, orthonormal null basis and minimum-norm solution of sparse M (r, n).

    rhs (r,) optional: also the step s (n,) of minimum norm minimising
    ||M s - rhs|| over the singular directions kept by the rank rule (the
    truncated pseudo-inverse, as the dense path's SVD step). basis=False
    skips the (n, d) basis: the rank then costs O(r f^3) only.
    """
    M = sp.csr_matrix(M, dtype=float)
    r, n = M.shape
    chunk = config.SWEEP_CHUNK_ROWS if chunk is None else chunk
    if s_max is None:
        s_max = spectral_norm(M)
    thr = tol_rel * max(s_max, 1e-300) * max(r, n, 1)
    if r == 0:
        N = np.eye(n) if basis else None
        return SweepResult(0, N, None if rhs is None else np.zeros(n), np.inf, 0.0, thr)
    perm = row_order(M)
    M = M[perm]
    b = None if rhs is None else np.asarray(rhs, float)[perm]
    coo = M.tocoo()
    first = np.full(n, r, dtype=np.int64)
    last = np.full(n, -1, dtype=np.int64)
    np.minimum.at(first, coo.col, coo.row)
    np.maximum.at(last, coo.col, coo.row)
    # columns get a slot (row of the stored basis) in the order they are first touched
    touched = np.flatnonzero(last >= 0)
    order = touched[np.argsort(first[touched], kind="stable")]
    slot = np.full(n, -1, dtype=np.int64)
    slot[order] = np.arange(order.size)
    fw = _forward_pass(M, b, first, last, order, slot, thr, chunk, basis or b is not None)
    rank = fw["rank"]
    N, step = None, None
    if fw["steps"] is not None:
        N, step = _backward_pass(fw, n, n - rank, order, last, basis, b is not None)
    return SweepResult(rank, N, step, fw["kept_margin"], fw["dropped_margin"], thr,
                       fw["max_live"])


def _forward_pass(M, b, first, last, order, slot, thr, chunk, record) -> dict:
    """The rows in chunks: the rank, the rank decisions' margins, and (``record``) each
    step's transform. Z (|stored|, k): the live null vectors on the frontier slots only
    (``stored``); pf: the affine step on those slots (for the residual of the rows to
    come). With X = [Z 0; 0 I_new] a step's live vectors become X T and the vectors it
    finalises X F; y is the step's part of the affine step (X y)."""
    r = M.shape[0]
    nt = order.size
    stored = np.zeros(0, dtype=np.int64)
    Z = np.zeros((0, 0))
    where = np.full(nt, -1, dtype=np.int64)
    pf = np.zeros(nt) if b is not None else None
    steps = [] if record else None
    rank, max_live, kept_margin, dropped_margin = 0, 0, np.inf, 0.0
    indptr, indices = M.indptr, M.indices
    for s0 in range(0, r, chunk):
        s1 = min(r, s0 + chunk)
        cols = np.unique(indices[indptr[s0]:indptr[s1]])
        sl = slot[cols]
        new_slots = np.sort(sl[first[cols] >= s0])
        n_new = new_slots.size
        k = Z.shape[1]
        max_live = max(max_live, k + n_new)
        rows_x = np.concatenate([stored, new_slots])
        Zx = np.zeros((rows_x.size, k + n_new))             # X over rows_x
        Zx[:stored.size, :k] = Z
        Zx[stored.size + np.arange(n_new), k + np.arange(n_new)] = 1.0
        where[rows_x] = np.arange(rows_x.size)
        B = M[s0:s1][:, cols].toarray()                      # (rows, |cols|)
        W = B @ Zx[where[sl]]                                # (rows, k + n_new)
        U, sig, Vt = np.linalg.svd(W, full_matrices=True)
        rho = int((sig > thr).sum())
        if rho:
            kept_margin = min(kept_margin, float(sig[rho - 1] / thr))
        if rho < sig.size:
            dropped_margin = max(dropped_margin, float(sig[rho] / thr))
        rank += rho
        y = None
        if pf is not None:
            y = Vt[:rho].T @ ((U[:, :rho].T @ (b[s0:s1] - B @ pf[sl])) / sig[:rho])
            pf[rows_x] += Zx @ y
        front = last[order[rows_x]] >= s1                    # slots used by a later row
        T, F = _split_live(Zx[front], Vt[rho:].T)
        Z = Zx[front] @ T
        stored = rows_x[front]
        if record:
            steps.append((new_slots, k, T, F, y))
    return {"rank": rank, "kept_margin": kept_margin, "dropped_margin": dropped_margin,
            "max_live": max_live, "steps": steps, "Z": Z, "nt": nt}


def _split_live(Zfront, Vn):
    """(T, F): the null vectors Vn (k + n_new, k') of a step rotated so that the first
    ones still touch the frontier (live: X T) and the rest do not (final: X F)."""
    ZF = Zfront @ Vn
    if Vn.shape[1] and Zfront.shape[0]:
        _, sf, vft = np.linalg.svd(ZF, full_matrices=True)
        lv = int((sf > config.SWEEP_LIVE_TOL).sum())
        Mx = Vn @ vft.T
    else:
        lv, Mx = 0, Vn
    return Mx[:, :lv], Mx[:, lv:]


def _backward_pass(fw, n, d, order, last, basis, affine):
    """(N (n, d) or None, step (n,) or None) from the recorded steps: Q (k_s, D)
    expresses the vectors finalised after step s in the live vectors of step s; g
    (k_s,) the rest of the affine step likewise."""
    steps, nt = fw["steps"], fw["nt"]
    N = np.zeros((n, d)) if basis else None
    p = np.zeros(nt) if affine else None
    kS = fw["Z"].shape[1]
    n_final = sum(F.shape[1] for *_x, F, _y in steps) + kS
    col = n_final - kS                                   # the last live ones are final
    Q = np.eye(kS)
    g = np.zeros(kS)
    for new_slots, k, T, F, y in reversed(steps):
        col -= F.shape[1]
        top = np.hstack([F[:k], T[:k] @ Q])
        if basis and new_slots.size:
            N[order[new_slots], col:n_final] = np.hstack([F[k:], T[k:] @ Q])
        if p is not None:
            tg = T @ g
            p[new_slots] = y[k:] + tg[k:]
            g = y[:k] + tg[:k]
        Q = top
    assert col == 0 and Q.shape[0] == 0, (col, Q.shape)
    untouched = np.flatnonzero(last < 0)
    if basis:
        N[untouched, n_final + np.arange(untouched.size)] = 1.0
    assert n_final + untouched.size == d, (n_final, untouched.size, d)
    step = None
    if p is not None:
        step = np.zeros(n)
        step[order] = p
    return N, step


# ----------------------------------------------------------------------------
# dense SVD or frontier sweep, by size
# ----------------------------------------------------------------------------
def _use_sweep(M) -> bool:
    return sp.issparse(M) and M.shape[1] >= config.SWEEP_MIN_COLUMNS and M.shape[0] > 0


def decided_sweep(M, rhs=None, tol_rel=None, basis=True):
    """The frontier sweep of sparse M, or None when a rank decision came within
    ``config.SWEEP_MARGIN`` of its threshold (the caller then uses the dense SVD)."""
    tol_rel = config.RANK_TOL if tol_rel is None else tol_rel
    res = sweep_null_space(M, rhs, tol_rel=tol_rel, basis=basis)
    if res.kept_margin < config.SWEEP_MARGIN or res.dropped_margin > 1.0 / config.SWEEP_MARGIN:
        return None
    return res


def _dense_rank(s, shape, tol_rel) -> int:
    """Singular values above tol_rel * s_max * max(shape) (s sorted descending)."""
    return int((s > tol_rel * max(s[0], 1e-300) * max(shape)).sum()) if s.size else 0


def rank(M, tol_rel=None) -> int:
    """Numerical rank of M (dense or sparse): singular values above
    tol_rel * s_max * max(M.shape) (default ``config.RANK_TOL``)."""
    tol_rel = config.RANK_TOL if tol_rel is None else tol_rel
    if _use_sweep(M):
        res = decided_sweep(M, tol_rel=tol_rel, basis=False)
        if res is not None:
            return res.rank
    M = M.toarray() if sp.issparse(M) else np.asarray(M)
    if M.size == 0:
        return 0
    return _dense_rank(np.linalg.svd(M, compute_uv=False), M.shape, tol_rel)


def null_basis(M, tol_rel=None, return_noise: bool = False):
    """Orthonormal basis N (ncol, d) of the null space of M (dense SVD).

    With ``return_noise``: also the round-off level of N's entries, eps times
    the condition number of M on its row space (s_max / s_rank); entries of N
    below a few hundred times that are indistinguishable from zero.
    """
    tol_rel = config.RANK_TOL if tol_rel is None else tol_rel
    M = M.toarray() if sp.issparse(M) else np.asarray(M)
    eps = np.finfo(float).eps
    if M.shape[0] == 0:
        N, noise = np.eye(M.shape[1]), eps
    else:
        u, s, vt = np.linalg.svd(M, full_matrices=True)
        r = _dense_rank(s, M.shape, tol_rel)
        N = vt[r:].T.copy()
        noise = eps * s[0] / s[r - 1] if r else eps
    return (N, float(noise)) if return_noise else N


def affine_hull(M, rhs, x0, tol_rel=None):
    """(N, xa, rank): orthonormal null basis of M (as :func:`null_basis`), x0 moved
    onto {M x = rhs} by the minimum-norm step, and the rank of M, all from one dense
    SVD of M. The step uses only the singular values above the rank threshold: a
    least-squares solve that keeps the round-off ones (1e-16 s_max, dependent rows)
    moves x0 along null directions, i.e. out of S (seen: 2e-2 <Fn> on a slice).
    Large sparse M (>= SWEEP_MIN_COLUMNS columns): the same three from the
    frontier sweep, another orthonormal basis of the same null space."""
    tol_rel = config.RANK_TOL if tol_rel is None else tol_rel
    if _use_sweep(M):
        x0 = np.asarray(x0, float)
        res = decided_sweep(M, M @ x0 - rhs, tol_rel=tol_rel)
        if res is not None:
            return res.basis, x0 - res.step, res.rank
    M = M.toarray() if sp.issparse(M) else np.asarray(M)
    if M.shape[0] == 0:
        return np.eye(M.shape[1]), np.asarray(x0, float).copy(), 0
    u, s, vt = np.linalg.svd(M, full_matrices=True)
    r = _dense_rank(s, M.shape, tol_rel)
    res_vec = M @ x0 - rhs
    step = vt[:r].T @ ((u[:, :r].T @ res_vec) / s[:r])
    return vt[r:].T.copy(), x0 - step, r


def onto_affine_hull(x, xa, N):
    """x (k,) projected orthogonally onto the affine hull {xa + N y} (N (k, d)
    orthonormal): xa + N N^T (x - xa). Exact in equilibrium and the hull's equalities
    (to round-off); any inequality x satisfied may be violated by the move."""
    return xa + N @ (N.T @ (np.asarray(x, float) - xa))


def project_on_range(M, v):
    """Least-squares projection of v (r,) onto range(M), M (r, k) sparse.

    Dense least squares (numpy's lstsq, cut-off eps max(shape) s_max) below
    ``config.SWEEP_MIN_COLUMNS`` columns; above, the frontier sweep with the same
    cut-off, falling back to the dense solve when a rank decision was close.
    """
    if M.shape[1] >= config.SWEEP_MIN_COLUMNS:
        res = decided_sweep(M, v, tol_rel=np.finfo(float).eps, basis=False)
        if res is not None:
            return M @ res.step
    Md = M.toarray()
    return Md @ np.linalg.lstsq(Md, v, rcond=None)[0]


def range_basis(C, tol_rel=None):
    """Orthonormal basis (ncol, r) of the row space of dense C (SVD, rank-revealing;
    default cut-off ``config.RANGE_RANK_TOL``)."""
    tol_rel = config.RANGE_RANK_TOL if tol_rel is None else tol_rel
    if C.shape[0] == 0:
        return np.zeros((C.shape[1], 0))
    _, s, vt = np.linalg.svd(C, full_matrices=False)
    return vt[:_dense_rank(s, C.shape, tol_rel)].T
