"""The paper's point-force experiment: depth of the rearrangement against mu.

Tasks: one per (mu, seed): settle a layer under gravity (``inputs/layer.toml``,
floor friction = disk friction), take its highest disk, find by LP the largest
downward point force F* its rigid contact network can carry
(:func:`forcespace.space.loads.max_point_force`), push with F* times
``OVERLOADS`` in turn (each from the settled state) until the push displaces a
disk by more than ``DISPLACED`` R, and, as a control, with nothing; the depth
of the displaced disks is the measure (:func:`forcespace.measures.rearrangement_depth`). The paper reports
the depth smallest near mu = 0.1, where eta peaks.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from forcespace import config as fs_config
from forcespace.engine.push import push
from forcespace.measures import rearrangement_depth, surface_disk
from forcespace.space.loads import max_point_force
from forcespace.sweep import Task

from .common import shared_packing

DISPLACED = fs_config.DISPLACED

QUICK = dict(scene="layer", n_disks=40, width=20.0, mus=(0.1, 1.0), seeds=(1, 2))
FULL = dict(scene="layer", n_disks=100, width=42.0, mus=(0.01, 0.03, 0.1, 0.3, 1.0),
            seeds=tuple(range(1, 11)))
OVERLOADS = (1.05, 1.1, 1.25, 1.5, 2.0, 3.0, 5.0)   # pushes, in units of F*, until one rearranges


def config(quick: bool) -> dict:
    return QUICK if quick else FULL


def tasks(quick: bool = False) -> list[Task]:
    cfg = config(quick)
    return [Task(f"mu{mu:.3g}_s{seed}", "forcespace_studies.pointforce:packing_task",
                 dict(scene=cfg["scene"], n_disks=cfg["n_disks"], width=cfg["width"], mu=mu,
                      seed=seed)) for mu in cfg["mus"] for seed in cfg["seeds"]]


def packing_task(scene: str, n_disks: int, width: float, mu: float, seed: int,
                 workdir) -> dict:
    wd = Path(workdir)
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks,
                              overrides={"physics__plate_mu": mu, "box__width": width})
    k = surface_disk(p)
    weight = float(np.asarray(p.density) * np.pi * p.r[k] ** 2 * p.gravity) \
        if np.ndim(p.density) == 0 else float(p.density[k] * np.pi * p.r[k] ** 2 * p.gravity)
    t0 = time.perf_counter()
    f_star = max_point_force(p, k)
    row = {"mu": mu, "seed": seed, "z": p.coordination(), "disk": k, "weight": weight,
           "carries_any_force": not math.isfinite(f_star), "t_jam_s": t_jam,
           "t_lp_s": time.perf_counter() - t0}
    if row["carries_any_force"]:        # (JSON has no infinity: f_star is left out)
        row["reason"] = "the rigid network carries any downward force on this disk"
        return row
    row.update(f_star=f_star, f_star_over_weight=f_star / weight)
    t0 = time.perf_counter()
    res = push(p, k, 0.0, seed)
    row["control_max_displacement"] = float(res.displacement.max())
    row["t_control_s"] = time.perf_counter() - t0
    # the smallest force (F* times OVERLOADS) that rearranges: near-contacts close and
    # normals turn as the disks settle by a tiny amount, so F* itself may be carried
    t0 = time.perf_counter()
    for factor in OVERLOADS:
        res = push(p, k, factor * f_star, seed)
        depth, moved = rearrangement_depth(p, k, res.displacement)
        if moved:
            break
    row.update(push_factor=factor, push_depth=depth if moved else None, push_displaced=moved,
               push_max_displacement=float(res.displacement.max()),
               push_steps=int(res.stats["steps"]), push_at_rest=res.at_rest,
               t_push_s=time.perf_counter() - t0)
    return row


def summarize(results: list[dict], out) -> dict:
    from matplotlib.figure import Figure

    from forcespace.plot import save_figure
    from .stats import argmax_bootstrap, interval_verdict, near
    from .report import Verdict, write_csv, write_section

    out = Path(out)
    rows = [r for r in results if r.get("ok")]
    failed = [r for r in results if not r.get("ok")]
    keys = ["mu", "seed", "z", "disk", "weight", "carries_any_force", "f_star", "f_star_over_weight", "push_depth",
            "push_factor", "push_displaced", "push_max_displacement", "control_max_displacement",
            "push_steps", "push_at_rest", "t_jam_s", "t_push_s"]
    write_csv(out / "pointforce.csv", rows, keys)
    # a layer whose control run (no force) moved a disk by > DISPLACED was not at rest
    restless = [r for r in rows if (r.get("control_max_displacement") or 0.0) > DISPLACED]
    pushed = [r for r in rows if r.get("push_depth") is not None and r not in restless]
    mus = sorted({r["mu"] for r in pushed})
    depth = {m: np.array([r["push_depth"] for r in pushed if r["mu"] == m]) for m in mus}
    moved = {m: np.array([r["push_displaced"] for r in pushed if r["mu"] == m]) for m in mus}
    fig = Figure(figsize=(10, 4))
    ax1, ax2 = fig.subplots(1, 2)
    if mus:
        for r in pushed:
            ax1.plot(r["mu"], r["push_depth"], ".", color="0.6")
        ax1.errorbar(mus, [depth[m].mean() for m in mus],
                     [depth[m].std(ddof=1) / np.sqrt(depth[m].size) if depth[m].size > 1
                      else 0 for m in mus], fmt="o-", capsize=3, label="mean ± s.e.")
        ax2.plot(mus, [moved[m].mean() for m in mus], "s-", label="disks displaced")
        fstar = [np.median([r["f_star_over_weight"] for r in pushed if r["mu"] == m])
                 for m in mus]
        ax2.plot(mus, fstar, "^-", label="F* / weight of the disk (median)")
    ax1.set(xscale="log", xlabel="mu", ylabel=f"depth of disks moved > {DISPLACED} R [R]",
            title="rearrangement under a point force")
    ax1.legend(fontsize=7)
    ax2.set(xscale="log", yscale="log", xlabel="mu", title="size of the rearrangement")
    ax2.legend(fontsize=7)
    save_figure(fig, out / "pointforce.png", tight=True)
    numbers = {"packings": len(rows), "pushed": len(pushed), "tasks_failed": len(failed),
               "not_at_rest_without_force": len(restless),
               "failed": [f"{r['task']}: {r.get('error')}" for r in failed],
               "carries_any_force": sum(1 for r in rows if r["carries_any_force"]),
               "no_rearrangement_up_to_max_overload": sum(
                   1 for r in rows if not r["carries_any_force"] and r["push_depth"] is None),
               "depth_by_mu": {f"{m:.3g}": [float(depth[m].mean()), float(depth[m].std())]
                               for m in mus},
               "control_max_displacement": max((r["control_max_displacement"] for r in pushed),
                                               default=None)}
    verdicts = []
    if len(mus) >= 3:
        neg = {m: -v for m, v in depth.items()}
        m_min, lo, hi = argmax_bootstrap(neg)
        numbers["depth_min_mu"] = {"mu": m_min, "ci95": [lo, hi]}
        verdicts.append(Verdict(
            "pointforce", "The rearrangement caused by a point force is shallowest near "
                          "mu ≈ 0.1 (where eta peaks)",
            f"smallest mean depth at mu = {m_min:g} (95 % bootstrap interval {lo:g}-{hi:g}); "
            + ", ".join(f"{depth[m].mean():.1f} ± {depth[m].std():.1f} R at mu = {m:g}"
                        for m in mus),
            interval_verdict(lo, hi, near(0.1))))
    text = (f"{len(rows)} layers ({rows[0]['params']['n_disks'] if rows else '?'} disks, "
            f"radii R-2R, periodic width {rows[0]['params']['width'] if rows else '?'} R, "
            f"settled under gravity on a floor with the disks' friction). The highest disk "
            f"is pushed down through its centre with F* times {OVERLOADS} in turn until a "
            f"disk moves; F* is the largest force its rigid network carries (LP). Depth: "
            f"from the pushed disk's centre down to the lowest disk displaced by more than "
            f"{DISPLACED} R. Layers left out: {len(failed)} that did not come to rest when "
            f"settling (creep past jamming.max_steps), {len(restless)} whose control run moved "
            f"a disk by more than {DISPLACED} R.")
    write_section(out, "pointforce", "Point force: depth of the rearrangement", text,
                  verdicts, numbers, ["pointforce.png"])
    return {"tasks": len(results), "failed": len(failed), "pushed": len(pushed),
            "verdicts": [v.verdict for v in verdicts]}
