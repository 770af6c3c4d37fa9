"""S of frictional sphere packings analysed exactly: dim S against the number of contacts,
the cones' faces, the inscribed ball and the CPU time of the analysis.

Usage::

    nice python studies/spheres_s.py PACKING.h5 [...] [--override-mu 0.01]
        [--out studies/results/spheres_s]
    nice python studies/spheres_s.py PACKING.h5 --pyramids 8 16 32 [--contacts 10]

Each packing's whole problem (every non-rattler sphere; the bottom plate a support, the
top plate's forces fixed loads: ``fs.sphere_full_problem``) is analysed by
``fs.ForceSpace`` (SOCPs by Clarabel: feasibility, the faces of the Coulomb cones by facial
reduction, boundedness, the affine hull, the certified inscribed ball), at the packing's
own mu and, with ``--override-mu``, frictionless packings also with that friction
switched on (the paper's frictionless packing "with friction"). ``OUT/rows.jsonl`` one row per analysis,
``OUT/spheres_s.md`` the table. CPU s is this process's user + system time of the
analysis alone (reading and building the problem excluded).

The paper's counting: 3 N_c unknowns, 6 n equations, so S has dimension
3 N_c - 6 n + (dependent rows) - (equalities of the cones' faces); a frictionless
isostatic packing has N_c ~ 3 n, hence dim S ~ N_c once friction is switched on. N_c
counts the unknown contacts (the bottom plate's among them: N_bottom, frictionless when
plate_mu = 0, so their f_t are fixed); the top plate's N_top contacts are loads.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from forcespace_studies.rows import append_row


def analyse(path: Path, mu: float | None) -> dict:
    import forcespace as fs
    from forcespace.extend import BOTTOM, TOP

    p = fs.read_packing(path)
    prob = fs.sphere_full_problem(p, mu=mu)
    t0 = time.process_time()
    S = fs.ForceSpace().compute(prob)
    cpu = time.process_time() - t0
    if not S.success:
        raise SystemExit(f"{path}: {S.message}")
    n, m = prob.n_interior, prob.n_contacts
    if not S.feasible:
        raise SystemExit(f"{path}: S is empty at mu = {mu}")
    a, b = np.asarray(p.a), np.asarray(p.b)
    n_bottom = int(((a[prob.contacts] == BOTTOM) | (b[prob.contacts] == BOTTOM)).sum())
    n_top = int(((a[prob.load_contacts] == TOP) | (b[prob.load_contacts] == TOP)).sum())
    return {"packing": path.name, "packing_mu": p.mu, "mu": p.mu if mu is None else mu,
            "n_interior": n, "n_contacts": m, "count_3Nc_minus_6n": 3 * m - 6 * n,
            "n_bottom": n_bottom, "n_top_loads": n_top, "n_unknowns": S.n_unknowns,
            "Nc_minus_2_plates": m - 2 * (n_bottom + n_top),
            "n_rows": int(prob.A.shape[0]), "rank_A": S.rank_A,
            "degree_of_indeterminacy": S.degree_of_indeterminacy, "dim_S": S.dim,
            "dim_S_over_Nc": S.dim / m, "n_on_a_ray": S.n_sliding, "n_at_the_apex": S.n_zero,
            "bounded": S.bounded, "radius_over_fn": S.radius / prob.force_scale,
            "jammed_in_S": bool(S.contains(prob.x_jammed)), "cpu_seconds": cpu}


def pyramids(path: Path, ks, n_contacts: int, seed: int = 0) -> dict:
    """The cross-check by pyramids on one packing: fn ranges of ``n_contacts`` random
    contacts that vary, by the cones (SOCPs) and by inscribed k-sided pyramids (LPs), the
    largest gap / <Fn> beside 1 - cos(pi / k); and the CPU s of the conic ranges."""
    import forcespace as fs
    from forcespace.extend import pyramid_fn_ranges

    p = fs.read_packing(path)
    prob = fs.sphere_full_problem(p)
    t0 = time.process_time()
    S = fs.ForceSpace(ranges=True).compute(prob)
    cpu = time.process_time() - t0
    width = np.ptp(S.fn_range, axis=1)
    varying = np.flatnonzero(width > 1e-6 * prob.force_scale)
    pick = np.sort(np.random.default_rng(seed).choice(varying, min(n_contacts, varying.size),
                                                      replace=False))
    out = {"packing": path.name, "ranges_cpu_seconds": cpu, "n_contacts": prob.n_contacts,
           "n_varying": int(varying.size), "contacts": pick.tolist(), "k": {}}
    for k in ks:
        rng = pyramid_fn_ranges(prob, k, pick)
        gap = np.abs(rng - S.fn_range[pick]).max() / prob.force_scale
        inside = bool(np.all(rng[:, 0] >= S.fn_range[pick, 0] - 1e-7 * prob.force_scale) and
                      np.all(rng[:, 1] <= S.fn_range[pick, 1] + 1e-7 * prob.force_scale))
        out["k"][k] = {"max_gap_over_fn": float(gap), "one_minus_cos": 1 - np.cos(np.pi / k),
                       "inside_conic_range": inside}
        print(f"k = {k}: largest gap {gap:.3e} <Fn>, 1 - cos(pi/k) = "
              f"{1 - np.cos(np.pi / k):.3e}, inside: {inside}", flush=True)
    return out


def table(rows) -> str:
    head = ("| packing | packing mu | mu of S | n | N_c | N_bottom | N_top | 3N_c - 6n | "
            "rank A | dim S | N_c - 2(N_bottom + N_top) | dim S / N_c | on a ray | at apex | "
            "radius/<Fn> | CPU s |")
    out = [head, "|" + "---|" * 16]
    for r in rows:
        out.append(f"| {r['packing']} | {r['packing_mu']:g} | {r['mu']:g} | {r['n_interior']} "
                   f"| {r['n_contacts']} | {r['n_bottom']} | {r['n_top_loads']} | "
                   f"{r['count_3Nc_minus_6n']} | {r['rank_A']} | {r['dim_S']} | "
                   f"{r['Nc_minus_2_plates']} | {r['dim_S_over_Nc']:.3f} | {r['n_on_a_ray']} | "
                   f"{r['n_at_the_apex']} | {r['radius_over_fn']:.2e} | "
                   f"{r['cpu_seconds']:.2f} |")
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packings", nargs="+", type=Path)
    ap.add_argument("--override-mu", type=float, default=None)
    ap.add_argument("--out", type=Path, default=Path("studies/results/spheres_s"))
    ap.add_argument("--pyramids", type=int, nargs="*", default=None, metavar="K",
                    help="instead: the cross-check by k-sided pyramids on the first packing")
    ap.add_argument("--contacts", type=int, default=10, help="contacts for --pyramids")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.pyramids:
        res = pyramids(args.packings[0], args.pyramids, args.contacts)
        (args.out / "pyramids.json").write_text(json.dumps(res, indent=1) + "\n")
        return 0
    rows = []
    for i, path in enumerate(args.packings):
        for mu in (None,) if args.override_mu is None else (None, args.override_mu):
            if mu is not None and rows[-1]["packing_mu"] != 0:
                continue            # friction is switched on in frictionless ones only
            row = analyse(path, mu)
            rows.append(row)
            append_row(args.out / "rows.jsonl", row)
            print(f"[{i + 1}/{len(args.packings)}] {path.name} mu {row['mu']:g}: "
                  f"N_c {row['n_contacts']}, dim S {row['dim_S']}, "
                  f"{row['cpu_seconds']:.1f} CPU s", flush=True)
    (args.out / "spheres_s.md").write_text(table(rows))
    print(np.mean([r["cpu_seconds"] for r in rows]), "CPU s per analysis on average")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
