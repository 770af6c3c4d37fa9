"""Which QP method for ``forcespace select``: the built-in weighted projection vs Clarabel.

Usage::

    python studies/bench_select.py [PACK.h5 ...] [--slice 28] [--repeat 3]

For each packing (default: the three seed-1 paper packings) and kt/kn in {2/7, 1}:
the compatible network of the slice by (a) ``forcespace.Selection`` (null-space
least-distance programming + verified active-set polish, scipy only) and (b)
Clarabel 0.11 (interior point; ``pip install clarabel``, not a forcespace
dependency), both at <Fn> = 1. Reported: wall time (best of ``--repeat``),
violation of S (/ <Fn>), KKT stationarity residual of the weighted problem
(relative), energy, and the rms difference of the two networks (/ <Fn>).
Prints JSON.
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np
import scipy.sparse as sp


def clarabel_select(P, kn, kt):
    """min 1/2 x^T W x s.t. A x = b, fixed columns = 0, G x <= 0 (P at <Fn> = 1)."""
    import clarabel

    G, _, _ = P.inequalities()
    fixed = P.fixed_columns()
    m2 = P.n_columns
    E = sp.csr_matrix((np.ones(fixed.size), (np.arange(fixed.size), fixed)), shape=(fixed.size, m2))
    w = np.empty(m2)
    w[0::2] = 1.0 / kn
    w[1::2] = 1.0 / kt
    Aeq = sp.vstack([P.A, E]).tocsc()
    Acon = sp.vstack([Aeq, G]).tocsc()
    bcon = np.concatenate([P.b, np.zeros(fixed.size), np.zeros(G.shape[0])])
    cones = [clarabel.ZeroConeT(Aeq.shape[0]), clarabel.NonnegativeConeT(G.shape[0])]
    st = clarabel.DefaultSettings()
    st.verbose = False
    st.tol_gap_abs = st.tol_gap_rel = 1e-12
    st.tol_feas = 1e-12
    solver = clarabel.DefaultSolver(sp.diags(w).tocsc(), np.zeros(m2), Acon, bcon, cones, st)
    sol = solver.solve()
    return np.array(sol.x), str(sol.status)


def kkt_residual(P, x, kn, kt, tol=1e-9):
    """Relative stationarity residual of min 1/2 x^T W x over S at x (active rows at tol)."""
    G, _, _ = P.inequalities()
    fixed = P.fixed_columns()
    m2 = P.n_columns
    w = np.empty(m2)
    w[0::2] = x[0::2] / kn
    w[1::2] = x[1::2] / kt
    w[fixed] = 0
    act = np.flatnonzero(G @ x > -tol)
    E = sp.csr_matrix((np.ones(fixed.size), (np.arange(fixed.size), fixed)), shape=(fixed.size, m2))
    B = sp.vstack([P.A, -G[act], E]).T.toarray()
    from scipy.optimize import lsq_linear
    nA, na = P.A.shape[0], act.size
    lo = np.r_[np.full(nA, -np.inf), np.zeros(na), np.full(fixed.size, -np.inf)]
    res = lsq_linear(B, w, bounds=(lo, np.inf), tol=1e-14, lsmr_tol="auto")
    return float(np.abs(B @ res.x - w).max() / np.abs(w).max())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packings", nargs="*", default=[f"studies/packings/paper_mu{m}.h5"
                                                     for m in ("0", "0.1", "0.5")])
    ap.add_argument("--slice", type=float, default=28.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    from forcespace import Selection, read_packing, slice_problem
    from forcespace.extend import unit_problem

    rows = []
    for path in args.packings:
        prob = slice_problem(read_packing(path), args.slice)
        P, _ = unit_problem(prob)
        m = P.n_contacts
        for ratio in (2 / 7, 1.0):
            kn, kt = np.ones(m), np.full(m, ratio)
            t_a, t_b = [], []
            for _ in range(args.repeat):
                t = time.perf_counter()
                S = Selection(kt_ratio=ratio).compute(P)
                t_a.append(time.perf_counter() - t)
                t = time.perf_counter()
                xb, status = clarabel_select(P, kn, kt)
                t_b.append(time.perf_counter() - t)
            xa = S.x
            e = lambda x: 0.5 * float(np.sum(x[0::2] ** 2 / kn + x[1::2] ** 2 / kt))  # noqa: E731
            rows.append({
                "packing": path, "n_contacts": m, "kt_ratio": ratio,
                "select_seconds": min(t_a), "clarabel_seconds": min(t_b),
                "select_violation": P.violation(xa), "clarabel_violation": P.violation(xb),
                "select_kkt": kkt_residual(P, xa, kn, kt),
                "clarabel_kkt": kkt_residual(P, xb, kn, kt),
                "clarabel_kkt_at_1e-6": kkt_residual(P, xb, kn, kt, tol=1e-6),
                "select_energy": e(xa), "clarabel_energy": e(xb), "clarabel_status": status,
                "rms_difference": float(np.linalg.norm(xa - xb) / np.sqrt(m))})
            print(json.dumps(rows[-1]), file=sys.stderr)
    print(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
