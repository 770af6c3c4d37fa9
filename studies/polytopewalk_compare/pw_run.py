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
The set-up (facial reduction, centre) is kept in FORM.npz.reduced.npz and its CPU s counted
in every walk's run.
"""
import argparse
import json
import resource
import sys

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
    ap.add_argument("--batch", type=int, default=20, help="steps per batch")
    ap.add_argument("--thin", type=int, default=1)
    a = ap.parse_args()
    f = np.load(a.form)
    A = sp.csc_matrix((f["data"], f["indices"], f["indptr"]), shape=tuple(f["shape"]))
    b, k, m2 = f["b"], int(f["k"]), int(f["n_forces"])
    reduced = bool(f["reduced"]) if "reduced" in f else False
    Ar, br, kr, V, init, c_setup = set_up(A, b, k, a.form + ".reduced.npz", reduced)
    c_setup += float(f["reduce_cpu_s"]) if "reduce_cpu_s" in f else 0.0
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
            Z = Z if Z.shape[1] == Ar.shape[1] else Z.T     # (samples, columns)
            state[c] = Z[-1].copy()
            chains[c].append(Z)
            spent[c] += cpu() - t0
        print(json.dumps({"samples_per_chain": sum(len(z) for z in chains[0]), "thin": a.thin,
                          "cpu_s": cpu() - c1}), flush=True)
    walk_cpu = cpu() - c1
    Zs = [np.vstack(z) for z in chains]
    n = min(len(z) for z in Zs)
    # back to the original z through the facial reduction's map, then the forces x
    X = np.stack([(V @ z[:n].T).T[:, :m2] for z in Zs])
    np.savez(a.out, X=X, setup_cpu_s=c_setup, walk_cpu_s=walk_cpu,
             peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
             walk=a.walk, reduced_shape=np.array(Ar.shape))
    return 0


def set_up(A, b, k, cache, reduced=False):
    """polytopewalk's facial reduction and analytic centre (as its sparseFullWalkRun does
    them), computed once and kept in ``cache``: (A_red, b_red, k_red, V (the map back to
    z), start, CPU s of the set-up)."""
    try:
        c = np.load(cache)
        Ar = sp.csc_matrix((c["data"], c["indices"], c["indptr"]), shape=tuple(c["shape"]))
        V = sp.csc_matrix((c["vdata"], c["vindices"], c["vindptr"]), shape=tuple(c["vshape"]))
        return Ar, c["b"], int(c["k"]), V, c["init"], float(c["cpu"])
    except (OSError, KeyError):
        pass
    c0 = cpu()
    if reduced:          # reduced by forcespace (its CPU s in the form): no FR here
        kr = k
        init = np.asarray(pws.SparseCenter().getInitialPoint(A, b, k), float).ravel()
        V = sp.identity(A.shape[1], format="csc")
        c_setup = cpu() - c0
        np.savez(cache, data=A.data, indices=A.indices, indptr=A.indptr, shape=A.shape, b=b,
                 k=kr, vdata=V.data, vindices=V.indices, vindptr=V.indptr, vshape=V.shape,
                 init=init, cpu=c_setup)
        return A, b, kr, V, init, c_setup
    red = pw.FacialReduction().reduce(A, b, k, True)
    Ar, br = sp.csc_matrix(red.sparse_A), np.asarray(red.sparse_b, float).ravel()
    kr = Ar.shape[0] - (A.shape[0] - k)        # as polytopewalk's sparseFullWalkRun does
    init = np.asarray(pws.SparseCenter().getInitialPoint(Ar, br, kr), float).ravel()
    V = sp.csc_matrix(red.saved_V)
    c_setup = cpu() - c0
    np.savez(cache, data=Ar.data, indices=Ar.indices, indptr=Ar.indptr, shape=Ar.shape, b=br,
             k=kr, vdata=V.data, vindices=V.indices, vindptr=V.indptr, vshape=V.shape,
             init=init, cpu=c_setup)
    return Ar, br, kr, V, init, c_setup


if __name__ == "__main__":
    sys.exit(main())
