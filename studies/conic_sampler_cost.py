"""Hit-and-run against the billiard walk on S of a sphere packing: ESS per CPU s.

Usage::

    nice python studies/conic_sampler_cost.py PACKING.h5 [...]

For each packing, its middle slice (the scene's slice height) and its whole problem
(``sphere_full_problem``), analysed once, then sampled by both uniform walks with their
defaults (400 samples, seed 1): one JSON line per (problem, sampler) with the smallest
bulk/tail ESS of the tracked statistics, the largest R-hat, the CPU s of the sampling, of
the burn-in and in all (this process's user + system time: analysis excluded, rounding and
burn-in included), and eta.
"""
import json
import sys
import time

import forcespace as fs
from forcespace.extend import sphere_problem_for


def main(paths):
    for path in paths:
        p = fs.read_packing(path)
        for kind, prob in (("slice", sphere_problem_for(p)), ("full", fs.sphere_full_problem(p))):
            S = fs.ForceSpace().compute(prob)
            for name, cls in (("hit-and-run", fs.HitAndRun), ("billiard", fs.BilliardWalk)):
                c0 = time.process_time()
                r = cls(400, seed=1).compute(prob, analysis=S)
                cpu = time.process_time() - c0
                s = r.summary()
                print(json.dumps({
                    "packing": str(path), "problem": kind, "dim": r.dim, "sampler": name,
                    "n": 400, "min_ess": round(s["min_ess"], 1),
                    "max_rhat": round(s["max_rhat"], 3), "cpu_total_s": round(cpu, 2),
                    "cpu_rounding_s": round(s["cpu"]["rounding_s"], 2),
                    "cpu_burn_in_s": round(s["cpu"]["burn_in_s"], 2),
                    "cpu_sampling_s": round(s["cpu"]["sampling_s"], 2),
                    "ess_per_sampling_cpu_s": round(s["min_ess"] / s["cpu"]["sampling_s"], 1),
                    "ess_per_total_cpu_s": round(s["min_ess"] / cpu, 1),
                    "eta": r.ensemble.eta}), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
