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

import forcespace as fs
from forcespace.sweep import Task

from .common import shared_packing

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
    out = [Task(f"mu{mu:.3g}_s{seed}", "forcespace_studies.fig1:packing_task",
                dict(common, mu=mu, seed=seed)) for mu in cfg["mus"] for seed in cfg["seeds"]]
    for seed in cfg["seeds"][:N_SQUARES]:
        for ms in (0.0, *cfg["mus"]):
            out.append(Task(f"mu0_on{ms:.3g}_s{seed}", "forcespace_studies.fig1:packing_task",
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
    wd = Path(workdir)
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks)
    rat = p.rattlers()
    live = p.force_bearing() & ((p.a < 0) | ~rat[np.maximum(p.a, 0)]) \
        & ((p.b < 0) | ~rat[np.maximum(p.b, 0)])
    prob = fs.slice_problem(p, slice_height, mu=mu_sample)
    t0 = time.perf_counter()
    an = fs.ForceSpace().compute(prob)
    row = {"mu": mu, "mu_sample": mu if mu_sample is None else mu_sample, "seed": seed,
           "z": p.coordination(), "n_rattlers": int(rat.sum()),
           "nc_full": int(live.sum()), "n_full": int((~rat).sum()),
           "dof_excess_full": int(2 * live.sum() - 3 * (~rat).sum()),
           "slice_contacts": prob.n_contacts, "feasible": an.feasible,
           "bounded": an.bounded, "dim_S": an.dim,
           "degree_of_indeterminacy": an.degree_of_indeterminacy,
           "t_jam_s": t_jam, "t_analyze_s": time.perf_counter() - t0,
           "eta_hit_and_run": None, "eta_relax": None}
    if not (an.feasible and an.bounded):
        return {"rows": [row]}
    tag = "" if mu_sample is None else f"_mu{mu_sample:.3g}"
    runs = []
    if an.dim:
        runs.append(("hit_and_run", fs.HitAndRun(n=samples, seed=seed)))
    else:
        row["eta_hit_and_run"] = 0.0                  # S is one point: no ambiguity
    if an.dim or row["mu_sample"] == 0:
        runs.append(("relax", fs.RelaxWalk(n=samples, seed=seed)))
    else:
        row["eta_relax"] = 0.0
    run_samplers(row, runs, prob, wd, max_seconds, tag)
    return {"rows": [row]}


def run_samplers(row: dict, runs, prob, wd, max_seconds, tag: str = "",
                 min_samples: int = 1) -> None:
    """Run each (name, sampler) of ``runs`` on ``prob`` into ``wd/NAME{tag}.h5`` and add
    eta_NAME (None below ``min_samples`` samples), n_NAME, t_NAME_s and the sampler's
    diagnostics (relax: projected stalls; hit-and-run: R-hat, thinning) to ``row``."""
    for name, sampler in runs:
        t0 = time.perf_counter()
        sampler.max_seconds = max_seconds
        ens = sampler.compute(prob, output=wd / f"{name}{tag}.h5").ensemble
        summary = sampler.summary()
        row[f"eta_{name}"] = ens.eta if ens.n_samples >= min_samples else None
        row[f"n_{name}"] = ens.n_samples
        row[f"t_{name}_s"] = time.perf_counter() - t0
        if name == "relax":
            row["relax_projected"] = summary.get("n_projected")
        else:
            row["rhat_hit_and_run"] = summary.get("rhat_projections_max")
            row["thin_hit_and_run"] = summary["params"]["thin"]


ROW_KEYS = ["task", "mu", "mu_sample", "seed", "z", "n_rattlers", "dim_S",
            "degree_of_indeterminacy", "slice_contacts", "nc_full", "n_full", "dof_excess_full",
            "eta_hit_and_run", "eta_relax", "n_hit_and_run", "n_relax", "relax_projected",
            "rhat_hit_and_run", "t_jam_s", "t_analyze_s", "t_hit_and_run_s", "t_relax_s"]
SMALL_MU = 0.01        # the "small friction" range of the paper's claims (fits, 2Nc - 3n)
SAMPLER_LABEL = {"hit_and_run": "hit-and-run (uniform)", "relax": "relax walk (paper)"}


def _rows(results):
    return [dict(row, task=r["task"]) for r in results if r.get("ok") for row in r["rows"]]


def _by_mu(rows, key):
    """{mu: array of the key over packings}, None entries dropped."""
    out: dict = {}
    for r in rows:
        if r.get(key) is not None:
            out.setdefault(r["mu_sample"], []).append(float(r[key]))
    return {m: np.array(v) for m, v in sorted(out.items())}


def slope_fit(mu, eta) -> tuple[float, float]:
    """Least-squares slope of log eta against log mu, and its standard error."""
    x, y = np.log(np.asarray(mu, float)), np.log(np.asarray(eta, float))
    if x.size < 3 or np.ptp(x) == 0:
        return float("nan"), float("nan")
    X = np.column_stack([np.ones_like(x), x])
    coef, res, *_ = np.linalg.lstsq(X, y, rcond=None)
    resid = y - X @ coef
    s2 = resid @ resid / (x.size - 2)
    cov = s2 * np.linalg.inv(X.T @ X)
    return float(coef[1]), float(np.sqrt(cov[1, 1]))


def location_verdict(lo: float, hi: float, near: float = 0.1) -> str:
    """Is an extremum "near ``near``"? Its 95 % interval [lo, hi] within half a decade of
    it (a factor sqrt(10), with a hair of round-off): reproduced; the interval excluding
    it: refuted; otherwise not decidable."""
    f = np.sqrt(10.0) * (1 + 1e-9)
    if near / f <= lo and hi <= near * f:
        return "reproduced"
    if hi < near or lo > near:
        return "refuted"
    return "not decidable"


def argmax_bootstrap(by_mu: dict, n_boot: int = 2000, seed: int = 0):
    """mu of the largest mean eta, and its 2.5-97.5 % bootstrap interval over packings."""
    mus = np.array(list(by_mu))
    means = np.array([v.mean() for v in by_mu.values()])
    rng = np.random.default_rng(seed)
    picks = []
    for _ in range(n_boot):
        m = [rng.choice(v, v.size).mean() for v in by_mu.values()]
        picks.append(mus[int(np.argmax(m))])
    lo, hi = np.quantile(picks, [0.025, 0.975], method="inverted_cdf")   # grid values
    return float(mus[int(np.argmax(means))]), float(lo), float(hi)


def summarize(results: list[dict], out) -> dict:
    """fig1.csv (one row per S), fig1_by_mu.csv, fig1.png/.pdf, verdicts.json, REPORT.md."""
    from matplotlib.figure import Figure

    from forcespace.plot import save_figure
    from .report import write_csv, write_section

    out = Path(out)
    rows = _rows(results)
    failed = [r for r in results if not r.get("ok")]
    write_csv(out / "fig1.csv", rows, ROW_KEYS)
    own = [r for r in rows if r["mu"] > 0]
    squares = [r for r in rows if r["mu"] == 0 and r["mu_sample"] > 0]
    floor_rows = [r for r in rows if r["mu"] == 0 and r["mu_sample"] == 0]
    floor = np.array([r["eta_relax"] for r in floor_rows if r.get("eta_relax") is not None])
    eta = {k: _by_mu(own, f"eta_{k}") for k in SAMPLER_LABEL}
    z = _by_mu(own, "z")
    dim = _by_mu(own, "dim_S")
    doi = _by_mu(own, "degree_of_indeterminacy")
    ratio_doi = _by_mu([dict(r, q=r["dof_excess_full"] / (r["nc_full"] / 2)) for r in own], "q")
    by_mu_rows = []
    for m in z:
        d = dim.get(m, np.array([]))
        by_mu_rows.append({
            "mu": m, "packings": int(z[m].size), "z_mean": z[m].mean(), "z_sd": z[m].std(),
            "dim_S_mean": d.mean() if d.size else None,
            "fraction_dim_S_0": float((d == 0).mean()) if d.size else None,
            "degree_of_indeterminacy_mean": doi[m].mean() if m in doi else None,
            "dof_excess_over_half_nc": ratio_doi[m].mean() if m in ratio_doi else None,
            **{f"eta_{k}_mean": eta[k][m].mean() if m in eta[k] else None for k in eta},
            **{f"eta_{k}_sd": eta[k][m].std() if m in eta[k] else None for k in eta}})
    if by_mu_rows:
        write_csv(out / "fig1_by_mu.csv", by_mu_rows, list(by_mu_rows[0]))

    fig = Figure(figsize=(14, 4.4))
    ax1, ax2, ax3 = fig.subplots(1, 3)
    for k, colour in (("hit_and_run", "C0"), ("relax", "C1")):
        pts = np.array([(r["mu_sample"], r[f"eta_{k}"]) for r in own
                        if r.get(f"eta_{k}")], float).reshape(-1, 2)
        ax1.plot(pts[:, 0], pts[:, 1], ".", color=colour, alpha=0.3, ms=4)
        ms = [m for m in eta[k] if eta[k][m].mean() > 0]
        mean = np.array([eta[k][m].mean() for m in ms])
        sd = np.array([eta[k][m].std() for m in ms])
        ax1.errorbar(ms, mean, [np.minimum(sd, 0.95 * mean), sd],   # log axis: clip below
                     fmt="o", color=colour, mfc=colour if k == "hit_and_run" else "none",
                     capsize=2, label=f"own packing, {SAMPLER_LABEL[k]}")
        sq = _by_mu(squares, f"eta_{k}")
        ms = [m for m in sq if sq[m].mean() > 0]
        ax1.plot(ms, [sq[m].mean() for m in ms], "s-", color=colour, mfc="none", lw=0.8,
                 label=f"mu = 0 packings, friction on, {SAMPLER_LABEL[k]}")
    if floor.size:
        ax1.axhline(floor.mean(), color="grey", ls="--", lw=1,
                    label=f"accuracy floor (relax walk on frictionless S): {floor.mean():.1e}")
    ax1.set(xscale="log", yscale="log", xlabel="mu", ylabel="eta = <dF> / <|F|>",
            title="force ambiguity (mean ± sd over packings)")
    ax1.legend(fontsize=6.5, loc="lower right")
    zm = list(z)
    ax2.errorbar(zm, [z[m].mean() for m in zm], [z[m].std() for m in zm], fmt="o", mfc="none",
                 capsize=2, label="own packing")
    z0 = np.array([r["z"] for r in floor_rows])
    if z0.size:
        ax2.axhline(z0.mean(), color="grey", ls=":", label=f"mu = 0: z = {z0.mean():.3f}")
    ax2.set(xscale="log", xlabel="mu", ylabel="z (rattlers excluded)",
            title="coordination number")
    ax2.legend(fontsize=7)
    dm = list(dim)
    ax3.plot(dm, [dim[m].mean() for m in dm], "o-", label="dim S (slice)")
    ax3.plot(list(doi), [v.mean() for v in doi.values()], "x--",
             label="degree of indeterminacy 2m - rank A (slice)")
    ax3.set(xscale="log", xlabel="mu", ylabel="dimension", title="size of S")
    ax3b = ax3.twinx()
    ax3b.plot(dm, [(dim[m] == 0).mean() for m in dm], "k^:", mfc="none",
              label="fraction with dim S = 0")
    ax3b.plot(list(ratio_doi), [v.mean() for v in ratio_doi.values()], "gv:", mfc="none",
              label="(2Nc - 3n) / (Nc/2), full packing")
    ax3b.set(ylabel="fraction, ratio", ylim=(0, 1.3))
    h1, l1 = ax3.get_legend_handles_labels()
    h2, l2 = ax3b.get_legend_handles_labels()
    ax3.legend(h1 + h2, l1 + l2, fontsize=6.5, loc="center left")
    fig.tight_layout()
    save_figure(fig, out / "fig1.png")

    numbers, verdicts = _verdicts(own, squares, floor, floor_rows, eta, z, dim, ratio_doi)
    numbers.update({"tasks": len(results), "tasks_failed": len(failed),
                    "failed": [f"{r['task']}: {r.get('error')}" for r in failed]})
    text = _text(own, squares, floor_rows)
    if failed:
        text += (f"\n\n{len(failed)} of {len(results)} tasks failed and are left out (the "
                 f"reasons are listed under `failed` in the numbers below).")
    write_section(out, "fig1", "Fig. 1: force ambiguity and coordination against friction",
                  text, verdicts, numbers, figures=["fig1.png"])
    return {"tasks": len(results), "failed": len(failed), "rows": len(rows),
            "table": str(out / "fig1.csv"), "figure": str(out / "fig1.png"),
            "verdicts": [v.verdict for v in verdicts]}


def _verdicts(own, squares, floor, floor_rows, eta, z, dim, ratio_doi):
    from .report import Verdict

    numbers: dict = {}
    verdicts = []
    if not own:
        return numbers, verdicts
    # eta proportional to mu at small mu
    for k in SAMPLER_LABEL:
        pts = [(r["mu_sample"], r[f"eta_{k}"]) for r in own
               if r["mu_sample"] <= SMALL_MU and r.get(f"eta_{k}")]
        slope, se = slope_fit(*zip(*pts)) if len(pts) >= 3 else (float("nan"),) * 2
        numbers[f"small_mu_slope_{k}"] = {"slope": slope, "se": se, "points": len(pts)}
    sl, se = numbers["small_mu_slope_hit_and_run"]["slope"], \
        numbers["small_mu_slope_hit_and_run"]["se"]
    slr = numbers["small_mu_slope_relax"]
    ok = abs(sl - 1) <= max(2 * se, 0.1)
    verdicts.append(Verdict(
        "fig1", f"eta grows proportionally to mu at small mu (mu <= {SMALL_MU})",
        f"slope d log eta / d log mu = {sl:.3f} ± {se:.3f} (hit-and-run), "
        f"{slr['slope']:.3f} ± {slr['se']:.3f} (relax walk), "
        f"{numbers['small_mu_slope_hit_and_run']['points']} packings",
        "reproduced" if ok else ("refuted" if np.isfinite(sl) else "not decidable")))
    # position of the maximum
    for k in SAMPLER_LABEL:
        if len(eta[k]) >= 3:
            m, lo, hi = argmax_bootstrap(eta[k])
            numbers[f"eta_max_mu_{k}"] = {"mu": m, "ci95": [lo, hi],
                                          "eta_max": float(eta[k][m].mean())}
    mx = numbers.get("eta_max_mu_hit_and_run")
    mxr = numbers.get("eta_max_mu_relax")
    if mx and mxr:
        # the paper's eta is its walk's: the verdict is on the relax walk, hit-and-run beside
        at10 = eta["relax"][max(eta["relax"])].mean()
        where = location_verdict(*mxr["ci95"])
        verdicts.append(Verdict(
            "fig1", "eta is largest around mu ≈ 0.1 and decreases beyond",
            f"maximum of the mean eta at mu = {mxr['mu']:.3g} (95 % bootstrap interval "
            f"{mxr['ci95'][0]:.3g}-{mxr['ci95'][1]:.3g}; relax walk, as the paper), "
            f"{mx['mu']:.3g} ({mx['ci95'][0]:.3g}-{mx['ci95'][1]:.3g}; hit-and-run); "
            f"relax eta there {mxr['eta_max']:.3g}, at mu = {max(eta['relax']):g}: {at10:.3g}",
            "not decidable" if max(eta["relax"]) < 1 else     # sweep not done yet
            (where if where != "reproduced" or at10 < mxr["eta_max"] else "refuted")))
    # coordination
    zlo, zhi = min(z), max(z)
    z0 = np.array([r["z"] for r in floor_rows])
    numbers["z"] = {"mu0": [float(z0.mean()), float(z0.std())] if z0.size else None,
                    f"mu{zlo:g}": [float(z[zlo].mean()), float(z[zlo].std())],
                    f"mu{zhi:g}": [float(z[zhi].mean()), float(z[zhi].std())]}
    verdicts.append(Verdict(
        "fig1", "z ≈ 4 as mu → 0 (isostatic frictionless packings)",
        f"z = {z[zlo].mean():.3f} ± {z[zlo].std():.3f} at mu = {zlo:g}"
        + (f"; {z0.mean():.3f} ± {z0.std():.3f} at mu = 0" if z0.size else ""),
        "reproduced" if abs(z[zlo].mean() - 4) < 0.05 else "refuted"))
    verdicts.append(Verdict(
        "fig1", "z falls towards ≈ 3 at large mu",
        f"z = {z[zhi].mean():.3f} ± {z[zhi].std():.3f} at mu = {zhi:g}",
        "not decidable" if zhi < 1 else                             # sweep not done yet
        "reproduced" if 2.9 <= z[zhi].mean() <= 3.35 else "refuted"))
    # squares: monotonic
    sq_ok, sq_n, worst = 0, 0, 1.0
    for seed in sorted({r["seed"] for r in squares}):
        seq = sorted((r["mu_sample"], r["eta_hit_and_run"]) for r in squares
                     if r["seed"] == seed and r.get("eta_hit_and_run") is not None)
        e = np.array([v for _, v in seq])
        if e.size >= 2:
            sq_n += 1
            steps = e[1:] / np.maximum(e[:-1], 1e-300)
            worst = min(worst, float(steps.min()))
            sq_ok += bool((steps >= 0.95).all())
    numbers["squares"] = {"packings": sq_n, "monotonic": sq_ok, "smallest_step_ratio": worst}
    if sq_n:
        verdicts.append(Verdict(
            "fig1", "frictionless packing with friction switched on: eta rises monotonically "
            "with mu",
            f"{sq_ok} of {sq_n} packings monotonic (hit-and-run eta; smallest ratio of "
            f"consecutive values {worst:.3f}, 0.95 allowed for sampling noise)",
            "reproduced" if sq_ok == sq_n else "refuted"))
    # determinate packings at large mu
    big = {m: v for m, v in dim.items() if m >= 0.5}
    frac = {m: float((v == 0).mean()) for m, v in big.items()}
    numbers["fraction_dim_S_0"] = {f"{m:.3g}": f for m, f in frac.items()}
    if frac:
        verdicts.append(Verdict(
            "fig1", "fully determined packings (dim S = 0) appear at large mu (around 1)",
            "fraction with dim S = 0: " + ", ".join(f"{f:.1f} at mu = {m:.2g}"
                                                   for m, f in frac.items()),
            "reproduced" if any(f > 0 for f in frac.values()) else "refuted"))
    # 2Nc - 3n ~ Nc/2 at small mu (full packing)
    small = [v for m, v in ratio_doi.items() if m <= SMALL_MU]
    if small:
        q = np.concatenate(small)
        numbers["dof_excess_over_half_nc_small_mu"] = [float(q.mean()), float(q.std())]
        verdicts.append(Verdict(
            "fig1", "degree of indeterminacy 2Nc - 3n ≈ Nc/2 at small mu",
            f"(2Nc - 3n) / (Nc/2) = {q.mean():.3f} ± {q.std():.3f} on the full packings "
            f"(force-bearing contacts, non-rattler disks, wall contacts counted), "
            f"mu <= {SMALL_MU}",
            "reproduced" if abs(q.mean() - 1) < 0.1 else "refuted"))
    # accuracy floor and the two samplers
    if floor.size:
        numbers["accuracy_floor_eta"] = [float(floor.mean()), float(floor.max())]
        verdicts.append(Verdict(
            "fig1", "eta ≈ 1e-7 in the frictionless limit is the calculation's accuracy "
            "floor",
            f"relax walk on the frictionless S (dim S = 0): eta = {floor.mean():.1e} "
            f"(tolerance 1e-9 <Fn>); at mu = {zlo:g}: "
            f"{eta['hit_and_run'][zlo].mean():.1e} (hit-and-run), all above the floor",
            "reproduced" if eta["hit_and_run"][zlo].mean() > 10 * floor.mean()
            else "not decidable"))
    both = [(r["eta_relax"], r["eta_hit_and_run"]) for r in own
            if r.get("eta_relax") and r.get("eta_hit_and_run")]
    if both:
        q = np.array([a / b for a, b in both])
        numbers["eta_relax_over_hit_and_run"] = {
            "geometric_mean": float(np.exp(np.log(q).mean())),
            "quantiles_5_50_95": np.quantile(q, [0.05, 0.5, 0.95]).tolist(), "n": int(q.size)}
    return numbers, verdicts


def _text(own, squares, floor_rows) -> str:
    if not own:
        return "No finished task."
    n_pack = len({(r["mu"], r["seed"]) for r in own})
    mus = sorted({r["mu"] for r in own})
    caps = [r for r in own if (r.get("n_relax") or 100) < 100 or
            (r.get("n_hit_and_run") or 100) < 100]
    proj = sum(r.get("relax_projected") or 0 for r in own)
    return (
        f"{n_pack} packings (paper protocol, n = {own[0].get('n_full', '?')}+ disks) at "
        f"{len(mus)} values of mu from {mus[0]:g} to {mus[-1]:g}, one new packing per mu and "
        f"seed; S of the 28 R slice sampled with uniform hit-and-run and with the paper's "
        f"relax walk. Squares: {len({r['seed'] for r in squares})} frictionless packings, "
        f"S taken with friction switched on at each mu. eta of a determinate S (dim S = 0) "
        f"is 0 exactly and is left off the log axis. Left: eta (filled: hit-and-run; open: "
        f"relax walk); middle: z; right: dim S, the degree of indeterminacy of the slice, "
        f"the fraction of determinate packings and (2Nc - 3n)/(Nc/2) of the full packing "
        f"(on the slice the fixed loads make that count meaningless).\n\n"
        f"Time-capped samplers: {len(caps)} of {len(own)} sampling runs stopped before 100 "
        f"samples (counts in fig1.csv). Relax samples finished by projection after a stall: "
        f"{proj} in all.")
