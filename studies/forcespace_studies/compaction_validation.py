"""A doubled time step while compacting (issue 42): does ``paper_fast_compaction``
(``paper_certified`` with ``solver.dt_compacting`` = 2 x ``solver.dt`` in every window that
follows a window faster than ``solver.compacting_speed``) jam the same packings,
statistically, as ``paper_certified``?

Both scenes jam the same seeds 1..k at n = 200 and 800 disks (boxes scaled as ``--n N
--scale-box``), mu = 0.1 and 1, at mu = 1 with the size study's ``solver.tolerance =
1e-8`` (as :mod:`forcespace_studies.certificate_speed`). Per packing: z, packing fraction,
rattler fraction, mobilised fraction (:func:`forcespace_studies.certificate_validation.
mobilised_fraction`), jam CPU s (process CPU of the jam, one BLAS thread), steps, how the
jam ended and the static residual. dim S / Nc and eta are not measured here (the slice
analysis and the billiard walk cost minutes per packing). The reference rows of
``paper_certified`` that ``studies/results/certificate_speed/rows.jsonl`` holds (factor
100: the shipped scene) are taken from there, not jammed again (the jam is
deterministic); the others are jammed here, reference and candidate alternately.

Per (n, mu) and quantity: mean +- standard error, Welch's t-test and the two-sample
Kolmogorov-Smirnov test (:func:`forcespace_studies.protocol_validation.table`); p < 0.05
counts as a difference, fixed before the run. Rows go to OUT/rows.jsonl as they finish (a
rerun skips the rows it has), the tables to stdout. Usage::

    python -m forcespace_studies.compaction_validation [--sizes 200,800] [--mus 0.1,1]
        [--seeds 10] [--jobs 1] [--out studies/results/compaction_validation]
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from .certificate_speed import QUANTITIES
from .certificate_validation import mobilised_fraction
from .protocol_validation import pool_rows, table
from .rows import read_rows

PROTOCOLS = {"reference": "paper_certified", "candidate": "paper_fast_compaction"}
SHIPPED = Path("studies/results/certificate_speed/rows.jsonl")   # paper_certified at 1e-2


def one(protocol: str, n: int, mu: float, seed: int) -> dict:
    """Jam and measure one packing of ``PROTOCOLS[protocol]`` (a worker process)."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from forcespace import load_scene
    from forcespace.extend import Setup, build_packing
    from .size import FULL
    scene, _ = load_scene(PROTOCOLS[protocol]).scaled_to(n)
    scene = scene.with_overrides(**{"physics.mu": mu, "scene.seed": seed,
                                    **FULL["protocol_by_mu"].get(mu, {})})
    t0 = time.process_time()
    p = build_packing(Setup.from_scene(scene), show_progress=False)
    cpu = time.process_time() - t0
    m = p.meta
    return {"protocol": protocol, "scene": PROTOCOLS[protocol], "n": n, "mu": mu,
            "seed": seed, "jam_cpu_s": cpu, "jam_steps": int(m["steps"]),
            "jam_end": m["jam_end"], "certificates": int(m["certificates_tried"]),
            "z": float(p.coordination()), "phi": float(p.packing_fraction()),
            "rattler_fraction": float(p.rattlers().mean()),
            "mobilised_fraction": mobilised_fraction(p, mu),
            "static_residual": float(m["static_residual"])}


def one_with_s(protocol: str, n: int, mu: float, seed: int, out: str) -> dict:
    """Jam, keep and measure one packing of ``PROTOCOLS[protocol]`` with its S (a worker)."""
    from .certificate_validation import one as measured
    return measured(protocol, n, mu, seed, out, {}, scenes=PROTOCOLS)


def shipped_rows() -> list:
    """paper_certified's rows of the certificate-speed study (the shipped scene)."""
    rows = read_rows(SHIPPED)
    return [dict(r, protocol="reference", scene=PROTOCOLS["reference"],
                 taken_from=str(SHIPPED)) for r in rows if r.get("factor") == 100.0]


def report(rows: list, quantities=QUANTITIES) -> str:
    """Tables per mu (reference against candidate over the seeds both have)."""
    out = []
    for mu in sorted({r["mu"] for r in rows}):
        sub = [r for r in rows if r["mu"] == mu]
        both = ({(r["n"], r["seed"]) for r in sub if r["protocol"] == "reference"}
                & {(r["n"], r["seed"]) for r in sub if r["protocol"] == "candidate"})
        sub = [r for r in sub if (r["n"], r["seed"]) in both]
        sizes = sorted({n for n, _s in both})
        out += [f"### mu = {mu:g}: paper_certified (reference) against paper_fast_compaction "
                "(candidate)", "", table(sub, sizes, "candidate", quantities), ""]
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="200,800")
    ap.add_argument("--mus", default="0.1,1")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--no-work", action="store_true", help="with --with-s: tables from the rows only")
    ap.add_argument("--bench", type=Path, default=None,
                    help="with --with-s: mean jam CPU s per set into this bench.json (section compaction)")
    ap.add_argument("--with-s", action="store_true",
                    help="jam both scenes again, keep the packings, measure dim S / Nc and eta")
    a = ap.parse_args(argv)
    if a.with_s:
        return with_s(a)
    a.out = a.out or Path("studies/results/compaction_validation")
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / "rows.jsonl"
    rows = read_rows(path)
    have = {(r["protocol"], r["n"], r["mu"], r["seed"]) for r in rows}
    shipped = [r for r in shipped_rows() if ("reference", r["n"], r["mu"], r["seed"]) not in have]
    have |= {(r["protocol"], r["n"], r["mu"], r["seed"]) for r in shipped}
    todo = [(one, (pr, int(n), float(mu), s)) for n in a.sizes.split(",")
            for mu in a.mus.split(",") for s in range(1, a.seeds + 1)
            for pr in PROTOCOLS if (pr, int(n), float(mu), s) not in have]
    pool_rows(todo, a.jobs, path, rows,
              lambda r: f"  {r['protocol']:9s} n={r['n']} mu={r['mu']:g} seed={r['seed']}: "
                        f"{r['jam_cpu_s']:.1f} CPU s, {r['jam_steps']} steps, z {r['z']:.4f}")
    print(report(rows + shipped))
    return 0


def with_s(a) -> int:
    """The ``--with-s`` run: every (n, mu, seed, protocol) not in OUT/rows.jsonl."""
    from .certificate_validation import COSTS, QUANTITIES as WITH_S
    out = a.out or Path("studies/results/compaction_validation_s")
    out.mkdir(parents=True, exist_ok=True)
    path = out / "rows.jsonl"
    rows = read_rows(path)
    have = {(r["protocol"], r["n"], r["mu"], r["seed"]) for r in rows}
    todo = [(one_with_s, (pr, int(n), float(mu), s, str(out))) for n in a.sizes.split(",")
            for mu in a.mus.split(",") for s in range(1, a.seeds + 1)
            for pr in PROTOCOLS if (pr, int(n), float(mu), s) not in have and not a.no_work]
    pool_rows(todo, a.jobs, path, rows,
              lambda r: f"  {r['protocol']:9s} n={r['n']} mu={r['mu']:g} seed={r['seed']}: "
                        f"{r.get('jam_cpu_s') or 0:.1f} CPU s, z {r['z']:.4f}, dim S / Nc "
                        f"{r.get('dim_S_over_Nc')}, eta {r.get('eta_billiard')}")
    print(report(rows, WITH_S + COSTS))
    if a.bench:
        bench_summary(a.bench, rows)
    return 0


def bench_summary(path: Path, rows: list) -> None:
    """Mean jam CPU s and steps per (mu, n, protocol) over the seeds both protocols have,
    into bench.json's section compaction, key ``validation`` (atomic)."""
    import numpy as np
    from forcespace.extend import write_json
    data = json.loads(path.read_text()) if path.is_file() else {}
    out = {"what": "paper_certified (old) and paper_fast_compaction (new) jammed alternately "
                   "in one run, seeds 1..k (forcespace_studies.compaction_validation --with-s); "
                   "mean jam CPU s (process CPU of the jam) and steps over the seeds both have"}
    for mu in sorted({r["mu"] for r in rows}):
        for n in sorted({r["n"] for r in rows if r["mu"] == mu}):
            sub = [r for r in rows if r["mu"] == mu and r["n"] == n]
            seeds = sorted({r["seed"] for r in sub if r["protocol"] == "reference"}
                           & {r["seed"] for r in sub if r["protocol"] == "candidate"})
            cell = {"seeds": len(seeds)}
            for pr, key in (("reference", "old"), ("candidate", "new")):
                mine = [r for r in sub if r["protocol"] == pr and r["seed"] in seeds
                        and r.get("jam_cpu_s") is not None]     # None: a packing reused
                cell[key] = {"cpu_s": float(np.mean([r["jam_cpu_s"] for r in mine])) if mine else None,
                             "steps": float(np.mean([r["jam_steps"] for r in mine])) if mine else None}
            out.setdefault(f"{mu:g}", {})[str(n)] = cell
    data.setdefault("compaction", {})["validation"] = out
    write_json(path, data, indent=2)


if __name__ == "__main__":
    raise SystemExit(main())
