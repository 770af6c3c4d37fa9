"""The paper's Fig. 2 and its elementary clusters: localisation of indeterminacy against mu.

Tasks: one per fig1 packing (mu, seed), read from the sibling ``fig1`` study
directory when it has it (jammed here otherwise). Per packing: the slice's S,
its decomposition into elementary clusters (:mod:`forcespace.clusters`): their
number and sizes, the density rho (elementary clusters per interior disk), the
largest domain's share of the slice's contacts, whether a domain percolates
(touches both the top and the bottom load). The paper's test of the same
clusters under other boundary loads: the loads are replaced by those of
another admissible network of the whole packing (the jammed network of the
full packing plus uniform kicks of +-<Fn>/2, projected exactly onto the full
packing's S), and the decomposition is redone; we count the elementary clusters
found again (same contact set).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import forcespace as fs
from forcespace.space.projection import distance_to_S
from forcespace.space.structure import decompose, extreme_pair
from forcespace.sweep import Task

from . import fig1
from .common import shared_packing

REUSE = ("fig1",)


def config(quick: bool) -> dict:
    return fig1.config(quick)


def tasks(quick: bool = False) -> list[Task]:
    cfg = config(quick)
    common = dict(scene=cfg["scene"], n_disks=cfg["n_disks"], slice_height=cfg["slice_height"])
    return [Task(f"mu{mu:.3g}_s{seed}", "forcespace_studies.fig2:packing_task",
                 dict(common, mu=mu, seed=seed)) for mu in cfg["mus"] for seed in cfg["seeds"]]


def other_loads(packing, seed: int):
    """The packing with the forces of another admissible network of its full S."""
    full = fs.full_problem(packing)
    rng = np.random.default_rng(seed)
    kick = rng.uniform(-0.5, 0.5, full.n_columns) * full.force_scale
    kick[full.fixed_columns()] = 0.0
    x = distance_to_S(full, full.x_jammed + kick).nearest
    return packing.with_forces(*full.to_packing_forces(x))


def cluster_sets(problem, dec) -> set:
    """Elementary clusters as frozensets of packing contact indices (empty without dec)."""
    return {frozenset(problem.contacts[c.contacts].tolist()) for c in
            (dec.clusters if dec else []) if c.elementary}


def domain_sets(problem, dec) -> set:
    """Domains of indeterminacy as frozensets of packing contact indices. Unlike a
    circuit basis (one of many), the domains are unique: the fair comparison."""
    return {frozenset(problem.contacts[g.contacts].tolist()) for g in
            (dec.domains if dec else [])}


def packing_task(scene: str, n_disks: int, slice_height: float, mu: float, seed: int,
                 workdir) -> dict:
    wd = Path(workdir)
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks, REUSE)
    prob = fs.slice_problem(p, slice_height)
    t0 = time.perf_counter()
    an = fs.ForceSpace().compute(prob)
    row = {"mu": mu, "seed": seed, "z": p.coordination(), "slice_disks": prob.n_interior,
           "slice_contacts": prob.n_contacts, "feasible": an.feasible, "bounded": an.bounded,
           "dim_S": an.dim, "t_jam_s": t_jam}
    if not an.feasible or not an.dim:
        row.update(n_elementary=0, density_rho=0.0, largest_domain_fraction=0.0,
                   percolates=False, t_clusters_s=time.perf_counter() - t0)
        return row
    dec = decompose(prob, an, p)
    s = dec.summary()
    row.update(s)
    row["largest_domain_fraction"] = s["largest_domain_contacts"] / max(prob.n_contacts, 1)
    row["percolates"] = bool(s["percolating_domains"])
    row["varying_fraction"] = sum(g.contacts.size for g in dec.domains) / prob.n_contacts
    row["t_clusters_s"] = time.perf_counter() - t0
    # the same clusters under other boundary loads?
    t0 = time.perf_counter()
    prob2 = fs.slice_problem(other_loads(p, seed), slice_height)
    an2 = fs.ForceSpace().compute(prob2)
    dec2 = decompose(prob2, an2, p) if an2.feasible and an2.dim else None
    row["other_loads"] = {
        "dim_S": an2.dim, "n_domains": len(dec.domains),
        "same_domains": len(domain_sets(prob, dec) & domain_sets(prob2, dec2)),
        "n_elementary": dec.n_elementary,
        "same_clusters": len(cluster_sets(prob, dec) & cluster_sets(prob2, dec2))}
    row["t_other_loads_s"] = time.perf_counter() - t0
    return row


def summarize(results: list[dict], out) -> dict:
    """fig2.csv, fig2_clusters.png (rho, domain fraction, percolation vs mu),
    fig2.png (the difference networks at mu = 0.1 and 0.5), verdicts, REPORT.md."""
    from matplotlib.figure import Figure

    from forcespace.plot import save_figure
    from .report import Verdict, write_csv, write_section

    out = Path(out)
    rows = [r for r in results if r.get("ok")]
    failed = [r for r in results if not r.get("ok")]
    keys = ["mu", "seed", "z", "slice_disks", "slice_contacts", "dim_S", "n_domains",
            "n_elementary", "density_rho", "largest_domain_fraction", "varying_fraction",
            "percolates", "elementary_sizes_contacts", "t_clusters_s"]
    write_csv(out / "fig2.csv",
              [dict(r, other_loads_same_domains=(r.get("other_loads") or {}).get("same_domains"),
                    other_loads_same_clusters=(r.get("other_loads") or {}).get("same_clusters"))
               for r in rows], keys + ["other_loads_same_domains", "other_loads_same_clusters"])
    mus = sorted({r["mu"] for r in rows})

    def per_mu(key):
        return [np.mean([float(r.get(key) or 0) for r in rows if r["mu"] == m]) for m in mus]

    def spread(key):
        return [np.std([float(r.get(key) or 0) for r in rows if r["mu"] == m]) for m in mus]

    fig = Figure(figsize=(10, 4))
    ax1, ax2 = fig.subplots(1, 2)
    ax1.errorbar(mus, per_mu("density_rho"), spread("density_rho"), fmt="o-", capsize=2,
                 label="rho: elementary clusters per interior disk")
    ax1.set(xscale="log", xlabel="mu", ylabel="rho", title="density of elementary clusters")
    ax1.legend(fontsize=7)
    ax2.plot(mus, per_mu("largest_domain_fraction"), "s-",
             label="largest domain / slice contacts")
    ax2.plot(mus, per_mu("varying_fraction"), "^-", label="varying contacts / slice contacts")
    ax2.plot(mus, per_mu("percolates"), "ko:", mfc="none", label="fraction percolating")
    ax2.set(xscale="log", xlabel="mu", ylabel="fraction", ylim=(-0.03, 1.03),
            title="localisation of indeterminacy")
    ax2.legend(fontsize=7)
    save_figure(fig, out / "fig2_clusters.png", tight=True)
    figures = ["fig2_clusters.png"]
    if _draw_examples(rows, out):
        figures.insert(0, "fig2.png")

    numbers: dict = {"packings": len(rows), "tasks_failed": len(failed),
                     "rho_by_mu": dict(zip([f"{m:.3g}" for m in mus], per_mu("density_rho"))),
                     "percolating_by_mu": dict(zip([f"{m:.3g}" for m in mus],
                                                   per_mu("percolates"))),
                     "largest_domain_fraction_by_mu": dict(zip(
                         [f"{m:.3g}" for m in mus], per_mu("largest_domain_fraction")))}
    verdicts = []
    small = [r for r in rows if r["mu"] <= 0.2 and r.get("dim_S")]
    large = [r for r in rows if r["mu"] >= 0.5 and r.get("dim_S")]
    if small and large:
        ps, pl = np.mean([r["percolates"] for r in small]), np.mean([r["percolates"] for r in
                                                                     large])
        fs_, fl = (np.mean([r["largest_domain_fraction"] for r in x]) for x in (small, large))
        verdicts.append(Verdict(
            "fig2", "Indeterminacy spans the system at small mu and localises into small "
                    "separated domains at large mu",
            f"largest domain {100 * fs_:.0f} % of the slice's contacts at mu <= 0.2, "
            f"{100 * fl:.0f} % at mu >= 0.5; percolating: {100 * ps:.0f} % vs {100 * pl:.0f} % "
            f"of the packings with dim S > 0",
            "reproduced" if fl < fs_ and pl <= ps else "refuted"))
    el = [r for r in rows if r.get("n_elementary") and r["mu"] >= 0.3]
    if el:
        sizes = np.concatenate([r["elementary_sizes_contacts"] for r in el])
        numbers["elementary_sizes_mu_ge_0.3"] = {"median": float(np.median(sizes)),
                                                 "min": int(sizes.min()),
                                                 "max": int(sizes.max())}
        verdicts.append(Verdict(
            "fig2", "At large mu the indeterminacy sits in small elementary clusters (one "
                    "degree of freedom, irreducible; smallest 4 disks and 5 contacts)",
            f"{sizes.size} elementary clusters at mu >= 0.3: {sizes.min()}-{sizes.max()} "
            f"contacts (median {np.median(sizes):.0f})",
            "reproduced" if sizes.min() <= 6 else "refuted"))
    ol = [r["other_loads"] for r in rows if r.get("other_loads")]
    if ol:
        tot = {k: sum(o[k] for o in ol) for k in ("n_domains", "same_domains", "n_elementary",
                                                   "same_clusters")}
        numbers["other_loads"] = tot
        verdicts.append(Verdict(
            "fig2", "The same clusters appear under other boundary loads (a property of the "
                    "contact network)",
            f"{tot['same_domains']} of {tot['n_domains']} domains of indeterminacy found again "
            f"(same contacts) after replacing the loads by another admissible network's "
            f"({len(ol)} packings); elementary clusters of the greedy basis: "
            f"{tot['same_clusters']} of {tot['n_elementary']} (a basis is one of many)",
            "reproduced" if tot["same_domains"] >= 0.8 * tot["n_domains"] else "refuted"))
    text = (f"{len(rows)} packings (the fig1 packings, slice 28 R). rho counts elementary "
            "clusters (circuits whose contacts carry exactly one degree of freedom) per "
            "interior disk; a circuit basis is chosen greedily from L1-minimal circuits, so "
            "rho is a lower bound where sparser bases exist. A domain percolates when its "
            "disks touch both the top and the bottom loads of the slice. Fig. 2: the "
            "difference of two vertices of S (far apart along a random direction of its "
            "affine hull), normal-force differences red (+) / blue (-), domains outlined in "
            "colour, elementary clusters dashed.")
    write_section(out, "fig2", "Fig. 2: elementary clusters and the localisation of "
                  "indeterminacy", text, verdicts, numbers, figures)
    return {"tasks": len(results), "failed": len(failed), "figures": figures,
            "verdicts": [v.verdict for v in verdicts]}


def _draw_examples(rows, out) -> bool:
    """fig2.png: the difference networks of the study's first seed at the mu nearest to
    0.1 and 0.5."""
    from matplotlib.figure import Figure

    from forcespace.plot import save_figure

    cand = [r for r in rows if r.get("dim_S")]
    if not cand:
        return False
    fig = Figure(figsize=(12, 6.5))
    for ax, target in zip(fig.subplots(1, 2), (0.1, 0.5)):
        r = min(cand, key=lambda r: (abs(np.log(r["mu"] / target)), r["seed"]))
        par = r["params"]
        p, _ = shared_packing(out, par["scene"], r["mu"], r["seed"], par["n_disks"], REUSE)
        prob = fs.slice_problem(p, par["slice_height"])
        an = fs.ForceSpace().compute(prob)
        dec = decompose(prob, an, p)
        x1, x2 = extreme_pair(prob, an, r["seed"])
        fs.plot_difference(p, prob, x1, x2, dec.domains, ax=ax, clusters=dec.clusters,
                        title=f"mu = {r['mu']:.3g} (seed {r['seed']}): dim S = {an.dim}, "
                              f"{dec.n_elementary} elementary")
    save_figure(fig, Path(out) / "fig2.png", tight=True)
    return True
