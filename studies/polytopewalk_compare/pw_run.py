"""Run polytopewalk's sparse walks on S in standard form (issue 46). Runs in polytopewalk's
own virtual environment (not a forcespace dependency): reads the standard form written by
``python -m forcespace_studies.polytopewalk_compare export``, writes the samples of the
force columns per chain, CPU s (user + sys of this process: getrusage) and peak RSS.

    python pw_run.py FORM.npz WALK OUT.npz [--chains 4] [--seconds 150] [--thin 1]

The standard form: z = [x (2m forces, free), t (p slacks of the cone rows, >= 0)] with
A x = b (equilibrium) and G x + t = 0, i.e. A_std z = b_std, the last k = p entries >= 0
(polytopewalk's "x >=_k 0"). Each chain runs walk.generateCompleteWalk from the analytic
centre polytopewalk's SparseCenter finds, after its FacialReduction, in batches until the
CPU budget is spent; a batch's samples are kept, its last state starts the next batch.
"""
import argparse
import json
import resource
import sys
import time

import numpy as np
import polytopewalk as pw
import scipy.sparse as sp
from polytopewalk import sparse as pws

WALKS = {"dikin": lambda: pws.SparseDikinWalk(r=0.5), "vaidya": lambda: pws.SparseVaidyaWalk(r=0.5),
         "john": lambda: pws.SparseJohnWalk(r=0.5), "hit_and_run": lambda: pws.SparseHitAndRun(r=0.5),
         "ball": lambda: pws.SparseBallWalk(r=0.5)}


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("form")
    ap.add_argument("walk", choices=sorted(WALKS))
    ap.add_argument("out")
    ap.add_argument("--chains", type=int, default=4)
    ap.add_argument("--seconds", type=float, default=150.0, help="CPU budget of the walks")
    ap.add_argument("--batch", type=int, default=20, help="samples per batch")
    ap.add_argument("--thin", type=int, default=1)
    a = ap.parse_args()
    f = np.load(a.form)
    A = sp.csc_matrix((f["data"], f["indices"], f["indptr"]), shape=tuple(f["shape"]))
    b, k, m2 = f["b"], int(f["k"]), int(f["n_forces"])
    c0 = cpu()
    fr = pw.FacialReduction()
    red = fr.reduce(A, b, k, True)
    Ar, br = red.sparse_A, red.sparse_b
    kr = Ar.shape[0] - (A.shape[0] - k)        # as polytopewalk's sparseFullWalkRun does
    init = pws.SparseCenter().getInitialPoint(Ar, br, kr)
    c_setup = cpu() - c0
    print(json.dumps({"setup_cpu_s": c_setup, "reduced_shape": list(Ar.shape)}), flush=True)
    walk = WALKS[a.walk]()
    chains = [[] for _ in range(a.chains)]
    state = [np.asarray(init, float).ravel() for _ in range(a.chains)]
    c1 = cpu()
    budget = a.seconds / a.chains
    spent = [0.0] * a.chains
    while min(spent) < budget:
        for c in range(a.chains):
            if spent[c] >= budget:
                continue
            t0 = cpu()
            Z = walk.generateCompleteWalk(a.batch, state[c].reshape(-1, 1), Ar, br, kr,
                                          burnin=0, thin=a.thin, seed=1000 * c + len(chains[c]) + 1)
            Z = np.asarray(Z)
            Z = Z if Z.shape[0] == a.batch else Z.T
            state[c] = Z[-1].copy()
            chains[c].append(Z)
            spent[c] += cpu() - t0
        print(json.dumps({"samples_per_chain": sum(len(z) for z in chains[0]),
                          "cpu_s": cpu() - c1}), flush=True)
    walk_cpu = cpu() - c1
    Zs = [np.vstack(z) for z in chains]
    n = min(len(z) for z in Zs)
    # back to the original z through the facial reduction's map, then the forces x
    X = np.stack([(red.saved_V @ z[:n].T).T[:, :m2] for z in Zs])
    np.savez(a.out, X=X, setup_cpu_s=c_setup, walk_cpu_s=walk_cpu,
             peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
             walk=a.walk, reduced_shape=np.array(Ar.shape))
    return 0


if __name__ == "__main__":
    sys.exit(main())
