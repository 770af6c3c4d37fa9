"""Soft (LIGGGHTS, pymunk) force networks against the rigid packing's force ensemble S.

Usage::

    python studies/soft_vs_rigid.py PACK_mu0.h5 PACK_mu0.1.h5 PACK_mu0.5.h5 [--out studies/out/soft_vs_rigid]
        [--kn-ladder 1e3 1e4 1e5 1e6 1e7] [--quick]

Packings come from ``forcespace pack inputs/paper.toml --mu M -o PACK.h5``; pass mu = 0.1 first.
Distances are to the plate S (TOP contacts unknown + plate balance row).
Per packing: a LIGGGHTS stiffness ladder (kn = K * <Fn>/R; top plate a frictionless
load-controlled plate via the servo mesh module), kt/kn = 2/7 and 1 at the middle K;
pymunk (load-controlled plate) at several iteration counts and time steps.
Where in S each soft network lands: distance of its projection onto S from the
centre of S and from the jammed contact-dynamics state; kt/kn = 2/7 vs 1.
Each run is stored as ``OUT/runs/<packing>__<run>.json`` and skipped when
present (checkpoint/resume). Outputs: ``OUT/table.csv``, ``OUT/distance_vs_kn.png/.pdf``
and the fitted exponent of relative distance vs K (log-log least squares).
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path

import numpy as np


def _run_liggghts(p, K, kt_ratio, work):
    from forcespace_adapters import liggghts as L
    from forcespace_adapters.problem import soft_problem
    prob = soft_problem(p, top="plate")
    d = work / f"lig_K{K:g}_kt{kt_ratio:.3f}"
    # tolerance 1e-6 <Fn>: at K = 1e7 the per-disk residual does not get below ~3e-7 <Fn>
    # (double-precision positions ~40 R, kn*ulp ~ 5e-9 F0 per contact); runs to 1e-7 at
    # K = 1e7 stall, with 1e-6 they converge in ~0.8M steps
    L.write_deck(prob, d, L.LiggghtsOptions(kn=K, kt_ratio=kt_ratio,
                                            tolerance=1e-6, max_steps=1_500_000))
    L.run_deck(d)
    soft, info = L.read_result(d, p)
    return soft, {**info, "K": K, "top": "plate"}


def _run_pymunk(p, iterations, dt):
    from forcespace_adapters.problem import soft_problem
    from forcespace_adapters.pymunk_sim import PymunkOptions, simulate
    soft, info = simulate(soft_problem(p, top="plate"),
                          PymunkOptions(iterations=iterations, dt=dt, max_steps=20000))
    return soft, {**info, "iterations": iterations, "dt": dt, "top": "plate"}


def _measure(p, soft, top, S_cache):
    from forcespace_adapters.distance import compare, make_problem
    if top not in S_cache:
        S_cache[top] = make_problem(p, top)
    try:
        c = compare(p, soft, S_cache[top])
    except Exception as exc:  # report, do not abort the study
        return {"relative_distance": float("nan"), "error": f"{type(exc).__name__}: {exc}"}
    c.pop("unmatched")
    c.pop("lost")
    c.pop("run")
    return c


def _landing(p, soft, S, centre):
    """Where in S the soft network lands: distances of its projection onto S from the
    centre of S (Chebyshev centre) and from the jammed contact-dynamics state, and of
    the jammed state from the centre -- all rms per contact in units of <Fn>."""
    from forcespace.extend import distance_to_S
    from forcespace_adapters.distance import soft_vector
    prob, x, _ = soft_vector(p, soft, S)
    y = distance_to_S(prob, x).nearest
    scale = prob.force_scale * np.sqrt(prob.n_contacts)
    return {"landing_from_centre": float(np.linalg.norm(y - centre) / scale),
            "landing_from_jammed": float(np.linalg.norm(y - prob.x_jammed) / scale),
            "jammed_from_centre": float(np.linalg.norm(prob.x_jammed - centre) / scale)}


def _soft_again(p, code, a1, a2, work, tag):
    """The soft network of a finished run: LIGGGHTS read back from its deck folder,
    pymunk (deterministic, < 1 s) run again. None if the deck is gone."""
    if code == "pymunk":
        return _run_pymunk(p, a1, a2)[0]
    from forcespace_adapters import liggghts as L
    d = work / tag
    return L.read_result(d, p)[0] if d.is_dir() else None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packings", nargs="+")
    ap.add_argument("--out", default="studies/out/soft_vs_rigid")
    ap.add_argument("--kn-ladder", type=float, nargs="+", default=[1e3, 1e4, 1e5, 1e6, 1e7])
    ap.add_argument("--quick", action="store_true", help="pymunk at one setting only")
    args = ap.parse_args(argv)
    from forcespace import read_packing
    out = Path(args.out)
    (out / "runs").mkdir(parents=True, exist_ok=True)
    rows = []
    summary = {}
    for path in args.packings:
        p = read_packing(path)
        name = Path(path).stem
        work = out / "work" / name
        work.mkdir(parents=True, exist_ok=True)
        S_cache = {}
        from forcespace_adapters.distance import make_problem
        S_cache["plate"] = make_problem(p, "plate")
        from forcespace import ForceSpace
        centre = ForceSpace(ranges=False).compute(S_cache["plate"]).centre
        softs = {}
        rigid_viol = S_cache["plate"].violation(S_cache["plate"].forces_from_packing(p.fn, p.ft))
        print(f"{name}: rigid packing violates the plate S by {rigid_viol:.2e} <Fn>", file=sys.stderr)
        summary.setdefault(name, {})["rigid_violation_plate_S"] = rigid_viol
        plan = [("liggghts", K, 2 / 7) for K in args.kn_ladder]
        mid = args.kn_ladder[len(args.kn_ladder) // 2]
        plan.append(("liggghts", mid, 1.0))
        pm = [(30, 0.01)] if args.quick else [(10, 0.01), (30, 0.01), (100, 0.01), (30, 0.003), (100, 0.003)]
        plan += [("pymunk", it, dt) for it, dt in pm]
        for code, a1, a2 in plan:
            tag = (f"lig_K{a1:g}_kt{a2:.3f}" if code == "liggghts" else f"pym_it{a1}_dt{a2:g}")
            f = out / "runs" / f"{name}__{tag}.json"
            if f.exists():
                rec = json.loads(f.read_text())
                print(f"[skip] {name} {tag}", file=sys.stderr)
            else:
                print(f"[run ] {name} {tag} ...", file=sys.stderr, flush=True)
                t = time.perf_counter()
                try:
                    soft, info = (_run_liggghts(p, a1, a2, work) if code == "liggghts"
                                  else _run_pymunk(p, a1, a2))
                    m = _measure(p, soft, info["top"], S_cache)
                except Exception as exc:
                    info, m = {}, {"error": f"{type(exc).__name__}: {exc}",
                                   "relative_distance": float("nan")}
                rec = {"packing": name, "mu": p.mu, "code": code, "tag": tag,
                       **{k: v for k, v in info.items() if isinstance(v, (int, float, str, bool))},
                       **m, "total_wall_s": time.perf_counter() - t}
                tmp = f.with_suffix(".tmp")
                tmp.write_text(json.dumps(rec, indent=1, default=float))
                tmp.replace(f)
            if "landing_from_centre" not in rec and "error" not in rec:
                soft = _soft_again(p, code, a1, a2, work, tag)
                if soft is not None:
                    rec.update(_landing(p, soft, S_cache["plate"], centre))
                    softs[tag] = soft
                    tmp = f.with_suffix(".tmp")
                    tmp.write_text(json.dumps(rec, indent=1, default=float))
                    tmp.replace(f)
            print(f"  {tag}: rel. distance {rec.get('relative_distance')}, max overlap "
                  f"{rec.get('max_overlap')}, wall {rec.get('wall_time_s')}", file=sys.stderr)
            rows.append(rec)
        pair = [f"lig_K{mid:g}_kt{kt:.3f}" for kt in (2 / 7, 1.0)]
        if all(t in softs for t in pair):
            from forcespace_adapters.distance import distance_between
            summary[name]["kt_2/7_vs_1_at_K"] = mid
            summary[name]["kt_2/7_vs_1_distance"] = distance_between(
                p, softs[pair[0]], softs[pair[1]], S_cache["plate"])
    keys = ["packing", "mu", "code", "tag", "K", "kt_ratio", "iterations", "dt", "top",
            "converged", "steps", "wall_time_s", "relative_distance", "max_violation_rel",
            "max_overlap", "unmatched_contacts", "max_unmatched_force_rel", "lost_contacts",
            "max_lost_rigid_force_rel", "landing_from_centre", "landing_from_jammed",
            "jammed_from_centre", "error"]
    with open(out / ".table.csv.tmp", "w", newline="") as fh:
        w = csv.DictWriter(fh, keys, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    (out / ".table.csv.tmp").replace(out / "table.csv")
    fits = {}
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5, 4))
    for name in sorted({r["packing"] for r in rows}):
        lig = [r for r in rows if r["packing"] == name and r["code"] == "liggghts"
               and abs(r.get("kt_ratio", 0) - 2 / 7) < 1e-9 and np.isfinite(r["relative_distance"])]
        if len(lig) >= 2:
            lig.sort(key=lambda r: r["K"])
            K = np.array([r["K"] for r in lig])
            d = np.array([r["relative_distance"] for r in lig])
            ok = d > 0
            slope = np.polyfit(np.log10(K[ok]), np.log10(d[ok]), 1)[0] if ok.sum() >= 2 else np.nan
            # same contact network as the rigid packing: no soft contact outside it
            same = ok & np.array([r.get("unmatched_contacts", 1) == 0 for r in lig])
            slope_same = (np.polyfit(np.log10(K[same]), np.log10(d[same]), 1)[0]
                          if same.sum() >= 2 else np.nan)
            fits[name] = slope
            summary.setdefault(name, {})["fitted_exponent_all"] = slope
            summary[name]["fitted_exponent_same_network"] = slope_same
            summary[name]["same_network_K"] = K[same].tolist()
            summary[name]["monotone_decrease"] = bool(np.all(np.diff(d) < 0))
            ax.loglog(K, d, "o-", label=f"{name} (slope {slope:.2f}; same network {slope_same:.2f})")
            ax.loglog(K[~same], d[~same], "x", color="k", ms=9)
    ax.set_xlabel("kn / (<Fn>/R)")
    ax.set_ylabel("relative distance to S (x: extra soft contacts)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    for ext in ("png", "pdf"):
        fig.savefig(out / f".distance_vs_kn.tmp.{ext}", format=ext)
        (out / f".distance_vs_kn.tmp.{ext}").replace(out / f"distance_vs_kn.{ext}")
    for name, rec in summary.items():
        pm = [r for r in rows if r["packing"] == name and r["code"] == "pymunk"]
        if pm:
            best = min(pm, key=lambda r: r.get("relative_distance", np.inf)
                       if np.isfinite(r.get("relative_distance", np.nan)) else np.inf)
            rec["pymunk_best"] = {k: best.get(k) for k in ("tag", "relative_distance",
                                                            "max_overlap", "converged")}
    (out / ".fits.json.tmp").write_text(json.dumps(summary, indent=1, default=float))
    (out / ".fits.json.tmp").replace(out / "fits.json")
    print(json.dumps({"summary": summary, "table": str(out / "table.csv")}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
