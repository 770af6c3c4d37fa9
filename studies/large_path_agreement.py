"""The billiard walk's large path against the code before a change (issue 46): the same
distribution, from long runs (the benchmark's runs to ESS 100 are too short to tell).

    python studies/large_path_agreement.py OLD_SRC OUT.json [--cases small,big]
        [--new-src NEW_SRC]

OLD_SRC: the old code's sources (a directory with src/, e.g. the benchmark's export
``studies/out/old_code_<commit>``); the new code is the installed one, or NEW_SRC (an
export of the commit measured, so that the checkout may change meanwhile). Each run is a
child process, ``BilliardWalk(n, seed=s, burn_in=50)`` (4 chains): the 800-disk slice
(dim 228) with seeds 1-3 and n = 2000, the 5000-disk slice (dim 1714) with seed 1 and n =
1000. Per run: eta and its error, and per-contact mean forces and their errors, by batch
means (each chain's two halves: 8 batches); old against new: eta of all runs pooled,
and z = (mean_old - mean_new) / hypot(err_old, err_new) over the columns that vary (max,
rms, share beyond 3). Writes OUT.json (the summary; the samples stay in a temporary
directory).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
CASES = {"small": (HERE / "sampler_cost" / "p800_mu0.1.h5", 56.0, (1, 2, 3), 2000),
         "big": (HERE / "big_slice" / "paper_fast_n5000_mu0.1_s1.h5", 140.0, (1,), 1000)}

CHILD = r"""
import json, sys, time
import numpy as np
import forcespace as fs
path, height, seed, n, out = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
prob = fs.slice_problem(fs.read_packing(path), height)
c0 = time.process_time()
b = fs.BilliardWalk(n, seed=seed, burn_in=50).compute(prob)
e = b.ensemble
X = np.array([e.samples[e.chains == c] for c in np.unique(e.chains)])
np.save(out, X)
print(json.dumps({"cpu_s": time.process_time() - c0, "min_ess": e.diagnostics["min_ess"],
                  "max_rhat": e.diagnostics["max_rhat"], "eta": float(fs.eta(e.samples))}))
"""


def run(src, packing, height, seed, n, npy: Path) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if src is not None:
        env["PYTHONPATH"] = str(Path(src) / "src")
    res = subprocess.run([sys.executable, "-c", CHILD, str(packing), f"{height:g}", str(seed),
                          str(n), str(npy)], capture_output=True, text=True, env=env)
    if res.returncode != 0:
        raise RuntimeError(f"run exited {res.returncode}: {res.stderr[-600:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def batches(X) -> np.ndarray:
    """(8 batches, draws / 2, 2m): each chain's two halves."""
    h = X.shape[1] // 2
    return np.concatenate([X[:, :h], X[:, h:2 * h]])


def summary(runs: list) -> dict:
    """eta (mean of the runs' batch etas) +- s.e., column means and errors (batch means)."""
    from forcespace import eta

    B = np.concatenate([batches(X) for X in runs])
    etas = np.array([eta(b) for b in B])
    means = B.mean(1)
    return {"eta": float(etas.mean()), "eta_se": float(etas.std(ddof=1) / np.sqrt(len(etas))),
            "mean": means.mean(0), "err": means.std(0, ddof=1) / np.sqrt(len(means))}


def compare(old: dict, new: dict, scale: float) -> dict:
    err = np.hypot(old["err"], new["err"])
    vary = err > 1e-9 * scale
    z = (old["mean"] - new["mean"])[vary] / err[vary]
    return {"eta_old": old["eta"], "eta_old_se": old["eta_se"], "eta_new": new["eta"],
            "eta_new_se": new["eta_se"],
            "eta_z": (new["eta"] - old["eta"]) / float(np.hypot(old["eta_se"], new["eta_se"])),
            "n_columns": int(vary.sum()), "max_abs_z": float(np.abs(z).max()),
            "rms_z": float(np.sqrt(np.mean(z ** 2))), "share_beyond_3": float(np.mean(np.abs(z) > 3))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old_src", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--cases", default="small,big")
    ap.add_argument("--new-src", type=Path, default=None)
    a = ap.parse_args(argv)
    result = {"old_src": a.old_src.name,
              "new_src": a.new_src.name if a.new_src else "installed", "cases": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for key in a.cases.split(","):
            packing, height, seeds, n = CASES[key]
            runs, logs = {"old": [], "new": []}, {"old": [], "new": []}
            for seed in seeds:
                for code in ("old", "new") if seed % 2 else ("new", "old"):
                    npy = Path(tmp) / f"{key}_{code}_{seed}.npy"
                    logs[code].append(run(a.old_src if code == "old" else a.new_src,
                                          packing, height, seed, n, npy))
                    runs[code].append(np.load(npy))
                    print(f"{key} seed {seed} {code}: {logs[code][-1]}", flush=True)
            scale = float(np.abs(runs["old"][0]).mean())
            result["cases"][key] = {"seeds": list(seeds), "n": n, "runs": logs,
                                    **compare(summary(runs["old"]), summary(runs["new"]), scale)}
            print(json.dumps({k: v for k, v in result["cases"][key].items() if k != "runs"}),
                  flush=True)
    a.out.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
