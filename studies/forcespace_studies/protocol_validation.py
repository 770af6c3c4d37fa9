"""Protocol validation (issue 22): does the faster paper_fast jam the same packings,
statistically, as paper_fast did before?

The reference is ``inputs/paper_fast.toml`` with ``solver.max_sweeps = 1000`` and every
key added by issue 22 at its neutral default (``solver.tolerance_moving = 0``,
``solver.relaxation_fallback = 0.5``): the protocol of commit 938734f, bit for bit. The
candidate is ``inputs/paper_fast.toml`` as it is. Both jam the same seeds (mu = 0.1,
boxes scaled by ``--n N --scale-box``) and each packing gives:

* z: the coordination of the non-rattlers (``Packing.coordination``);
* packing fraction (``Packing.packing_fraction``);
* rattler fraction (rattlers / n);
* dim S / Nc of the paper's slice (height 28 sqrt(n / 200) R): dim S as
  ``ForceSpace().compute(slice_problem(p, h)).dim`` computes it (:func:`slice_dim`), over
  the slice's unknown contacts Nc.

Per size and quantity: mean +- standard error over seeds for each protocol, Welch's
t-test on the means and the two-sample Kolmogorov-Smirnov test (scipy), both p-values
reported; a difference counts as significant at p < 0.05 (with 8 comparisons, about 0.3
false alarms are expected by chance). Also the CPU seconds, steps and contact updates.

Usage::

    python -m forcespace_studies.protocol_validation [--sizes 200,800] [--seeds 10]
        [--jobs 2] [--out studies]

Rows go to OUT/protocol_validation.jsonl as they finish (a rerun skips the rows it
has), the table to OUT/protocol_validation.md.

Any other change of the solver is validated the same way: ``--mu``, ``--reference``
(scene overrides, ``key=value,...``; "issue22" is the reference above, "" the scene as
shipped), ``--candidate`` (overrides of the shipped scene) and ``--name`` (the stem of
the two output files), e.g. the tighter contact solve for the size study at mu = 1::

    python -m forcespace_studies.protocol_validation --mu 1 --reference "" \
        --candidate solver.tolerance=1e-8 --name tolerance_mu1 --sizes 200,400
"""
from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from .rows import append_row, read_rows

REFERENCE = {"solver.max_sweeps": 1000, "solver.tolerance_moving": 0.0,
             "solver.moving_speed": 0.0, "solver.max_sweeps_moving": 0,
             "solver.relaxation_fallback": 0.5}
QUANTITIES = (("z", "z"), ("phi", "packing fraction"), ("rattler_fraction", "rattler fraction"),
              ("dim_s_per_nc", "dim S / Nc"))


def slice_dim(prob) -> int:
    """dim S of a statics problem by the steps of ``ForceSpace().compute(prob).dim``
    (problem scaled to <Fn> = 1, implicit equalities by LP, the rank of [A; fixed
    columns; implicit rows]) without the rest of the analysis: its varying-contact LPs
    (one pair per undecided column) took over 10 CPU minutes on some 800-disk slices."""
    from forcespace.extend import affine_hull, eq_system, implicit_equalities, unit_problem
    P, scale = unit_problem(prob)
    G, _owner, _kind = P.inequalities()
    Eq, rhs = eq_system(P, G[implicit_equalities(P)])
    N, _xa, _rank = affine_hull(Eq, rhs, prob.x_jammed / scale)
    return int(N.shape[1])


def one(protocol: str, n: int, seed: int, scene_file: str = "paper_fast", mu: float = 0.1,
        overrides: dict | None = None, keep=None) -> dict:
    """Jam one packing and measure it (runs in a worker process). ``overrides``: scene
    keys of this protocol (default: REFERENCE for "reference", none otherwise).
    ``keep``: a study directory the packing is also kept in, as that study's own jam of
    (scene, mu, seed, n) (:func:`~forcespace_studies.common.packing_path`; the study's
    lock is held while jamming, so a study running beside it waits and reuses it). A
    packing the study has jammed already is measured, not jammed again: the jam is
    deterministic and every scene key is checked; its row has cpu_s None (not timed)."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from forcespace import write_packing
    from forcespace.extend import build_packing
    from forcespace.errors import NumericalError
    from forcespace import load_scene, slice_problem

    from .common import jam_lock, packing_path, reused
    scene, _ = load_scene(scene_file).scaled_to(n)
    over = {"physics.mu": mu, "scene.seed": seed}
    if overrides is None:
        overrides = REFERENCE if protocol == "reference" else {}
    over.update(overrides)
    scene = scene.with_overrides(**over)
    t0 = time.process_time()
    kept = packing_path(keep, scene_file, mu, seed, n) if keep else None
    cpu = None                           # not timed: the study jammed it (same scene)
    try:
        with jam_lock(kept) if kept else contextlib.nullcontext():
            if kept and kept.is_file():  # every scene key checked against this one's
                p = reused(kept, {k.replace(".", "__"): v for k, v in scene.values.items()
                                  if k != "scene.name"})
            else:
                p = build_packing(scene, show_progress=False)
                cpu = time.process_time() - t0
                if kept:
                    write_packing(p, kept)
    except NumericalError as e:          # a protocol that fails to jam: a result, counted
        return {"protocol": protocol, "n": n, "seed": seed, "mu": mu,
                "cpu_s": time.process_time() - t0, "error": str(e)}
    h = 28.0 * math.sqrt(n / 200.0)
    prob = slice_problem(p, h)
    dim = slice_dim(prob)
    m = p.meta
    return {"protocol": protocol, "n": n, "seed": seed, "mu": mu, "cpu_s": cpu,
            "steps": int(m["steps"]), "sweeps": int(m["sweeps_total"]),
            "updates": int(m["normal_updates"] + m["tangential_updates"]),
            "z": float(p.coordination()), "phi": float(p.packing_fraction()),
            "rattler_fraction": float(p.rattlers().mean()),
            "dim_s": int(dim), "slice_contacts": int(prob.n_contacts),
            "dim_s_per_nc": dim / prob.n_contacts if prob.n_contacts else float("nan")}


def run(sizes, seeds, jobs: int, path: Path, protocols=("reference", "candidate"),
        scene_file: str = "paper_fast", mu: float = 0.1, overrides: dict | None = None,
        keep=None) -> list:
    """Jam and measure every (protocol, n, seed) not yet in ``path``; ``overrides``:
    {protocol: scene overrides} (default: those of :func:`one`); ``keep``: a study
    directory the candidate's packings are kept in (:func:`one`)."""
    rows = read_rows(path)
    have = {(r["protocol"], r["n"], r["seed"]) for r in rows}
    todo = [(pr, n, s) for n in sizes for s in range(1, seeds + 1)
            for pr in protocols if (pr, n, s) not in have]

    def said(row):
        cpu = "kept, untimed" if row["cpu_s"] is None else f"{row['cpu_s']:6.1f} CPU s"
        what = (f"FAILED: {row['error']}" if "error" in row else
                f"z {row['z']:.3f}, phi {row['phi']:.4f}, "
                f"dim S/Nc {row['dim_s_per_nc']:.3f}")
        return f"  {row['protocol']:9s} n={row['n']:4d} seed={row['seed']:2d}: {cpu}, {what}"

    pool_rows([(one, (*t, scene_file, mu, (overrides or {}).get(t[0]),
                      keep if t[0] == "candidate" else None)) for t in todo],
              jobs, path, rows, said)
    return rows


def pool_rows(tasks, jobs: int, path: Path, rows: list, said) -> list:
    """Run every (function, arguments) of ``tasks`` in ``jobs`` worker processes; append
    each row (a dict) to ``rows`` and to ``path`` (JSON lines) as it finishes and print
    ``said(row)``. Returns ``rows``."""
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futures = [pool.submit(fn, *args) for fn, args in tasks]
        for fut in as_completed(futures):
            row = fut.result()
            rows.append(row)
            append_row(path, row)
            print(said(row), flush=True)
    return rows


COSTS = (("cpu_s", "CPU s"), ("steps", "steps"), ("updates", "contact updates"))


def table(rows, sizes, candidate: str = "candidate", quantities=None) -> str:
    """Markdown table: reference against the rows labelled ``candidate``; ``quantities``:
    ((row key, label), ...) (default: QUANTITIES and COSTS; keys ending in cpu_s, steps
    or updates are printed to 4 significant digits, a row without the key is skipped)."""
    from scipy import stats
    out = ["| n | quantity | reference (mean +- s.e.) | candidate (mean +- s.e.) | "
           "difference / s.e. | Welch t p | KS p |", "|---|---|---|---|---|---|---|"]
    failed = []
    for n in sizes:
        ref = [r for r in rows if r["n"] == n and r["protocol"] == "reference"]
        new = [r for r in rows if r["n"] == n and r["protocol"] == candidate]
        failed += [f"{label} n = {n} seed {r['seed']} ({r['cpu_s']:.0f} CPU s): {r['error']}"
                   for label, rs in (("reference", ref), ("candidate", new))
                   for r in rs if "error" in r]
        ref = [r for r in ref if "error" not in r]
        new = [r for r in new if "error" not in r]
        if len(ref) < 2 or len(new) < 2:
            continue
        for key, label in quantities or QUANTITIES + COSTS:
            a = np.array([r[key] for r in ref if r.get(key) is not None], float)
            b = np.array([r[key] for r in new if r.get(key) is not None], float)
            if a.size < 2 or b.size < 2:
                continue
            sa, sb = a.std(ddof=1) / np.sqrt(a.size), b.std(ddof=1) / np.sqrt(b.size)
            t = stats.ttest_ind(a, b, equal_var=False).pvalue
            ks = stats.ks_2samp(a, b).pvalue
            z = (b.mean() - a.mean()) / math.hypot(sa, sb) if math.hypot(sa, sb) else 0.0
            fmt = ".4g" if key.endswith(("cpu_s", "steps", "updates")) else ".4f"
            out.append(f"| {n} ({a.size}+{b.size} seeds) | {label} | {a.mean():{fmt}} +- "
                       f"{sa:{fmt}} | {b.mean():{fmt}} +- {sb:{fmt}} | {z:+.2f} | {t:.3f} | "
                       f"{ks:.3f} |")
    if failed:
        out += ["", "Jams that failed (not in the table; a protocol's failures are part of "
                "its result):", ""] + [f"- {x}" for x in failed]
    return "\n".join(out)


def parse_overrides(text: str) -> dict:
    """"key=value,key=value" -> {key: value}, each value read as a scene file reads it
    (TOML: 1e-8 a float, 2000 an integer, true a boolean), unquoted text as a string
    ("" -> {})."""
    try:                                            # the scene files' TOML reader
        import tomllib
    except ModuleNotFoundError:                     # Python 3.10
        import tomli as tomllib
    out = {}
    for item in filter(None, (t.strip() for t in text.split(","))):
        key, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"protocol_validation: error: override {item!r} is not key=value")
        try:
            out[key.strip()] = tomllib.loads(f"v = {value}")["v"]
        except tomllib.TOMLDecodeError:
            out[key.strip()] = value.strip()
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="200,800")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("studies"))
    ap.add_argument("--protocols", default="reference,candidate",
                    help="which protocols to run (rows already in the JSONL are kept)")
    ap.add_argument("--scene", default="paper_fast", help="the paper_fast scene (name or file)")
    ap.add_argument("--mu", type=float, default=0.1)
    ap.add_argument("--reference", default="issue22",
                    help='scene overrides of the reference, key=value,... ("issue22": the '
                         'protocol of 938734f; "": the scene as shipped)')
    ap.add_argument("--candidate", default="", help="scene overrides of the candidate")
    ap.add_argument("--name", default="protocol_validation", help="output file stem")
    ap.add_argument("--keep", type=Path, default=None,
                    help="a study directory (e.g. the size study's) the candidate's packings "
                         "are also kept in, as that study's jams")
    a = ap.parse_args(argv)
    sizes = [int(s) for s in a.sizes.split(",")]
    ref = REFERENCE if a.reference == "issue22" else parse_overrides(a.reference)
    cand = parse_overrides(a.candidate)
    a.out.mkdir(parents=True, exist_ok=True)
    rows = run(sizes, a.seeds, a.jobs, a.out / f"{a.name}.jsonl",
               tuple(a.protocols.split(",")), a.scene, a.mu,
               {"reference": ref, "candidate": cand}, a.keep)
    if a.reference == "issue22" and not cand:
        from forcespace import load_scene
        sc = load_scene(a.scene)
        changed = {k: sc[k] for k in REFERENCE}
        head = (f"# Protocol validation: paper_fast before and after issue 22\n\n"
                f"Made by `python -m forcespace_studies.protocol_validation --sizes {a.sizes} "
                f"--seeds {a.seeds}` (see its docstring for the method). mu = 0.1, boxes "
                f"scaled with n, seeds 1-{a.seeds}. Reference: paper_fast with {REFERENCE} "
                f"(the protocol of 938734f); candidate: paper_fast as shipped, {changed}.\n\n")
    else:
        head = (f"# Protocol validation: {a.scene} {cand or 'as shipped'} against "
                f"{ref or 'as shipped'}\n\n"
                f"Made by `python -m forcespace_studies.protocol_validation --sizes {a.sizes} "
                f"--seeds {a.seeds} --mu {a.mu:g} --reference \"{a.reference}\" --candidate "
                f"\"{a.candidate}\" --name {a.name}` (see its docstring for the method). "
                f"mu = {a.mu:g}, boxes scaled with n, seeds 1-{a.seeds}.\n\n")
    text = head + table(rows, sizes) + "\n"
    for label in sorted({r["protocol"] for r in rows} - {"reference", "candidate"}):
        text += f"\n## Tried, not shipped: {label}\n\n" + table(rows, sizes, label) + "\n"
    (a.out / f"{a.name}.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
