"""The LIGGGHTS stiffness ladder: does every run converge, and how far is its network from S?

Usage::

    python studies/liggghts_ladder.py studies/packings/paper_mu0.1.h5 \\
        studies/packings/paper_mu0.1_seed2.h5 ... [--kn 1e4 1e5 1e6 1e7] [--tolerance 1e-6] \\
        [--out studies/out/liggghts_ladder] [--workers 2]

Per packing and stiffness K (kn = K <Fn>/R, the adapters' unit): a LIGGGHTS deck with the
load-controlled top plate (``forcespace_adapters.liggghts``: static convergence test,
servo with an integral term near convergence, tolerance raised to the run's precision
floor), run, read back, and measured against the plate S
(``forcespace_adapters.distance.compare``: relative distance = rms per contact distance to
S in <Fn>, and the verdict at the soft code's own accuracy). One JSON per run in
``OUT/runs/`` (a rerun skips the runs already there); ``OUT/ladder.md`` is the table.

Sphere packings (issue 43) run natively in 3-D (``forcespace_adapters.liggghts3d``: box
periodic in x and y, plates as walls, the same load-controlled top plate and convergence
test) and are measured against the sphere plate problem; for both kinds the table adds the
soft network's equilibrium residual on the rigid geometry and its largest Coulomb excess,
both in <Fn> (``compare``: rigid_equilibrium_residual, coulomb_violation)::

    python studies/liggghts_ladder.py P1.h5 P2.h5 P3.h5 --kn 1e3 1e4 1e5 \
        --out studies/results/liggghts_ladder3d
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from forcespace.errors import InputError


def run_one(packing_path: str, K: float, tolerance: float, work: str,
            remeasure: bool = False) -> dict:
    """One ladder run; returns its record (JSON-ready)."""
    from forcespace import read_packing
    from forcespace_adapters import (compare, liggghts as L, liggghts3d as L3, make_problem,
                                     soft_problem)

    p = read_packing(packing_path)
    spheres = getattr(p, "dim", 2) == 3
    d = Path(work)
    t = time.perf_counter()
    if remeasure and (d / "status.json").is_file():     # measure a finished deck again
        st = json.loads((d / "status.json").read_text())
    else:
        opt = L.LiggghtsOptions(kn=K, tolerance=tolerance)
        if spheres:
            L3.write_deck3(p, d, opt, source=packing_path)
        else:
            L.write_deck(soft_problem(p), d, opt)
        st = L.run_deck(d)
    soft, info = (L3.read_result3 if spheres else L.read_result)(d, p)
    scale = info["force_scale"]
    force, torque, plate = soft.net_forces()
    try:
        c = compare(p, soft, make_problem(p, "plate"))
    except InputError as e:      # the soft run rearranged the packing: no common network
        return {"packing": Path(packing_path).stem, "mu": p.mu, "seed": p.seed, "K": K,
                "steps": st["steps"], "converged": st["converged"], "tolerance": tolerance,
                "tolerance_used": info["tolerance_used"],
                "precision_floor": info["precision_floor"],
                "static_residual": info["max_residual_force"] / scale,
                "plate_error": abs(plate) / scale, "max_overlap": None,
                "relative_distance": None, "rigid_residual": None,
                "coulomb_violation": None, "dimension": 3 if spheres else 2,
                "inside_S": False, "verdict": f"not comparable: {e}",
                "max_displacement": max_displacement(p, soft),
                "liggghts_s": st["wall_time_s"], "total_s": time.perf_counter() - t}
    return {"packing": Path(packing_path).stem, "mu": p.mu, "seed": p.seed, "K": K,
            "steps": st["steps"], "converged": st["converged"],
            "tolerance": tolerance, "tolerance_used": info["tolerance_used"],
            "precision_floor": info["precision_floor"],
            "static_residual": info["max_residual_force"] / scale,
            "plate_error": abs(plate) / scale,
            "max_overlap": c["max_overlap"], "relative_distance": c["relative_distance"],
            "rigid_residual": c["rigid_equilibrium_residual"],
            "coulomb_violation": c["coulomb_violation"], "dimension": 3 if spheres else 2,
            "inside_S": c["verdict"]["inside_S"], "verdict": c["verdict"]["text"],
            "unmatched_contacts": c["unmatched_contacts"], "lost_contacts": c["lost_contacts"],
            "max_displacement": max_displacement(p, soft),
            "liggghts_s": st["wall_time_s"], "total_s": time.perf_counter() - t}


def max_displacement(rigid, soft) -> float:
    """The largest distance [R] between a grain's rigid and soft centres (periodic axes
    by the minimum image; grains the soft run left out, rattlers, not counted)."""
    if getattr(rigid, "dim", 2) == 3:
        d = soft.pos - rigid.pos
        lat = np.asarray(rigid.lateral, float)
        d[:, :2] -= lat * np.round(d[:, :2] / lat)
    else:
        d = np.column_stack([soft.x - rigid.x, soft.y - rigid.y])
        if rigid.periodic_x:
            d[:, 0] -= rigid.width * np.round(d[:, 0] / rigid.width)
    live = ~rigid.rattlers()
    return float(np.linalg.norm(d, axis=1)[live].max(initial=0.0))


def _cell(v, fmt="{:.2g}"):
    return "—" if v is None else fmt.format(v)


def table(rows) -> str:
    head = ("| μ | seed | K = kn R/⟨Fn⟩ | steps | converged | tolerance used [⟨Fn⟩] | "
            "static residual [⟨Fn⟩] | plate error [⟨Fn⟩] | max overlap [R] | "
            "residual on the rigid geometry [⟨Fn⟩] | Coulomb excess [⟨Fn⟩] | "
            "relative distance to S | inside S at its accuracy | largest displacement [R] |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    lines = []
    for r in sorted(rows, key=lambda r: (r["mu"], r["seed"], r["K"])):
        lines.append(f"| {r['mu']:g} | {r['seed']} | {r['K']:.0e} | {r['steps']:,} | "
                     f"{'yes' if r['converged'] else '**no**'} | {r['tolerance_used']:.1e} | "
                     f"{r['static_residual']:.1e} | {r['plate_error']:.1e} | "
                     f"{_cell(r['max_overlap'], '{:.1e}')} | "
                     f"{_cell(r.get('rigid_residual'), '{:.1e}')} | "
                     f"{_cell(r.get('coulomb_violation'), '{:.1e}')} | "
                     f"{_cell(r['relative_distance'], '{:.2e}')} | "
                     f"{'yes' if r['inside_S'] else 'no'} | "
                     f"{_cell(r.get('max_displacement'), '{:.2g}')} |")
    return head + "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packings", nargs="+")
    ap.add_argument("--kn", type=float, nargs="+", default=[1e4, 1e5, 1e6, 1e7],
                    help="stiffnesses K in <Fn>/R")
    ap.add_argument("--tolerance", type=float, default=1e-6, help="[<Fn>] (default 1e-6)")
    ap.add_argument("--out", default="studies/out/liggghts_ladder")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--remeasure", action="store_true",
                    help="measure every finished deck in OUT/work again (no LIGGGHTS run)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    (out / "runs").mkdir(parents=True, exist_ok=True)
    jobs = {}
    with ProcessPoolExecutor(args.workers) as pool:
        for path in args.packings:
            for K in args.kn:
                tag = f"{Path(path).stem}__K{K:g}"
                f = out / "runs" / f"{tag}.json"
                if args.remeasure or not f.exists():
                    jobs[pool.submit(run_one, path, K, args.tolerance,
                                     str(out / "work" / tag), args.remeasure)] = f
        for fut, f in jobs.items():
            rec = fut.result()
            f.write_text(json.dumps(rec, indent=1))
            print(f"{f.stem}: steps {rec['steps']}, converged {rec['converged']}, "
                  f"distance {_cell(rec['relative_distance'], '{:.2e}')}", file=sys.stderr,
                  flush=True)
    rows = [json.loads(f.read_text()) for f in sorted((out / "runs").glob("*.json"))]
    (out / "ladder.md").write_text(table(rows))
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
