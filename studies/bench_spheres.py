"""The cost of a single-contact update, spheres beside disks (issue 43): CPU ns per update.

Usage::

    nice python studies/bench_spheres.py DISKS.h5 SPHERES.h5 [--sweeps 200] [--rounds 5]
        [--out studies/results/spheres3d/bench_updates.json]

Each packing's plate problem (``fs.plate_problem``, ``fs.sphere_plate_problem``) is frozen
as the engine's static solve sees it (``frozen_contacts``, ``frozen_contacts3``: dt = 1,
gaps closed, masses as preconditioner) and relaxed from zero forces by ``--sweeps``
Gauss-Seidel sweeps at tolerance 0 (every sweep runs: the paper's order, single contacts
shuffled, no over-relaxation), once with the packing's friction and once with mu = 0
(frictionless: the tangential code never runs). CPU time (user + sys of this process)
over the normal updates the kernel counts; the four cases interleaved round by round,
the median over rounds reported (the machine is shared). Writes a JSON file with the
per-round numbers, the packings and the code version, and prints a table.
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np


def cases(disks_path: str, spheres_path: str) -> dict:
    """{name: (frozen system, description)} of the four timed cases."""
    import forcespace as fs
    from forcespace.extend import frozen_contacts, frozen_contacts3

    disks, spheres = fs.read_packing(disks_path), fs.read_packing(spheres_path)
    if getattr(disks, "dim", 2) != 2 or getattr(spheres, "dim", 2) != 3:
        raise SystemExit(f"{disks_path} must hold disks and {spheres_path} spheres")
    out = {}
    for mu, tag in ((None, "frictional"), (0.0, "frictionless")):
        d = fs.plate_problem(disks, mu=mu)
        s = fs.sphere_plate_problem(spheres, mu=mu)
        out[f"disks {tag}"] = (frozen_contacts(d), f"{disks.n_disks} disks, "
                               f"{d.n_contacts} contacts, mu {disks.mu if mu is None else mu:g}")
        out[f"spheres {tag}"] = (frozen_contacts3(s), f"{spheres.n_spheres} spheres, "
                                 f"{s.n_contacts} contacts, "
                                 f"mu {spheres.mu if mu is None else mu:g}")
    return out


def time_case(system, sweeps: int, seed: int) -> tuple[float, int, int]:
    """(CPU s, normal updates, tangential updates) of ``sweeps`` sweeps from zero forces."""
    nc = system.mu.shape[0]
    rn = np.zeros(nc)
    rt = np.zeros((nc, 3)) if system.__class__.__name__.endswith("3") else np.zeros(nc)
    motion = system.velocities(rn, rt)
    t0 = time.process_time()
    st = system.sweep(rn, rt, motion, sweeps, seed)
    return time.process_time() - t0, int(st.normal_updates), int(st.tangential_updates)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("disks")
    ap.add_argument("spheres")
    ap.add_argument("--sweeps", type=int, default=200)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", default="studies/results/spheres3d/bench_updates.json")
    args = ap.parse_args(argv)
    from forcespace.extend import code_version, write_json

    systems = cases(args.disks, args.spheres)
    for system, _ in systems.values():          # compile every kernel first
        time_case(system, 2, 0)
    runs = {name: [] for name in systems}
    for k in range(args.rounds):
        for name, (system, _) in systems.items():
            cpu, normal, tangential = time_case(system, args.sweeps, k + 1)
            runs[name].append({"cpu_s": cpu, "normal_updates": normal,
                               "tangential_updates": tangential,
                               "ns_per_update": 1e9 * cpu / normal})
        print(f"round {k + 1}/{args.rounds}: " + ", ".join(
            f"{n} {runs[n][-1]['ns_per_update']:.0f} ns" for n in runs), file=sys.stderr,
            flush=True)
    table = {name: {"what": systems[name][1],
                    "ns_per_update_median": float(np.median([r["ns_per_update"]
                                                             for r in runs[name]])),
                    "tangential_updates": runs[name][0]["tangential_updates"],
                    "rounds": runs[name]} for name in runs}
    write_json(Path(args.out), {
        "description": "CPU ns per single-contact Gauss-Seidel update of the frozen plate "
                       "problem, disks beside spheres (studies/bench_spheres.py)",
        "units": "ns of CPU time (user + sys) per normal update",
        "sweeps": args.sweeps, "rounds": args.rounds, "packings": [args.disks, args.spheres],
        "machine": platform.platform(), "code_version": code_version(), "cases": table})
    print("| case | packing | CPU ns per update (median) | tangential updates |\n"
          "|---|---|---|---|")
    for name, row in table.items():
        print(f"| {name} | {row['what']} | {row['ns_per_update_median']:.0f} | "
              f"{row['tangential_updates']:,} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
