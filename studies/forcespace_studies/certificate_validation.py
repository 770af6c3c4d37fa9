"""Certificate validation (issue 42): does ``paper_certified`` (jam ended by an exact static
certificate, <= 300 sweeps per step throughout) jam the same packings, statistically, as
``paper_fast``?

Both protocols jam the same seeds 1..k at n = 200 and 800 disks (boxes scaled as
``--n N --scale-box``), mu = 0.1 and 1, with the size study's protocol at each mu (mu =
1: ``solver.tolerance = 1e-8``, ``size.FULL["protocol_by_mu"]``), and every packing is
measured by the size study's own task (:func:`forcespace_studies.size.packing_task`:
its scaled slice's S, the billiard walk's uniform eta, 4 chains to ESS 100, capped at
20 000 samples and 900 s) plus, on the whole packing: z, packing fraction, rattler
fraction and the mobilised fraction (force-bearing disk-disk contacts between
non-rattlers at the Coulomb limit, :data:`forcespace_studies.fig1.MOBILISED`).

The reference's slice analysis and eta need not be recomputed: the size study made them
for exactly these packings (``--reference-from studies/results/size/size.csv``). The
reference packing is jammed again here (its packing fraction, mobilised fraction and jam
CPU time are not in that table), and its z and rattler count are checked against the
size study's row: equal to the last digit means the same packing (the jam is
deterministic), and its dim S / Nc and eta are then taken from the row; a mismatch runs
the task in full.

Per (n, mu) and quantity: mean +- standard error for each protocol, Welch's t-test and
the two-sample Kolmogorov-Smirnov test (:func:`forcespace_studies.protocol_validation.
table`); a difference counts as significant at p < 0.05, fixed before the run. Jam CPU
seconds are process CPU time (user + sys) of the jam alone, one BLAS thread.

Usage::

    python -m forcespace_studies.certificate_validation [--sizes 200,800] [--mus 0.1,1]
        [--seeds 10] [--jobs 2] [--out studies/results/certificate_validation]
        [--reference-from studies/results/size/size.csv]

Rows go to OUT/rows.jsonl as they finish (a rerun skips the rows it has; packings are
kept in OUT/PROTOCOL/packings), the table to studies/certificate_validation.md.
"""
from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from pathlib import Path

import numpy as np

from .protocol_validation import pool_rows
from .rows import read_rows

PROTOCOLS = {"reference": "paper_fast", "candidate": "paper_certified"}
CAPS = {"billiard": 20000}
MAX_SECONDS = 900.0
CLUSTERS_MAX_DIM = 60
QUANTITIES = (("z", "z"), ("phi", "packing fraction"), ("rattler_fraction", "rattler fraction"),
              ("dim_S_over_Nc", "dim S / Nc"), ("mobilised_fraction", "mobilised fraction"),
              ("eta_billiard", "eta (billiard, slice)"))
COSTS = (("jam_cpu_s", "jam CPU s"), ("jam_steps", "steps"))


def mobilised_fraction(p, mu: float) -> float:
    """Fraction of the force-bearing disk-disk contacts between non-rattlers that sit at
    the Coulomb limit, |ft| >= mu fn (1 - fig1.MOBILISED) (fig1's definition)."""
    from .fig1 import MOBILISED
    rat = p.rattlers()
    live = p.force_bearing() & (p.a >= 0) & (p.b >= 0)
    live &= ~rat[np.maximum(p.a, 0)] & ~rat[np.maximum(p.b, 0)]
    ratio = np.abs(p.ft) / np.maximum(mu * p.fn, 1e-300)
    return float((live & (ratio >= 1 - MOBILISED)).sum() / max(live.sum(), 1))


def jam_timed(out: Path, scene: str, n: int, mu: float, seed: int):
    """(packing, jam CPU seconds or None when it was kept already) of the study's shared
    packing (scene, mu, seed, n), jammed as the size study jams it."""
    from . import size
    from .common import shared_packing
    _h, _n0, over = size.scaled_geometry(scene, n)
    over.update({k.replace(".", "__"): v
                 for k, v in size.FULL["protocol_by_mu"].get(float(mu), {}).items()})
    t0 = time.process_time()
    p, wall = shared_packing(out, scene, mu, seed, n, overrides=over)
    return p, (time.process_time() - t0 if wall > 0 else None)


def one(protocol: str, n: int, mu: float, seed: int, out: str, reference_rows: dict,
        scenes: dict | None = None) -> dict:
    """Jam and measure one packing (a worker process); see the module docstring.
    ``scenes``: protocol -> scene name (default PROTOCOLS; another study's pair)."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from . import size
    from forcespace.errors import NumericalError
    scene = (scenes or PROTOCOLS)[protocol]
    base = Path(out) / protocol
    t0 = time.process_time()
    try:
        p, cpu = jam_timed(base, scene, n, mu, seed)
    except NumericalError as e:     # a protocol that fails to jam: a result, counted
        return {"protocol": protocol, "n": n, "mu": mu, "seed": seed,
                "cpu_s": time.process_time() - t0, "jam_cpu_s": None, "z": float("nan"),
                "jam_end": "failed", "error": str(e)}
    known = reference_rows.get((n, mu, seed)) if protocol == "reference" else None
    same = (known is not None and float(known["z"]) == p.coordination()
            and int(known["n_rattlers"]) == int(p.rattlers().sum()))
    if same:
        row = {k: (float(known[k]) if known[k] not in ("", None) else None)
               for k in ("dim_S", "dim_S_over_Nc", "eta_billiard", "slice_contacts")}
        row["from"] = "size study row (same z and rattlers)"
    else:
        wd = base / "tasks" / f"n{n}_mu{mu:g}_s{seed}"
        wd.mkdir(parents=True, exist_ok=True)
        row = size.packing_task(scene, n, mu, seed, wd, CAPS, MAX_SECONDS, False,
                                CLUSTERS_MAX_DIM, size.window_size(scene),
                                size.FULL["protocol_by_mu"].get(float(mu)))
        row["from"] = "measured here"
    m = p.meta
    row.update(protocol=protocol, n=n, mu=mu, seed=seed, jam_cpu_s=cpu,
               jam_steps=int(m["steps"]), jam_end=m.get("jam_end", "rest"),
               z=p.coordination(), phi=p.packing_fraction(),
               rattler_fraction=float(p.rattlers().mean()),
               mobilised_fraction=mobilised_fraction(p, mu),
               static_residual=float(m["static_residual"]))
    return {k: (float(v) if isinstance(v, (np.floating, np.integer)) else v)
            for k, v in row.items()}


def size_rows(path) -> dict:
    """{(n, mu, seed): row} of the size study's table (the reference's analysis)."""
    if not path:
        return {}
    with open(path) as fh:
        return {(int(r["n"]), float(r["mu"]), int(r["seed"])): r for r in csv.DictReader(fh)}


def run(sizes, mus, seeds, jobs, out: Path, reference_from=None) -> list:
    """Every (protocol, n, mu, seed) not yet in OUT/rows.jsonl, smallest n first."""
    path = out / "rows.jsonl"
    rows = read_rows(path)
    have = {(r["protocol"], r["n"], r["mu"], r["seed"]) for r in rows}
    ref = size_rows(reference_from)
    todo = [(pr, n, mu, s) for n in sizes for mu in mus for s in range(1, seeds + 1)
            for pr in PROTOCOLS if (pr, n, mu, s) not in have]

    def said(row):
        cpu = "kept" if row["jam_cpu_s"] is None else f"{row['jam_cpu_s']:.1f} CPU s"
        return (f"  {row['protocol']:9s} n={row['n']:4d} mu={row['mu']:g} seed={row['seed']:2d}"
                f": {cpu}, z {row['z']:.3f}, ended by {row['jam_end']}, eta "
                f"{row.get('eta_billiard')}")

    pool_rows([(one, (*t, str(out), ref)) for t in todo], jobs, path, rows, said)
    return rows


def report(rows, sizes, mus) -> str:
    """The validation table per (n, mu), as protocol_validation's."""
    from .protocol_validation import table
    parts = []
    for mu in mus:
        sub = [dict(r, protocol=r["protocol"]) for r in rows if r["mu"] == mu]
        parts.append(f"### mu = {mu:g}\n\n" + table(sub, sizes, "candidate",
                                                      QUANTITIES + COSTS))
    return "\n\n".join(parts)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="200,800")
    ap.add_argument("--mus", default="0.1,1")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("studies/results/certificate_validation"))
    ap.add_argument("--reference-from", default=None,
                    help="the size study's size.csv: the reference's slice analysis and eta "
                         "(checked packing by packing, module docstring)")
    ap.add_argument("--report", type=Path, default=Path("studies/certificate_validation.md"))
    a = ap.parse_args(argv)
    sizes = [int(s) for s in a.sizes.split(",")]
    mus = [float(m) for m in a.mus.split(",")]
    a.out.mkdir(parents=True, exist_ok=True)
    rows = run(sizes, mus, a.seeds, a.jobs, a.out, a.reference_from)
    text = report(rows, sizes, mus)
    print(text)
    a.report.with_suffix(".table.md").write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
