"""The paper's point-force experiment: depth of the rearrangement against mu.

The paper reports that the rearrangement caused by a point force on a surface disk is
shallowest near mu ~ 0.1, where eta peaks. Judged by the report's rules (report.RULES).

Tasks: one per (mu, seed), seed-major (every mu of seed 1, then of seed 2, ...), so an
interrupted run holds complete seed rounds. Per task: settle a layer under gravity
(bundled scene ``layer``, floor friction = disk friction, periodic
width ``width``), take its highest disk, find by LP the largest downward point force F*
its rigid contact network can carry (:func:`forcespace.space.loads.max_point_force`),
and push with F* times ``OVERLOADS`` in turn (each from the settled state, its contact
forces the dynamics' warm start) until the push rearranges the layer around the pushed
disk; as a control, run the same dynamics with no force (a layer that moves then was
not at rest).

The rearrangement (:func:`forcespace.measures.rearrangement_depth`) is the connected
displaced region around the push: the disks displaced by more than ``DISPLACED`` R that
are joined through contacts of the settled layer, via displaced disks, to the pushed disk
or its contact neighbours. A disk creeping elsewhere in the layer is not part of it.
Depth: from the pushed disk's centre down to the lowest centre of the region. A region
that reaches the bottom layer (a disk whose lowest point is less than ``FLOOR_LAYER`` R
above the floor) is censored: the floor cut it off.

Rules fixed before the full run (module constants): the depth that counts as deep,
``DEEP``; the thickness the layers must have, ``MIN_THICKNESS`` (the pushed disk's
centre above the floor); the operational readings of the verdicts (``_verdicts``).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from forcespace import config as fs_config
from forcespace.extend import max_point_force, push, rearrangement_depth, surface_disk
from .runner import Task

from .common import shared_packing

DISPLACED = fs_config.DISPLACED       # [R] a disk moved by more than this was displaced
FLOOR_LAYER = fs_config.FLOOR_LAYER   # [R] a region this close to the floor is censored
DEEP = 10.0            # [R] a rearrangement deeper than this below the pushed centre is deep
MIN_THICKNESS = 60.0   # [R] the full run's layers: pushed disk's centre above the floor
CLAIM_MU = 0.1         # the paper: shallowest near mu = 0.1
OVERLOADS = (1.05, 1.1, 1.25, 1.5, 2.0, 3.0, 5.0)   # pushes, in units of F*, until one rearranges

# min_pushes: judged pushes (rearranged, at rest, control at rest) a mu needs to enter the
# verdicts. QUICK is a smoke test of the code (~1 min on 2 workers). FULL: 320 disks in the
# 42 R periodic box settle to a layer whose highest centre lies ~65-70 R above the floor
# (measured: 66.6 R at mu = 0.1, seed 1; 100 disks: 20.1-23.2 R over 10 layers, 200 disks:
# 42.8 R, so the densest scale to ~64 R), and a region is cut off by the floor only below
# ~60 R; 40 seeds per mu. Cost, measured: 33 tasks with the contact solver at 1e-8,
# 110 CPU s each (7 of them failed: the layer never settled), then with the layer scene
# at 1e-10 (every layer settles) 155 CPU s each over the first 80 (a layer pushed up
# to 5 F* costs most: 541 CPU s): ~8.6 CPU-h for the 200 tasks.
# The plain sweep (layer): the fast one of paper_fast (runs of 64 contacts, omega 1.8) was
# not faster on these layers (100 disks, 12 layers: 80 CPU s of jamming with it, 74
# without; 200 disks, mu = 0.1, seed 1: not at rest after 24 CPU min, against 18 s).
QUICK = dict(scene="layer", n_disks=40, width=20.0, mus=(0.01, 0.1, 1.0), seeds=2,
             min_pushes=2)
FULL = dict(scene="layer", n_disks=320, width=42.0, mus=(0.01, 0.03, 0.1, 0.3, 1.0),
            seeds=40, min_pushes=20)


def config(quick: bool) -> dict:
    return QUICK if quick else FULL


def tasks(quick: bool = False) -> list[Task]:
    cfg = config(quick)
    return [Task(f"mu{mu:.3g}_s{seed}", "forcespace_studies.pointforce:packing_task",
                 dict(scene=cfg["scene"], n_disks=cfg["n_disks"], width=cfg["width"], mu=mu,
                      seed=seed))
            for seed in range(1, cfg["seeds"] + 1) for mu in cfg["mus"]]


def packing_task(scene: str, n_disks: int, width: float, mu: float, seed: int,
                 workdir) -> dict:
    """Settle (or reuse) the layer (mu, seed), find F* on its highest disk, run the
    control and the pushes (module docstring)."""
    wd = Path(workdir)
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks,
                              overrides={"physics__plate_mu": mu, "box__width": width})
    k = surface_disk(p)
    weight = float(p.mass[k]) * p.gravity
    t0 = time.perf_counter()
    f_star = max_point_force(p, k)
    row = {"mu": mu, "seed": seed, "z": p.coordination(), "disk": k, "weight": weight,
           "thickness": float(p.y[k] - p.y_bottom),
           "layer_top": float(np.max(p.y + p.r) - p.y_bottom),
           "carries_any_force": not math.isfinite(f_star), "t_jam_s": t_jam,
           "t_lp_s": time.perf_counter() - t0}
    if row["carries_any_force"]:        # (JSON has no infinity: f_star is left out)
        row["reason"] = "the rigid network carries any downward force on this disk"
        return row
    row.update(f_star=f_star, f_star_over_weight=f_star / weight)
    t0 = time.perf_counter()
    res = push(p, k, 0.0, seed)
    row.update(control_max_displacement=float(res.displacement.max()),
               control_displaced=int((res.displacement > DISPLACED).sum()),
               control_at_rest=res.at_rest, t_control_s=time.perf_counter() - t0)
    row.update(_pushes(p, k, f_star, seed))
    return row


def _pushes(p, k, f_star, seed) -> dict:
    """The smallest push (F* times OVERLOADS) that rearranges the layer around disk k:
    near-contacts close and normals turn as the disks settle by a tiny amount, so F*
    itself may be carried. A push that displaces only disks away from the pushed one
    (no connected region) does not count; the next factor is tried."""
    t0 = time.perf_counter()
    remote_only = 0
    for factor in OVERLOADS:
        res = push(p, k, factor * f_star, seed)
        rea = rearrangement_depth(p, k, res.displacement)
        if rea.size:
            break
        remote_only += rea.displaced > 0
    return {"push_factor": factor, "rearranged": bool(rea.size),
            "depth": rea.depth if rea.size else None, "region_size": rea.size,
            "reaches_floor": rea.reaches_floor if rea.size else None,
            "floor_gap": rea.floor_gap if rea.size else None,
            "displaced_total": rea.displaced, "displaced_outside": rea.displaced - rea.size,
            "pushes_remote_only": int(remote_only),
            "push_max_displacement": float(res.displacement.max()),
            "push_steps": int(res.stats["steps"]), "push_at_rest": res.at_rest,
            "t_push_s": time.perf_counter() - t0}


ROW_KEYS = ["task", "mu", "seed", "z", "disk", "thickness", "layer_top", "weight",
            "carries_any_force", "f_star", "f_star_over_weight", "control_max_displacement",
            "control_displaced", "control_at_rest", "push_factor", "rearranged", "depth",
            "region_size", "reaches_floor", "floor_gap", "displaced_total",
            "displaced_outside", "pushes_remote_only", "push_max_displacement",
            "push_steps", "push_at_rest", "t_jam_s", "t_lp_s", "t_control_s", "t_push_s"]


# ----------------------------------------------------------------------------
# the bookkeeping and the statistics
# ----------------------------------------------------------------------------
def status(row: dict) -> str:
    """What a finished layer contributes: "judged" (a rearrangement around the push that
    came to rest, on a layer at rest), or why not: "carries_any_force" (no finite F*),
    "restless" (the control run without force displaced a disk: not at rest),
    "no_rearrangement" (none up to the largest overload), "push_not_at_rest" (the pushed
    layer still moved after the push's step cap: its region may still grow)."""
    if row.get("carries_any_force"):
        return "carries_any_force"
    if (row.get("control_max_displacement") or 0.0) > DISPLACED:
        return "restless"
    if not row.get("rearranged"):
        return "no_rearrangement"
    if not row.get("push_at_rest"):
        return "push_not_at_rest"
    return "judged"


STATUSES = ("judged", "carries_any_force", "restless", "no_rearrangement", "push_not_at_rest")


def per_mu(results: list[dict], n_boot: int = 2000) -> dict:
    """{mu: statistics over its judged layers}: counts of every status and of failed
    tasks, median depth, fraction deeper than DEEP, fraction censored (reaching the
    floor), each with its 95 % bootstrap interval over layers, the median region size,
    and the thinnest layer."""
    from .stats import bootstrap_stat

    rows = [r for r in results if r.get("ok")]
    mus = sorted({_mu_of(r) for r in results})
    out = {}
    for mu in mus:
        here = [r for r in rows if r["mu"] == mu]
        judged = [r for r in here if status(r) == "judged"]
        d = np.array([r["depth"] for r in judged], float)
        cens = np.array([bool(r["reaches_floor"]) for r in judged], float)
        s = {"tasks": sum(1 for r in results if _mu_of(r) == mu), "layers": len(here),
             "failed": sum(1 for r in results if _mu_of(r) == mu and not r.get("ok")),
             **{k: sum(1 for r in here if status(r) == k) for k in STATUSES},
             "thickness_min": min((r["thickness"] for r in here), default=None),
             "thickness_median": float(np.median([r["thickness"] for r in here]))
             if here else None}
        if d.size:
            b = bootstrap_stat({0: d}, np.median, n_boot)[0]
            f = bootstrap_stat({0: (d > DEEP).astype(float)}, np.mean, n_boot)[0]
            c = bootstrap_stat({0: cens}, np.mean, n_boot)[0]
            s.update(depth_median=b[0], depth_lo=b[1], depth_hi=b[2],
                     deep_fraction=f[0], deep_lo=f[1], deep_hi=f[2],
                     censored_fraction=c[0], censored_lo=c[1], censored_hi=c[2],
                     region_size_median=float(np.median([r["region_size"] for r in judged])),
                     f_star_over_weight_median=float(np.median(
                         [r["f_star_over_weight"] for r in judged])))
        out[mu] = s
    return out


def _mu_of(r: dict) -> float:
    return float(r["mu"]) if "mu" in r else float(r["params"]["mu"])


def judged_by_mu(results: list[dict], key: str = "depth") -> dict:
    """{mu: array over the judged layers of ``key``} (depth, or "deep": depth > DEEP)."""
    out: dict = {}
    for r in results:
        if r.get("ok") and status(r) == "judged":
            v = r["depth"] > DEEP if key == "deep" else r[key]
            out.setdefault(float(r["mu"]), []).append(float(v))
    return {m: np.array(v) for m, v in sorted(out.items())}


# ----------------------------------------------------------------------------
# the verdicts
# ----------------------------------------------------------------------------
def _verdicts(results: list[dict], stats_mu: dict, min_pushes: int):
    """The paper's claim under its stated reading, and ours beside. Returns
    (numbers, verdicts)."""
    from . import stats
    from .report import Verdict

    depth = {m: v for m, v in judged_by_mu(results).items() if v.size >= min_pushes}
    deep = {m: v for m, v in judged_by_mu(results, "deep").items() if m in depth}
    numbers: dict = {"mus_judged": sorted(depth), "min_pushes": min_pushes,
                     "deep_R": DEEP, "floor_layer_R": FLOOR_LAYER, "displaced_R": DISPLACED}
    verdicts = []
    near = stats.near(CLAIM_MU)
    rule = (f"shallowest: the mu of the smallest median depth of the connected displaced "
            f"region; near: its 95 % bootstrap interval (layers resampled within each mu) "
            f"inside {near[0]:.3g}-{near[1]:.3g} (half a decade either side of 0.1); not "
            f"decidable if half or more of the pushes at that mu reach the floor (its "
            f"median would be a lower bound), or if fewer than 3 mu have {min_pushes} "
            f"judged pushes")
    claim = "The rearrangement caused by a point force is shallowest near mu ≈ 0.1 " \
            "(where eta peaks)"
    if len(depth) < 3:      # the claim stays in the table, with what is missing
        counts = "; ".join(f"mu = {m:g}: {s['judged']}" for m, s in stats_mu.items())
        verdicts.append(Verdict(
            "pointforce", claim, f"judged pushes per mu: {counts}; {len(depth)} mu have the "
            f"{min_pushes} a verdict needs, 3 are needed", "not decidable", rule=rule))
        return numbers, verdicts
    m_min, lo, hi = stats.argmax_bootstrap({m: -v for m, v in depth.items()}, stat=np.median)
    cens_min = stats_mu[m_min]["censored_fraction"]
    numbers["shallowest_median_mu"] = {"mu": m_min, "ci95": [lo, hi],
                                       "censored_fraction_there": cens_min}
    verdict = stats.interval_verdict(lo, hi, near) if cens_min < 0.5 else "not decidable"
    medians = "; ".join(
        f"mu = {m:g}: {stats_mu[m]['depth_median']:.1f} R [{stats_mu[m]['depth_lo']:.1f}, "
        f"{stats_mu[m]['depth_hi']:.1f}], censored {stats_mu[m]['censored_fraction']:.2f}, "
        f"{depth[m].size} pushes" for m in depth)
    verdicts.append(Verdict(
        "pointforce", claim,
        f"smallest median depth at mu = {m_min:g} (95 % bootstrap interval over layers "
        f"{lo:g}-{hi:g}); median depth [95 % interval]: {medians}", verdict, rule=rule))
    ends = (min(deep), max(deep))
    if CLAIM_MU in deep and CLAIM_MU not in ends:
        diffs = {e: stats.difference_interval(deep[e], deep[CLAIM_MU]) for e in ends}
        numbers["deep_fraction_minus_at_0.1"] = {f"{e:g}": list(v) for e, v in diffs.items()}
        if all(v[1] > 0 for v in diffs.values()):
            ours = "supported"
        elif any(v[2] < 0 for v in diffs.values()):
            ours = "not supported"
        else:
            ours = "not decidable"
        verdicts.append(Verdict(
            "pointforce", f"fewer pushes rearrange deeper than {DEEP:g} R at mu = 0.1 than "
                          f"at either end of the mu range",
            "; ".join(f"fraction deeper at mu = {m:g}: {deep[m].mean():.2f}"
                      for m in deep) + "; " + "; ".join(
                f"mu = {e:g} minus mu = 0.1: {v[0]:+.2f} [{v[1]:+.2f}, {v[2]:+.2f}]"
                for e, v in diffs.items()), ours, kind="ours",
            rule=f"both 95 % bootstrap intervals of (fraction deeper than {DEEP:g} R at "
                 f"mu = {ends[0]:g}, resp. {ends[1]:g}) minus (at mu = 0.1) above 0; not "
                 f"supported if either lies below 0. Censoring-proof: a region cut off by "
                 f"the floor (>= {MIN_THICKNESS:g} R down) is deeper than {DEEP:g} R either "
                 f"way"))
    return numbers, verdicts


# ----------------------------------------------------------------------------
# the summary
# ----------------------------------------------------------------------------
def summarize(results: list[dict], out) -> dict:
    """pointforce.csv (one row per layer), pointforce_by_mu.csv, pointforce.png/.pdf,
    verdicts.json, REPORT.md."""
    from .report import RULES_VERSION, failed_tasks_note, study_info, write_csv, write_section

    out = Path(out)
    rows = [r for r in results if r.get("ok")]
    failed = [r for r in results if not r.get("ok")]
    write_csv(out / "pointforce.csv", rows, ROW_KEYS)
    cfg = study_info(out).get("config") or {}
    stats_mu = per_mu(results)
    by_mu = [dict(mu=m, **s) for m, s in stats_mu.items()]
    if by_mu:
        write_csv(out / "pointforce_by_mu.csv", by_mu, list(by_mu[0]))
    numbers, verdicts = _verdicts(results, stats_mu, cfg.get("min_pushes", FULL["min_pushes"]))
    numbers.update({"tasks": len(results), "tasks_failed": len(failed),
                    "failed": [f"{r['task']}: {r.get('error')}" for r in failed],
                    "by_mu": {f"{m:g}": s for m, s in stats_mu.items()}})
    figures = []
    if any(s.get("depth_median") is not None for s in stats_mu.values()):
        _figure(out, results, stats_mu)
        figures = ["pointforce.png"]
    text = _text(rows, stats_mu, numbers)
    text += (f" A mu enters the verdicts with at least {numbers['min_pushes']} judged pushes"
             + ("." if verdicts else f"; {len(numbers['mus_judged'])} mu have them, 3 are "
                                     f"needed: no verdict."))
    text += failed_tasks_note(failed, results)
    write_section(out, "pointforce", "Point force: depth of the rearrangement", text,
                  verdicts, numbers, figures, rules_version=RULES_VERSION)
    return {"tasks": len(results), "failed": len(failed),
            "pushed": sum(s["judged"] for s in stats_mu.values()),
            "verdicts": [v.verdict for v in verdicts]}


def _figure(out, results, stats_mu) -> None:
    from matplotlib.figure import Figure
    from matplotlib.ticker import FormatStrFormatter, LogLocator

    from forcespace.extend import save_figure

    mus = [m for m, s in stats_mu.items() if s.get("depth_median") is not None]
    s = [stats_mu[m] for m in mus]
    fig = Figure(figsize=(14, 5.6))
    a1, a2, a3 = fig.subplots(1, 3)
    rng = np.random.default_rng(0)
    judged = [r for r in results if r.get("ok") and status(r) == "judged"]
    for cens, mk, lab in ((False, "o", "one layer"),
                          (True, "^", "one layer, region reaches the floor (censored)")):
        pts = [r for r in judged if bool(r["reaches_floor"]) == cens]
        x = np.array([r["mu"] for r in pts]) * np.exp(rng.uniform(-0.1, 0.1, len(pts)))
        style = dict(ms=4, lw=0, alpha=0.75, zorder=3, label=lab,
                     color="C3" if cens else "0.45", mfc="none" if cens else "0.45")
        a1.plot(x, [r["depth"] for r in pts], mk, **style)
        a3.plot(x, [r["region_size"] for r in pts], mk, **style)
    a1.fill_between(mus, [q["depth_lo"] for q in s], [q["depth_hi"] for q in s], color="C0",
                    alpha=0.25, lw=0, label="median: 95 % bootstrap interval over layers")
    a1.plot(mus, [q["depth_median"] for q in s], "-", color="C0", lw=2, label="median")
    a1.axhline(DEEP, color="k", ls=":", lw=0.8, label=f"deep: {DEEP:g} R")
    thin = min(q["thickness_min"] for q in s)
    a1.axhline(thin, color="C3", ls="--", lw=0.8,
               label=f"thinnest layer: pushed centre {thin:.0f} R above the floor")
    a1.set(xscale="log", xlabel=r"friction coefficient $\mu$", ylim=(-1, 1.05 * max(r["thickness"] for r in judged)),
           ylabel="depth below the pushed disk's centre [R]",
           title=f"depth of the connected region displaced > {DISPLACED:g} R")
    for key, c, mk, ls, lab in (("deep", "C1", "s", "-", f"deeper than {DEEP:g} R"),
                                ("censored", "C3", "o", "--", "reaching the floor (censored)")):
        a2.fill_between(mus, [q[f"{key}_lo"] for q in s], [q[f"{key}_hi"] for q in s],
                        color=c, alpha=0.18, lw=0, label=f"{lab}: 95 % bootstrap interval")
        a2.plot(mus, [q[f"{key}_fraction"] for q in s], mk, ls=ls, color=c, mfc="none",
                ms=7 if key == "deep" else 4, label=f"{lab}: fraction of the pushes")
    a2.set(xscale="log", xlabel=r"friction coefficient $\mu$", ylabel="fraction of pushes",
           ylim=(-0.03, 1.03), title="deep and censored rearrangements")
    a3.plot(mus, [q["region_size_median"] for q in s], "-", color="C2", lw=2, label="median")
    a3.set(xscale="log", yscale="log", xlabel=r"friction coefficient $\mu$",
           ylabel="disks in the region", title="size of the rearrangement")
    a3.yaxis.set_major_formatter(FormatStrFormatter("%g"))
    a3.yaxis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))   # labels at 2, 5, 20, 50, ...
    a3.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
    for ax in (a1, a2, a3):
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14))
    save_figure(fig, out / "pointforce.png", tight=True)


def _text(rows, stats_mu, numbers) -> str:
    if not rows:
        return "No finished task."
    prm = rows[0].get("params") or {}
    counts = "; ".join(
        f"mu = {m:g}: {s['tasks']} tasks, {s['judged']} judged"
        + "".join(f", {s[k]} {k.replace('_', ' ')}" for k in STATUSES[1:] + ("failed",)
                  if s[k])
        + (f", thickness {s['thickness_min']:.1f} R (thinnest), {s['thickness_median']:.1f} R "
           f"(median)" if s["thickness_min"] is not None else "")
        for m, s in stats_mu.items())
    thin = [s["thickness_min"] for s in stats_mu.values() if s["thickness_min"] is not None]
    scene = prm.get("scene", "?")
    return (
        f"{len(rows)} layers ({prm.get('n_disks', '?')} disks, radii R-2R, periodic width "
        f"{prm.get('width', '?')} R, settled under gravity on a floor with the disks' "
        f"friction; scene `{scene}`). Thickness: the pushed (highest) disk's centre above "
        f"the floor, at least {min(thin):.1f} R here"
        + (f" (the rule for the full run: >= {MIN_THICKNESS:g} R)" if min(thin) < MIN_THICKNESS
           else "") + ". "
        f"The highest disk is pushed down through its centre with F* times {OVERLOADS} in "
        f"turn until the push rearranges the layer around it; F* is the largest force its "
        f"rigid network carries (LP). The rearrangement is the connected displaced region: "
        f"disks displaced by more than {DISPLACED:g} R joined through contacts of the "
        f"settled layer (via displaced disks) to the pushed disk or its contact neighbours; "
        f"a disk creeping elsewhere is not part of it (counted as `displaced_outside`). "
        f"Depth: from the pushed disk's centre down to the lowest centre of the region. A "
        f"region reaching the bottom layer (lowest point < {FLOOR_LAYER:g} R above the "
        f"floor) is censored. Statistics over the judged pushes of each mu: median depth, "
        f"fraction deeper than {DEEP:g} R (fixed before the run), fraction censored, each "
        f"with a 95 % bootstrap interval over layers.\n\n"
        f"Judged: a rearrangement around the push that came to rest, on a layer whose "
        f"control run (the same dynamics without force) displaced no disk by more than "
        f"{DISPLACED:g} R. The control and every push restart the dynamics from the "
        f"settled layer with its own contact forces (a warm start: restarted from zero "
        f"forces, the contact solver rebuilt the network over many steps and the layer "
        f"sagged meanwhile, at mu = 1 by up to 2.8 R with no push; runs before that fix "
        f"are not used). "
        f"Per mu: {counts}. Not judged: restless (the control "
        f"moved a disk), no rearrangement up to {OVERLOADS[-1]:g} F*, "
        f"push not at rest (still moving after the push's step cap), carries any force "
        f"(no finite F*); failed: the layer did not settle (creep past jamming.max_steps).")
