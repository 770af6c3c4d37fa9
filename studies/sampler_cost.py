"""Cost of a uniform sample of S against dim S: coordinate hit-and-run (the reference)
beside the billiard walk (issue 23), in CPU seconds, on real slices dim 48-1714.

    OMP_NUM_THREADS=1 nice python studies/sampler_cost.py studies/sampler_cost [--cases a,b]
        [--har CASES]    # hit-and-run measured in the same run only for these cases
    python studies/sampler_cost.py studies/sampler_cost --table     # tables of the note
    python studies/sampler_cost.py studies/sampler_cost --figure    # sampler_cost.png
    python studies/sampler_cost.py studies/sampler_cost --bench     # entry in bench.json

Cases (real slices of growing size; packing files under studies/):
  paper_mu0.1, paper_mu0.01   studies/packings/paper_mu*.h5, slice 28 R (dim 48, 70)
  p400, p800                  studies/sampler_cost/p{400,800}.h5 (forcespace pack
                              inputs/paper_fast.toml --n N --scale-box --mu 0.01), slice
                              28 sqrt(N / 200) R (dim 184, 398)
  n5000_h50 ... n5000_h140    studies/big_slice/paper_fast_n5000_mu0.1_s1.h5, slices of
                              height 50, 80, 110, 140 R (dim 537, 953, 1344, 1714)

Per case (CPU seconds = user + sys of this process, time.process_time; run it with one
BLAS thread): the LP analysis (ForceSpace, shared by both samplers, reported apart), then

* the billiard walk (forcespace.BilliardWalk, defaults) to a target ESS of 100 (the goal:
  time to ESS 100 with R-hat <= 1.05, everything after the analysis counted) and to 400
  (the cost per effective sample = CPU of the draws / min ESS);
* hit-and-run (forcespace.HitAndRun, defaults: thinning d^2, burn-in 10 d^2 per chain,
  4 chains), 100 samples, for the cases named by ``--har``; for the others its numbers
  are read from ``OUTDIR/old_branch/<case>.json``, the run of the sampler branch that
  measured both samplers side by side (the hit-and-run code is the same; above dim 600
  that run used thinning d^2 / 20 and burn-in d^2, the defaults would take hours).

Both are judged by the same statistics (forcespace.sampling.diagnostics: |x - xbar|^2
and 4 fixed random projections of x; ArviZ bulk and tail ESS, rank-normalised split
R-hat). Writes OUTDIR/<case>.json (existing ones are skipped: the study resumes).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import forcespace as fs
from forcespace.extend import by_chain

HERE = Path(__file__).parent
BIG = HERE / "big_slice" / "paper_fast_n5000_mu0.1_s1.h5"
CASES = {
    "paper_mu0.1": (HERE / "packings" / "paper_mu0.1.h5", 28.0),
    "paper_mu0.01": (HERE / "packings" / "paper_mu0.01.h5", 28.0),
    "p400": (HERE / "sampler_cost" / "p400.h5", 28.0 * np.sqrt(2.0)),
    "p800": (HERE / "sampler_cost" / "p800.h5", 56.0),
    "n5000_h50": (BIG, 50.0),
    "n5000_h80": (BIG, 80.0),
    "n5000_h110": (BIG, 110.0),
    "n5000_h140": (BIG, 140.0),
}


def judged(ens, sampling_cpu):
    """The convergence numbers of an ensemble and its CPU seconds per effective sample."""
    d = ens.diagnostics
    X = by_chain(ens.samples, ens.chains)
    return {"n_samples": ens.n_samples, "min_ess": d["min_ess"], "max_rhat": d["max_rhat"],
            "worst": d["worst"], "statistics": d["statistics"],
            "cpu_per_effective_sample": sampling_cpu / d["min_ess"],
            "eta": float(fs.eta(ens.samples)),
            "eta_per_chain": [float(fs.eta(x)) for x in X], "message": ens.message}


def billiard(prob, an, target, seed):
    c0 = time.process_time()
    b = fs.BilliardWalk(100_000, seed=seed, target_ess=target, progress=True).compute(
        prob, analysis=an)
    total = time.process_time() - c0
    return {"target_ess": target, "success": b.success, "cpu": b.cpu, "total_s": total,
            "dim_S": b.dim, "n_rows": b.n_rows,
            "counts": b.counts, "params": b.params, "walk": b.walk_info,
            "max_violation": float(b.ensemble.violations.max()),
            **judged(b.ensemble, b.cpu["sampling_s"])}


def hit_and_run(prob, an, seed):
    h = fs.HitAndRun(100, seed=seed, progress=True).compute(prob, analysis=an)
    cpu = h.cpu
    return {"source": "this run", "thin": h.params["thin"], "burn_in": h.params["burn_in"],
            "chains": h.params["chains"], "rounding": h.params["rounding"],
            "rounding_s": cpu["rounding_s"], "burn_in_s": cpu["burn_in_s"],
            "sampling_s": cpu["sampling_s"], **judged(h.ensemble, cpu["sampling_s"])}


def old_hit_and_run(outdir, name):
    old = json.loads((outdir / "old_branch" / f"{name}.json").read_text())["hit_and_run"]
    return {**old, "source": "old_branch (sampler branch, 61f6b43)"}


def warm_up():
    """Compile (or load from numba's cache) both samplers' kernels before any timing."""
    path, height = CASES["paper_mu0.1"]
    prob = fs.slice_problem(fs.read_packing(path), height)
    fs.BilliardWalk(8, burn_in=4).compute(prob)
    fs.HitAndRun(4, thin=10, burn_in=10).compute(prob)


def run_case(name, outdir, har, seed=1):
    path, height = CASES[name]
    prob = fs.slice_problem(fs.read_packing(path), height)
    res = {"case": name, "packing": path.name, "slice_height": height}
    t = time.process_time()
    an = fs.ForceSpace(ranges=False, centre=True).compute(prob)
    res["analyze_s"] = time.process_time() - t
    for key, target in (("billiard_goal", 100.0), ("billiard", 400.0)):
        res[key] = billiard(prob, an, target, seed)
        print(f"{name}: billiard target {target:.0f}: {res[key]['total_s']:.1f} CPU s, min "
              f"ESS {res[key]['min_ess']:.0f}, R-hat {res[key]['max_rhat']:.3f}",
              file=sys.stderr, flush=True)
    res["dim_S"], res["n_rows"] = res["billiard"]["dim_S"], res["billiard"]["n_rows"]
    res["hit_and_run"] = hit_and_run(prob, an, seed) if name in har else \
        old_hit_and_run(outdir, name)
    res["machine"] = "2 cores shared with other jobs; CPU seconds (process_time), " \
                     "OMP_NUM_THREADS=1, nice"
    (outdir / f"{name}.json").write_text(json.dumps(res, indent=1, default=float))
    return res


def fit(d, y, lo=150):
    """Least-squares exponent k of y ~ d^k over d >= lo, and its standard error."""
    ok = d >= lo
    A = np.vstack([np.log(d[ok]), np.ones(ok.sum())]).T
    coef, *_ = np.linalg.lstsq(A, np.log(y[ok]), rcond=None)
    r = np.log(y[ok]) - A @ coef
    cov = (r @ r) / max(ok.sum() - 2, 1) * np.linalg.inv(A.T @ A)
    return float(coef[0]), float(np.sqrt(cov[0, 0]))


def load(outdir):
    rows = [json.loads(p.read_text()) for p in sorted(outdir.glob("*.json"))
            if not p.name.startswith("tune_")]
    return sorted(rows, key=lambda r: r["dim_S"])


def cost_table(rows, old):
    print("| case | dim S | rows | hit-and-run: samples | min ESS | max R-hat | s per ES "
          "| billiard (old branch): s per ES | billiard (port): samples | min ESS "
          "| max R-hat | s per ES | ratio HR / port | eta HR / port |")
    print("|" + "---|" * 14)
    for r in rows:
        h, b, o = r["hit_and_run"], r["billiard"], old[r["case"]]["billiard"]
        mark = "" if h["source"] == "this run" else " *"
        print(f"| {r['case']} | {r['dim_S']} | {r['n_rows']} | {h['n_samples']}{mark} "
              f"| {h['min_ess']:.0f} | {h['max_rhat']:.3f} "
              f"| {h['cpu_per_effective_sample']:.3g} | {o['cpu_per_effective_sample']:.3g} "
              f"| {b['n_samples']} | {b['min_ess']:.0f} | {b['max_rhat']:.3f} "
              f"| {b['cpu_per_effective_sample']:.3g} "
              f"| {h['cpu_per_effective_sample'] / b['cpu_per_effective_sample']:.0f} "
              f"| {h['eta']:.4f} / {b['eta']:.4f} |")


def goal_table(rows):
    print("| case | dim S | analysis [s] | frame [s] | rounding [s] | Gram [s] | burn-in [s] "
          "| draws [s] | diagnostics [s] | total after analysis [s] | samples | min ESS "
          "| max R-hat | reflections per trajectory | ESS per trajectory |")
    print("|" + "---|" * 15)
    for r in rows:
        g, b = r["billiard_goal"], r["billiard"]
        c = g["cpu"]
        print(f"| {r['case']} | {r['dim_S']} | {r['analyze_s']:.3g} | {c['frame_s']:.2g} "
              f"| {c['rounding_s']:.3g} | {c['gram_s']:.3g} | {c['burn_in_s']:.3g} "
              f"| {c['sampling_s']:.3g} | {c['diagnostics_s']:.2g} | {g['total_s']:.3g} "
              f"| {g['n_samples']} | {g['min_ess']:.0f} | {g['max_rhat']:.3f} "
              f"| {b['counts']['reflections'] / b['counts']['trajectories']:.0f} "
              f"| {b['min_ess'] / b['counts']['trajectories']:.2f} |")


def table(outdir):
    """The markdown tables of studies/sampler_cost.md from OUTDIR/*.json."""
    rows = load(outdir)
    old = {r["case"]: r for r in load(outdir / "old_branch")}
    cost_table(rows, old)
    print()
    goal_table(rows)
    d = np.array([r["dim_S"] for r in rows], float)
    series = {"hit-and-run": [r["hit_and_run"] for r in rows],
              "billiard (port)": [r["billiard"] for r in rows],
              "billiard (old branch)": [old[r["case"]]["billiard"] for r in rows]}
    print()
    for key, runs in series.items():
        y = np.array([x["cpu_per_effective_sample"] for x in runs])
        fits = [fit(d, y, lo) for lo in (150, 500)]
        print(f"* {key}: s per ES ~ d^{fits[0][0]:.2f} +- {fits[0][1]:.2f} (dim >= 150), "
              f"d^{fits[1][0]:.2f} +- {fits[1][1]:.2f} (dim >= 500)")
    refl = np.array([r["billiard"]["counts"]["reflections"] /
                     r["billiard"]["counts"]["trajectories"] for r in rows])
    k, e = fit(d, refl)
    print(f"* billiard reflections per trajectory ~ d^{k:.2f} +- {e:.2f} (dim >= 150)")
    for p in sorted((outdir / "old_branch").glob("tune_*.json")):
        tune_table(json.loads(p.read_text()))


def tune_table(t):
    """The rounding and walk-parameter scans of the sampler branch (old_branch/tune_*)."""
    print(f"\n{t['case']} (dim {t['dim_S']}, {t['n_rows']} rows): rounding CPU s "
          + ", ".join(f"{r['max_updates']} updates {r['cpu_s']:.3g}" for r in t["rounding"]))
    print("\n| updates | law | tau_factor | tau | reflections / trajectory | min ESS "
          "| max R-hat | s per ES |")
    print("|" + "---|" * 8)
    for r in t["walk"]:
        print(f"| {r['max_updates']} | {r['length']} | {r['tau_factor']:g} | {r['tau']:.3g} "
              f"| {r['reflections_per_trajectory']:.0f} | {r['min_ess']:.0f} "
              f"| {r['max_rhat']:.3f} | {r['cpu_per_effective_sample']:.3g} |")


def figure(outdir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = load(outdir)
    d = np.array([r["dim_S"] for r in rows], float)
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for key, label, style in (("hit_and_run", "coordinate hit-and-run (reference)", "o-"),
                              ("billiard", "billiard walk", "s-")):
        y = np.array([r[key]["cpu_per_effective_sample"] for r in rows])
        ax.loglog(d, y, style, label=label)
        ok = d >= 150
        k, c = np.polyfit(np.log(d[ok]), np.log(y[ok]), 1)
        ax.loglog(d[ok], np.exp(c) * d[ok] ** k, ":", color="grey")
        ax.text(d[ok][-1], y[ok][-1] * 1.6, f"fit d >= 150: d^{k:.2f}", ha="right", fontsize=8)
    ax.set_xlabel("dim S")
    ax.set_ylabel("CPU seconds per effective sample")
    ax.set_title("Uniform sampling of S (min ESS over 5 statistics)", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(outdir / "sampler_cost.png", dpi=120)
    print(outdir / "sampler_cost.png")


def bench(outdir, case="n5000_h140"):
    """Record the billiard walk's run on the 5000-disk slice in studies/out/bench.json."""
    r = json.loads((outdir / f"{case}.json").read_text())
    g, b, h = r["billiard_goal"], r["billiard"], r["hit_and_run"]
    path = HERE / "out" / "bench.json"
    data = json.loads(path.read_text()) if path.exists() else {}
    data["sampler"] = {
        "case": f"{r['packing']}, slice {r['slice_height']:g} R", "dim_S": r["dim_S"],
        "n_rows": r["n_rows"], "timing": "CPU (user + sys), OMP_NUM_THREADS=1, 2 shared cores",
        "forcespace_version": fs.__version__, "analysis_s": r["analyze_s"],
        "billiard_to_ess_100": {"cpu": g["cpu"], "total_after_analysis_s": g["total_s"],
                                "n_samples": g["n_samples"], "min_ess": g["min_ess"],
                                "max_rhat": g["max_rhat"]},
        "billiard_s_per_effective_sample": b["cpu_per_effective_sample"],
        "hit_and_run_s_per_effective_sample": h["cpu_per_effective_sample"],
        "hit_and_run_source": h["source"], "hit_and_run_min_ess": h["min_ess"],
        "hit_and_run_max_rhat": h["max_rhat"]}
    path.write_text(json.dumps(data, indent=2))
    print(f"wrote the 'sampler' entry of {path}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir")
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--har", default="paper_mu0.1,paper_mu0.01,p400,p800",
                    help="cases whose hit-and-run is measured in this run (the others: "
                         "OUTDIR/old_branch)")
    ap.add_argument("--figure", action="store_true")
    ap.add_argument("--table", action="store_true", help="print the markdown tables")
    ap.add_argument("--bench", action="store_true", help="write the bench.json entry")
    a = ap.parse_args()
    out = Path(a.outdir)
    out.mkdir(parents=True, exist_ok=True)
    if a.figure or a.table or a.bench:
        return figure(out) if a.figure else table(out) if a.table else bench(out)
    warm_up()
    for name in a.cases.split(","):
        if not (out / f"{name}.json").exists():
            run_case(name, out, set(a.har.split(",")))


if __name__ == "__main__":
    main()
