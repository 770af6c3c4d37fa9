"""The paper's Fig. 2 and its elementary clusters: localisation of indeterminacy against mu.

Tasks: one per fig1 packing (mu, seed), read from the sibling ``fig1`` study
directory when it has it (jammed here otherwise). Per packing: the slice's S,
its decomposition into domains of indeterminacy and elementary clusters
(:mod:`forcespace.space.structure`): their number and sizes, the density rho
(elementary clusters per interior disk), the largest domain's share of the slice's
contacts, whether a domain percolates (its disks touch both the top and the bottom
load of the slice). A determinate S (dim S = 0) keeps its row: no domain, rho = 0.

The paper's test of the same clusters under other boundary loads: the slice's loads
are replaced by those of another admissible network of the whole packing, a generic
one (:func:`other_loads`: inside the full packing's S, not on its boundary), S of the
slice is analysed again and decomposed again. Each domain is stored with its size,
dimension, whether it percolates, whether it is found again (the same contact set is a
domain under the other loads) and its best Jaccard overlap with a domain under the
other loads, so the summary decides from the task files. Verdicts follow the report's rules
(:data:`forcespace_studies.report.RULES`); the operational readings are the
constants below, fixed before the runs.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import forcespace as fs
from forcespace.errors import ForcespaceError, NumericalError
from forcespace.extend import decompose, distance_to_S, extreme_pair
from .runner import Task

from . import fig1, stats
from .common import kept_packing, no_packing_panel, shared_packing
from .report import (AS_HYPOTHESIS, RULES_VERSION, Verdict, failed_tasks_note, failures_per_mu,
                     write_csv, write_section)

REUSE = ("fig1",)
SMALL_MU = 0.2        # "small mu": mu <= this
LARGE_MU = 0.5        # "large mu" of the elementary clusters: mu >= this (the paper's example)
PAPER_EXAMPLE_MU = 0.5   # the paper's Fig. 2b: localised domains at mu = 0.5
MIN_WINDOW = 10       # packings with dim S > 0 a large-mu window needs (a grid mu's seeds)
SPANS = 0.5           # spans the system: the largest domain holds >= half the slice's contacts
LOCAL = 0.2           # small / localised: a domain (cluster) holds <= a fifth of them
ELEMENTARY_SHARE = 0.5  # "sits in elementary clusters": >= half of dim S in them
FOUND_AGAIN = 0.8     # "the same clusters appear": >= 80 % of the domains found again


def config(quick: bool) -> dict:
    return fig1.config(quick)


def tasks(quick: bool = False) -> list[Task]:
    """One task per fig1 packing (mu, seed), seed-major as fig1's: an interrupted run
    leaves complete seed rounds across mu, and a run beside an unfinished fig1 finds the
    packings of its first seeds there."""
    cfg = config(quick)
    common = dict(scene=cfg["scene"], n_disks=cfg["n_disks"], slice_height=cfg["slice_height"])
    return [Task(f"mu{mu:.3g}_s{seed}", "forcespace_studies.fig2:packing_task",
                 dict(common, mu=mu, seed=seed)) for seed in cfg["seeds"] for mu in cfg["mus"]]


def other_loads(packing, seed: int):
    """The packing with the forces of another admissible network of its full S, in the
    relative interior of S: the midpoint of (a) the full packing's jammed network kicked by
    uniform +-<Fn>/2 on its free force components and projected exactly onto S (seeded)
    and (b) S's Chebyshev centre. The projection alone lands on the boundary of S, where
    contacts are held at zero force or at the Coulomb limit; under such loads the slice's
    S is a lower-dimensional face (dim S fell by 1 on 2 of 9 paper packings at mu <= 0.37,
    to 0 on quick ones) and its domains change for that reason alone. Other loads in the
    paper's sense are generic ones."""
    full = fs.full_problem(packing)
    an = fs.ForceSpace().compute(full)
    if not (an.success and an.feasible and an.bounded):
        raise NumericalError("the full packing's S: " + (an.message if not an.success else
                                                          "empty or unbounded"))
    rng = np.random.default_rng(seed)
    kick = rng.uniform(-0.5, 0.5, full.n_columns) * full.force_scale
    kick[full.fixed_columns()] = 0.0
    x = 0.5 * (distance_to_S(full, full.x_jammed + kick).nearest + an.centre)
    return packing.with_forces(*full.to_packing_forces(x))


def domain_sets(problem, dec) -> list:
    """Domains of indeterminacy as frozensets of packing contact indices, in the
    decomposition's order. Unlike a circuit basis (one of many), the domains are unique:
    the fair comparison."""
    return [frozenset(problem.contacts[g.contacts].tolist()) for g in
            (dec.domains if dec else [])]


def match_domains(before: list, after: list) -> list[dict]:
    """For each contact set of ``before``: found_again (the same set is in ``after``),
    jaccard (the largest |A & B| / |A | B| over ``after``; 0 when it is empty) and
    match (the index in ``after`` of that best set, None when empty)."""
    out = []
    for a in before:
        best, j = 0.0, None
        for k, b in enumerate(after):
            jac = len(a & b) / max(len(a | b), 1)
            if jac > best:
                best, j = jac, k
        out.append({"found_again": a in set(after), "jaccard": best, "match": j})
    return out


DETERMINATE = dict(n_domains=0, domain_dims=[], n_clusters=0, n_elementary=0,
                   elementary_sizes_contacts=[], elementary_sizes_disks=[], density_rho=0.0,
                   largest_domain_contacts=0, percolating_domains=0,
                   largest_domain_fraction=0.0, varying_fraction=0.0, percolates=False,
                   domains=[])


def packing_task(scene: str, n_disks: int, slice_height: float, mu: float, seed: int,
                 workdir) -> dict:
    """One packing's analysis row (rule 5: kept when a later step fails; the failure is
    named in error_analysis or error_other_loads)."""
    wd = Path(workdir)
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks, REUSE)
    prob = fs.slice_problem(p, slice_height)
    t0 = time.perf_counter()
    an = fs.ForceSpace().compute(prob)
    row = {"mu": mu, "seed": seed, "z": p.coordination(), "slice_disks": prob.n_interior,
           "slice_contacts": prob.n_contacts, "analysis_ok": an.success, "t_jam_s": t_jam}
    if not (an.success and an.feasible and an.bounded):
        row["error_analysis"] = an.message if not an.success else "S empty or unbounded"
        return row
    row.update(feasible=True, bounded=True, dim_S=an.dim)
    if not an.dim:          # determinate: no domain, no cluster (rho = 0 exactly)
        row.update(DETERMINATE, t_clusters_s=time.perf_counter() - t0)
        return row
    dec = decompose(prob, an, p)
    s = dec.summary()
    row.update(s)
    row["largest_domain_fraction"] = s["largest_domain_contacts"] / max(prob.n_contacts, 1)
    row["percolates"] = bool(s["percolating_domains"])
    row["varying_fraction"] = sum(g.contacts.size for g in dec.domains) / prob.n_contacts
    row["domains"] = [{"contacts": int(g.contacts.size), "disks": int(g.disks.size),
                       "dim": int(g.dim), "percolates": bool(perc)}
                      for g, perc in zip(dec.domains, dec.percolates)]
    row["t_clusters_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    try:
        row["other_loads"] = _other_loads(p, prob, an, dec, seed, slice_height, row["domains"])
    except ForcespaceError as exc:      # rule 5: the analysis row stays
        row["error_other_loads"] = f"{type(exc).__name__}: {exc}"
    row["t_other_loads_s"] = time.perf_counter() - t0
    return row


def _other_loads(p, prob, an, dec, seed, slice_height, domains) -> dict:
    """S of the slice under the loads of another admissible network; marks each of
    ``domains`` (dicts, in dec's order) found again or not, with its best overlap."""
    prob2 = fs.slice_problem(other_loads(p, seed), slice_height)
    an2 = fs.ForceSpace().compute(prob2)
    if not (an2.success and an2.feasible):
        raise ForcespaceError("the slice under the other loads: " + (
            an2.message if not an2.success else "S empty"))
    dec2 = decompose(prob2, an2, p) if an2.dim else None
    after = domain_sets(prob2, dec2)
    for d, m in zip(domains, match_domains(domain_sets(prob, dec), after)):
        d.update(found_again=m["found_again"], jaccard=m["jaccard"],
                 dim_again=None if m["match"] is None else int(dec2.domains[m["match"]].dim))
    return {"dim_S": int(an2.dim), "dim_S_change": int(an2.dim) - int(an.dim),
            "n_domains": len(after)}


ROW_KEYS = ["task", "mu", "seed", "z", "slice_disks", "slice_contacts", "dim_S", "n_domains",
            "n_elementary", "density_rho", "largest_domain_fraction", "varying_fraction",
            "percolates", "elementary_sizes_contacts", "elementary_sizes_disks",
            "other_loads_dim_S", "dim_S_change", "localised_domains",
            "localised_found_again", "percolating_domains", "percolating_found_again",
            "percolating_jaccard", "error_analysis", "error_other_loads", "t_clusters_s",
            "t_other_loads_s"]
DOMAIN_KEYS = ["task", "mu", "seed", "domain", "contacts", "disks", "dim", "percolates",
               "found_again", "jaccard", "dim_again", "dim_S", "other_loads_dim_S"]


def _table_row(r) -> dict:
    ol = r.get("other_loads") or {}
    doms = [d for d in r.get("domains") or [] if "found_again" in d]
    loc = [d for d in doms if not d["percolates"]]
    perc = [d for d in doms if d["percolates"]]
    return dict(r, other_loads_dim_S=ol.get("dim_S"), dim_S_change=ol.get("dim_S_change"),
                localised_domains=len(loc) if ol else None,
                localised_found_again=sum(d["found_again"] for d in loc) if ol else None,
                percolating_found_again=sum(d["found_again"] for d in perc) if ol else None,
                percolating_jaccard=min((d["jaccard"] for d in perc), default=None))


def summarize(results: list[dict], out) -> dict:
    """fig2.csv (one row per packing), fig2_domains.csv (one per domain), fig2_clusters.png
    (rho, localisation, domains found again, against mu), fig2.png (the difference
    networks at mu = 0.1 and 0.5), verdicts, REPORT.md."""
    out = Path(out)
    rows = [dict(r, task=r.get("task")) for r in results if r.get("ok")]
    failed = [r for r in results if not r.get("ok")]
    write_csv(out / "fig2.csv", [_table_row(r) for r in rows], ROW_KEYS)
    write_csv(out / "fig2_domains.csv",
              [dict(d, task=r["task"], mu=r["mu"], seed=r["seed"], domain=i,
                    dim_S=r.get("dim_S"), other_loads_dim_S=(r.get("other_loads") or {})
                    .get("dim_S")) for r in rows for i, d in enumerate(r.get("domains") or [])],
              DOMAIN_KEYS)
    numbers, verdicts = judge(results)
    figures = []
    if numbers["by_mu"]:
        _figure(out, numbers["by_mu"], numbers.get("localised_from"))
        figures.append("fig2_clusters.png")
    if _draw_examples(rows, out):
        figures.insert(0, "fig2.png")
    text = _text(rows, numbers) + failed_tasks_note(failed, results)
    write_section(out, "fig2", "Fig. 2: elementary clusters and the localisation of "
                  "indeterminacy", text, verdicts, numbers, figures,
                  rules_version=RULES_VERSION)
    return {"tasks": len(results), "failed": len(failed), "figures": figures,
            "verdicts": [v.verdict for v in verdicts]}


def judge(results: list[dict]) -> tuple[dict, list[Verdict]]:
    """The numbers and verdicts of the study from its task results (a pure function of
    them: the report's rules, readings fixed by the module's constants)."""
    rows = [r for r in results if r.get("ok")]
    failed = [r for r in results if not r.get("ok")]
    done = [r for r in rows if r.get("dim_S") is not None]     # analysed
    ind = [r for r in done if r["dim_S"]]                       # indeterminate
    numbers: dict = {"tasks": len(results), "tasks_failed": len(failed),
                     "failed": [f"{r.get('task')}: {r.get('error')}" for r in failed],
                     "failures_by_mu": failures_per_mu(results, ("error_analysis",
                                                                  "error_other_loads")),
                     "packings_analysed": len(done), "packings_determinate": len(done) - len(ind),
                     "by_mu": _by_mu(done)}
    verdicts = [_localisation(ind, numbers), _elementary(ind, numbers)]
    verdicts += _same_domains(ind, numbers)
    return numbers, [v for v in verdicts if v is not None]


def _by_mu(done) -> list[dict]:
    out = []
    for m in sorted({r["mu"] for r in done}):
        here = [r for r in done if r["mu"] == m]
        ind = [r for r in here if r["dim_S"]]
        doms = [d for r in ind for d in r.get("domains") or [] if "found_again" in d]
        loc = [d for d in doms if not d["percolates"]]
        perc = [d for d in doms if d["percolates"]]
        out.append({
            "mu": m, "packings": len(here), "determinate": len(here) - len(ind),
            "rho_mean": float(np.mean([r["density_rho"] for r in here])),
            "rho_sd": float(np.std([r["density_rho"] for r in here])),
            "largest_domain_fraction": float(np.mean([r["largest_domain_fraction"]
                                                      for r in ind])) if ind else None,
            "varying_fraction": float(np.mean([r["varying_fraction"] for r in ind]))
            if ind else None,
            "percolating": float(np.mean([r["percolates"] for r in ind])) if ind else None,
            "localised_domains": len(loc),
            "localised_found_again": sum(d["found_again"] for d in loc),
            "percolating_domains": len(perc),
            "percolating_found_again": sum(d["found_again"] for d in perc),
            "percolating_jaccard": float(np.mean([d["jaccard"] for d in perc])) if perc
            else None})
    return out


def _interval(b) -> str:
    return f"{b[0]:.2f} (95 %: {b[1]:.2f}-{b[2]:.2f})"


def localised_from(ind) -> dict | None:
    """Where the data place the localisation: the smallest mu above SMALL_MU from which on
    (every packing with dim S > 0 at mu >= it, at least MIN_WINDOW of them) the mean share
    of the slice's contacts in the largest domain has its 95 % bootstrap interval inside
    [0, LOCAL]; {mu, below (the grid mu before it), packings, share (mean, lo, hi)}, or
    None when no such window exists. Fixed in issue 45, after the data were seen."""
    mus = sorted({r["mu"] for r in ind if r["mu"] > SMALL_MU})
    for i, m in enumerate(mus):
        tail = [r for r in ind if r["mu"] >= m]
        if len(tail) < MIN_WINDOW:
            return None
        b = stats.bootstrap_mean({0: [r["largest_domain_fraction"] for r in tail]})[0]
        if stats.interval_verdict(b[1], b[2], (0.0, LOCAL)) == "reproduced":
            return {"mu": m, "below": mus[i - 1] if i else SMALL_MU, "packings": len(tail),
                    "share": b, "percolating": sum(bool(r["percolates"]) for r in tail)}
    return None


def _localisation(ind, numbers) -> Verdict:
    claim = ("Indeterminacy spans the system at small mu and localises into small separated "
             "domains at large mu")
    rule = (f"packings with dim S > 0; the mean share of the slice's contacts in the largest "
            f"domain, 95 % bootstrap interval over packings: inside [{SPANS:g}, 1] at mu <= "
            f"{SMALL_MU:g} (spans), and inside [0, {LOCAL:g}] over every packing from some "
            f"mu > {SMALL_MU:g} on (at least {MIN_WINDOW} packings; the smallest such mu is "
            f"where the data place the transition); refuted if the small-mu interval lies "
            f"outside or the interval of the last such window lies above {LOCAL:g} (issue "
            f"45: the large-mu window found from the data, after they were seen; it was mu >= "
            f"{PAPER_EXAMPLE_MU:g})")
    small = [r["largest_domain_fraction"] for r in ind if r["mu"] <= SMALL_MU]
    large = [r for r in ind if r["mu"] > SMALL_MU]
    if not (small and len(large) >= MIN_WINDOW):
        return Verdict("fig2", claim, f"packings with dim S > 0: {len(small)} at mu <= "
                       f"{SMALL_MU:g}, {len(large)} above; {MIN_WINDOW} above are needed",
                       "not decidable", rule=rule)
    b_small = stats.bootstrap_mean({0: small})[0]
    spans = stats.interval_verdict(b_small[1], b_small[2], (SPANS, 1.0))
    tr = localised_from(ind)
    example = _at_example(ind)
    numbers["largest_domain_fraction"] = {"small": b_small}
    numbers["localised_from"] = tr
    numbers["at_paper_example_mu"] = example
    if tr:
        where = (f"{_interval(tr['share'])} over the {tr['packings']} packings at mu >= "
                 f"{tr['mu']:g} ({tr['percolating']} percolating): the data place "
                 f"the transition between mu = {tr['below']:g} and {tr['mu']:g}, "
                 + ("above" if tr["below"] >= PAPER_EXAMPLE_MU else "at or below")
                 + f" the paper's mu = {PAPER_EXAMPLE_MU:g} example (its Fig. 2b)")
        verdict = stats.all_of(spans, "reproduced")
    else:
        mus = sorted({r["mu"] for r in large})
        last = max((m for m in mus if sum(r["mu"] >= m for r in large) >= MIN_WINDOW))
        b = stats.bootstrap_mean({0: [r["largest_domain_fraction"] for r in large
                                      if r["mu"] >= last]})[0]
        where = (f"no window from some mu on has it below {LOCAL:g}: {_interval(b)} at mu >= "
                 f"{last:g}")
        verdict = stats.all_of(spans, stats.interval_verdict(b[1], b[2], (0.0, LOCAL)))
    return Verdict(
        "fig2", claim,
        f"largest domain's share of the slice's contacts: {_interval(b_small)} at mu <= "
        f"{SMALL_MU:g} ({len(small)} packings); {where}; at mu = {PAPER_EXAMPLE_MU:g}: "
        f"{example}", verdict, rule=rule)


def _at_example(ind) -> str:
    """The packings at the paper's example mu: largest domain share and percolation."""
    here = [r for r in ind if r["mu"] == PAPER_EXAMPLE_MU]
    if not here:
        return "no packing with dim S > 0"
    share = np.mean([r["largest_domain_fraction"] for r in here])
    perc = sum(bool(r["percolates"]) for r in here)
    return (f"mean share {share:.2f}, {perc} of {len(here)} packings with dim S > 0 "
            f"percolate")


def _elementary(ind, numbers) -> Verdict:
    claim = ("At large mu the indeterminacy sits in small elementary clusters (one degree of "
             "freedom, irreducible; smallest 4 disks and 5 contacts)")
    rule = (f"packings with dim S > 0 at mu >= {LARGE_MU:g}; 95 % bootstrap intervals over "
            f"packings: the mean share of dim S in elementary clusters (n_elementary / dim S) "
            f"inside [{ELEMENTARY_SHARE:g}, 1], and the mean share of the slice's contacts in "
            f"the packing's largest elementary cluster inside [0, {LOCAL:g}]; the smallest "
            "cluster found is reported, not judged (4 disks, 5 contacts is a lower bound by "
            "counting; a finite sample need not reach it)")
    large = [r for r in ind if r["mu"] >= LARGE_MU]
    if not large:
        return Verdict("fig2", claim, f"no packing with dim S > 0 at mu >= {LARGE_MU:g}",
                       "not decidable", rule=rule)
    share = [r["n_elementary"] / r["dim_S"] for r in large]
    size = [max(r["elementary_sizes_contacts"], default=0) / max(r["slice_contacts"], 1)
            for r in large]
    b = stats.bootstrap_mean({"share": share, "size": size})
    sizes = [s for r in large for s in r["elementary_sizes_contacts"]]
    disks = [s for r in large for s in r.get("elementary_sizes_disks") or []]
    numbers["elementary_large_mu"] = {
        "packings": len(large), "share_of_dim_S": b["share"], "largest_cluster_share": b["size"],
        "clusters": len(sizes), "contacts_min_median_max": [min(sizes), float(np.median(sizes)),
                                                            max(sizes)] if sizes else None,
        "disks_min": min(disks) if disks else None}
    verdict = stats.all_of(
        stats.interval_verdict(b["share"][1], b["share"][2], (ELEMENTARY_SHARE, 1.0)),
        stats.interval_verdict(b["size"][1], b["size"][2], (0.0, LOCAL)))
    found = (f"{len(sizes)} elementary clusters of {min(sizes)}-{max(sizes)} contacts (median "
             f"{np.median(sizes):.0f}; smallest on {min(disks) if disks else '?'} disks)"
             if sizes else "no elementary cluster")
    return Verdict(
        "fig2", claim,
        f"{len(large)} packings with dim S > 0 at mu >= {LARGE_MU:g}: share of dim S in "
        f"elementary clusters {_interval(b['share'])}; largest elementary cluster's share of "
        f"the slice's contacts {_interval(b['size'])}; {found}", verdict, rule=rule)


def _found(ind, percolating: bool) -> dict:
    """Domains (localised or percolating) pooled over the packings whose other-loads step
    ran: counts, the pooled fraction found again with its bootstrap interval over
    packings, the best-match overlaps and the change of dim S."""
    hits, totals, jac, change, mus, missed, share = [], [], [], [], [], [], []
    for r in ind:
        if not r.get("other_loads"):
            continue
        doms = [d for d in r.get("domains") or [] if d["percolates"] == percolating
                and "found_again" in d]
        if not doms:
            continue
        hits.append(sum(d["found_again"] for d in doms))
        totals.append(len(doms))
        jac += [d["jaccard"] for d in doms]
        share += [d["contacts"] / max(r.get("slice_contacts") or 1, 1) for d in doms]
        change.append(r["other_loads"]["dim_S_change"])
        missed += [d["jaccard"] for d in doms if not d["found_again"]]
        mus += [r["mu"]] * (len(doms) - hits[-1])
    frac = stats.pooled_fraction(hits, totals)
    return {"packings": len(totals), "domains": int(sum(totals)), "found_again": int(sum(hits)),
            "fraction": frac, "jaccard_mean": float(np.mean(jac)) if jac else None,
            "jaccard_min": float(np.min(jac)) if jac else None,
            "missed_jaccard_mean": float(np.mean(missed)) if missed else None,
            "missed_at_mu": sorted({float(m) for m in mus}),
            "largest_share_of_slice": float(max(share)) if share else None,
            "dim_S_change": {"mean": float(np.mean(change)), "min": int(min(change)),
                             "max": int(max(change))} if change else None}


def _same_domains(ind, numbers) -> list[Verdict]:
    rule = (f"a domain counts as found again when the same contact set is a domain of S "
            f"under the other loads; the fraction found again, pooled over packings (95 % "
            f"bootstrap interval, packings resampled), inside [{FOUND_AGAIN:g}, 1]; refuted "
            f"if the interval lies below {FOUND_AGAIN:g}")
    loc, perc = _found(ind, False), _found(ind, True)
    numbers["other_loads"] = {"localised": loc, "percolating": perc}
    out = []
    claim = ("The same clusters appear under other boundary loads (a property of the contact "
             "network): the localised domains, elementary clusters as the paper shows them")
    rule_loc = "localised (non-percolating) domains of packings with dim S > 0; " + rule
    if not loc["domains"]:
        out.append(Verdict("fig2", claim, "no localised domain with the other-loads step "
                           "done", "not decidable", rule=rule_loc))
    else:
        f = loc["fraction"]
        out.append(Verdict(
            "fig2", claim,
            f"{loc['found_again']} of {loc['domains']} localised domains found again "
            f"({loc['packings']} packings): {_interval(f)}; best-match Jaccard of the "
            f"contact sets: mean {loc['jaccard_mean']:.3f}, min {loc['jaccard_min']:.3f}; "
            f"the largest holds {100 * loc['largest_share_of_slice']:.0f} % of its slice's "
            "contacts", stats.interval_verdict(f[1], f[2], (FOUND_AGAIN, 1.0)), rule=rule_loc))
    if perc["domains"]:
        f, ch = perc["fraction"], perc["dim_S_change"]
        out.append(Verdict(
            "fig2", "The percolating domain is found again exactly (same contact set) under "
                    "other boundary loads",
            f"{perc['found_again']} of {perc['domains']} percolating domains found again "
            f"({perc['packings']} packings): {_interval(f)}"
            + (f", misses at mu = {', '.join(f'{m:g}' for m in perc['missed_at_mu'])}"
               if perc["missed_at_mu"] else "")
            + f"; best-match Jaccard of the contact sets: mean {perc['jaccard_mean']:.3f}, "
              f"min {perc['jaccard_min']:.3f}; dim S under the other loads minus dim S: mean "
              f"{ch['mean']:+.2f}, range {ch['min']:+d} to {ch['max']:+d}",
            AS_HYPOTHESIS[stats.interval_verdict(f[1], f[2], (FOUND_AGAIN, 1.0))], kind="ours",
            rule="percolating domains of packings with dim S > 0; " + rule
                 + "; the overlap and the change of dim S are reported beside"))
    return out


def _figure(out, by_mu, localised=None) -> None:
    from matplotlib.figure import Figure

    from forcespace.extend import save_figure

    mus = [b["mu"] for b in by_mu]
    fig = Figure(figsize=(15, 4.4))
    ax1, ax2, ax3 = fig.subplots(1, 3)
    ax1.errorbar(mus, [b["rho_mean"] for b in by_mu], [b["rho_sd"] for b in by_mu], fmt="o-",
                 capsize=2, label="mean ± sd over packings (determinate packings count 0)")
    ax1.set(xscale="log", xlabel=r"$\mu$",
            ylabel=r"$\rho$: elementary clusters per interior disk",
            title="density of elementary clusters")
    ax1.legend(fontsize=7, loc="upper right")

    def line(ax, key, fmt, label, bs=None):
        pts = [(b["mu"], b[key]) for b in (bs or by_mu) if b[key] is not None]
        if pts:
            ax.plot(*zip(*pts), fmt, mfc="none" if ":" in fmt else None, label=label)

    line(ax2, "largest_domain_fraction", "s-", "largest domain / slice contacts")
    line(ax2, "varying_fraction", "^-", "varying contacts / slice contacts")
    line(ax2, "percolating", "ko:", "fraction of packings percolating")
    ax2.axvline(SMALL_MU, color="grey", lw=0.8, ls="--",
                label=f"verdict windows: mu <= {SMALL_MU:g}"
                + (f", mu >= {localised['mu']:g} (localised from there on)"
                   if localised else ""))
    if localised:
        ax2.axvline(localised["mu"], color="grey", lw=0.8, ls="--")
    ax2.set(xscale="log", xlabel=r"$\mu$", ylabel="fraction", ylim=(-0.03, 1.03),
            title="localisation of indeterminacy (dim S > 0)")
    ax2.legend(fontsize=7)
    for key, n, fmt, label in (("localised_found_again", "localised_domains", "o-",
                                "localised domains found again (same contacts)"),
                               ("percolating_found_again", "percolating_domains", "s-",
                                "percolating domains found again (same contacts)")):
        pts = [(b["mu"], b[key] / b[n]) for b in by_mu if b[n]]
        if pts:
            ax3.plot(*zip(*pts), fmt, label=label)
    line(ax3, "percolating_jaccard", "kd:", "percolating domains: best-match Jaccard")
    ax3.axhline(FOUND_AGAIN, color="grey", lw=0.8, ls="--",
                label=f"verdict threshold {FOUND_AGAIN:g}")
    ax3.set(xscale="log", xlabel=r"$\mu$", ylabel="fraction", ylim=(-0.03, 1.03),
            title="the same domains under other loads")
    ax3.legend(fontsize=7)
    save_figure(fig, out / "fig2_clusters.png", tight=True)


def _text(rows, numbers) -> str:
    if not rows:
        return "No finished task."
    par = rows[0].get("params") or {}
    h = par.get("slice_height")
    h = f"{h:g} R" if h is not None else "slice"
    loc, perc = numbers["other_loads"]["localised"], numbers["other_loads"]["percolating"]
    n_fail = sum(len(v) for v in numbers["failures_by_mu"].values())
    return (
        f"{numbers['packings_analysed']} packings analysed (the fig1 packings: "
        f"{par.get('n_disks', '?')} disks of the scene `{par.get('scene', '?')}`, one per mu "
        f"and seed; the slice is the middle {h}, contacts with disks outside are fixed "
        f"loads), {numbers['packings_determinate']} of them determinate (dim S = 0: no "
        "domain, rho = 0, kept in the table and in rho; the localisation verdicts are about "
        "packings with dim S > 0). rho counts elementary clusters (circuits whose contacts "
        "carry exactly one degree of freedom) per interior disk; a circuit basis is chosen "
        "greedily from L1-minimal circuits, so rho is a lower bound where sparser bases "
        "exist. A domain of indeterminacy is a set of contacts whose forces vary together in "
        "S (unique, unlike a basis); it percolates when its disks touch both the top and the "
        "bottom loads of the slice, and is localised otherwise.\n\n"
        "Other loads: the loads of the slice are replaced by those of another admissible "
        "network of the whole packing, a generic one: the midpoint of the full packing's "
        "jammed network kicked by uniform +-<Fn>/2 on its free force components and "
        "projected exactly onto the full packing's S (seeded by the packing's seed), and "
        "the Chebyshev centre of that S, so a point inside S, not on its boundary (the "
        "projection alone lands on the boundary, where the slice's S under its loads is a "
        "lower-dimensional face, so its domains change for that reason alone; the "
        "change of dim S under the other loads is reported). S of the slice is analysed "
        "and decomposed again. A domain is found again when the same contact set is a "
        "domain "
        "under the other loads; its overlap is the best Jaccard index |A & B| / |A | B| "
        "with a domain under the other loads. The paper's claim is judged on the localised "
        "domains (the elementary clusters it shows); the percolating domain, where exact "
        "set equality turns on single contacts, is reported separately with its overlap "
        f"and the change of dim S: {loc['found_again']} of {loc['domains']} localised and "
        f"{perc['found_again']} of {perc['domains']} percolating domains found again.\n\n"
        "Figures: the difference of two vertices of S (far apart along a random direction "
        "of its affine hull), normal-force differences red (+) / blue (-), domains outlined "
        "in colour, elementary clusters dashed; rho, localisation and the domains found "
        "again against mu (table: `fig2.csv`, per domain `fig2_domains.csv`). "
        + (f"{n_fail} failures (tasks, analyses or other-loads steps) are listed per mu under "
           "`failures_by_mu` in the numbers below." if n_fail else "No task, analysis or "
           "other-loads step failed."))


def _draw_examples(rows, out) -> bool:
    """fig2.png: the difference networks of the study's first seed at the mu nearest to
    0.1 and 0.5."""
    from matplotlib.figure import Figure

    from forcespace.extend import save_figure

    cand = [r for r in rows if r.get("dim_S")]
    if not cand:
        return False
    fig = Figure(figsize=(12, 6.5))
    for ax, target in zip(fig.subplots(1, 2), (0.1, 0.5)):
        r = min(cand, key=lambda r: (abs(np.log(r["mu"] / target)), r["seed"]))
        par = r["params"]
        p = kept_packing(out, par["scene"], r["mu"], r["seed"], par["n_disks"], REUSE)
        if p is None:               # a summary never jams (--report-only runs nothing)
            no_packing_panel(ax, f"mu = {r['mu']:.3g}, seed {r['seed']}")
            continue
        prob = fs.slice_problem(p, par["slice_height"])
        an = fs.ForceSpace().compute(prob)
        dec = decompose(prob, an, p)
        x1, x2 = extreme_pair(prob, an, r["seed"])
        fs.plot_difference(p, prob, x1, x2, dec.domains, ax=ax, clusters=dec.clusters,
                        title=f"$\\mu$ = {r['mu']:.3g} (seed {r['seed']}): dim $S$ = {an.dim}, "
                              f"{dec.n_elementary} elementary")
    save_figure(fig, Path(out) / "fig2.png", tight=True)
    return True
