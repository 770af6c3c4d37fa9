"""CLI command ``view``: write a packing and its force network for OVITO and ParaView.

    forcespace view PACK.h5 [ENS.h5] -o DIR [--format ovito,vtk]

A command of its own rather than ``export ovito|vtk``: ``export`` belongs to the DEM
adapters (a plug-in that forcespace never imports), and viewer files are part of the
library itself, so they must work without the adapters installed.
"""
from __future__ import annotations

from .printing import print_result
from ..errors import InputError


def register(sub) -> None:
    p = sub.add_parser(
        "view", help="write a packing and its force network for OVITO (LAMMPS dump) and "
        "ParaView (VTK .vtp)",
        description="Write the packing (positions, radii, rattler flags, walls) and its "
        "force network (per contact fn, ft, |F|, mobilisation |ft|/(mu fn); with an "
        "ensemble file also each contact's mean and spread over the samples) into DIR. "
        "OVITO: open DIR/packing.dump and load DIR/contacts.dump as bonds with the Load "
        "trajectory modifier (or run DIR/load_in_ovito.py). ParaView: open "
        "DIR/packing.vtm. Units: lengths R, forces F0.")
    p.add_argument("packing", metavar="PACK.h5", help="packing file")
    p.add_argument("ensemble", metavar="ENS.h5", nargs="?", default=None,
                   help="optional ensemble of this packing (forcespace sample): adds the "
                        "per-contact mean and spread")
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="directory to write (created; replaced only while everything in it "
                        "is forcespace's own)")
    p.add_argument("--format", default="ovito,vtk", metavar="F[,F]",
                   help="ovito, vtk or both (default ovito,vtk)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_view)


def cmd_view(args) -> int:
    from ..sampling.diagnostics import read_ensemble
    from ..io.outputs import check_output_dir
    from ..io.packing_file import read_packing
    from ..io.viewers import FORMATS, write_viewer_files

    formats = tuple(f.strip() for f in args.format.split(",") if f.strip())
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise InputError("command line", "--format", "must be ovito, vtk or ovito,vtk",
                         got=args.format)
    check_output_dir(args.output)
    packing = read_packing(args.packing)
    ens = read_ensemble(args.ensemble) if args.ensemble else None
    files = write_viewer_files(packing, args.output, formats, ens)
    print_result({"output": str(args.output), "files": [f.name for f in files],
                  ("n_spheres" if getattr(packing, "dim", 2) == 3 else "n_disks"):
                      packing.n_disks, "n_contacts": packing.n_contacts,
                  "ensemble_samples": ens.n_samples if ens is not None else None}, args.json)
    return 0
