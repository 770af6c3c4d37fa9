"""The cost of S of a sphere slice: the exact analysis and converged uniform sampling (issue 44).

Usage::

    python studies/spheres_slice_cost.py PACKING.h5 --out studies/results/spheres_slice_cost
        [--target-ess 100] [--cap 4000] [--seed 1]

The packing's middle slice (its scene's slice height: ``sphere_problem_for``), as the
500-sphere slice of ``studies/conic_sampler_cost.md`` was measured:

1. the exact analysis, ``fs.ForceSpace().compute`` (defaults: no per-contact ranges, the
   certified centre), CPU s per stage (the rank of A, feasibility and the cones' faces,
   boundedness, the affine hull, the centre; the rest of ``compute``: checks, scaling);
2. the billiard walk (``fs.BilliardWalk``, its defaults, ``--seed``) until converged:
   ``target_ess`` on every tracked statistic (bulk and tail ESS) and R-hat <=
   ``config.RHAT_MAX`` = 1.05, at most ``--cap`` samples; CPU s of its rounding, burn-in
   and sampling (the driver's own split) and in all.

CPU s: this process's user + system time (``time.process_time``); peak memory: the
process's maximum resident set (``ru_maxrss``) after each part. Writes OUT/NAME.json
(atomically, after each part: a killed run keeps what finished) with the code version.
"""
from __future__ import annotations

import argparse
import json
import platform
import resource
import sys
import time
from pathlib import Path


def peak_mib() -> float:
    """The process's peak resident memory so far [MiB] (Linux ru_maxrss is in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def timed_analysis(prob):
    """(ForceSpace, {stage: CPU s}): the default analysis and its stages' CPU time."""
    import forcespace as fs

    S = fs.ForceSpace().compute(prob)
    return S, dict(S.stage_cpu_s)


def range_costs(prob, S, k: int, k_old: int) -> dict:
    """CPU s per contact of the ranges of fn (2 SOCPs) and of |f_t| (its min, 1 SOCP; its
    max by the certified bounds, ``ft_range``, and on the first ``k_old`` also by the
    support ascent, ``ft_range_ascent``) on k contacts S moves, drawn at random (seed 0);
    the two maxima side by side [<Fn>]."""
    import numpy as np
    from forcespace.extend import conic_fn_range as fn_range
    from forcespace.extend import conic_ft_range as ft_range
    from forcespace.extend import conic_ft_range_ascent as ft_range_ascent

    unit = prob.scaled(1.0 / prob.force_scale)
    faces = S.faces
    m = prob.n_contacts
    moving = np.flatnonzero(np.linalg.norm(S.affine_basis.reshape(m, 3, -1), axis=(1, 2))
                            > 1e-9)
    rows = []
    for i, j in enumerate(np.random.default_rng(0).choice(moving, min(k, moving.size),
                                                           replace=False)):
        c0 = time.process_time()
        points = []
        fn = fn_range(unit, faces, int(j), points)
        c1 = time.process_time()
        new = ft_range(unit, faces, int(j), fn[1], points)
        c2 = time.process_time()
        old = ft_range_ascent(unit, faces, int(j)) if i < k_old else (np.nan, np.nan)
        c3 = time.process_time() if i < k_old else np.nan
        rows.append({"contact": int(j), "fn_range": list(map(float, fn)),
                     "ft_max_new": float(new[1]), "ft_max_old": float(old[1]),
                     "ft_min": float(new[0]), "cpu_fn_s": c1 - c0, "cpu_ft_new_s": c2 - c1,
                     "cpu_ft_old_s": c3 - c2})
        print(json.dumps(rows[-1]), flush=True)
    mean = {key: float(np.nanmean([r[key] for r in rows]))
            for key in ("cpu_fn_s", "cpu_ft_new_s", "cpu_ft_old_s")} if k_old else \
        {key: float(np.mean([r[key] for r in rows])) for key in ("cpu_fn_s", "cpu_ft_new_s")}
    diff = [abs(r["ft_max_new"] - r["ft_max_old"]) for r in rows[:k_old]]
    return {"units": "CPU s per contact; forces in <Fn>", "moving_contacts": int(moving.size),
            "sampled_contacts": len(rows), "mean_cpu_per_contact_s": mean,
            "old_on": min(k_old, len(rows)),
            "max_abs_ft_max_difference": float(max(diff)) if diff else None,
            "contacts": rows}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packing", nargs="?")
    ap.add_argument("--out", default="studies/results/spheres_slice_cost")
    ap.add_argument("--target-ess", type=float, default=100.0)
    ap.add_argument("--cap", type=int, default=4000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--ranges", type=int, default=0, metavar="K",
                    help="after the analysis: the per-contact ranges of K contacts drawn at "
                         "random (seed 0) among those S moves, |f_t| by the certified bounds "
                         "and, on the first --old of them, by the first method (support "
                         "ascent), old beside new")
    ap.add_argument("--old", type=int, default=0, metavar="K2")
    ap.add_argument("--no-sampling", action="store_true")
    ap.add_argument("--report", action="store_true",
                    help="measure nothing: OUT/table.md, verdicts.json and REPORT.md from the "
                         "JSON files in OUT")
    args = ap.parse_args(argv)
    if args.report:
        write_report(Path(args.out))
        return 0
    if not args.packing:
        ap.error("PACKING is required (a sphere packing file), unless --report")
    import forcespace as fs
    from forcespace import config
    from forcespace.extend import code_version, sphere_problem_for, write_json

    p = fs.read_packing(args.packing)
    out = Path(args.out) / (f"n{p.n_spheres}_{Path(args.packing).stem}"
                            f"{'_ranges' if args.ranges else ''}.json")
    prob = sphere_problem_for(p)
    row = {"description": "CPU s of the exact analysis and of converged billiard sampling "
                          "of S of a sphere packing's middle slice "
                          "(studies/spheres_slice_cost.py)",
           "units": {"cpu": "s of CPU time (user + sys) of this process",
                     "peak_memory": "MiB, the process's peak resident set after the part"},
           "packing": Path(args.packing).name, "n_spheres": int(p.n_spheres),
           "mu": float(p.mu), "slice_height_R": p.scene_slice_height,
           "n_contacts_unknown": int(prob.n_contacts), "code_version": code_version(),
           "machine": platform.platform(), "rhat_max": config.RHAT_MAX,
           "target_ess": args.target_ess, "cap": args.cap, "seed": args.seed}
    print(f"{row['packing']}: {prob.n_contacts} unknown contacts; analysis ...", flush=True)
    c0 = time.process_time()
    S, split = timed_analysis(prob)
    row["analysis"] = {"cpu_s": time.process_time() - c0, "stages_cpu_s": split,
                       "dim": S.dim, "bounded": S.bounded, "radius": S.radius,
                       "peak_memory_mib": peak_mib()}
    write_json(out, row)
    print(json.dumps(row["analysis"]), flush=True)
    if args.ranges:
        row["ranges"] = range_costs(prob, S, args.ranges, args.old)
        row["ranges"]["peak_memory_mib"] = peak_mib()
        write_json(out, row)
        print(json.dumps({k: v for k, v in row["ranges"].items() if k != "contacts"}))
    if args.no_sampling:
        return 0
    c0 = time.process_time()
    r = fs.BilliardWalk(args.cap, seed=args.seed, target_ess=args.target_ess,
                        progress=True).compute(prob, analysis=S)
    cpu = time.process_time() - c0
    s = r.summary()
    row["sampling"] = {"sampler": "billiard", "cpu_s": cpu,
                       "cpu_rounding_s": s["cpu"]["rounding_s"],
                       "cpu_burn_in_s": s["cpu"]["burn_in_s"],
                       "cpu_sampling_s": s["cpu"]["sampling_s"],
                       "n_samples": int(r.ensemble.n_samples),
                       "min_ess": s["min_ess"], "max_rhat": s["max_rhat"],
                       "status": r.status, "message": r.message, "eta": r.ensemble.eta,
                       "peak_memory_mib": peak_mib()}
    write_json(out, row)
    print(json.dumps(row["sampling"]), flush=True)
    return 0


def cost_cells(d: dict) -> list[str]:
    """A row of the cost table from one JSON file of this script."""
    a, s = d["analysis"], d.get("sampling")
    st = a["stages_cpu_s"]
    stages = ", ".join(f"{'set-up (rank of A)' if k == 'set-up' else k} {v:.1f}"
                       for k, v in st.items())
    rest = a["cpu_s"] - sum(st.values())
    if rest > 0.05 * a["cpu_s"]:
        stages += f", set-up (rank of A) and checks {rest:.1f}"
    part = d.get("sampling_partial")
    samp = ((f"not finished: stopped in the rounding after {part['rounding_cpu_s_so_far']:.0f} "
             f"CPU s ({part['note']})" if part else "not finished") if s is None else
            f"{s['cpu_s']:.1f} (rounding {s['cpu_rounding_s']:.1f}, burn-in "
            f"{s['cpu_burn_in_s']:.1f}, {s['n_samples']} samples {s['cpu_sampling_s']:.1f})")
    conv = "—" if s is None else f"{s['min_ess']:.0f} / {s['max_rhat']:.3f}"
    mem = max(a["peak_memory_mib"], (s or part or {}).get("peak_memory_mib", 0))
    return [str(d["n_spheres"]), str(d["n_contacts_unknown"]), str(a["dim"]),
            f"{a['cpu_s']:.1f} ({stages})", samp, conv, f"{mem:.0f}"]


def write_report(out: Path) -> None:
    """OUT/table.md and the report section (verdicts.json, REPORT.md) from OUT/n*.json."""
    from forcespace_studies.report import RULES_VERSION, Verdict, write_section

    docs = [json.loads(f.read_text()) for f in sorted(out.glob("n*_*.json"))
            if not f.stem.endswith("_ranges")]
    if not docs:
        raise SystemExit(f"{out}: no cost file (n*_*.json) of this script to report")
    docs.sort(key=lambda d: d["n_spheres"])
    head = ("| spheres | unknown contacts | dim S | exact analysis, CPU s (by stage) | "
            "billiard to convergence, CPU s | min ESS / max R-hat | peak memory [MiB] |\n"
            "|---|---|---|---|---|---|---|\n")
    table = head + "".join("| " + " | ".join(cost_cells(d)) + " |\n" for d in docs)
    (out / "table.md").write_text(table)
    verdicts = []
    for d in docs:
        s = d.get("sampling")
        ok = s is not None and s["status"] == 0
        verdicts.append(Verdict(
            "spheres_slice_cost", f"S of a {d['n_spheres']}-sphere slice (paper3d_certified, "
            f"mu = {d['mu']:g}) is analysed exactly and sampled uniformly to convergence on "
            "the project's machine", "; ".join(
                f"{h}: {c}" for h, c in zip(("spheres", "contacts", "dim S",
                                             "analysis CPU s", "billiard CPU s",
                                             "min ESS / max R-hat", "peak MiB"),
                                            cost_cells(d))),
            "supported" if ok else "not decidable", sampler="billiard", kind="ours",
            rule=f"the billiard's own stop: every tracked statistic's bulk and tail ESS >= "
                 f"{d['target_ess']:g} and R-hat <= {d['rhat_max']:g}, at most {d['cap']} "
                 "samples; CPU s of this process"))
    write_section(out, "spheres_slice_cost", "Spheres: the cost of the exact analysis and "
                  "of converged uniform sampling of a slice", "The middle slice of "
                  "`paper3d_certified` packings (issue 43) at mu = 0.1, seed 1; CPU s are "
                  "user + system time of one process on the shared 2-core machine "
                  "(`studies/spheres_slice_cost.py`; one JSON per packing here).\n\n" + table,
                  verdicts, {"rows": docs}, [], rules_version=RULES_VERSION)


if __name__ == "__main__":
    sys.exit(main())
