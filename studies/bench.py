"""Benchmarks of the reference engine (``make bench``); figures go to studies/out/bench.*.

Measured, not asserted:
1. (Contact updates per second: moved to ``python -m forcespace_studies.bench_engine``,
   CPU time, old code and pymunk interleaved.)
2. Wall time to jam ``inputs/paper.toml`` (mu = 0 and mu = 0.1).
3. What accuracy costs in time: equilibrium residual of the static solve
   (cold start, zero forces) against sweeps and seconds, and the compression's
   overlap and time against the per-step NLGS tolerance.

Ratios of numbers measured in the same run are the robust part (the machine is
shared); absolute rates carry the machine's noise.
"""
from __future__ import annotations

import json
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from forcespace import __version__, read_packing
from forcespace.extend import build_packing, make_bodies, save_figure, static_solve
from forcespace import load_scene, Packing
from forcespace.extend import Setup

OUT = Path(__file__).parent / "out"


def tile(p: Packing, k: int) -> Packing:
    """The packing repeated k times along periodic x (n -> k n disks, same forces)."""
    n = p.n_disks
    shift = np.repeat(np.arange(k), n)
    x = np.tile(p.x, k) + shift * p.width
    fields = {}
    a_blocks, b_blocks, img_blocks = [], [], []
    for c in range(k):
        a = np.where(p.a >= 0, p.a + c * n, p.a)
        # b's image: the copy (c + image) mod k, with the wrap carried by the new image
        tgt = c + p.image
        b = np.where(p.b >= 0, p.b + (tgt % k) * n, p.b)
        a_blocks.append(a)
        b_blocks.append(b)
        img_blocks.append(np.where(p.b >= 0, np.floor_divide(tgt, k), 0))
    for name in ("normal", "point", "gap", "fn", "ft"):
        fields[name] = np.concatenate([getattr(p, name)] * k)
    return replace(p, x=x, y=np.tile(p.y, k), r=np.tile(p.r, k), width=k * p.width,
                   top_force=k * p.top_force, a=np.concatenate(a_blocks),
                   b=np.concatenate(b_blocks), image=np.concatenate(img_blocks), **fields)


def static_convergence(scene, packing: Packing, seed=1):
    """Residual against sweeps and seconds of the static solve from zero forces
    on the jammed configuration of ``packing`` (cold start: the worst case)."""
    bodies = make_bodies(Setup.from_scene(scene), packing.x, packing.y, packing.r,
                         packing.y_top)
    history = []
    for cap in (100, 300, 1000, 3000, 10000, 30000, 100000, 300000):
        s = scene.with_overrides(**{"jamming.static_max_sweeps": cap,
                                    "jamming.static_tolerance": 1e-13})
        t0 = time.perf_counter()
        _p, st = static_solve(Setup.from_scene(s), bodies, seed, show_progress=False)
        history.append((cap, time.perf_counter() - t0, st["static_residual"]))
        if st["static_residual"] <= 1e-13:
            break
    return history


def scaling(p: Packing, tiles=(1, 5, 10, 25), sample_tiles=(1, 3, 6), height=28.0,
            n_samples=100, seed=1):
    """Cost growth of the exact analysis and of hit-and-run with system size.

    The packing tiled k times along periodic x (:func:`tile`) and its slice of
    ``height``. Per k: the work of ``forcespace analyze --slice`` (analyze
    without ranges, then the domains), CPU and wall seconds. Per k in
    ``sample_tiles``: one default hit-and-run run of ``n_samples`` samples
    (4 chains, thinning d^2 coordinate steps): dim S, rounding method and time,
    burn-in time, the time of 100 samples and the time per effective sample
    (sampling time over the smallest ESS of |x - mean|^2 and three random
    projections); wall seconds from the sampler, CPU/wall of the whole run beside
    them. CPU seconds are the robust numbers on a shared machine
    (everything here is single threaded); the growth exponent is the slope of
    log CPU time against log n over the largest two sizes.
    """
    from forcespace import ForceSpace, HitAndRun, slice_problem
    from forcespace.extend import domains

    def clock():
        return time.process_time(), time.perf_counter()

    rows, samp = [], []
    for k in sorted(set(tiles) | set(sample_tiles)):
        q = tile(p, k) if k > 1 else p
        prob = slice_problem(q, height)
        c0, w0 = clock()
        an = ForceSpace(ranges=False).compute(prob)
        domains(prob, an)
        c1, w1 = clock()
        row = {"n_disks": q.n_disks, "n_contacts": prob.n_contacts, "dim_S": an.dim,
               "analyze_cpu_s": c1 - c0, "analyze_wall_s": w1 - w0}
        rows.append(row)
        print(f"  analyze n={q.n_disks:5d} m={prob.n_contacts:5d} dim S={an.dim:4d}: "
              f"{c1 - c0:8.2f} s CPU ({w1 - w0:.1f} s wall)", flush=True)
        if k not in sample_tiles or not an.dim:
            continue
        c0, w0 = clock()
        res = HitAndRun(n_samples, seed=seed).compute(prob, analysis=an).summary()
        c1, w1 = clock()
        d = res["dim_S"]
        ess = min(v for v in (res.get("ess_sqdev"), res.get("ess_projections_min"))
                  if v is not None)
        sampling_s = res["sampling_s"]
        per_100 = sampling_s * 100.0 / res["n_samples"]
        srow = {"n_disks": q.n_disks, "dim_S": d, "rows": res["n_rows"],
                "rounding_method": res["params"]["rounding"], "rounding_s": res["rounding_s"],
                "burn_in_s": res["burn_in_s"], "sampling_s": sampling_s,
                "thin": res["params"]["thin"], "s_100_samples": per_100,
                "rounding_over_100_samples": res["rounding_s"] / per_100,
                "ess": ess, "rhat_sqdev": res.get("rhat_sqdev"),
                "s_per_effective_sample": sampling_s / ess,
                "cpu_s": c1 - c0, "wall_s": w1 - w0}
        samp.append(srow)
        print(f"  hit-and-run dim S={d:4d} ({res['n_rows']} rows): {srow['rounding_method']} "
              f"rounding {res['rounding_s']:.2f} s, burn-in {res['burn_in_s']:.1f} s, 100 "
              f"samples {per_100:.2f} s (rounding / 100 samples "
              f"{srow['rounding_over_100_samples']:.2f}); {n_samples} samples ESS {ess:.0f}, "
              f"{srow['s_per_effective_sample']:.3f} s per effective sample "
              f"(wall; CPU/wall {(c1 - c0) / (w1 - w0):.2f})", flush=True)
    big = rows[-2:]
    expo = (np.log(big[1]["analyze_cpu_s"] / big[0]["analyze_cpu_s"])
            / np.log(big[1]["n_disks"] / big[0]["n_disks"])) if len(big) == 2 else None
    if expo is not None:
        print(f"  analyze cost growth: CPU ~ n^{expo:.2f} between n={big[0]['n_disks']} and "
              f"n={big[1]['n_disks']}", flush=True)
    return {"analyze": rows, "hit_and_run": samp, "analyze_growth_exponent": expo}


def jam_fast_vs_paper(n_disks=(200, 500), mu=0.1, seeds=(1, 2)) -> list:
    """Jam cost of inputs/paper.toml (random single-contact order, omega = 1) against
    inputs/paper_fast.toml (runs of 64 contacts, omega = 1.8), run alternately on the same
    seeds and sizes (boxes scaled by Scene.scaled_to); contact updates are the
    load-independent measure of work, wall seconds carry the machine's noise."""
    import os
    rows = []
    for n in n_disks:
        for seed in seeds:
            for name in ("paper", "paper_fast"):
                sc = load_scene(f"inputs/{name}.toml")
                if n != sc["disks.n"]:
                    sc = sc.scaled_to(n)[0]
                sc = sc.with_overrides(**{"physics.mu": mu, "scene.seed": seed})
                t0 = time.perf_counter()
                p = build_packing(sc, show_progress=False)
                m = p.meta
                rows.append({"scene": name, "n": n, "seed": seed, "mu": mu,
                             "seconds": time.perf_counter() - t0, "steps": m["steps"],
                             "sweeps": m["sweeps_total"], "capped": m["steps_at_sweep_cap"],
                             "updates": m["normal_updates"] + m["tangential_updates"],
                             "z": p.coordination(), "max_overlap": p.max_overlap(),
                             "residual": p.equilibrium_residual(), "load": os.getloadavg()[0]})
                print(f"  {name:10s} n={n} seed={seed}: {rows[-1]['seconds']:.1f} s, "
                      f"{m['steps']} steps, {m['sweeps_total']} sweeps, z {rows[-1]['z']:.3f}",
                      flush=True)
    return rows


def analysis_scaling(p: Packing, tiles=(1, 5, 10, 25), old_max_tiles=10, height=28.0):
    """Dense (old) against sparse (new) exact analysis, side by side per size.

    Per k (the packing tiled k times, its slice of ``height``): the work of
    ``forcespace analyze --slice`` split into building the problem (the load
    projection onto range(A)), ``analyze`` without ranges and ``domains``, CPU
    and wall seconds, first by the dense path (polytope/measures
    SWEEP_MIN_COLUMNS set above every size: dense SVDs, QR circuits, simplex
    LPs) for k <= ``old_max_tiles``, then by the default path (frontier sweep,
    LU circuits, interior-point LPs above SWEEP_MIN_COLUMNS columns), and
    whether the two agree (dim S, varying contacts, domains). The growth
    exponent is the slope of log CPU against log n over the largest two sizes.
    """
    import os

    from forcespace import ForceSpace, config, slice_problem
    from forcespace.extend import domains

    default = config.SWEEP_MIN_COLUMNS

    def clock():
        return time.process_time(), time.perf_counter()

    def run(q, threshold):
        config.SWEEP_MIN_COLUMNS = threshold     # read at call time by space and linalg
        try:
            c0, w0 = clock()
            prob = slice_problem(q, height)
            c1, w1 = clock()
            an = ForceSpace(ranges=False).compute(prob)
            c2, w2 = clock()
            doms = domains(prob, an)
            c3, w3 = clock()
        finally:
            config.SWEEP_MIN_COLUMNS = default
        t = {"build_cpu_s": c1 - c0, "analyze_cpu_s": c2 - c1, "domains_cpu_s": c3 - c2,
             "total_cpu_s": c3 - c0, "total_wall_s": w3 - w0}
        return prob, an, doms, t

    rows = []
    for k in tiles:
        q = tile(p, k) if k > 1 else p
        row = {"n_disks": q.n_disks, "load_average": os.getloadavg()}
        if k <= old_max_tiles:
            _, a0, d0, row["dense"] = run(q, 10**9)
        prob, an, doms, row["sparse"] = run(q, default)
        row.update(n_contacts=prob.n_contacts, n_columns=prob.n_columns, dim_S=an.dim,
                   n_varying=int(an.varying.sum()), n_domains=len(doms))
        if "dense" in row:
            row["agree"] = bool(a0.dim == an.dim and np.array_equal(a0.varying, an.varying)
                                and sorted((tuple(g.contacts), g.dim) for g in d0)
                                == sorted((tuple(g.contacts), g.dim) for g in doms))
            row["speedup_cpu"] = row["dense"]["total_cpu_s"] / row["sparse"]["total_cpu_s"]
        rows.append(row)
        dense = (f"dense {row['dense']['total_cpu_s']:7.2f} s CPU, " if "dense" in row else "")
        print(f"  n={q.n_disks:5d} m={prob.n_contacts:5d} dim S={an.dim:5d}: {dense}sparse "
              f"{row['sparse']['total_cpu_s']:7.2f} s CPU ({row['sparse']['total_wall_s']:.1f} s "
              f"wall; build {row['sparse']['build_cpu_s']:.2f}, analyze "
              f"{row['sparse']['analyze_cpu_s']:.2f}, domains {row['sparse']['domains_cpu_s']:.2f})"
              + (f", agree {row['agree']}" if "agree" in row else ""), flush=True)
    out = {"analysis": rows}
    for key in ("dense", "sparse"):
        big = [r for r in rows if key in r][-2:]
        if len(big) == 2:
            out[f"{key}_growth_exponent"] = float(
                np.log(big[1][key]["total_cpu_s"] / big[0][key]["total_cpu_s"])
                / np.log(big[1]["n_disks"] / big[0]["n_disks"]))
            print(f"  {key} cost growth: CPU ~ n^{out[key + '_growth_exponent']:.2f} between "
                  f"n={big[0]['n_disks']} and n={big[1]['n_disks']}", flush=True)
    return out


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    paper = load_scene("inputs/paper.toml")
    results = {"forcespace_version": __version__, "machine": platform.platform(),
               "python": sys.version.split()[0]}
    print("jamming inputs/paper.toml at mu = 0 and 0.1 ...", flush=True)
    jam = {}
    packings = {}
    for mu in (0.0, 0.1):
        t0 = time.perf_counter()
        p = build_packing(paper.with_overrides(**{"physics.mu": mu}), show_progress=True)
        jam[mu] = {"seconds": time.perf_counter() - t0, "steps": p.meta["steps"],
                   "z": p.coordination(), "max_overlap": p.max_overlap(),
                   "residual": p.equilibrium_residual(),
                   "updates": p.meta["normal_updates"] + p.meta["tangential_updates"]}
        packings[mu] = p
        print(f"  mu={mu}: {jam[mu]}", flush=True)
    results["jam_paper"] = {str(k): v for k, v in jam.items()}
    print("jamming: the paper's sweep against the fast sweep (inputs/paper_fast.toml) ...",
          flush=True)
    results["jam_fast_vs_paper"] = jam_fast_vs_paper()

    print("accuracy against time ...", flush=True)
    acc = {}
    for mu in (0.0, 0.1):
        acc[f"static mu={mu}"] = static_convergence(paper.with_overrides(**{"physics.mu": mu}),
                                                    packings[mu])
    quick = load_scene("inputs/quick.toml")
    for beta in (0.0, quick["solver.overlap_correction"]):
        sweep_tol = []
        for tol in (1e-4, 1e-5, 1e-6, 1e-7):
            t0 = time.perf_counter()
            p = build_packing(quick.with_overrides(**{"solver.tolerance": tol,
                                                      "solver.overlap_correction": beta}),
                              show_progress=False)
            sweep_tol.append((tol, time.perf_counter() - t0, p.max_overlap(), p.coordination()))
        acc[f"compression tolerance (quick.toml, overlap correction {beta})"] = sweep_tol
    results["engine_accuracy_vs_time"] = acc

    print("exact analysis and hit-and-run against system size ...", flush=True)
    results["scaling"] = scaling(packings[0.1])
    print("exact analysis, dense against sparse path ...", flush=True)
    results["analysis_dense_vs_sparse"] = analysis_scaling(packings[0.1])

    path = OUT / "bench.json"          # other sections (engine, analysis, ...) are kept
    data = json.loads(path.read_text()) if path.is_file() else {}
    data.update(results)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(data, indent=2, default=float))
    tmp.replace(path)
    plot(results)
    print(f"wrote {OUT / 'bench.json'}, {OUT / 'bench.png'} (+ .pdf)")


def plot(results):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    for key, hist in results["engine_accuracy_vs_time"].items():
        if key.startswith("static"):
            h = np.array(hist)
            ax1.loglog(h[:, 1], h[:, 2], "o-", label=key.replace("static ", "paper, "))
    ax1.axhline(1e-10, color="0.5", ls=":", label="required 1e-10")
    ax1.set_xlabel("static solve wall time [s]")
    ax1.set_ylabel("relative equilibrium residual")
    ax1.set_title("static solve: accuracy vs time")
    ax1.legend()
    for key, hist in results["engine_accuracy_vs_time"].items():
        if key.startswith("compression"):
            h = np.array(hist)
            ax2.loglog(h[:, 1], h[:, 2], "s-", label="beta = " + key.split()[-1].rstrip(")"))
            for tol, t, ov, _z in h:
                ax2.annotate(f"eps={tol:.0e}", (t, ov), fontsize=7)
    ax2.legend(title="overlap correction")
    ax2.set_xlabel("jamming wall time [s] (quick.toml)")
    ax2.set_ylabel("max overlap [R]")
    ax2.set_title("compression: NLGS tolerance vs overlap")
    fig.tight_layout()
    save_figure(fig, OUT / "bench.png")


if __name__ == "__main__":
    if sys.argv[1:2] == ["analysis"]:    # bench.py analysis PACKING [k ...]: dense vs sparse
        ks = tuple(int(a) for a in sys.argv[3:]) or (1, 5, 10, 25)
        OUT.mkdir(parents=True, exist_ok=True)
        table = analysis_scaling(read_packing(sys.argv[2]), tiles=ks)
        (OUT / "bench_analysis.json").write_text(json.dumps(table, indent=2))
        print(f"wrote {OUT / 'bench_analysis.json'}")
    elif sys.argv[1:2] == ["scaling"]:
        # only this section: bench.py scaling PACKING [k ...] [--height H] [--sample K,K]
        import argparse
        ap = argparse.ArgumentParser(prog="bench.py scaling")
        ap.add_argument("packing")
        ap.add_argument("tiles", nargs="*", type=int, default=[1, 5, 10, 25])
        ap.add_argument("--height", type=float, default=28.0, help="slice height [R]")
        ap.add_argument("--sample", default=None,
                        help="comma-separated tile counts to sample (default: those <= 6)")
        a = ap.parse_args(sys.argv[2:])
        ks = tuple(a.tiles)
        st = tuple(int(k) for k in a.sample.split(",")) if a.sample else \
            tuple(k for k in ks if k <= 6)
        OUT.mkdir(parents=True, exist_ok=True)
        table = scaling(read_packing(a.packing), tiles=ks, sample_tiles=st, height=a.height)
        (OUT / "bench_scaling.json").write_text(json.dumps(table, indent=2))
        print(f"wrote {OUT / 'bench_scaling.json'}")
    else:
        main()
