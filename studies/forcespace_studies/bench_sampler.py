"""Billiard-walk benchmark at scale (issue 46): a run to ESS >= 100 on every tracked
statistic with split R-hat <= 1.05, set-up included (analysis of S for the frame, frame,
rounding, Gram matrix, burn-in, draws, diagnostics), new code beside the code before
(``--old`` commit, default c794887: before session 43's large path; 90bd720: before issue
46), exported from git and run from its sources, alternating which goes first, in CPU
seconds (user + sys of the child process, getrusage), peak RSS of the child.

Cases: an 800-disk mu = 0.1 packing (``studies/sampler_cost/p800_mu0.1.h5``, slice 56 R:
dim S 228), the committed 5000-disk packing (``studies/big_slice/``, slice 140 R: dim S
1714) and, for dim ~3000, the 10 000-disk one jammed by ``forcespace_studies.big_jam
paper_fast_compaction --n 10000 --mu 0.1 --seed 1`` (case "n10000": the scene's slice,
28 sqrt(N / 200) R = 198 R as 140 R at 5000 disks; dim S ~3400).
Variants: "old" (the old commit), "new" (defaults), "new_float32" (``gram="float32"``;
only with ``--float32``); ``--no-old`` leaves the old code out (where the new code alone
is measured, as at dim ~3000). Numba's caches are warmed once, untimed, on the small
case, whichever cases run.
Each child reads the packing, cuts the slice and runs ``BilliardWalk(100000, seed=1,
target_ess=100)``; "run_cpu_s" is the CPU of that call (everything after reading the
packing), "process_cpu_s" the whole child (Python start and imports included). The
ensembles are compared: eta, and per-contact means of fn and ft (z-scores against their
Monte-Carlo errors from chain means), new against old (and float32 against float64).

Writes (merges) the section ``billiard`` of OUT/bench.json. Usage::

    python -m forcespace_studies.bench_sampler [--rounds 3] [--big-rounds 1]
        [--out studies/out] [--cases small,big] [--old COMMIT] [--float32] [--keep DIR]

A run of some cases replaces those cases' rows and keeps the others.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from forcespace.extend import write_json

from .bench_engine import _children_cpu, log, old_sources

OLD_COMMIT = "c794887"
CASES = {"small": ("p800 mu0.1 slice 56", "studies/sampler_cost/p800_mu0.1.h5", 56.0),
         "big": ("paper_fast n5000 mu0.1 slice 140", "studies/big_slice/"
                 "paper_fast_n5000_mu0.1_s1.h5", 140.0),
         "n10000": ("paper_fast_compaction n10000 mu0.1 slice 198", "studies/packings/"
                    "paper_fast_compaction_n10000_mu0.1_s1.h5", 28.0 * np.sqrt(50.0))}
VARIANTS = {"old": {}, "new": {}}
FLOAT32 = {"new_float32": {"gram": "float32"}}

CHILD = r"""
import json, resource, sys, time
c0 = time.process_time()
import numpy as np
import forcespace as fs
path, height, kw, out = sys.argv[1], float(sys.argv[2]), json.loads(sys.argv[3]), sys.argv[4]
prob = fs.slice_problem(fs.read_packing(path), height)
c1 = time.process_time()
b = fs.BilliardWalk(100000, seed=1, target_ess=100, **kw).compute(prob)
c2 = time.process_time()
e = b.ensemble
X = e.samples
chains = np.unique(e.chains)
per = np.array([X[e.chains == c].mean(0) for c in chains])
np.savez(out, mean=X.mean(0), err=per.std(0, ddof=1) / np.sqrt(len(chains)),
         X=np.array([X[e.chains == c] for c in chains], np.float32))
print(json.dumps({"run_cpu_s": c2 - c1, "read_cpu_s": c1 - c0, "cpu": b.cpu, "dim_S": b.dim,
                  "n_rows": b.n_rows, "n_samples": e.n_samples,
                  "min_ess": e.diagnostics["min_ess"], "max_rhat": e.diagnostics["max_rhat"],
                  "eta": float(fs.eta(X)), "eta_per_chain": e.diagnostics["eta_per_chain"],
                  "max_violation": float(e.violations.max()), "counts": b.counts,
                  "rounding": b.walk_info.get("rounding", {}), "tau": b.walk_info.get("tau"),
                  "gram_form": b.walk_info.get("gram_form", "float64"),
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def run_child(src: Path | None, packing: str, height: float, kw: dict, npz: Path) -> dict:
    """One run in a child process (``src``: old sources on PYTHONPATH; None: the installed
    code): its JSON line and the child's CPU s (user + sys)."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if src is not None:
        env["PYTHONPATH"] = str(src / "src")
    c0, w0 = _children_cpu(), time.perf_counter()
    res = subprocess.run([sys.executable, "-c", CHILD, packing, repr(float(height)),
                          json.dumps(kw), str(npz)], capture_output=True, text=True, env=env)
    cpu, wall = _children_cpu() - c0, time.perf_counter() - w0
    if res.returncode != 0:
        raise RuntimeError(f"billiard run exited {res.returncode}: {res.stderr[-800:]}")
    out = json.loads(res.stdout.strip().splitlines()[-1])
    return {**out, "process_cpu_s": cpu, "wall_s": wall}


def agreement(a: Path, b: Path, ra: dict, rb: dict) -> dict:
    """Per-contact means of two ensembles: max |z| over the columns that vary, eta's
    relative difference."""
    A, B = np.load(a), np.load(b)
    err = np.hypot(A["err"], B["err"])
    vary = err > 1e-12 * np.abs(A["mean"]).max()
    z = np.abs(A["mean"] - B["mean"])[vary] / err[vary]
    return {"max_abs_z_mean": float(z.max()), "n_columns": int(vary.sum()),
            "eta_rel_diff": float(rb["eta"] / ra["eta"] - 1)}


def bench_case(key: str, old: tuple, rounds: int, tmp: Path, variants: dict) -> dict:
    name, packing, height = CASES[key]
    old_commit, old_src = old
    srcs = {v: (old_src if v == "old" else None) for v in variants}
    runs = {v: [] for v in variants}
    for k in range(rounds):
        order = list(variants) if k % 2 == 0 else list(variants)[::-1]
        for v in order:
            runs[v].append(run_child(srcs[v], packing, height, variants[v],
                                     tmp / f"{key}_{v}.npz"))
            r = runs[v][-1]
            log(f"  {name} {v}: run {r['run_cpu_s']:.1f} CPU s (process "
                f"{r['process_cpu_s']:.1f}), ESS {r['min_ess']:.0f}, R-hat "
                f"{r['max_rhat']:.3f}, {r['peak_rss_mb']:.0f} MB")
    row = {"case": name, "packing": packing, "slice_height": height,
           "old_commit": old_commit if "old" in variants else None}
    for v, rs in runs.items():
        best = int(np.argsort([r["run_cpu_s"] for r in rs])[len(rs) // 2])
        row[v] = {**rs[best], "run_cpu_s_runs": [r["run_cpu_s"] for r in rs],
                  "process_cpu_s_runs": [r["process_cpu_s"] for r in rs]}
    if "old" in variants:
        row["same_samples_old_new"] = bool(
            np.array_equal(np.load(tmp / f"{key}_old.npz")["mean"],
                           np.load(tmp / f"{key}_new.npz")["mean"]))
        row["new_vs_old"] = agreement(tmp / f"{key}_old.npz", tmp / f"{key}_new.npz",
                                      row["old"], row["new"])
        row["speedup_run_cpu"] = row["old"]["run_cpu_s"] / row["new"]["run_cpu_s"]
    if "new_float32" in variants:
        row["float32_vs_float64"] = agreement(tmp / f"{key}_new.npz",
                                              tmp / f"{key}_new_float32.npz", row["new"],
                                              row["new_float32"])
    return row


def warm(srcs: dict, variants: dict, tmp: Path) -> None:
    """Untimed runs of the small case: numba's caches warm (the same kernels at every
    size)."""
    _, packing, height = CASES["small"]
    for v in variants:
        run_child(srcs[v], packing, height, variants[v], tmp / f"warm_{v}.npz")


def merge_section(path: Path, section: dict) -> None:
    """Write ``section`` as key "billiard" of the JSON file, other keys kept (atomic); rows
    of cases it does not carry are kept from the file's section."""
    data = json.loads(path.read_text()) if path.is_file() else {}
    ran = {r["case"] for r in section["cases"]}
    kept = [r for r in data.get("billiard", {}).get("cases", []) if r["case"] not in ran]
    data["billiard"] = {**data.get("billiard", {}), **section,
                        "cases": kept + section["cases"]}
    write_json(path, data, indent=2)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3, help="rounds of the small case")
    ap.add_argument("--big-rounds", type=int, default=1, help="rounds of the dim-1714 case")
    ap.add_argument("--out", type=Path, default=Path("studies/out"))
    ap.add_argument("--cases", default="small,big")
    ap.add_argument("--old", default=OLD_COMMIT, help="commit of the old code")
    ap.add_argument("--old-src", type=Path, default=None,
                    help="sources of the old code (default: exported from git at --old)")
    ap.add_argument("--float32", action="store_true", help="also the float32-Gram variant")
    ap.add_argument("--no-old", action="store_true", help="the new code only")
    ap.add_argument("--keep", type=Path, default=None,
                    help="directory to keep each run's samples (by chain), column means and "
                         "errors in")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    variants = {**VARIANTS, **(FLOAT32 if a.float32 else {})}
    if a.no_old:
        variants.pop("old")
        old_src = None
    else:
        old_src = a.old_src or old_sources(Path.cwd(), a.out / f"old_code_{a.old}", a.old)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        if a.keep is not None:
            a.keep.mkdir(parents=True, exist_ok=True)
            tmp = a.keep
        warm({v: (old_src if v == "old" else None) for v in variants}, variants, Path(tmp))
        for key in a.cases.split(","):
            log(f"billiard to ESS 100, {CASES[key][0]}: {', '.join(variants)}"
                + ("" if a.no_old else f" (old: {a.old})"))
            rows.append(bench_case(key, (a.old, old_src),
                                   a.rounds if key == "small" else a.big_rounds, Path(tmp),
                                   variants))
    header = {} if a.no_old else {     # without old code: the section's header is kept
        "old_commit": a.old, "machine": platform.platform(), "cpu_count": os.cpu_count(),
        "timing": "CPU (user + sys) of the child process, median of the rounds; "
                  "OMP_NUM_THREADS=1; 2 cores shared with other jobs",
        "run": "BilliardWalk(100000, seed=1, target_ess=100).compute(slice)"}
    merge_section(a.out / "bench.json", {**header, "cases": rows})
    log(f"wrote section 'billiard' of {a.out / 'bench.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
