"""The paper's Fig. 1: force ambiguity eta and coordination z against friction mu.

Tasks: one per (mu, seed): jam a packing at mu (the paper's protocol), analyse the
slice's S and the whole packing (z, mobilised contacts, the rank-based degree of
indeterminacy), and sample S with both samplers (uniform hit-and-run and the paper's
relax walk, 4 chains each, to ESS 100); and the "squares": frictionless packings with
friction switched on, S taken at each mu of the sweep. A task whose sampling fails
keeps its analysis row.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import forcespace as fs
from forcespace.extend import BOTTOM, TOP, rank
from .runner import Task

from . import stats
from .common import SAMPLERS, determinate, run_samplers, sampler, shared_packing
from .report import (RULES_VERSION, SAMPLERS as LABELS, Verdict, failed_tasks_note, write_csv,
                     write_section)

MUS = sorted({float(f"{m:.3g}") for m in np.logspace(-4, 1, 15)}
             | {0.02, 0.045, 0.1, 0.22, 0.5})   # 15 log values and 5 more around the peak
QUICK = dict(scene="quick", n_disks=30, slice_height=12.0, mus=(0.01, 0.1, 1.0), seeds=(1, 2),
             cap=800, max_seconds=None, squares=1)
FULL = dict(scene="paper", n_disks=200, slice_height=28.0, mus=tuple(MUS),
            seeds=tuple(range(1, 11)), cap=3000, max_seconds=900.0, squares=5)
SMALL_MU = 0.01        # the "small friction" range of the paper's claims (fits, 2Nc - 3n)
PEAK_WINDOW = (0.01, 1.0)   # the parabola for the maximum of eta is fitted here
MOBILISED = 1e-6       # a contact with |ft| >= mu fn (1 - this) is at the Coulomb limit
NEAR_MOBILISED = 0.95  # ... and with |ft| >= 0.95 mu fn nearly so (the usual histogram bin)
DECREASE_FROM = 0.1    # "beyond the maximum": mu >= the paper's maximum, mu ≈ 0.1
TREND_LEVEL = 0.01     # a trend test decides at one-sided p below this


def config(quick: bool) -> dict:
    return QUICK if quick else FULL


def tasks(quick: bool = False) -> list[Task]:
    """Seed-major, so that an interrupted study has complete seed rounds across the sweep:
    for each seed, its own-mu packings (every mu), then, for the first ``squares`` seeds,
    its mu = 0 packing sampled at mu = 0 (the accuracy floor) and at each mu of the sweep
    (the squares), one task each."""
    cfg = config(quick)
    common = dict(scene=cfg["scene"], n_disks=cfg["n_disks"], slice_height=cfg["slice_height"],
                  cap=cfg["cap"], max_seconds=cfg["max_seconds"])
    out = []
    for k, seed in enumerate(cfg["seeds"]):
        out += [Task(f"mu{mu:.3g}_s{seed}", "forcespace_studies.fig1:packing_task",
                     dict(common, mu=mu, seed=seed)) for mu in cfg["mus"]]
        if k < cfg["squares"]:
            out += [Task(f"mu0_on{ms:.3g}_s{seed}", "forcespace_studies.fig1:packing_task",
                         dict(common, mu=0.0, seed=seed, mu_sample=ms))
                    for ms in (0.0, *cfg["mus"])]
    return out


def packing_row(p, mu: float) -> dict:
    """What the whole packing says: z, rattlers, packing fraction, the mobilised contacts
    (force-bearing, at the Coulomb limit), the counting degree 2Nc - 3n (Nc: force-bearing
    contacts of non-rattlers, plate contacts included), and the rank of the full
    problem's equilibrium matrix A (3n rows; columns: its unknowns, which leave out the
    top plate's forces, loads, and the bottom plate's tangential ones, frictionless):
    ``unknowns_full``, ``rank_full``, ``dof_rank_full`` = unknowns - rank, and the plate
    contacts ``nc_top_full``, ``nc_bottom_full`` that the paper's count of two unknowns
    per contact includes."""
    rat = p.rattlers()
    live = p.force_bearing() & ((p.a < 0) | ~rat[np.maximum(p.a, 0)]) \
        & ((p.b < 0) | ~rat[np.maximum(p.b, 0)])
    disk = live & (p.a >= 0) & (p.b >= 0)
    ratio = np.abs(p.ft) / np.maximum(mu * p.fn, 1e-300) if mu > 0 else np.zeros(p.n_contacts)
    mob = disk & (ratio >= 1 - MOBILISED)
    full = fs.full_problem(p)
    free = np.setdiff1d(np.arange(full.n_columns), full.fixed_columns())
    nc, n = int(live.sum()), int((~rat).sum())
    r = int(rank(full.A[:, free]))
    return {"z": p.coordination(), "n_rattlers": int(rat.sum()),
            "rattler_fraction": float(rat.mean()), "packing_fraction": p.packing_fraction(),
            "nc_full": nc, "n_full": n, "dof_excess_full": 2 * nc - 3 * n,
            "unknowns_full": int(free.size), "rank_full": r, "dof_rank_full": int(free.size) - r,
            "nc_top_full": int((live & ((p.a == TOP) | (p.b == TOP))).sum()),
            "nc_bottom_full": int((live & ((p.a == BOTTOM) | (p.b == BOTTOM))).sum()),
            "mobilised": int(mob.sum()), "mobilised_fraction": float(mob.sum() / max(disk.sum(), 1)),
            "near_mobilised_fraction": float((disk & (ratio >= NEAR_MOBILISED)).sum()
                                             / max(disk.sum(), 1)),
            "mobilised_per_disk": float(mob.sum() / max(n, 1))}


def packing_task(scene: str, n_disks: int, slice_height: float, mu: float, seed: int,
                 workdir, cap: int = 3000, max_seconds=None, mu_sample=None) -> dict:
    """Jam (or reuse) the packing (mu, seed), analyse it and its slice's S, sample S both
    ways (``mu_sample``: friction of S instead of the packing's, the squares). A
    determinate S (dim 0) has eta = 0 exactly for mu > 0; at mu_sample = 0 the relax
    walk runs anyway: its eta is the solver's accuracy floor."""
    wd = Path(workdir)
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks)
    prob = fs.slice_problem(p, slice_height, mu=mu_sample)
    t0 = time.perf_counter()
    an = fs.ForceSpace().compute(prob)
    ms = mu if mu_sample is None else mu_sample
    row = {"mu": mu, "mu_sample": ms, "seed": seed, **packing_row(p, mu),
           "slice_contacts": prob.n_contacts, "feasible": an.feasible, "bounded": an.bounded,
           "dim_S": an.dim, "degree_of_indeterminacy": an.degree_of_indeterminacy,
           "analysis_ok": an.success, "t_jam_s": t_jam,
           "t_analyze_s": time.perf_counter() - t0}
    if not (an.success and an.feasible and an.bounded):
        row["error_analysis"] = an.message if not an.success else "S empty or unbounded"
        return {"rows": [row]}
    tag = "" if mu_sample is None else f"_mu{ms:.3g}"
    runs = []
    if an.dim:
        runs.append(("hit_and_run", sampler("hit_and_run", seed, cap, max_seconds)))
    if an.dim or ms == 0:
        runs.append(("relax", sampler("relax", seed, cap, max_seconds)))
    if not an.dim and ms > 0:
        determinate(row)
    elif not an.dim:
        determinate(row, ("hit_and_run",))
    run_samplers(row, runs, prob, wd, tag, analysis=an)
    return {"rows": [row]}


ROW_KEYS = ["task", "mu", "mu_sample", "seed", "z", "n_rattlers", "rattler_fraction",
            "packing_fraction", "mobilised_fraction", "near_mobilised_fraction",
            "mobilised_per_disk", "dim_S",
            "degree_of_indeterminacy", "slice_contacts", "nc_full", "n_full",
            "dof_excess_full", "dof_rank_full", "unknowns_full", "rank_full", "nc_top_full",
            "nc_bottom_full", "analysis_ok", "eta_hit_and_run",
            "converged_hit_and_run", "n_hit_and_run", "ess_hit_and_run", "rhat_hit_and_run",
            "eta_relax", "converged_relax", "n_relax", "ess_relax", "rhat_relax",
            "relax_projected", "stop_hit_and_run", "stop_relax", "error_analysis", "error_hit_and_run", "error_relax",
            "t_jam_s", "t_analyze_s", "t_hit_and_run_s", "t_relax_s"]


def _rows(results):
    return [dict(row, task=r["task"]) for r in results if r.get("ok") for row in r["rows"]]


def by_mu(rows, key, converged: str | None = None) -> dict:
    """{mu_sample: array over packings of ``key``}: None values dropped, and with
    ``converged`` (a sampler name) only its converged runs (rule 4)."""
    out: dict = {}
    for r in rows:
        if r.get(key) is None or (converged and not r.get(f"converged_{converged}")):
            continue
        out.setdefault(r["mu_sample"], []).append(float(r[key]))
    return {m: np.array(v) for m, v in sorted(out.items())}


def exclusions(rows, name) -> dict:
    """{mu: [runs excluded from sampler ``name``'s verdicts (rule 4), failed runs]}."""
    out: dict = {}
    for r in rows:
        if r.get("dim_S") is None:
            continue
        ex = r.get(f"eta_{name}") is not None and not r.get(f"converged_{name}")
        fail = bool(r.get(f"error_{name}"))
        if ex or fail:
            e = out.setdefault(f"{r['mu_sample']:g}", [0, 0])
            e[0] += ex
            e[1] += fail
    return out


def summarize(results: list[dict], out) -> dict:
    """fig1.csv (one row per S), fig1_by_mu.csv, fig1.png/.pdf, verdicts.json, REPORT.md."""
    out = Path(out)
    rows = _rows(results)
    failed = [r for r in results if not r.get("ok")]
    write_csv(out / "fig1.csv", rows, ROW_KEYS)
    own = [r for r in rows if r["mu"] > 0]
    squares = [r for r in rows if r["mu"] == 0 and r["mu_sample"] > 0]
    floor_rows = [r for r in rows if r["mu"] == 0 and r["mu_sample"] == 0]
    eta = {k: by_mu(own, f"eta_{k}", converged=k) for k in SAMPLERS}
    band = {k: stats.bootstrap_mean(eta[k]) for k in SAMPLERS}
    by_mu_rows = _by_mu_table(own, eta, band)
    if by_mu_rows:
        write_csv(out / "fig1_by_mu.csv", by_mu_rows, list(by_mu_rows[0]))
    numbers, verdicts = _verdicts(own, squares, floor_rows, eta)
    numbers.update({"tasks": len(results), "tasks_failed": len(failed),
                    "failed": [f"{r['task']}: {r.get('error')}" for r in failed],
                    "excluded_and_failed_runs_per_mu": {k: exclusions(own, k)
                                                        for k in SAMPLERS}})
    figures = ["fig1.png"] if own else []
    if own:
        _figure(out, own, squares, floor_rows, eta, band, numbers)
    text = _text(own, squares, floor_rows, numbers)
    text += failed_tasks_note(failed, results)
    write_section(out, "fig1", "Fig. 1: force ambiguity and coordination against friction",
                  text, verdicts, numbers, figures=figures, rules_version=RULES_VERSION)
    return {"tasks": len(results), "failed": len(failed), "rows": len(rows),
            "table": str(out / "fig1.csv"), "figures": figures,
            "verdicts": [v.verdict for v in verdicts]}


def _by_mu_table(own, eta, band) -> list[dict]:
    z = by_mu(own, "z")
    dim = by_mu(own, "dim_S")
    fm = by_mu(own, "mobilised_fraction")
    fm95 = by_mu(own, "near_mobilised_fraction")
    out = []
    for m in z:
        d = dim.get(m, np.array([]))
        row = {"mu": m, "packings": int(z[m].size), "z_mean": z[m].mean(), "z_sd": z[m].std(),
               "mobilised_fraction_mean": fm[m].mean() if m in fm else None,
               "near_mobilised_fraction_mean": fm95[m].mean() if m in fm95 else None,
               "dim_S_mean": d.mean() if d.size else None,
               "fraction_dim_S_0": float((d == 0).mean()) if d.size else None}
        for k in eta:
            b = band[k].get(m)
            row.update({f"eta_{k}_mean": b[0] if b else None, f"eta_{k}_lo": b[1] if b else None,
                        f"eta_{k}_hi": b[2] if b else None,
                        f"eta_{k}_packings": int(eta[k][m].size) if m in eta[k] else 0})
        out.append(row)
    return out


def _figure(out, own, squares, floor_rows, eta, band, numbers) -> None:
    from matplotlib.figure import Figure

    from forcespace.extend import LABELS as PLOT_LABELS, save_figure

    fig = Figure(figsize=(15, 6.4))
    ax1, ax2, ax3 = fig.subplots(1, 3)
    for k, colour in (("hit_and_run", "C0"), ("relax", "C1")):
        ms = [m for m, b in band[k].items() if b[0] > 0]
        mean = np.array([band[k][m][0] for m in ms])
        lo = np.array([band[k][m][1] for m in ms])
        hi = np.array([band[k][m][2] for m in ms])
        ax1.fill_between(ms, np.maximum(lo, 1e-12), hi, color=colour, alpha=0.2, lw=0)
        ax1.plot(ms, mean, "o-", color=colour, mfc=colour if k == "hit_and_run" else "white",
                 ms=4, lw=1, label=f"{LABELS[k]}: mean, 95 % band over packings")
        pk = numbers.get(f"eta_peak_{k}", {})
        if pk.get("peak"):
            ax1.axvline(pk["peak"], color=colour, ls=":", lw=1,
                        label=rf"{LABELS[k]}: fitted maximum $\mu$ = {pk['peak']:.2g}")
        sq = by_mu(squares, f"eta_{k}", converged=k)
        sqm = [m for m in sq if sq[m].mean() > 0]
        ax1.plot(sqm, [sq[m].mean() for m in sqm], "s--", color=colour, mfc="none", lw=0.8,
                 ms=4, label=rf"$\mu$ = 0 packings with friction on, {LABELS[k]}")
    floor = [r["eta_relax"] for r in floor_rows if r.get("eta_relax") is not None]
    if floor:
        ax1.axhline(np.mean(floor), color="grey", ls="--", lw=1,
                    label=f"our accuracy floor (relax walk, frictionless S): "
                          f"{np.mean(floor):.1e}")
    positive = [b[0] for k in band for b in band[k].values() if b[0] > 0]
    if positive:      # a band reaching 0 (determinate packings) is cut at the axis
        ax1.set_ylim(bottom=0.1 * min(positive + ([np.mean(floor)] if floor else [])))
    ax1.set(xscale="log", yscale="log", xlabel=PLOT_LABELS.get("mu", r"$\mu$"),
            ylabel=r"$\eta = \langle \delta F \rangle / \langle |F| \rangle$",
            title="force ambiguity (converged chains only)")
    below = dict(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), frameon=False)
    ax1.legend(**below)        # legends under their panels: never on the data
    z, fm = by_mu(own, "z"), by_mu(own, "mobilised_fraction")
    zm = list(z)
    ax2.errorbar(zm, [z[m].mean() for m in zm], [z[m].std() for m in zm], fmt="o-", ms=4,
                 capsize=2, color="C2", label=r"$z$ (rattlers excluded), mean $\pm$ sd")
    ax2.set(xscale="log", xlabel=r"$\mu$", ylabel=r"coordination $z$",
            title="coordination and mobilisation")
    ax2b = ax2.twinx()
    ax2b.plot(list(fm), [v.mean() for v in fm.values()], "v:", color="C3", mfc="none",
              label=r"fraction of contacts at $|f_t| = \mu f_n$")
    fm95 = by_mu(own, "near_mobilised_fraction")
    ax2b.plot(list(fm95), [v.mean() for v in fm95.values()], "^:", color="C4", mfc="none",
              label=rf"fraction at $|f_t| \geq {NEAR_MOBILISED:g}\,\mu f_n$")
    ax2b.set(ylabel="mobilised fraction", ylim=(0, 1))
    h1, l1 = ax2.get_legend_handles_labels()
    h2, l2 = ax2b.get_legend_handles_labels()
    ax2.legend(h1 + h2, l1 + l2, **below)
    dim, doi = by_mu(own, "dim_S"), by_mu(own, "degree_of_indeterminacy")
    dm = list(dim)
    ax3.plot(dm, [dim[m].mean() for m in dm], "o-", ms=4, label=r"dim $S$ (slice)")
    ax3.plot(list(doi), [v.mean() for v in doi.values()], "x--",
             label=r"degree of indeterminacy $2m - \mathrm{rank}\,A$ (slice)")
    ax3.set(xscale="log", xlabel=r"$\mu$", ylabel="dimension", title=r"size of $S$")
    ax3b = ax3.twinx()
    ax3b.plot(dm, [(dim[m] == 0).mean() for m in dm], "k^:", mfc="none",
              label=r"fraction with dim $S$ = 0")
    ax3b.set(ylabel="fraction", ylim=(0, 1.05))
    h1, l1 = ax3.get_legend_handles_labels()
    h2, l2 = ax3b.get_legend_handles_labels()
    ax3.legend(h1 + h2, l1 + l2, **below)
    save_figure(fig, out / "fig1.png", tight=True)


def _verdicts(own, squares, floor_rows, eta):
    numbers: dict = {}
    verdicts: list[Verdict] = []
    if not own:
        return numbers, verdicts
    for k in SAMPLERS:
        verdicts += _eta_verdicts(own, eta[k], k, numbers)
        verdicts += _square_verdicts(squares, k, numbers)
    verdicts += _packing_verdicts(own, floor_rows, numbers)
    floor = [r["eta_relax"] for r in floor_rows if r.get("eta_relax") is not None]
    if floor:
        numbers["accuracy_floor_eta"] = [float(np.mean(floor)), float(np.max(floor))]
        verdicts.append(Verdict(
            "fig1", "eta ≈ 1e-7 in the frictionless limit is the calculation's accuracy "
            "floor", f"a fact about the paper's solver; ours: the relax walk on the "
            f"frictionless, determinate S gives eta = {np.mean(floor):.1e} (every sample "
            f"within 1e-9 <Fn> of S)", "not applicable", sampler="relax"))
    both = [(r["eta_relax"], r["eta_hit_and_run"]) for r in own
            if r.get("converged_relax") and r.get("converged_hit_and_run")
            and r.get("eta_hit_and_run")]
    if both:
        q = np.array([a / b for a, b in both])
        numbers["eta_relax_over_hit_and_run"] = {
            "geometric_mean": float(np.exp(np.log(q).mean())),
            "quantiles_5_50_95": np.quantile(q, [0.05, 0.5, 0.95]).tolist(), "n": int(q.size)}
    return numbers, verdicts


def _eta_verdicts(own, eta, k, numbers) -> list[Verdict]:
    out = []
    small = [(m, e) for m, v in eta.items() if 0 < m <= SMALL_MU for e in v if e > 0]
    fit = stats.slope_interval(*zip(*small)) if len(small) >= 3 else None
    numbers[f"small_mu_slope_{k}"] = fit
    if fit:
        out.append(Verdict(
            "fig1", f"eta grows proportionally to mu at small mu (mu <= {SMALL_MU})",
            f"d log eta / d log mu = {fit['slope']:.3f} (95 %: {fit['lo']:.3f} to "
            f"{fit['hi']:.3f}), {fit['points']} packings",
            stats.interval_verdict(fit["lo"], fit["hi"], (0.8, 1.2)), sampler=k,
            rule="the slope's 95 % interval inside [0.8, 1.2]"))
    pk = stats.peak_bootstrap(eta, PEAK_WINDOW)
    numbers[f"eta_peak_{k}"] = pk
    near = stats.near(0.1)
    out.append(Verdict(
        "fig1", "eta is largest around mu ≈ 0.1",
        (f"fitted maximum at mu = {pk['peak']:.3g} (95 % bootstrap interval "
         f"{pk['lo']:.3g}-{pk['hi']:.3g}; parabola in log-log over mu in "
         f"{PEAK_WINDOW[0]:g}-{PEAK_WINDOW[1]:g}, {pk['points']} packings)")
        if pk["peak"] else f"no maximum inside mu {PEAK_WINDOW[0]:g}-{PEAK_WINDOW[1]:g} "
                           f"(the fitted parabola curves up)",
        stats.interval_verdict(pk["lo"], pk["hi"], near) if pk["peak"] else "refuted",
        sampler=k, rule=f"the maximum's 95 % interval inside {near[0]:.3g}-{near[1]:.3g} "
                        "(half a decade either side of 0.1)"))
    decrease = decrease_verdict(eta, k, numbers)
    return out + ([decrease] if decrease else [])


def decrease_verdict(eta: dict, k: str, numbers: dict) -> Verdict | None:
    """"For larger mu it decreases again": a trend, judged by a trend test (rule 2) over
    every packing at mu >= DECREASE_FROM (the paper's maximum), converged runs of sampler
    ``k`` (rule 4); a determinate packing (dim S = 0) counts with eta = 0, as it is (the
    paper's "fully determined states", the end of the decrease). Rule fixed in issue 45,
    after the earlier reading (one grid point against the maximum) was seen."""
    pts = [(m, e) for m, v in eta.items() if m >= DECREASE_FROM for e in v]
    if len(pts) < 3:
        return None
    x, y = np.array(pts).T
    t = stats.trend_test(x, y, TREND_LEVEL)
    numbers[f"eta_trend_beyond_maximum_{k}"] = dict(t, determinate=int((y == 0).sum()),
                                                    mus=int(np.unique(x).size))
    lo_mu, hi_mu = x.min(), x.max()
    means = {m: float(np.mean(v)) for m, v in eta.items() if m in (lo_mu, hi_mu)}
    return Verdict(
        "fig1", "eta decreases beyond the maximum",
        f"Kendall tau(mu, eta) = {t['tau']:.2f} (one-sided p = {t['p_decreasing']:.1e} for a "
        f"decrease) over {t['points']} packings at {np.unique(x).size} values of mu from "
        f"{lo_mu:g} to {hi_mu:g}, {int((y == 0).sum())} of them determinate (eta = 0); mean "
        f"eta {means[lo_mu]:.3g} at mu = {lo_mu:g}, {means[hi_mu]:.3g} at mu = {hi_mu:g}",
        {"decreases": "reproduced", "increases": "refuted"}.get(t["call"], "not decidable"),
        sampler=k, rule=f"trend test over every packing at mu >= {DECREASE_FROM:g} (the "
                        f"paper's maximum): Kendall's tau-b below 0 at one-sided p < "
                        f"{TREND_LEVEL:g}; determinate packings count with eta = 0 (issue "
                        f"45, after the data were seen: it was the largest mu's interval "
                        f"against those near the fitted maximum)")


def _square_verdicts(squares, k, numbers) -> list[Verdict]:
    """The frictionless packings with friction switched on: eta rises monotonically."""
    ok, n, worst = 0, 0, float("inf")
    for seed in sorted({r["seed"] for r in squares}):
        seq = sorted((r["mu_sample"], r[f"eta_{k}"]) for r in squares
                     if r["seed"] == seed and r.get(f"converged_{k}")
                     and r.get(f"eta_{k}") is not None)
        e = np.array([v for _, v in seq])
        if e.size >= 3:
            n += 1
            steps = e[1:] / np.maximum(e[:-1], 1e-300)
            worst = min(worst, float(steps.min()))
            ok += bool((steps >= 0.9).all())
    numbers[f"squares_{k}"] = {"packings": n, "monotonic": ok, "smallest_step_ratio": worst}
    if not n:
        return []
    return [Verdict(
        "fig1", "a frictionless packing with friction switched on: eta rises monotonically "
        "with mu", f"{ok} of {n} packings monotonic (smallest ratio of consecutive values "
        f"{worst:.3f})", "reproduced" if ok == n else "refuted", sampler=k,
        rule="every ratio of consecutive values >= 0.9 (10 % for sampling noise at ESS 100) "
             "on every packing")]


def _packing_verdicts(own, floor_rows, numbers) -> list[Verdict]:
    z, dim = by_mu(own, "z"), by_mu(own, "dim_S")
    zlo, zhi = min(z), max(z)
    z0 = np.array([r["z"] for r in floor_rows])
    numbers["z"] = {"mu0": [float(z0.mean()), float(z0.std())] if z0.size else None,
                    f"mu{zlo:g}": [float(z[zlo].mean()), float(z[zlo].std())],
                    f"mu{zhi:g}": [float(z[zhi].mean()), float(z[zhi].std())]}
    out = [Verdict("fig1", "z ≈ 4 as mu → 0 (isostatic frictionless packings)",
                   f"z = {z[zlo].mean():.3f} ± {z[zlo].std():.3f} at mu = {zlo:g}"
                   + (f"; {z0.mean():.3f} ± {z0.std():.3f} at mu = 0" if z0.size else ""),
                   "reproduced" if abs(z[zlo].mean() - 4) < 0.05 else "refuted",
                   rule="mean within 0.05 of 4")]
    if zhi >= 1:
        out.append(Verdict("fig1", "z falls towards ≈ 3 at large mu",
                           f"z = {z[zhi].mean():.3f} ± {z[zhi].std():.3f} at mu = {zhi:g}",
                           "reproduced" if 2.9 <= z[zhi].mean() <= 3.35 else "refuted",
                           rule="mean in [2.9, 3.35] at the largest mu"))
    frac = {m: float((v == 0).mean()) for m, v in dim.items() if m >= 0.5}
    numbers["fraction_dim_S_0"] = {f"{m:.3g}": [f, int(dim[m].size)] for m, f in frac.items()}
    if frac:
        out.append(Verdict(
            "fig1", "fully determined packings (dim S = 0) appear at large mu (around 1)",
            "fraction with dim S = 0 (packings analysed): " + ", ".join(
                f"{f:.2f} of {dim[m].size} at mu = {m:.2g}" for m, f in frac.items()),
            "reproduced" if any(f > 0 for f in frac.values()) else "refuted",
            rule="at least one packing with dim S = 0 at mu >= 0.5"))
    small = [r for r in own if r["mu"] <= SMALL_MU]
    if small:
        q = np.array([r["dof_excess_full"] / (r["nc_full"] / 2) for r in small])
        numbers["dof_over_half_nc_small_mu"] = {"counting": [float(q.mean()), float(q.std())]}
        out.append(Verdict(
            "fig1", "degree of indeterminacy 2Nc - 3n ≈ Nc/2 at small mu",
            f"(2Nc - 3n) / (Nc/2) = {q.mean():.3f} ± {q.std():.3f} (force-bearing contacts, "
            f"non-rattler disks, walls counted; it restates z ≈ 4)",
            "reproduced" if abs(q.mean() - 1) < 0.1 else "refuted",
            rule="mean within 10 % of 1, counted as the paper counts"))
        out.append(rank_degree_verdict(small, numbers))
    return out


RANK_CLAIM = ("the same degree from the rank of the equilibrium matrix, the unknowns counted "
              "as the paper counts them (two per contact, plate contacts included): "
              f"2Nc - rank(A) ≈ Nc/2 at small mu (mu <= {SMALL_MU})")


def rank_degree_verdict(small: list[dict], numbers: dict) -> Verdict:
    """The project's check of the paper's count by the rank of the full packing's
    equilibrium matrix A (3n rows): the unknowns counted as the paper counts them, two per
    force-bearing contact (Nc, plates included), the degree is 2Nc - rank A; it equals the
    paper's 2Nc - 3n up to 3n - rank A (1 for a rigid packing: the horizontal balance of
    the whole packing holds identically). The full problem's own unknowns - rank A is
    short of it by the plates' share 2 N_top + N_bottom (top-plate forces are loads, the
    bottom plate frictionless), less two per touching contact that carries no force. Rows
    written before the plate counts and rank A were recorded cannot split the gap: not
    decidable."""
    half = np.array([r["nc_full"] / 2 for r in small])
    ours = np.array([r["dof_rank_full"] for r in small]) / half
    gap = np.array([r["dof_excess_full"] - r["dof_rank_full"] for r in small])
    rule = ("mean of (2Nc - rank A) / (Nc/2) within 10 % of 1, Nc the force-bearing "
            "contacts with the plates' (two unknowns each, as the paper counts; the full "
            "problem has none for the top plate, a load, and one per bottom-plate contact, "
            "frictionless); not decidable without the plate counts and rank A (issue 45: "
            "the earlier reading compared the full problem's unknowns - rank A)")
    numbers["dof_over_half_nc_small_mu"]["rank_full_problem"] = [float(ours.mean()),
                                                                  float(ours.std())]
    if any(r.get("rank_full") is None or r.get("nc_top_full") is None for r in small):
        return Verdict(
            "fig1", RANK_CLAIM,
            f"(unknowns - rank A) / (Nc/2) = {ours.mean():.3f} ± {ours.std():.3f} on the full "
            f"packings, whose top-plate forces are loads (no unknowns) and bottom plate "
            f"frictionless (one unknown per contact); the gap to the paper's count, (2Nc - "
            f"3n) - (unknowns - rank A) = {gap.mean():.1f} ± {gap.std():.1f} per packing, is "
            f"the plates' share 2 N_top + N_bottom less 3n - rank A (>= 1: the horizontal "
            f"balance of the whole packing holds identically) and two per touching contact "
            f"without force; these {len(small)} rows "
            f"predate the plate counts and cannot split it (the current code records N_top, "
            f"N_bottom and rank A; the jammed packings are not kept)",
            "not decidable", kind="ours", rule=rule)
    paper = np.array([2 * r["nc_full"] - r["rank_full"] for r in small]) / half
    plates = np.array([2 * r["nc_top_full"] + r["nc_bottom_full"] for r in small])
    deficit = np.array([3 * r["n_full"] - r["rank_full"] for r in small])
    numbers["dof_over_half_nc_small_mu"].update(
        {"rank_paper_count": [float(paper.mean()), float(paper.std())],
         "plates_share": [float(plates.mean()), float(plates.std())],
         "three_n_minus_rank": [int(deficit.min()), int(deficit.max())]})
    return Verdict(
        "fig1", RANK_CLAIM,
        f"(2Nc - rank A) / (Nc/2) = {paper.mean():.3f} ± {paper.std():.3f} on the full "
        f"packings, mu <= {SMALL_MU} ({len(small)} packings); 3n - rank A = "
        f"{deficit.min()}-{deficit.max()}; beside: the full problem's own unknowns - rank A = "
        f"{ours.mean():.3f} ± {ours.std():.3f} of Nc/2, short by the plates' share 2 N_top + "
        f"N_bottom = {plates.mean():.1f} ± {plates.std():.1f} (top-plate forces are loads, "
        "the bottom plate is frictionless; less two per touching contact without force)",
        "supported" if abs(paper.mean() - 1) < 0.1 else "not supported", kind="ours",
        rule=rule)


def _text(own, squares, floor_rows, numbers) -> str:
    if not own:
        return "No finished task."
    n_pack = len({(r["mu"], r["seed"]) for r in own})
    mus = sorted({r["mu"] for r in own})
    n = sorted({r["n_full"] + r["n_rattlers"] for r in own})
    proj = sum(r.get("relax_projected") or 0 for r in own)
    ex = numbers["excluded_and_failed_runs_per_mu"]
    excl = "; ".join(f"{LABELS[k]}: {sum(v[0] for v in ex[k].values())} unconverged and "
                     f"{sum(v[1] for v in ex[k].values())} failed runs" for k in SAMPLERS)
    return (
        f"{n_pack} packings ({n[0]} disks, the scene's protocol) at {len(mus)} values of mu "
        f"from {mus[0]:g} to {mus[-1]:g}, one new packing per mu and seed; S of the middle "
        f"slice sampled by uniform hit-and-run and by the paper's relax walk, each in 4 "
        f"chains until every tracked statistic reached ESS 100 with split R-hat <= 1.05. "
        f"Squares: {len({r['seed'] for r in squares})} frictionless packings with S taken "
        f"at each mu. eta of a determinate S (dim S = 0) is 0 exactly (no sampling). Left: "
        f"eta with its 95 % bootstrap band over the converged packings and the fitted "
        f"maximum; middle: z and the fraction of contacts at the Coulomb limit; right: dim S, "
        f"the degree of indeterminacy of the slice and the fraction of determinate "
        f"packings.\n\nExcluded from the verdicts (rule 4): {excl} (per mu in the numbers "
        f"below). Relax samples finished by the exact projection after a stall: {proj}. "
        f"The mobilised fraction is the share of disk-disk force-bearing contacts with "
        f"|ft| = mu fn (to {MOBILISED:g}); generalised isostaticity relates it to z.")
