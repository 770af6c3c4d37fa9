"""Analyse and sample one big slice (issue 12: the 5000-disk packing), with wall times.

    python studies/big_slice.py PACK.h5 HEIGHT OUTDIR [--samples 100]

Writes OUTDIR/big_slice.json (analysis and hit-and-run wall/CPU seconds, dim S,
the sampler's summary: set-up parts, ESS, R-hat, per-chain eta),
OUTDIR/analyze_profile.txt (cProfile of the analysis, cumulative) and the samples
to OUTDIR/hit_and_run.h5 (resumable; large: 100 x 2 m floats). Hit-and-run thins
d^2/20 steps and burns in d^2 per chain (the defaults d^2 and 10 d^2 would take
hours at dim S ~ 1700; ESS and R-hat say what the shorter chains bought).
Run with OMP_NUM_THREADS=1 on a shared machine (BLAS threads oversubscribe).
"""
import argparse
import cProfile
import io
import json
import pstats
import time
from pathlib import Path

from forcespace import HitAndRun, read_packing, slice_problem
from forcespace.extend import atomic_path, domains
from forcespace import ForceSpace


def atomic_write_text(path, text: str) -> None:
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packing")
    ap.add_argument("height", type=float, help="slice height [R]")
    ap.add_argument("outdir")
    ap.add_argument("--samples", type=int, default=100)
    a = ap.parse_args()
    out = Path(a.outdir)
    out.mkdir(parents=True, exist_ok=True)
    res = {"packing": Path(a.packing).name, "slice_height": a.height}
    p = read_packing(a.packing)
    prob = slice_problem(p, a.height)
    prof = cProfile.Profile()
    prof.enable()
    t, c = time.perf_counter(), time.process_time()
    an = ForceSpace(ranges=False).compute(prob)
    res["analyze_wall_s"], res["analyze_cpu_s"] = time.perf_counter() - t, time.process_time() - c
    t, c = time.perf_counter(), time.process_time()
    doms = domains(prob, an)
    res["domains_wall_s"], res["domains_cpu_s"] = time.perf_counter() - t, time.process_time() - c
    prof.disable()
    text = io.StringIO()
    pstats.Stats(prof, stream=text).strip_dirs().sort_stats("cumulative").print_stats(35)
    atomic_write_text(out / "analyze_profile.txt", text.getvalue())
    res.update(n_disks=p.n_disks, slice_disks=prob.n_interior, contacts=prob.n_contacts,
               dim_S=an.dim, bounded=an.bounded, n_domains=len(doms))
    print(json.dumps(res), flush=True)
    d = an.dim
    t, c = time.perf_counter(), time.process_time()
    summ = HitAndRun(a.samples, seed=1, thin=max(1, d * d // 20), burn_in=d * d, progress=True, checkpoint_every=5).compute(prob, output=out / "hit_and_run.h5", analysis=an).summary()
    summ["call_wall_s"], summ["call_cpu_s"] = time.perf_counter() - t, time.process_time() - c
    res["hit_and_run"] = summ
    atomic_write_text(out / "big_slice.json", json.dumps(res, indent=1, default=float))
    print(json.dumps(res, default=float), flush=True)


if __name__ == "__main__":
    main()
