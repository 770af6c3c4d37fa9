"""The cross-check by pyramids for eta: S of a sphere packing sampled with its circular
cones and with every cone replaced by its inscribed k-sided pyramid (k = 8, 16, 32).

Usage::

    nice python studies/spheres_pyramids_eta.py PACKING.h5 [...] [--full] [--n 800]
        [--out studies/results/spheres_pyramids_eta]

Per packing and problem (the middle slice, or ``--full`` the whole packing): eta from
``HitAndRun(n, seed=1)`` on the cones (exact chords) and from
``HitAndRun(n, seed=1, pyramids=k)`` (the polytope walk: its hit-and-run kernel and MVE
rounding on the pyramids' polytope), each with its jackknife standard error; the relative
difference eta_k / eta - 1 beside 1 - cos(pi / k) (how far an inscribed pyramid falls
short of its cone). One JSON line per run in ``OUT/rows.jsonl``, the table in
``OUT/pyramids_eta.md``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from forcespace_studies.rows import append_row, read_rows


def runs(path: Path, full: bool, n: int):
    import forcespace as fs
    from forcespace.extend import sphere_problem_for

    p = fs.read_packing(path)
    prob = fs.sphere_full_problem(p) if full else sphere_problem_for(p)
    S = fs.ForceSpace().compute(prob)
    for k in (None, 8, 16, 32):
        c0 = time.process_time()
        hr = fs.HitAndRun(n, seed=1, pyramids=k).compute(prob, analysis=S)
        ci = hr.ensemble.eta_interval()
        yield {"packing": path.name, "problem": "full" if full else "slice", "dim_S": S.dim,
               "pyramid_sides": k, "eta": ci["eta"], "eta_se": ci["se"],
               "min_ess": hr.ensemble.diagnostics["min_ess"],
               "max_rhat": hr.ensemble.diagnostics["max_rhat"], "n": n,
               "cpu_s": time.process_time() - c0}


def table(rows) -> str:
    out = ["| packing | problem | dim S | k | eta (± s.e.) | eta_k / eta - 1 (± s.e.) | "
           "1 - cos(pi/k) | min ESS | max R-hat |", "|---|---|---|---|---|---|---|---|---|"]
    ref = {(r["packing"], r["problem"]): r for r in rows if r["pyramid_sides"] is None}
    for r in rows:
        c = ref.get((r["packing"], r["problem"]))
        k = r["pyramid_sides"]
        if k is None or c is None:
            rel, gap = "–", "cone (exact chords)"
        else:
            q = r["eta"] / c["eta"]
            se = q * np.hypot(r["eta_se"] / r["eta"], c["eta_se"] / c["eta"])
            rel, gap = f"{q - 1:+.4f} ± {se:.4f}", f"{1 - np.cos(np.pi / k):.4f}"
        out.append(f"| {r['packing']} | {r['problem']} | {r['dim_S']} | {k or '∞'} | "
                   f"{r['eta']:.5g} ± {r['eta_se']:.2g} | {rel} | {gap} | "
                   f"{r['min_ess']:.0f} | {r['max_rhat']:.3f} |")
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packings", nargs="+", type=Path)
    ap.add_argument("--full", action="store_true")
    ap.add_argument("--n", type=int, default=800)
    ap.add_argument("--out", type=Path, default=Path("studies/results/spheres_pyramids_eta"))
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows_file = args.out / "rows.jsonl"
    for path in args.packings:
        for row in runs(path, args.full, args.n):
            append_row(rows_file, row)
            print(json.dumps(row), file=sys.stderr, flush=True)
    rows = read_rows(rows_file)
    (args.out / "pyramids_eta.md").write_text(table(rows))
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
