"""The paper's Fig. 3: is the jammed force network "central" in S, and is the relax walk uniform?

Tasks: one per packing (mu = 0.01, 20 seeds): jam, take the slice's S, sample it
with uniform hit-and-run (twice, independent seeds: the second run is the null
reference of the uniformity test) and with the paper's relax walk. Per packing:

- distances l of the samples from a centre, in units of their mean lbar, and
  l0 / lbar of the jammed network x0, for the four pairs (samples of sampler A,
  centre = mean of sampler B's samples), A, B in {hit-and-run, relax};
- the relative boundary: a network lies on it when one of S's inequalities that
  is not tight for all of S (not an implicit equality) has slack below
  ``BOUNDARY_TOL`` <Fn>; the count for x0 and the fraction of samples on it;
- uniformity: per-column two-sample Kolmogorov-Smirnov statistics D between
  the relax walk and hit-and-run, and between two independent hit-and-run runs
  (the null: what D looks like when both are uniform), over the columns that
  vary in S; and the ratio of eta (relax / hit-and-run).

The summary draws the histograms, the 2-D cross-section of S through x0 (the
inset) for the first packing, and judges the paper's claims.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import forcespace as fs
from forcespace.sweep import Task

from .common import shared_packing

QUICK = dict(scene="quick", n_disks=30, slice_height=12.0, mu=0.01, seeds=(1, 2, 3),
             samples=16, max_seconds=None)
FULL = dict(scene="paper", n_disks=200, slice_height=28.0, mu=0.01, seeds=tuple(range(1, 21)),
            samples=100, max_seconds=240.0)
BOUNDARY_TOL = 1e-7     # slack [<Fn>] below which a network is on S's relative boundary
VARYING_TOL = 1e-6      # a column varies in S when its hit-and-run spread exceeds this [<Fn>]
NULL_SEED_OFFSET = 1_000_003
SAMPLERS = ("hit_and_run", "relax")


def config(quick: bool) -> dict:
    return QUICK if quick else FULL


def tasks(quick: bool = False) -> list[Task]:
    cfg = config(quick)
    common = {k: cfg[k] for k in ("scene", "n_disks", "slice_height", "mu", "samples",
                                  "max_seconds")}
    return [Task(f"mu{cfg['mu']:.3g}_s{seed}", "forcespace_studies.fig3:packing_task",
                 dict(common, seed=seed)) for seed in cfg["seeds"]]


def centre_distances(X, centre, x0) -> tuple[np.ndarray, float]:
    """(l / lbar (k,), l0 / lbar): distances from ``centre`` of the samples X (k, 2m)
    and of x0 (2m,), in units of the samples' mean distance lbar."""
    ell = np.linalg.norm(X - centre, axis=1)
    lbar = ell.mean()
    return ell / lbar, float(np.linalg.norm(x0 - centre) / lbar)


def free_slacks(problem, analysis, X):
    """(rows, slack (len(rows), k) [<Fn>]): the inequalities that are not implicit
    equalities (rows of ``problem.inequalities()``) and their slack at each row of X."""
    G, _, _ = problem.inequalities()
    free = np.setdiff1d(np.arange(G.shape[0]), analysis.implicit_rows)
    return free, -(G[free] @ np.atleast_2d(X).T) / problem.force_scale


def boundary_slack(problem, analysis, X) -> np.ndarray:
    """Smallest slack [<Fn>] of the non-implicit inequalities at each row of X (k, 2m)."""
    free, slack = free_slacks(problem, analysis, X)
    return slack.min(axis=0) if free.size else np.full(slack.shape[1], np.inf)


def ks_statistics(X, Y, columns) -> np.ndarray:
    """Two-sample Kolmogorov-Smirnov statistic D of every column in ``columns``."""
    from scipy.stats import ks_2samp
    return np.array([ks_2samp(X[:, j], Y[:, j]).statistic for j in columns])


def packing_task(scene: str, n_disks: int, slice_height: float, samples: int, mu: float,
                 seed: int, workdir, max_seconds=None) -> dict:
    wd = Path(workdir)
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks)
    prob = fs.slice_problem(p, slice_height)
    an = fs.ForceSpace().compute(prob)
    row = {"mu": mu, "seed": seed, "z": p.coordination(), "slice_contacts": prob.n_contacts,
           "feasible": an.feasible, "bounded": an.bounded, "dim_S": an.dim,
           "t_jam_s": t_jam, "usable": bool(an.feasible and an.bounded and an.dim >= 2)}
    if not row["usable"]:
        row["reason"] = "S is empty, unbounded or of dimension < 2: no distances to compare"
        return row
    X, t = {}, {}
    for name, sampler, file in (
            ("hit_and_run", fs.HitAndRun(n=samples, seed=seed, max_seconds=max_seconds),
             "hit_and_run.h5"),
            ("null", fs.HitAndRun(n=samples, seed=seed + NULL_SEED_OFFSET,
                                  max_seconds=max_seconds), "hit_and_run_null.h5"),
            ("relax", fs.RelaxWalk(n=samples, seed=seed, max_seconds=max_seconds), "relax.h5")):
        t0 = time.perf_counter()
        X[name] = sampler.compute(prob, output=wd / file).ensemble.samples
        t[name] = time.perf_counter() - t0
        if name == "relax":
            row["relax_projected"] = int(sampler.projected.size)
    x0 = prob.x_jammed
    centres = {name: X[name].mean(0) for name in SAMPLERS}
    free, slack_x0 = free_slacks(prob, an, x0)
    slack0 = float(slack_x0.min()) if free.size else np.inf
    for a in SAMPLERS:
        row[f"n_{a}"] = int(len(X[a]))
        row[f"eta_{a}"] = fs.eta(X[a])
        row[f"t_{a}_s"] = t[a]
        for b in SAMPLERS:
            rel, rel0 = centre_distances(X[a], centres[b], x0)
            row[f"l_{a}_centre_{b}"] = rel.tolist()
            row[f"l0_centre_{b}_lbar_{a}"] = rel0
        slack = boundary_slack(prob, an, X[a])
        row[f"on_boundary_fraction_{a}"] = float((slack < BOUNDARY_TOL).mean())
        row[f"min_slack_quantiles_{a}"] = np.quantile(slack, [0.05, 0.5, 0.95]).tolist()
        # how close to S's boundary x0 is, measured against the samples: the fraction of
        # samples nearer to the boundary than x0 (about 0: x0 sits at the edge of S)
        row[f"jammed_slack_rank_{a}"] = float((slack < slack0).mean())
    row["eta_null"] = fs.eta(X["null"])
    _, owner, _ = prob.inequalities()
    tight = free[slack_x0[:, 0] < BOUNDARY_TOL]
    row["jammed_min_slack"] = slack0
    row["jammed_tight_contacts"] = int(np.unique(owner[tight]).size)
    spread = X["hit_and_run"].std(0) / prob.force_scale
    cols = np.flatnonzero(spread > VARYING_TOL)
    row["ks_columns"] = int(cols.size)
    row["ks_relax_vs_hit_and_run"] = ks_statistics(X["relax"], X["hit_and_run"], cols).tolist()
    row["ks_null"] = ks_statistics(X["null"], X["hit_and_run"], cols).tolist()
    return row


def _mean_se(v) -> tuple[float, float]:
    v = np.asarray(v, float)
    return float(v.mean()), float(v.std(ddof=1) / np.sqrt(v.size)) if v.size > 1 else np.nan


def summarize(results: list[dict], out) -> dict:
    """fig3.csv, fig3.png/.pdf, verdicts.json and section.md under ``out``."""
    from matplotlib.figure import Figure
    from scipy.stats import mannwhitneyu, wilcoxon

    from forcespace.plot import save_figure
    from .report import Verdict, write_csv, write_section

    out = Path(out)
    rows = [r for r in results if r.get("ok") and r.get("usable")]
    skipped = [r for r in results if r.get("ok") and not r.get("usable")]
    failed = [r for r in results if not r.get("ok")]
    keys = ["seed", "mu", "z", "dim_S", "slice_contacts", "n_hit_and_run", "n_relax",
            "relax_projected", "eta_hit_and_run", "eta_relax", "eta_null",
            "l0_centre_hit_and_run_lbar_hit_and_run", "l0_centre_relax_lbar_relax",
            "l0_centre_relax_lbar_hit_and_run", "l0_centre_hit_and_run_lbar_relax",
            "jammed_tight_contacts", "on_boundary_fraction_hit_and_run",
            "on_boundary_fraction_relax", "ks_columns", "t_jam_s", "t_hit_and_run_s",
            "t_relax_s"]
    write_csv(out / "fig3.csv", sorted(rows, key=lambda r: r["seed"]), keys)
    numbers: dict = {"packings_used": len(rows), "packings_skipped": len(skipped),
                     "tasks_failed": len(failed)}
    verdicts = []
    fig = Figure(figsize=(14, 4.4))
    axes = fig.subplots(1, 3, gridspec_kw={"width_ratios": [1, 1, 1.15]})
    if rows:
        for ax, c in zip(axes[:2], SAMPLERS):
            l0 = np.array([r[f"l0_centre_{c}_lbar_{c}"] for r in rows])
            pool = np.concatenate([r[f"l_{c}_centre_{c}"] for r in rows])
            other = [s for s in SAMPLERS if s != c][0]
            pool_other = np.concatenate([r[f"l_{other}_centre_{c}"] for r in rows])
            bins = np.linspace(0, max(2.5, pool.max(), l0.max()) * 1.02, 40)
            ax.hist(pool, bins, density=True, histtype="step", lw=1.5,
                    label=f"{c.replace('_', '-')} samples, l/lbar")
            ax.hist(pool_other, bins, density=True,
                    histtype="step", ls=":", label=f"{other.replace('_', '-')} samples "
                    f"(own lbar)")
            ax.hist(l0, bins, density=True, histtype="stepfilled", alpha=0.4,
                    label="jammed networks, l0/lbar")
            ax.set(xlabel="distance from centre / lbar", ylabel="density",
                   title=f"centre = mean of the {c.replace('_', '-')} samples")
            ax.legend(fontsize=7)
            m, se = _mean_se(l0)
            numbers[f"l0_over_lbar_centre_{c}"] = {"mean": m, "se": se,
                                                   "fraction_below_1": float((l0 < 1).mean())}
            numbers[f"sample_l_over_lbar_centre_{c}_sd"] = float(pool.std())
            p_mw = float(mannwhitneyu(l0, pool, alternative="less").pvalue)
            numbers[f"mannwhitney_p_centre_{c}"] = p_mw
        for c, how in (("relax", "the paper's walk, centre = mean of its samples"),
                       ("hit_and_run", "uniform samples of S, centre = their mean")):
            m, p_mw = numbers[f"l0_over_lbar_centre_{c}"], numbers[f"mannwhitney_p_centre_{c}"]
            o = numbers[f"l0_over_lbar_centre_{[s for s in SAMPLERS if s != c][0]}"]
            verdicts.append(Verdict(
                "fig3", f"The jammed network is closer to the centre of S than sampled "
                f"networks (mu = 0.01; {how})",
                f"l0/lbar = {m['mean']:.2f} ± {m['se']:.2f} (sample l/lbar: 1 ± "
                f"{numbers[f'sample_l_over_lbar_centre_{c}_sd']:.2f}); "
                f"{100 * m['fraction_below_1']:.0f} % of {len(rows)} packings below 1; "
                f"Mann-Whitney p = {p_mw:.1e}; with the other sampler's centre "
                f"{o['mean']:.2f} ± {o['se']:.2f}",
                _closer_verdict(m, p_mw)))
        tight = np.array([r["jammed_tight_contacts"] for r in rows])
        onb = {c: float(np.mean([r[f"on_boundary_fraction_{c}"] for r in rows]))
               for c in SAMPLERS}
        rank = np.array([r["jammed_slack_rank_hit_and_run"] for r in rows
                         if "jammed_slack_rank_hit_and_run" in r])    # (added later: may be
        if rank.size == 0:                                               # missing in old rows)
            rank = np.array([np.nan])
        numbers["jammed_tight_contacts"] = {"mean": float(tight.mean()),
                                            "min": int(tight.min()), "max": int(tight.max())}
        numbers["on_boundary_fraction"] = onb
        numbers["jammed_slack_rank_hit_and_run"] = {
            "median": float(np.median(rank)), "max": float(rank.max())}
        verdicts.append(Verdict(
            "fig3", "...yet the jammed network lies on the edge of 2-D cross-sections of S",
            f"the jammed network is nearer to the boundary of S than "
            f"{100 * (1 - np.median(rank)):.0f} % of uniform samples (median over "
            f"{rank.size} packings; {100 * (rank <= 0.05).mean():.0f} % of them below the "
            f"5th percentile), but exactly on it (a contact at the "
            f"Coulomb limit to {BOUNDARY_TOL:g} <Fn>) in {int((tight > 0).sum())} of "
            f"{len(rows)}; relax-walk samples are on it in {100 * onb['relax']:.0f} %, "
            f"uniform samples in {100 * onb['hit_and_run']:.0f} %",
            "not decidable" if not np.isfinite(rank).all() else
            "reproduced" if np.median(rank) <= 0.05 else "refuted"))
        ks = np.concatenate([r["ks_relax_vs_hit_and_run"] for r in rows])
        null = np.concatenate([r["ks_null"] for r in rows])
        q95 = float(np.quantile(null, 0.95)) if null.size else np.nan
        frac = float((ks > q95).mean()) if ks.size else np.nan
        ratios = np.array([r["eta_relax"] / r["eta_hit_and_run"] for r in rows])
        null_ratios = np.array([r["eta_null"] / r["eta_hit_and_run"] for r in rows])
        pw = float(wilcoxon(np.log(ratios)).pvalue) if len(rows) >= 6 else np.nan
        numbers["ks"] = {"median_relax_vs_hit_and_run": float(np.median(ks)),
                         "median_null": float(np.median(null)), "null_q95": q95,
                         "fraction_above_null_q95": frac, "columns": int(ks.size)}
        numbers["eta_ratio_relax_over_hit_and_run"] = {
            "geometric_mean": float(np.exp(np.log(ratios).mean())),
            "min": float(ratios.min()), "max": float(ratios.max()), "wilcoxon_p": pw}
        numbers["eta_ratio_null"] = {"geometric_mean": float(np.exp(np.log(null_ratios).mean())),
                                     "min": float(null_ratios.min()),
                                     "max": float(null_ratios.max())}
        uniform = frac <= 0.10 and abs(np.log(np.exp(np.log(ratios).mean()))) < 0.1
        verdicts.append(Verdict(
            "fig3", "The paper's perturb-and-relax walk samples S (close to) uniformly "
            "(assumed, not shown, by the paper)",
            f"per-column KS D relax vs hit-and-run: median {np.median(ks):.2f} against "
            f"{np.median(null):.2f} for two uniform runs; {100 * frac:.0f} % of "
            f"{ks.size} columns above the null's 95th percentile (5 % expected if uniform); "
            f"eta relax / hit-and-run = {numbers['eta_ratio_relax_over_hit_and_run']['geometric_mean']:.2f} "
            f"(geometric mean; range {ratios.min():.2f}-{ratios.max():.2f}; two uniform runs: "
            f"{numbers['eta_ratio_null']['geometric_mean']:.2f})",
            "reproduced" if uniform else "refuted"))
        _section_panel(axes[2], rows[0], out)
    save_figure(fig, out / "fig3.png", tight=True)
    text = _section_text(numbers, rows)
    write_section(out, "fig3", "Fig. 3: where the jammed network sits in S, and is the walk "
                  "uniform?", text, verdicts, numbers, figures=["fig3.png"])
    return {"tasks": len(results), "failed": len(failed), "usable": len(rows),
            "table": str(out / "fig3.csv"), "figure": str(out / "fig3.png"),
            "verdicts": [v.verdict for v in verdicts]}


def _closer_verdict(m, p) -> str:
    """Closer: mean l0/lbar two standard errors below 1 and the rank test at 1 %."""
    if m["mean"] + 2 * m["se"] < 1 and p < 0.01:
        return "reproduced"
    if m["mean"] - 2 * m["se"] > 1:
        return "refuted"
    return "not decidable"


def _section_panel(ax, row, out) -> None:
    """The inset: the cross-section of S through the first packing's jammed network."""
    par = row["params"]
    p, _ = shared_packing(out, par["scene"], par["mu"], par["seed"], par["n_disks"])
    sec = fs.Section(n=121, seed=row["seed"]).compute(fs.slice_problem(p, par["slice_height"]))
    sec.plot(ax, title=f"cross-section of S, seed {row['seed']} (dim S = {row['dim_S']})")


def _section_text(numbers: dict, rows: list[dict]) -> str:
    if not rows:
        return "No usable packing (S empty, unbounded or of dimension < 2 on every one)."
    dims = [r["dim_S"] for r in rows]
    n = [r["n_relax"] for r in rows] + [r["n_hit_and_run"] for r in rows]
    return (
        f"{len(rows)} packings at mu = {rows[0]['mu']} (dim S {min(dims)}-{max(dims)}), "
        f"{min(n)}-{max(n)} samples per sampler and packing. Distances are Euclidean in the "
        "space of all unknown (fn, ft) [F0]; l/lbar uses the mean distance of the same "
        "sampler's samples from the stated centre. Left: centre = mean of the hit-and-run "
        "samples; middle: centre = mean of the relax-walk samples (the paper's choice); "
        "right: a 2-D cross-section of S through the jammed network along two random "
        "directions of its affine hull (white inside S, grey by Coulomb violation / <Fn>).\n\n"
        f"The uniformity test compares each varying column's marginal: the KS statistic D "
        f"of relax vs hit-and-run against D of two independent hit-and-run runs of the same "
        f"length (the null; consecutive relax samples are correlated, which widens their "
        f"D even for a uniform walk, so a modest excess is not decisive, a large one is).")
