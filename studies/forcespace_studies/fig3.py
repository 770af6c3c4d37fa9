"""The paper's Fig. 3: is the jammed force network "central" in S, and is the relax walk uniform?

Tasks: one per packing (mu = 0.01, 20 seeds): jam, take the slice's S, sample it
with uniform hit-and-run (twice, independent seeds: the second run is the null
reference of the uniformity test) and with the paper's relax walk, each 4 chains to
ESS 100 (the report's rule 4; a run that does not converge is kept and excluded from
the verdicts). Per packing:

- distances l of the samples from a centre, in units of their mean lbar, and
  l0 / lbar of the jammed network x0, for the four pairs (samples of sampler A,
  centre = mean of sampler B's samples), A, B in {hit-and-run, relax};
- the relative boundary: a network lies on it when one of S's inequalities that
  is not tight for all of S (not an implicit equality) has slack below
  ``BOUNDARY_TOL`` <Fn>; the count for x0 and the fraction of samples on it;
- the 2-D sections of the paper's claim: in ``SECTIONS`` random planes of S's affine
  hull through x0, the distance of x0 from the section's boundary over the section's
  extent (``Section.x0_edge_ratio``), and the same for each of as many uniform samples
  (each in its own random plane through it), the reference;
- uniformity: per-column two-sample Kolmogorov-Smirnov statistics D between
  the relax walk and hit-and-run, and between two independent hit-and-run runs
  (the null: what D looks like when both are uniform), over the columns that
  vary in S; and the ratio of eta (relax / hit-and-run).

The summary draws the histograms, the 2-D cross-section of S through x0 (the
inset) for the first packing, and judges the paper's claims.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

import forcespace as fs
from .runner import Task

from . import stats
from .common import (SAMPLERS, kept_packing, no_packing_panel, run_samplers, sampler,
                     shared_packing)

QUICK = dict(scene="quick", n_disks=30, slice_height=12.0, mu=0.01, seeds=(1, 2, 3),
             cap=800, max_seconds=None)
FULL = dict(scene="paper", n_disks=200, slice_height=28.0, mu=0.01, seeds=tuple(range(1, 21)),
            cap=3000, max_seconds=900.0)
BOUNDARY_TOL = 1e-7     # slack [<Fn>] below which a network is on S's relative boundary
EDGE_RATIO = 0.01       # x0 is "on the edge" of a 2-D section when its distance from the
                        # section's boundary is below 1 % of the section's extent (the
                        # resolution of a drawn section; a central point sits at ~0.3)
SECTIONS = 10           # random 2-D sections per packing (and uniform reference points)
VARYING_TOL = 1e-6      # a column varies in S when its hit-and-run spread exceeds this [<Fn>]
NULL_SEED_OFFSET = 1_000_003
EDGE_CALL = {"most": "reproduced", "few": "refuted", "undecided": "not decidable"}
NEARER = {"most": "supported", "few": "not supported", "undecided": "not decidable"}


def config(quick: bool) -> dict:
    return QUICK if quick else FULL


def tasks(quick: bool = False) -> list[Task]:
    cfg = config(quick)
    common = {k: cfg[k] for k in ("scene", "n_disks", "slice_height", "mu", "cap",
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


def packing_task(scene: str, n_disks: int, slice_height: float, cap: int, mu: float,
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
    x0 = prob.x_jammed
    row.update(_sections(prob, an, x0, seed))
    ens = run_samplers(row, [(k, sampler(k, seed, cap, max_seconds)) for k in SAMPLERS],
                       prob, wd, analysis=an)
    null_row: dict = {}
    ens.update({"null": run_samplers(null_row, [("hit_and_run", sampler(
        "hit_and_run", seed + NULL_SEED_OFFSET, cap, max_seconds))], prob, wd,
        "_null", analysis=an).get("hit_and_run")})
    row.update({k.replace("hit_and_run", "null"): v for k, v in null_row.items()})
    X = {k: e.samples for k, e in ens.items() if e is not None and e.n_samples >= 2}
    for a in SAMPLERS:
        if a in X:
            row.update(_boundary(prob, an, row["jammed_min_slack"], X[a], a))
    for a in SAMPLERS:
        for b in SAMPLERS:
            if a in X and b in X:
                rel, rel0 = centre_distances(X[a], X[a if a == b else b].mean(0), x0)
                row[f"l_{a}_centre_{b}"] = rel.tolist()
                row[f"l0_centre_{b}_lbar_{a}"] = rel0
    if "hit_and_run" in X:
        row["uniform_edge_ratio"] = _sample_sections(prob, an, X["hit_and_run"], seed)
    if all(k in X for k in ("hit_and_run", "relax", "null")):
        spread = X["hit_and_run"].std(0) / prob.force_scale
        cols = np.flatnonzero(spread > VARYING_TOL)
        row["ks_columns"] = int(cols.size)
        row["ks_relax_vs_hit_and_run"] = ks_statistics(X["relax"], X["hit_and_run"],
                                                       cols).tolist()
        row["ks_null"] = ks_statistics(X["null"], X["hit_and_run"], cols).tolist()
    return row


def _sections(prob, an, x0, seed) -> dict:
    """x0 in SECTIONS random 2-D sections: its distance from each section's boundary over
    the section's extent, and its smallest slack and tight contacts in S itself."""
    ratios = [fs.Section(n=3, seed=seed * SECTIONS + k).compute(prob, x0, analysis=an)
              .x0_edge_ratio for k in range(SECTIONS)]
    free, slack_x0 = free_slacks(prob, an, x0)
    _, owner, _ = prob.inequalities()
    tight = free[slack_x0[:, 0] < BOUNDARY_TOL]
    return {"jammed_edge_ratio": ratios,
            "jammed_min_slack": float(slack_x0.min()) if free.size else np.inf,
            "jammed_tight_contacts": int(np.unique(owner[tight]).size)}


def _sample_sections(prob, an, X, seed) -> list:
    """The reference: SECTIONS uniform samples, each in a random 2-D section through it."""
    pick = np.linspace(0, len(X) - 1, SECTIONS).astype(int)
    return [fs.Section(n=3, seed=seed * SECTIONS + k).compute(prob, X[i], analysis=an)
            .x0_edge_ratio for k, i in enumerate(pick)]


def _boundary(prob, an, slack0: float, X, a) -> dict:
    """Sampler ``a``'s samples against S's relative boundary, and x0 (its smallest slack
    ``slack0`` [<Fn>], from :func:`_sections`) among them."""
    slack = boundary_slack(prob, an, X)
    # the fraction of samples nearer to S's boundary than x0 (about 0: x0 at the edge)
    return {f"on_boundary_fraction_{a}": float((slack < BOUNDARY_TOL).mean()),
            f"min_slack_quantiles_{a}": np.quantile(slack, [0.05, 0.5, 0.95]).tolist(),
            f"jammed_slack_rank_{a}": float((slack < slack0).mean())}


def _mean_se(v) -> tuple[float, float]:
    v = np.asarray(v, float)
    return float(v.mean()), float(v.std(ddof=1) / np.sqrt(v.size)) if v.size > 1 else np.nan


CSV_KEYS = ["seed", "mu", "z", "dim_S", "slice_contacts", "n_hit_and_run", "n_relax", "n_null",
            "converged_hit_and_run", "converged_relax", "converged_null", "ess_hit_and_run",
            "rhat_hit_and_run", "ess_relax", "rhat_relax", "relax_projected",
            "eta_hit_and_run", "eta_relax", "eta_null",
            "l0_centre_hit_and_run_lbar_hit_and_run", "l0_centre_relax_lbar_relax",
            "l0_centre_relax_lbar_hit_and_run", "l0_centre_hit_and_run_lbar_relax",
            "jammed_edge_ratio_median", "uniform_edge_ratio_median", "jammed_min_slack",
            "jammed_tight_contacts", "jammed_slack_rank_hit_and_run",
            "on_boundary_fraction_hit_and_run", "on_boundary_fraction_relax", "ks_columns",
            "error_hit_and_run", "error_relax", "t_jam_s", "t_hit_and_run_s", "t_relax_s"]


def summarize(results: list[dict], out) -> dict:
    """fig3.csv, fig3.png/.pdf, verdicts.json and section.md under ``out``."""
    from matplotlib.figure import Figure

    from forcespace.extend import save_figure
    from .report import RULES_VERSION, write_csv, write_section

    out = Path(out)
    rows = [r for r in results if r.get("ok") and r.get("usable")]
    skipped = [r for r in results if r.get("ok") and not r.get("usable")]
    failed = [r for r in results if not r.get("ok")]
    for r in rows:
        for k in ("jammed_edge_ratio", "uniform_edge_ratio"):
            if r.get(k):
                r[f"{k}_median"] = float(np.median(r[k]))
    write_csv(out / "fig3.csv", sorted(rows, key=lambda r: r["seed"]), CSV_KEYS)
    conv = {a: [r for r in rows if r.get(f"converged_{a}")] for a in SAMPLERS}
    numbers: dict = {"packings_used": len(rows), "packings_skipped": len(skipped),
                     "tasks_failed": len(failed),
                     "converged": {a: len(conv[a]) for a in SAMPLERS},
                     "excluded_unconverged": {a: len(rows) - len(conv[a]) for a in SAMPLERS},
                     "failed_runs": {a: sum(bool(r.get(f"error_{a}")) for r in rows)
                                     for a in SAMPLERS}}
    verdicts = []
    fig = Figure(figsize=(18, 4.4))
    axes = fig.subplots(1, 4, gridspec_kw={"width_ratios": [1, 1, 1, 1.15]})
    for ax, c in zip(axes[:2], SAMPLERS):
        verdicts += _centre_verdict(ax, c, conv, numbers)
    verdicts += _edge_verdicts(axes[2], rows, conv["hit_and_run"], numbers)
    verdicts += _uniformity_verdict(rows, numbers)
    if rows:
        _section_panel(axes[3], rows[0], out)
    save_figure(fig, out / "fig3.png", tight=True)
    text = _section_text(numbers, rows)
    write_section(out, "fig3", "Fig. 3: where the jammed network sits in S, and is the walk "
                  "uniform?", text, verdicts, numbers, figures=["fig3.png"],
                  rules_version=RULES_VERSION)
    return {"tasks": len(results), "failed": len(failed), "usable": len(rows),
            "table": str(out / "fig3.csv"), "figure": str(out / "fig3.png"),
            "verdicts": [v.verdict for v in verdicts]}


def _centre_verdict(ax, c, conv, numbers) -> list:
    """The paper's centrality claim judged on sampler ``c``'s converged runs; the panel:
    l/lbar of the samples and l0/lbar of the jammed networks, centre = mean of c's."""
    from scipy.stats import mannwhitneyu

    from .report import SAMPLERS as LABELS, Verdict
    other = [s for s in SAMPLERS if s != c][0]
    rows = conv[c]
    how = {"relax": "the paper's walk, centre = mean of its samples",
           "hit_and_run": "uniform samples of S, centre = their mean"}[c]
    claim = f"The jammed network is closer to the centre of S than sampled networks ({how})"
    ax.set(xlabel=r"distance from the centre / $\bar\ell$", ylabel="density",
           title=f"centre: mean of the {LABELS[c].split(' (')[0]} samples")
    ax.title.set_fontsize(10)
    if len(rows) < 3:
        return [Verdict("fig3", claim, f"{len(rows)} converged runs (3 needed)",
                        "not decidable", sampler=c, rule="rule 4: converged runs only")]
    l0 = np.array([r[f"l0_centre_{c}_lbar_{c}"] for r in rows])
    pool = np.concatenate([r[f"l_{c}_centre_{c}"] for r in rows])
    bins = np.linspace(0, max(2.5, pool.max(), l0.max()) * 1.02, 40)
    ax.hist(pool, bins, density=True, histtype="step", lw=1.5,
            label=rf"{LABELS[c]} samples, $\ell/\bar\ell$")
    both = [r for r in rows if f"l_{other}_centre_{c}" in r and r.get(f"converged_{other}")]
    if both:
        ax.hist(np.concatenate([r[f"l_{other}_centre_{c}"] for r in both]), bins,
                density=True, histtype="step", ls=":",
                label=rf"{LABELS[other]} samples (own $\bar\ell$)")
    ax.hist(l0, bins, density=True, histtype="stepfilled", alpha=0.4,
            label=rf"jammed networks, $\ell_0/\bar\ell$ ({len(rows)} packings)")
    ax.legend(fontsize=7)
    m, se = _mean_se(l0)
    p_mw = float(mannwhitneyu(l0, pool, alternative="less").pvalue)
    numbers[f"l0_over_lbar_centre_{c}"] = {"mean": m, "se": se, "packings": len(rows),
                                           "fraction_below_1": float((l0 < 1).mean())}
    numbers[f"mannwhitney_p_centre_{c}"] = p_mw
    cross = np.array([r[f"l0_centre_{other}_lbar_{c}"] for r in both]) if both else None
    extra = (f"; with the other sampler's centre {cross.mean():.2f} ± "
             f"{_mean_se(cross)[1]:.2f}" if cross is not None and cross.size > 1 else "")
    return [Verdict(
        "fig3", claim,
        f"l0/lbar = {m:.2f} ± {se:.2f} (samples: 1 ± {pool.std():.2f}); "
        f"{100 * (l0 < 1).mean():.0f} % of {len(rows)} packings below 1; Mann-Whitney "
        f"p = {p_mw:.1e}{extra}", _closer_verdict({"mean": m, "se": se}, p_mw), sampler=c,
        rule="closer: mean l0/lbar two standard errors below 1 and the rank test against "
             "the samples at 1 %; farther: two standard errors above 1")]


def _edge_verdicts(ax, rows, har_rows, numbers) -> list:
    """"...yet on the edge of 2-D sections", as the paper states it, and our two tests of
    x0 against uniform samples (in the sections; in S itself), with the panel."""
    from .report import Verdict
    claim = ("...yet the jammed network lies on the edge of 2-D cross-sections of S (random "
             "planes through it)")
    jam = np.concatenate([r["jammed_edge_ratio"] for r in rows if r.get("jammed_edge_ratio")]
                         or [np.zeros(0)])
    uni = np.concatenate([r["uniform_edge_ratio"] for r in har_rows
                          if r.get("uniform_edge_ratio")] or [np.zeros(0)])
    _edge_panel(ax, jam, uni, len(rows))
    if not jam.size:
        return [Verdict("fig3", claim, "no section", "not decidable")]
    out = [edge_verdict(claim, [r for r in rows if r.get("jammed_edge_ratio")], numbers,
                        uni)]
    return out + nearer_verdicts(har_rows, numbers)


def _edge_panel(ax, jam, uni, packings: int) -> None:
    ax.set(xscale="log", xlabel="distance from the section's boundary / its extent",
           ylabel="sections", title="the jammed network in 2-D sections of S")
    ax.title.set_fontsize(10)
    if not jam.size:
        return
    lo = max(min(jam.min(), uni.min() if uni.size else 1), 1e-8)
    bins = np.logspace(np.log10(lo) - 0.1, 0.1, 40)
    ax.hist(np.maximum(jam, lo), bins, histtype="stepfilled", alpha=0.4,
            label=f"jammed network ({packings} packings x {SECTIONS} sections;\n"
                  f"on the boundary: drawn at {lo:.0e})")
    if uni.size:
        ax.hist(np.maximum(uni, lo), bins, histtype="step", lw=1.5,
                label="uniform samples (reference)")
    ax.axvline(EDGE_RATIO, color="grey", ls="--", lw=1, label=f"edge: < {EDGE_RATIO:g}")
    ax.legend(fontsize=7, loc="upper left")


def _on_edge(r) -> float:
    """The share of a packing's sections with x0 on the edge."""
    return float((np.asarray(r["jammed_edge_ratio"]) < EDGE_RATIO).mean())


def edge_verdict(claim: str, rows: list[dict], numbers: dict, uni=None):
    """The paper's "we always find it at the edge of two dimensional cross sections",
    over packings (rule 6): a packing's jammed network is on the edge when it is so in
    most of its random sections (the median ratio below EDGE_RATIO); reproduced when the
    exact 95 % interval of the share of such packings lies above 1/2, refuted below.
    Beside: the packings whose x0 lies on S's relative boundary (a contact at the
    Coulomb limit: slack exactly 0, or below BOUNDARY_TOL <Fn>), where every generic
    section has x0 on its edge, the case the paper's explanation describes. ``uni``: the
    uniform samples' section ratios, the reference reported beside."""
    from .report import Verdict
    uni = np.zeros(0) if uni is None else np.asarray(uni, float)
    edge = [r for r in rows if np.median(r["jammed_edge_ratio"]) < EDGE_RATIO]
    exact = [r for r in rows if r["jammed_min_slack"] <= 0]
    tol = [r for r in rows if 0 < r["jammed_min_slack"] < BOUNDARY_TOL]
    inside = [r for r in rows if r["jammed_min_slack"] >= BOUNDARY_TOL]
    jam = np.concatenate([r["jammed_edge_ratio"] for r in rows])
    call = stats.majority_call(len(edge), len(rows))
    numbers["edge_ratio"] = {
        "jammed_median": float(np.median(jam)), "jammed_on_edge": float((jam < EDGE_RATIO)
                                                                         .mean()),
        "packings_on_edge": len(edge), "packings": len(rows),
        "packings_at_coulomb_limit_exactly": len(exact),
        "packings_within_boundary_tol": len(tol),
        "uniform_median": float(np.median(uni)) if uni.size else None,
        "uniform_on_edge": float((uni < EDGE_RATIO).mean()) if uni.size else None,
        "sections_on_edge_by_class": {k: float(np.mean([_on_edge(r) for r in g])) if g
                                      else None for k, g in (("exact", exact), ("within_tol",
                                                             tol), ("inside", inside))}}
    by = numbers["edge_ratio"]["sections_on_edge_by_class"]

    def share(g, key):
        return f"{100 * by[key]:.0f} % of their sections" if g else "-"
    return Verdict(
        "fig3", claim,
        f"{len(edge)} of {len(rows)} packings have the jammed network on the edge (distance "
        f"from the section's boundary below {EDGE_RATIO:g} of its extent) in most of their "
        f"{SECTIONS} random sections (median ratio over all sections {np.median(jam):.4f}). "
        f"Beside: {len(exact)} packings have a contact exactly at the Coulomb limit (x0 on "
        f"S's boundary), {len(tol)} one within {BOUNDARY_TOL:g} <Fn> of it: on the edge in "
        f"{share(exact, 'exact')} and {share(tol, 'within_tol')}; the {len(inside)} others "
        f"(smallest slack >= {BOUNDARY_TOL:g} <Fn>): {share(inside, 'inside')}"
        + (f"; uniform samples, each in a random section through itself: "
           f"{100 * (uni < EDGE_RATIO).mean():.0f} % on the edge" if uni.size else ""),
        EDGE_CALL[call],
        rule=f"random planes through x0 (two random orthonormal directions of S's affine "
             f"hull); a packing is on the edge when its median section ratio is below "
             f"{EDGE_RATIO:g}; reproduced when the exact 95 % interval of the share of such "
             f"packings lies above 1/2, refuted when below (issue 45: per packing, after "
             f"the data were seen)")


def _to_decide(k: int, n: int) -> str:
    """What would decide an undecided sign test, if the share stayed ("" if decided)."""
    if stats.majority_call(k, n) != "undecided":
        return ""
    m = stats.packings_to_decide(k, n)
    return (f"; undecided: at this share {m} packings would decide it" if m else
            "; undecided: at this share no number of packings would decide it")


def nearer_verdicts(har_rows: list[dict], numbers: dict) -> list:
    """Ours, one row per test (rule 2): is the jammed network nearer the boundary than
    uniform samples (a) in random 2-D sections (its median section ratio below the
    uniform samples' median, each in a random section through itself) and (b) in S
    itself (its smallest slack below the median uniform sample's: rank < 1/2)? Each
    over packings, a sign test: supported when the exact 95 % interval of the share of
    packings where it is nearer lies above 1/2, not supported below."""
    from .report import Verdict
    rule = ("per packing, nearer than the median uniform sample; supported when the exact "
            "95 % interval of the share of such packings lies above 1/2, not supported "
            "when below (issue 45: a sign test over packings, after the data were seen)")
    out = []
    sec = [r for r in har_rows if r.get("jammed_edge_ratio") and r.get("uniform_edge_ratio")]
    if len(sec) >= 3:
        k = sum(np.median(r["jammed_edge_ratio"]) < np.median(r["uniform_edge_ratio"])
                for r in sec)
        numbers["nearer_in_sections"] = {"packings": len(sec), "nearer": int(k)}
        out.append(Verdict(
            "fig3", "in random 2-D sections the jammed network is nearer the section's "
            "boundary than uniform samples are (each in a random section through itself)",
            f"nearer than the uniform samples' median ratio on {k} of {len(sec)} packings "
            f"(median ratio over the packings: jammed "
            f"{np.median([np.median(r['jammed_edge_ratio']) for r in sec]):.3f}, uniform "
            f"{np.median([np.median(r['uniform_edge_ratio']) for r in sec]):.3f})"
            + _to_decide(k, len(sec)),
            NEARER[stats.majority_call(k, len(sec))],
            sampler="hit_and_run", kind="ours", rule=rule))
    rank = np.array([r["jammed_slack_rank_hit_and_run"] for r in har_rows
                     if "jammed_slack_rank_hit_and_run" in r])
    if rank.size >= 3:
        k = int((rank < 0.5).sum())
        numbers["jammed_slack_rank_hit_and_run"] = {"median": float(np.median(rank)),
                                                    "max": float(rank.max()),
                                                    "packings": int(rank.size), "nearer": k}
        out.append(Verdict(
            "fig3", "in S itself the jammed network is nearer S's boundary than uniform "
            "samples are (smallest slack of its inequalities)",
            f"nearer than the median uniform sample on {k} of {rank.size} packings; share "
            f"of uniform samples nearer than it: median {100 * np.median(rank):.0f} % (max "
            f"{100 * rank.max():.0f} %)" + _to_decide(k, rank.size),
            NEARER[stats.majority_call(k, rank.size)],
            sampler="hit_and_run", kind="ours", rule=rule))
    return out


def _uniformity_verdict(rows, numbers) -> list:
    """Is the relax walk uniform: per-column KS against hit-and-run, beside two hit-and-run
    runs (the null), and the ratio of eta; on packings where all three runs converged."""
    from scipy.stats import wilcoxon

    from .report import Verdict
    claim = ("The paper's perturb-and-relax walk samples S (close to) uniformly (assumed, "
             "not shown, by the paper)")
    ok = [r for r in rows if r.get("converged_relax") and r.get("converged_hit_and_run")
          and r.get("converged_null") and "ks_null" in r]
    numbers["uniformity_packings"] = len(ok)
    if len(ok) < 3:
        return [Verdict("fig3", claim, f"{len(ok)} packings with three converged runs "
                        "(3 needed)", "not decidable", sampler="relax")]
    ks = np.concatenate([r["ks_relax_vs_hit_and_run"] for r in ok])
    null = np.concatenate([r["ks_null"] for r in ok])
    q95 = float(np.quantile(null, 0.95)) if null.size else np.nan
    frac = float((ks > q95).mean()) if ks.size else np.nan
    ratios = np.array([r["eta_relax"] / r["eta_hit_and_run"] for r in ok])
    null_ratios = np.array([r["eta_null"] / r["eta_hit_and_run"] for r in ok])
    pw = float(wilcoxon(np.log(ratios)).pvalue) if len(ok) >= 6 else np.nan
    gm = float(np.exp(np.log(ratios).mean()))
    numbers["ks"] = {"median_relax_vs_hit_and_run": float(np.median(ks)),
                     "median_null": float(np.median(null)), "null_q95": q95,
                     "fraction_above_null_q95": frac, "columns": int(ks.size)}
    numbers["eta_ratio_relax_over_hit_and_run"] = {
        "geometric_mean": gm, "min": float(ratios.min()), "max": float(ratios.max()),
        "wilcoxon_p": pw}
    numbers["eta_ratio_null"] = {"geometric_mean": float(np.exp(np.log(null_ratios).mean())),
                                 "min": float(null_ratios.min()), "max": float(null_ratios.max())}
    uniform = frac <= 0.10 and abs(np.log(gm)) < 0.1
    return [Verdict(
        "fig3", claim,
        f"per-column KS D relax vs hit-and-run: median {np.median(ks):.2f} against "
        f"{np.median(null):.2f} for two uniform runs; {100 * frac:.0f} % of {ks.size} "
        f"columns above the null's 95th percentile (5 % expected if uniform); eta relax / "
        f"hit-and-run = {gm:.2f} (geometric mean over {len(ok)} packings; range "
        f"{ratios.min():.2f}-{ratios.max():.2f}; two uniform runs: "
        f"{numbers['eta_ratio_null']['geometric_mean']:.2f})",
        "reproduced" if uniform else "refuted", sampler="relax",
        rule="uniform: at most 10 % of columns above the null's 95th percentile and eta "
             "within 10 % of hit-and-run's")]


def _closer_verdict(m, p) -> str:
    """Closer: mean l0/lbar two standard errors below 1 and the rank test at 1 %."""
    if m["mean"] + 2 * m["se"] < 1 and p < 0.01:
        return "reproduced"
    if m["mean"] - 2 * m["se"] > 1:
        return "refuted"
    return "not decidable"


def _section_panel(ax, row, out) -> None:
    """The inset: the cross-section of S through the first packing's jammed network
    (packings are not kept with committed results: without it, the panel says so)."""
    par = row["params"]
    p = kept_packing(out, par["scene"], par["mu"], par["seed"], par["n_disks"])
    if p is None:
        no_packing_panel(ax, "cross-section")
        return
    sec = fs.Section(n=121, seed=row["seed"]).compute(fs.slice_problem(p, par["slice_height"]))
    sec.plot(ax, title=f"cross-section of S, seed {row['seed']} (dim S = {row['dim_S']})")


def _section_text(numbers: dict, rows: list[dict]) -> str:
    if not rows:
        return "No usable packing (S empty, unbounded or of dimension < 2 on every one)."
    dims = [r["dim_S"] for r in rows]
    n = [r[k] for r in rows for k in ("n_relax", "n_hit_and_run") if r.get(k)]
    conv, excl = numbers["converged"], numbers["excluded_unconverged"]
    return (
        f"{len(rows)} packings at mu = {rows[0]['mu']} (dim S {min(dims)}-{max(dims)}), "
        f"{min(n, default=0)}-{max(n, default=0)} samples per sampler and packing (4 chains "
        f"each, run to ESS 100). Converged runs (rule 4): hit-and-run {conv['hit_and_run']}, "
        f"relax walk {conv['relax']}; excluded as unconverged: {excl['hit_and_run']} and "
        f"{excl['relax']}; failed runs: {numbers['failed_runs']['hit_and_run']} and "
        f"{numbers['failed_runs']['relax']}. Distances are Euclidean in the space of all "
        "unknown (fn, ft) [F0]; l/lbar uses the mean distance of the same sampler's samples "
        "from the stated centre. Panels, left to right: centre = mean of the hit-and-run "
        "samples; centre = mean of the relax-walk samples (the paper's choice); the jammed "
        f"network's distance from the boundary of {SECTIONS} random 2-D sections of S "
        "through it, over the section's extent, beside the same for uniform samples (each "
        "in a random section through itself); a 2-D cross-section of S through the jammed "
        "network (white inside S, grey by Coulomb violation / <Fn>).\n\n"
        "The uniformity test compares each varying column's marginal: the KS statistic D "
        "of relax vs hit-and-run against D of two independent hit-and-run runs (the null; "
        "consecutive relax samples are correlated, which widens their D even for a uniform "
        "walk, so a modest excess is not decisive, a large one is).")
