"""The large path's three interior-point LPs, HiGHS' IPX against Clarabel (issue 46):
CPU s of each on the committed 5000-disk slice (dim S 1714), two interleaved rounds.

    OMP_NUM_THREADS=1 python studies/interior_lp_compare.py > studies/sampler_cost/interior_lps.jsonl

One JSON line per (round, solver): the strict-rows LP (interior_strict_rows: CPU s,
rows found strict, the point's violation of S [<Fn>]), max sum fn (interior_max_sum_fn)
and the Chebyshev centre (centre_and_radius, interior=True: CPU s, radius, violation), on the problem at <Fn> = 1, the implicit rows
and hull from one analysis. config.INTERIOR_SOLVERS keeps the faster for each LP.
"""
import json
import time
from pathlib import Path

import forcespace as fs
from forcespace import config
from forcespace.extend import (centre_and_radius, interior_max_sum_fn, interior_strict_rows,
                               unit_problem)

BIG = Path(__file__).parent / "big_slice" / "paper_fast_n5000_mu0.1_s1.h5"


def main() -> None:
    prob = fs.slice_problem(fs.read_packing(BIG), 140.0)
    P, _ = unit_problem(prob)
    an = fs.ForceSpace(ranges=False, centre=False, varying=False).compute(prob)
    N, imp = an.affine_basis, an.implicit_rows
    for rnd in range(2):
        for solver in ("highs-ipm", "clarabel")[::1 if rnd == 0 else -1]:
            for key in config.INTERIOR_SOLVERS:
                config.INTERIOR_SOLVERS[key] = solver
            c0 = time.process_time()
            x, strict = interior_strict_rows(P)
            t1 = time.process_time()
            msum = interior_max_sum_fn(P)
            t2 = time.process_time()
            xc, r = centre_and_radius(P, N, imp, interior=True)
            t3 = time.process_time()
            print(json.dumps({"solver": solver, "round": rnd, "strict_rows_cpu_s": t1 - c0,
                              "n_strict": int(strict.sum()), "violation_strict": P.violation(x),
                              "max_sum_fn_cpu_s": t2 - t1, "max_sum_fn": msum,
                              "centre_cpu_s": t3 - t2, "radius": r,
                              "violation_centre": P.violation(xc),
                              "units": "CPU s; max_sum_fn, radius, violations in <Fn>"}),
                  flush=True)


if __name__ == "__main__":
    main()
