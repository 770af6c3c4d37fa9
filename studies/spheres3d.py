"""Frictional spheres by the paper's protocol: coordination, packing fraction, rattlers vs mu.

Usage::

    nice python studies/spheres3d.py [--mu 0 0.01 0.1 1] [--seeds 1 2 3 4 5] [--n 500]
        [--workers 2] [--out studies/results/spheres3d] [--scene paper3d]

``--n`` other than 500 scales the box with it (``forcespace pack --n N --scale-box``: the
lateral extents by (n/500)^(1/3), the plate's load and mass by its area), so a smaller
study is the same protocol in a smaller box.

Every packing is ``forcespace pack paper3d --mu MU --seed SEED`` (``--scene
paper3d_certified``: the same with the jam ended by an exact static certificate) (500 spheres, radii
uniform in [R, 2R], a box periodic in x and y, compressed along z by a constant force on
the top plate, no gravity; then the static solve to residual <= 1e-10). Each is written
to ``OUT/packings/mu{MU}_s{SEED}.h5`` with its compression checkpoint beside it while it
runs, so a stopped study resumes where it was (rerun the same command); finished packings
are skipped. ``OUT/rows.jsonl`` holds one row per packing, ``OUT/spheres3d.md`` the table
(mean and standard error over the seeds of each mu; rattlers excluded from z, the
convention of ``forcespace info``: a rattler carries no force-bearing contact), and
``OUT/verdicts.json`` / ``OUT/REPORT.md`` the study's verdicts
(:mod:`forcespace_studies.spheres3d`), which ``forcespace study report`` collects into
``studies/REPORT.md``. ``--report-only`` rewrites them from the rows without jamming.
"""
from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from forcespace_studies.rows import append_row, read_rows
from forcespace_studies.spheres3d import summarize, table


def jam_one(mu: float, seed: int, n: int, out: str, scene_name: str = "paper3d") -> dict:
    """Jam one packing (resuming its checkpoint) and return its row."""
    import forcespace as fs
    from forcespace.extend import build_packing

    path = Path(out) / "packings" / f"mu{mu:g}_s{seed}.h5"
    t0 = time.process_time()
    if path.is_file():
        p = fs.read_packing(path)
        cpu = p.meta.get("cpu_seconds", float("nan"))
    else:
        scene = fs.load_scene(scene_name).with_overrides(
            **{"physics.mu": float(mu), "scene.seed": int(seed)})
        if n != scene["disks.n"]:
            scene, _ = scene.scaled_to(int(n))
        p = build_packing(scene, show_progress=False,
                          checkpoint=path.with_suffix(".checkpoint.h5"))
        cpu = time.process_time() - t0
        p.meta["cpu_seconds"] = cpu          # this process's CPU (a resumed run: its part)
        fs.write_packing(p, path)
    s = p.summary()
    return {"mu": mu, "seed": seed, "n": s["n_spheres"], "z": s["z"],
            "packing_fraction": s["packing_fraction"],
            "rattler_fraction": s["n_rattlers"] / s["n_spheres"],
            "n_contacts": s["n_contacts"], "n_force_bearing": s["n_force_bearing"],
            "residual": s["equilibrium_residual"], "coulomb_violation": s["coulomb_violation"],
            "max_overlap": s["max_overlap"], "steps": s["steps"],
            "static_restart": s.get("static_restart", ""),
            "static_retries": s.get("static_retries", 0), "cpu_seconds": cpu,
            "scene": p.scene_name, "jam_end": p.meta.get("jam_end", ""),
            "static_network": p.meta.get("static_network", ""),
            "file": str(path.relative_to(Path(out)))}


def validation(rows, ref_rows) -> str:
    """The markdown table comparing this study's packings (candidate) with a reference
    study's, per mu over the seeds both have (the same seed: the same loose start):
    mean +- standard deviation of each, and the paired difference candidate - reference
    (mean +- its standard error over the seeds, and that mean in units of its s.e.)."""
    keys = (("z", "z", "{:.3f}"), ("packing_fraction", "φ", "{:.4f}"),
            ("rattler_fraction", "rattler fraction", "{:.3f}"), ("steps", "steps", "{:.0f}"),
            ("cpu_seconds", "CPU s", "{:.0f}"))
    out = ["| μ | seeds | quantity | reference | candidate | paired difference | "
           "difference / s.e. |", "|---|---|---|---|---|---|---|"]
    ref = {(r["mu"], r["seed"]): r for r in ref_rows}
    new = {(r["mu"], r["seed"]): r for r in rows}
    for mu in sorted({k[0] for k in new} & {k[0] for k in ref}):
        seeds = sorted(k[1] for k in new if k[0] == mu and k in ref)
        for key, name, fmt in keys:
            a = np.array([ref[mu, s][key] for s in seeds], float)
            b = np.array([new[mu, s][key] for s in seeds], float)
            d = b - a
            se = d.std(ddof=1) / np.sqrt(d.size) if d.size > 1 else float("nan")
            t = d.mean() / se if se > 0 else float("nan")
            out.append(f"| {mu:g} | {len(seeds)} | {name} | {fmt.format(a.mean())} ± "
                       f"{fmt.format(a.std(ddof=1))} | {fmt.format(b.mean())} ± "
                       f"{fmt.format(b.std(ddof=1))} | {fmt.format(d.mean())} ± "
                       f"{fmt.format(se)} | {t:+.1f} |")
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mu", type=float, nargs="+", default=[0.0, 0.01, 0.1, 1.0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--n", type=int, default=500)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default="studies/results/spheres3d")
    ap.add_argument("--scene", default="paper3d",
                    help="the bundled scene (paper3d, or paper3d_certified: the jam ended "
                         "by an exact static certificate)")
    ap.add_argument("--report-only", action="store_true",
                    help="jam nothing: write the table, verdicts.json and REPORT.md of the "
                         "rows already in OUT")
    ap.add_argument("--reference", default=None,
                    help="a finished study directory (its rows.jsonl) to compare with: "
                         "writes OUT/validation.md and does not jam")
    args = ap.parse_args(argv)
    out = Path(args.out)
    if args.reference:
        try:
            text = validation(read_rows(out / "rows.jsonl", required=True),
                              read_rows(Path(args.reference) / "rows.jsonl", required=True))
        except FileNotFoundError as exc:
            ap.error(str(exc))
        (out / "validation.md").write_text(text)
        print(text)
        return 0
    (out / "packings").mkdir(parents=True, exist_ok=True)
    rows_file = out / "rows.jsonl"
    rows = read_rows(rows_file)
    if args.report_only:
        summarize(rows, out, args.scene)
        print(table(rows))
        return 0
    done = {(r["mu"], r["seed"]) for r in rows}
    todo = [(mu, seed) for seed in args.seeds for mu in args.mu if (mu, seed) not in done]
    print(f"{len(todo)} packings to jam ({len(done)} done)", file=sys.stderr, flush=True)
    with ProcessPoolExecutor(args.workers) as pool:
        jobs = {pool.submit(jam_one, mu, seed, args.n, str(out), args.scene): (mu, seed)
                for mu, seed in todo}
        for fut in as_completed(jobs):
            row = fut.result()
            rows.append(row)
            append_row(rows_file, row)
            print(f"mu {row['mu']:g} seed {row['seed']}: z {row['z']:.3f}, phi "
                  f"{row['packing_fraction']:.4f}, residual {row['residual']:.1e}, "
                  f"{row['cpu_seconds']:.0f} CPU s", file=sys.stderr, flush=True)
            summarize(rows, out, args.scene)
    if rows:
        summarize(rows, out, args.scene)
        print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
