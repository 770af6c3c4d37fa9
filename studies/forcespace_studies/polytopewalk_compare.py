"""polytopewalk's sparse walks on S in standard form, beside the billiard walk (issue 46).

polytopewalk (PyPI) samples {z : A z = b, the last k entries of z >= 0}. S of a slice is
brought to that form with one slack per cone row and the equilibrium equalities as they
are: z = [x (2m forces [<Fn>], free), t (p slacks, >= 0)],

    [A 0] z = b (equilibrium),   [G I] z = 0 (G x + t = 0: the cone rows G x <= 0),

plus x_j = 0 for the fixed columns (ft of frictionless contacts); with ``--reduce`` this
package's analysis does the facial reduction (:func:`reduced_form`) and polytopewalk's is
skipped. The walks run in
polytopewalk's own virtual environment (``studies/polytopewalk_compare/pw_run.py``; not a
forcespace dependency); this module writes the form and judges the samples with this
package's estimators (bulk/tail ESS and rank-normalised split R-hat of |x - mean|^2 and 4
random projections, seed 1: the same as for the billiard walk and hopsy), the first fifth
of each chain dropped as burn-in.

    python -m forcespace_studies.polytopewalk_compare export PACKING HEIGHT FORM.npz [--reduce]
    <pw venv>/bin/python studies/polytopewalk_compare/pw_run.py FORM.npz WALK OUT.npz
    python -m forcespace_studies.polytopewalk_compare judge PACKING HEIGHT OUT.npz [...]
"""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np
import scipy.sparse as sp

import forcespace as fs
from forcespace.extend import summarize, tracked_statistics


def standard_form(problem):
    """(A_std (q, 2m + p) CSC, b_std (q,), k = p, n_forces = 2m) of S at <Fn> = 1."""
    P = problem.scaled(1.0 / problem.force_scale)
    G, _, _ = P.inequalities()
    p, m2 = G.shape
    fixed = P.fixed_columns()
    blocks = [[sp.csr_matrix(P.A), sp.csr_matrix((P.A.shape[0], p))],
              [G, sp.identity(p, format="csr")]]
    rhs = [np.asarray(P.b, float), np.zeros(p)]
    if fixed.size:
        blocks.append([sp.csr_matrix((np.ones(fixed.size), (np.arange(fixed.size), fixed)),
                                     shape=(fixed.size, m2)), sp.csr_matrix((fixed.size, p))])
        rhs.append(np.zeros(fixed.size))
    return sp.bmat(blocks, format="csc"), np.concatenate(rhs), p, m2


def reduced_form(problem):
    """The standard form with this package's facial reduction instead of polytopewalk's:
    the implicit rows' slacks dropped (their rows G_i x = 0 kept as equalities) and the
    equalities of x cut to independent rows (Householder QR of their transpose),
    so that every slack left is positive somewhere in S and the matrix has full row rank.
    (A_std, b_std, k, n_forces, CPU s of the analysis and the reduction)."""
    import time
    import scipy.linalg as sla
    c0 = time.process_time()
    P = problem.scaled(1.0 / problem.force_scale)
    an = fs.ForceSpace(ranges=False, centre=False, varying=False).compute(P)
    G, _, _ = P.inequalities()
    imp = np.asarray(an.implicit_rows, int)
    free = np.setdiff1d(np.arange(G.shape[0]), imp)
    fixed = P.fixed_columns()
    Eq = sp.vstack([sp.csr_matrix(P.A), G[imp], sp.csr_matrix(
        (np.ones(fixed.size), (np.arange(fixed.size), fixed)), shape=(fixed.size, G.shape[1]))])
    rhs = np.concatenate([P.b, np.zeros(imp.size + fixed.size)])
    R = sla.qr(Eq.toarray().T, mode="r", overwrite_a=True, check_finite=False)[0]
    diag = np.abs(np.diag(R))                     # Householder QR, BLAS 3 (pivoted: >160 s
    keep = np.flatnonzero(diag > 1e-10 * diag.max())  # at dim 1714): a row in the span of
                                                      # the rows before it has R_jj ~ 0
    m2, pf = G.shape[1], free.size
    A = sp.bmat([[Eq.tocsr()[keep], sp.csr_matrix((keep.size, pf))],
                 [G[free], sp.identity(pf, format="csr")]], format="csc")
    return A, np.concatenate([rhs[keep], np.zeros(pf)]), pf, m2, time.process_time() - c0


def export(packing: str, height: float, out: str, reduce: bool = False) -> dict:
    """Write the standard form (``reduce``: :func:`reduced_form`) for pw_run.py."""
    problem = fs.slice_problem(fs.read_packing(packing), height)
    A, b, k, m2, cpu = reduced_form(problem) if reduce else (*standard_form(problem), 0.0)
    np.savez(out, data=A.data, indices=A.indices, indptr=A.indptr, shape=np.array(A.shape),
             b=b, k=k, n_forces=m2, force_scale=problem.force_scale, reduced=reduce,
             reduce_cpu_s=cpu)
    return {"shape": list(A.shape), "k": k, "n_forces": m2, "reduced": reduce,
            "reduce_cpu_s": cpu}


def judge(packing: str, height: float, runs: list[str]) -> list[dict]:
    """Per run: min ESS, max R-hat, eta, CPU s, ESS per CPU s, peak RSS, max violation."""
    problem = fs.slice_problem(fs.read_packing(packing), height)
    rows = []
    for path in runs:
        r = np.load(path)
        X = r["X"] * problem.force_scale                  # (chains, draws, 2m) [F0]
        X = X[:, X.shape[1] // 5:]
        s = summarize(tracked_statistics(X, seed=1))
        flat = X.reshape(-1, X.shape[2])
        cpu = float(r["setup_cpu_s"] + r["walk_cpu_s"])
        rows.append({"walk": str(r["walk"]), "chains": X.shape[0], "draws_kept": X.shape[1],
                     "min_ess": s["min_ess"], "max_rhat": s["max_rhat"],
                     "eta": float(fs.eta(flat)), "setup_cpu_s": float(r["setup_cpu_s"]),
                     "walk_cpu_s": float(r["walk_cpu_s"]), "ess_per_cpu_s": s["min_ess"] / cpu,
                     "peak_rss_mb": float(r["peak_rss_mb"]),
                     "max_violation": max(problem.violation(x) for x in flat)})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    e = sub.add_parser("export")
    e.add_argument("packing")
    e.add_argument("height", type=float)
    e.add_argument("out")
    e.add_argument("--reduce", action="store_true",
                   help="this package's facial reduction instead of polytopewalk's")
    j = sub.add_parser("judge")
    j.add_argument("packing")
    j.add_argument("height", type=float)
    j.add_argument("runs", nargs="+")
    a = ap.parse_args(argv)
    res = export(a.packing, a.height, a.out, a.reduce) if a.cmd == "export" else \
        judge(a.packing, a.height, a.runs)
    print(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
