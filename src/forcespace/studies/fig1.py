"""The paper's Fig. 1: force ambiguity eta and coordination z versus friction mu.

Tasks: one per (mu, seed): jam a packing at mu, analyse the slice's S, sample
it with both samplers (uniform hit-and-run and the paper's relax walk), and
the "squares": frictionless packings sampled with friction switched on at the
same mu. The degree of indeterminacy 2Nc - 3n is measured on the full packing
(force-bearing contacts and non-rattler disks, wall contacts counted), where
it is a property of the packing rather than of a slice's boundary.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..study import Task

QUICK = dict(scene="quick", n_disks=30, slice_height=12.0, mus=(0.01, 0.1, 1.0), seeds=(1, 2),
             samples=12, max_seconds=60.0)
FULL = dict(scene="paper", n_disks=200, slice_height=28.0,
            mus=tuple(float(m) for m in np.logspace(-4, 1, 15)), seeds=(1, 2, 3, 4, 5),
            samples=100, max_seconds=240.0)
N_SQUARES = 3          # frictionless packings sampled with friction switched on


def config(quick: bool) -> dict:
    return QUICK if quick else FULL


def tasks(quick: bool = False) -> list[Task]:
    """Own-mu packings first, then the mu = 0 packings: the accuracy floor (S at mu = 0)
    and the squares (the same packing, S at each mu of the sweep), one task each."""
    cfg = config(quick)
    common = dict(scene=cfg["scene"], n_disks=cfg["n_disks"], slice_height=cfg["slice_height"],
                  samples=cfg["samples"], max_seconds=cfg["max_seconds"])
    out = [Task(f"mu{mu:.3g}_s{seed}", "forcespace.studies.fig1:packing_task",
                dict(common, mu=mu, seed=seed)) for mu in cfg["mus"] for seed in cfg["seeds"]]
    for seed in cfg["seeds"][:N_SQUARES]:
        for ms in (0.0, *cfg["mus"]):
            out.append(Task(f"mu0_on{ms:.3g}_s{seed}", "forcespace.studies.fig1:packing_task",
                            dict(common, mu=0.0, seed=seed, mu_sample=ms)))
    return out


def packing_task(scene: str, n_disks: int, slice_height: float, samples: int, mu: float,
                 seed: int, workdir, mu_sample=None, max_seconds=None) -> dict:
    """Jam (or reuse) the packing (mu, seed), analyse its slice's S, sample it both ways.

    ``mu_sample``: friction of S instead of the packing's (the squares). Each sampler
    stops at ``samples`` samples or after ``max_seconds`` (the number reached is in
    the row). A determinate S (dim 0) has eta = 0 exactly for mu > 0; at mu_sample = 0
    the relax walk is run anyway: its eta is the solver's accuracy floor.
    """
    from .. import HitAndRun, RelaxWalk, slice_problem
    from ..polytope import analyze
    from ..study import shared_packing

    wd = Path(workdir)
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks)
    rat = p.rattlers()
    live = p.force_bearing() & ((p.a < 0) | ~rat[np.maximum(p.a, 0)]) \
        & ((p.b < 0) | ~rat[np.maximum(p.b, 0)])
    prob = slice_problem(p, slice_height, mu=mu_sample)
    t0 = time.perf_counter()
    an = analyze(prob, ranges=False)
    row = {"mu": mu, "mu_sample": mu if mu_sample is None else mu_sample, "seed": seed,
           "z": p.coordination(), "n_rattlers": int(rat.sum()),
           "nc_full": int(live.sum()), "n_full": int((~rat).sum()),
           "dof_excess_full": int(2 * live.sum() - 3 * (~rat).sum()),
           "slice_contacts": prob.n_contacts, "feasible": an.feasible,
           "bounded": an.bounded, "dim_S": an.dim_S,
           "degree_of_indeterminacy": an.degree_of_indeterminacy,
           "t_jam_s": t_jam, "t_analyze_s": time.perf_counter() - t0,
           "eta_hit_and_run": None, "eta_relax": None}
    if not (an.feasible and an.bounded):
        return {"rows": [row]}
    tag = "" if mu_sample is None else f"_mu{mu_sample:.3g}"
    runs = []
    if an.dim_S:
        runs.append(("hit_and_run", HitAndRun(n=samples, seed=seed)))
    else:
        row["eta_hit_and_run"] = 0.0                  # S is one point: no ambiguity
    if an.dim_S or row["mu_sample"] == 0:
        runs.append(("relax", RelaxWalk(n=samples, seed=seed)))
    else:
        row["eta_relax"] = 0.0
    for name, sampler in runs:
        t0 = time.perf_counter()
        ens = sampler.run(prob, output=wd / f"{name}{tag}.h5", max_seconds=max_seconds)
        row[f"eta_{name}"] = ens.eta
        row[f"n_{name}"] = ens.n_samples
        row[f"t_{name}_s"] = time.perf_counter() - t0
        if name == "relax":
            row["relax_projected"] = sampler.summary.get("n_projected")
        else:
            row["rhat_hit_and_run"] = sampler.summary.get("rhat_projections_max")
    return {"rows": [row]}


def summarize(results: list[dict], out) -> dict:
    """fig1.csv (one row per task) and fig1.png/.pdf (eta and z against mu)."""
    import csv

    from matplotlib.figure import Figure

    from ..draw import save_figure

    out = Path(out)
    ok = [dict(row, task=r["task"]) for r in results if r.get("ok") for row in r["rows"]]
    keys = ["task", "mu", "mu_sample", "seed", "z", "dim_S", "degree_of_indeterminacy",
            "nc_full", "n_full", "dof_excess_full", "eta_hit_and_run", "eta_relax"]
    with open(out / "fig1.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        for r in ok:
            w.writerow({k: r.get(k) for k in keys})
    fig = Figure(figsize=(9, 4))
    ax1, ax2 = fig.subplots(1, 2)
    own = [r for r in ok if r["mu"] > 0]
    squares = [r for r in ok if r["mu"] == 0]
    for rows, marker, label in ((own, "o", "own packing"), (squares, "s", "mu = 0 packing")):
        for key, colour in (("eta_hit_and_run", "C0"), ("eta_relax", "C1")):
            pts = np.array([(r["mu_sample"], r[key]) for r in rows if r[key]], float)
            if pts.size:
                ax1.plot(pts[:, 0], pts[:, 1], marker, color=colour, mfc="none",
                         label=f"{label}, {key[4:].replace('_', '-')}")
    ax1.set(xscale="log", yscale="log", xlabel="mu", ylabel="eta")
    ax1.legend(fontsize=7)
    pts = np.array([(r["mu"], r["z"]) for r in own], float)
    if pts.size:
        ax2.plot(pts[:, 0], pts[:, 1], "o")
    ax2.set(xscale="log", xlabel="mu", ylabel="z (rattlers excluded)")
    fig.tight_layout()
    save_figure(fig, out / "fig1.png")
    return {"tasks": len(results), "failed": sum(not r.get("ok") for r in results),
            "rows": len(ok),
            "table": str(out / "fig1.csv"), "figure": str(out / "fig1.png")}
