"""When to try the certificate (issue 42): ``paper_certified`` with its
``jamming.certificate_speed`` multiplied by FACTOR (100: from 1e-4 to 1e-2, a certificate
tried after every window slower than 1e-2 sqrt(F0 rbar / mbar)) against the packings of
``studies/certificate_validation.md`` (``paper_fast`` and ``paper_certified`` at 1e-4,
its rows in ``studies/results/certificate_validation/rows.jsonl``), same seeds, boxes
scaled as ``--n N --scale-box``, at mu = 1 the size study's ``solver.tolerance = 1e-8``.

Per packing: z, packing fraction, rattler fraction, mobilised fraction (as
:mod:`forcespace_studies.certificate_validation`), jam CPU s (process CPU of the jam, one
BLAS thread), steps, certificates tried. dim S / Nc and eta are not measured here (the
slice analysis and the billiard walk cost minutes per packing). Rows go to
OUT/rows.jsonl as they finish (a rerun skips the rows it has), the tables (Welch and KS
as :func:`forcespace_studies.protocol_validation.table`, and per seed whether the
packing is the same as at 1e-4) to stdout. Usage::

    python -m forcespace_studies.certificate_speed [--factor 100] [--sizes 200,800]
        [--mus 1,0.1] [--seeds 10] [--jobs 2] [--out studies/results/certificate_speed]
"""
from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from .certificate_validation import mobilised_fraction
from .protocol_validation import pool_rows, table
from .rows import read_rows

BEFORE = Path("studies/results/certificate_validation/rows.jsonl")
QUANTITIES = (("z", "z"), ("phi", "packing fraction"), ("rattler_fraction", "rattler fraction"),
              ("mobilised_fraction", "mobilised fraction"), ("jam_cpu_s", "jam CPU s"),
              ("jam_steps", "steps"))


def one(factor: float, n: int, mu: float, seed: int) -> dict:
    """Jam and measure one packing (a worker process)."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from forcespace import load_scene
    from forcespace.extend import Setup, build_packing
    from .size import FULL
    scene, _ = load_scene("paper_certified").scaled_to(n)
    scene = scene.with_overrides(**{
        "physics.mu": mu, "scene.seed": seed, **FULL["protocol_by_mu"].get(mu, {}),
        "jamming.certificate_speed": scene["jamming.certificate_speed"] * factor})
    t0 = time.process_time()
    p = build_packing(Setup.from_scene(scene), show_progress=False)
    cpu = time.process_time() - t0
    m = p.meta
    return {"protocol": "candidate", "factor": factor, "n": n, "mu": mu, "seed": seed,
            "jam_cpu_s": cpu, "jam_steps": int(m["steps"]), "jam_end": m["jam_end"],
            "certificates": int(m["certificates_tried"]), "z": float(p.coordination()),
            "phi": float(p.packing_fraction()),
            "rattler_fraction": float(p.rattlers().mean()),
            "mobilised_fraction": mobilised_fraction(p, mu),
            "static_residual": float(m["static_residual"])}


def report(rows: list, before: list, factor: float) -> str:
    """Tables per mu: the candidate against paper_fast and against paper_certified as
    shipped before, over the seeds both have; then per seed, same packing or not."""
    out = []
    for mu in sorted({r["mu"] for r in rows}):
        new = [dict(r, protocol="new") for r in rows if r["mu"] == mu]
        seeds = {(r["n"], r["seed"]) for r in new}
        sizes = sorted({n for n, _s in seeds})
        for base, name in (("reference", "paper_fast"),
                           ("candidate", "paper_certified, certificate from 1e-4")):
            ref = [dict(r, protocol="reference") for r in before
                   if r["mu"] == mu and r["protocol"] == base and (r["n"], r["seed"]) in seeds]
            out += [f"### mu = {mu:g}: {name} (reference) against the certificate from "
                    f"{factor:g} x (candidate)", "", table(ref + new, sizes, "new", QUANTITIES),
                    ""]
        old = {(r["n"], r["seed"]): r for r in before
               if r["mu"] == mu and r["protocol"] == "candidate"}
        same = [f"n {r['n']} seed {r['seed']}: "
                + ("same packing" if (r["n"], r["seed"]) in old
                   and old[r["n"], r["seed"]]["jam_steps"] == r["jam_steps"]
                   and old[r["n"], r["seed"]]["z"] == r["z"] else
                   f"steps {old[r['n'], r['seed']]['jam_steps']} -> {r['jam_steps']}"
                   if (r["n"], r["seed"]) in old else f"{r['jam_steps']} steps (no packing before)")
                for r in sorted(new, key=lambda r: (r["n"], r["seed"]))]
        out += [f"Per seed at mu = {mu:g}: " + "; ".join(same) + ".", ""]
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--factor", type=float, default=100.0)
    ap.add_argument("--sizes", default="200,800")
    ap.add_argument("--mus", default="1,0.1")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("studies/results/certificate_speed"))
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / "rows.jsonl"
    rows = read_rows(path)
    have = {(r["n"], r["mu"], r["seed"]) for r in rows if r["factor"] == a.factor}
    todo = [(one, (a.factor, int(n), float(mu), s)) for n in a.sizes.split(",")
            for mu in a.mus.split(",") for s in range(1, a.seeds + 1)
            if (int(n), float(mu), s) not in have]
    pool_rows(todo, a.jobs, path, rows,
              lambda r: f"  n={r['n']} mu={r['mu']:g} seed={r['seed']}: {r['jam_cpu_s']:.1f} "
                        f"CPU s, {r['jam_steps']} steps, z {r['z']:.4f}")
    before = read_rows(BEFORE, required=True)
    print(report([r for r in rows if r["factor"] == a.factor], before, a.factor))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
