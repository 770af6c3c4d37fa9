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
per-round numbers, the packings and the code version, and prints a table. (The same
measurement runs in ``make bench``: ``forcespace_studies.bench_spheres``.)
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
from pathlib import Path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("disks")
    ap.add_argument("spheres")
    ap.add_argument("--sweeps", type=int, default=200)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", default="studies/results/spheres3d/bench_updates.json")
    args = ap.parse_args(argv)
    from forcespace.extend import code_version, write_json

    from forcespace_studies.bench_spheres import update_costs

    table = update_costs(args.disks, args.spheres, args.sweeps, args.rounds)
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
