"""CLI commands of measured networks: ``convert`` (a frame from another code or an
experiment into a packing file) and ``check`` (the measured network against S)."""
from __future__ import annotations

import sys

from .printing import print_json, print_result
from ..errors import InputError


def register(sub):
    p = sub.add_parser("convert", help="read a measured frame (CSV pair, PeGS, PeGS2, LAMMPS "
                       "dump) into a packing file",
                       description="Read one frame of another code or an experiment into a "
                       "forcespace packing file that keeps the measured network and its "
                       "provenance (source files and their SHA-256, units, pixel scale, "
                       "conventions). Every bad input is one line naming the file and the "
                       "field, before anything is written.")
    fmt = p.add_subparsers(dest="format", metavar="FORMAT")
    fmt.required = True
    _format_parsers(fmt)
    for q in fmt.choices.values():
        q.add_argument("-o", "--output", required=True, help="packing file to write (HDF5)")
        q.add_argument("--mu", type=float, required=True, help="Coulomb coefficient of the "
                       "particle contacts (the data do not carry it)")
        q.add_argument("--wall-mu", type=float, default=None, help="of the wall contacts "
                       "(default --mu)")
        q.add_argument("--length-unit", default=None, help="what one length unit is (e.g. mm)")
        q.add_argument("--force-unit", default=None, help="what one force unit is (e.g. N)")
        q.add_argument("--gap-tol", type=float, default=None, metavar="G",
                       help="refuse a contact whose gap or overlap exceeds G x the smaller "
                            "radius (default 0.1)")
        q.set_defaults(func=cmd_convert)

    p = sub.add_parser("check", help="a measured network against S: imbalance, Coulomb, "
                       "distance, nearest admissible network, per-contact ranges",
                       description="Check the network of a packing file (a measured frame, "
                       "or any packing) against S of a region: per-disk force and torque "
                       "imbalance and Coulomb violations (in <Fn>), the distance to S and the "
                       "nearest admissible network (QP), the per-contact ranges of fn and ft "
                       "over S, dim S and its domains, uniform samples on request. An empty "
                       "S is an answer: the least-violating network and the smallest "
                       "relaxation of the loads are reported (exit 0).")
    p.add_argument("packing")
    p.add_argument("--region", default="rim=1",
                   help="rim=K (frame minus K rim layers; default 1), distance=D [length "
                        "unit], box=x0,y0,x1,y1, slice=H, or all")
    p.add_argument("--walls", choices=("loads", "unknown"), default="loads",
                   help="wall contacts: fixed loads from the measurement (default) or "
                        "unknowns with --wall-mu")
    p.add_argument("--wall-mu", type=float, default=None,
                   help="with --walls unknown: their Coulomb coefficient (default: the file's)")
    p.add_argument("--weighted", action="store_true",
                   help="nearest network in the metric of the measurement's uncertainty")
    p.add_argument("--no-ranges", dest="ranges", action="store_false",
                   help="skip the per-contact ranges (4 LPs per contact)")
    p.add_argument("--samples", type=int, default=0, metavar="N",
                   help="uniform samples of S (billiard walk, at most N, until ESS 100)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--figure", default=None, metavar="FIG.png",
                   help="draw the measured and the nearest network and the ranges")
    p.add_argument("--json", action="store_true", help="print the full report as JSON")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_check)


def _format_parsers(fmt):
    """The readers of `convert`, one subcommand each."""
    q = fmt.add_parser("csv", help="particles.csv + contacts.csv (README: Bring your own "
                       "packing)")
    q.add_argument("particles", help="particles.csv: id, x, y, r [, boundary, fx, fy, torque]")
    q.add_argument("contacts", help="contacts.csv: i, j, fn, ft [, nx, ny, px, py, sigma_fn, "
                   "sigma_ft, image]")
    q.add_argument("--width", type=float, default=None, metavar="W",
                   help="period along x (the frame is periodic in x; default: not)")
    q = fmt.add_parser("pegs", help="PeGS matrices: *_ParticleData.dlm and its Norm/Tan/Binary "
                       "weighted adjacency matrices")
    q.add_argument("particle_data", help="the *_ParticleData.dlm file (the matrices beside it)")
    q.add_argument("--pixel-scale", type=float, required=True, metavar="S",
                   help="length units per pixel")
    q.add_argument("--edge-column", type=int, default=None, metavar="K",
                   help="ParticleData column (0-based) of PeGS2's edge flag (needed when the "
                        "matrices carry the wall column)")
    q.add_argument("--y-up", action="store_true",
                   help="pixel y already points up (default: image coordinates, y down)")
    q = fmt.add_parser("pegs2", help="PeGS2's own files: an adjacency list and the particle "
                       "positions")
    q.add_argument("adjacency", help="*_Adjacency.txt or Adjacency_list.txt (frame, id1, id2, "
                   "fTan, fNorm; id2 = -1 the wall)")
    q.add_argument("positions", help="particle_positions.txt (frame, id, x, y, r, edge) or "
                   "*_centers.txt (x, y, r, edge)")
    q.add_argument("--frame", type=float, default=None,
                   help="which frame (default: the only one in the files)")
    q.add_argument("--pixel-scale", type=float, required=True, metavar="S",
                   help="length units per pixel")
    q.add_argument("--y-up", action="store_true",
                   help="pixel y already points up (default: image coordinates, y down)")
    q = fmt.add_parser("lammps", help="LIGGGHTS/LAMMPS atom dump + dump local of compute "
                       "pair/gran/local")
    q.add_argument("atoms", help="atom dump (id x y radius ...)")
    q.add_argument("contacts", help="dump local of compute pair/gran/local")
    q.add_argument("--keywords", default="id force force_normal force_tangential delta",
                   help="the compute's keywords in order (default: the adapter's)")
    q.add_argument("--wall", action="append", default=None, metavar="NAME:NX,NY",
                   help="per-atom wall-force columns NAME[1] NAME[2] and the wall's normal into "
                        "the atoms (repeatable; default f_force_wall:0,1 f_force_wallt:0,-1)")
    q.add_argument("--step", type=int, default=None, help="timestep (default: the last in both)")


def _walls(specs):
    if specs is None:
        return None
    out = {}
    for spec in specs:
        name, sep, vec = spec.partition(":")
        try:
            nx, ny = (float(v) for v in vec.split(","))
            if not sep or not name or (nx == 0 and ny == 0):
                raise ValueError
        except ValueError:
            raise InputError("command line", "--wall", "must be NAME:NX,NY (a per-atom "
                             "column name and a nonzero normal)", got=spec) from None
        out[name] = (nx, ny)
    return out


def cmd_convert(args) -> int:
    from .. import config
    from ..io import readers
    from ..io.outputs import check_output_file, output_lock
    from ..io.packing_file import write_packing

    units = dict(length_unit=args.length_unit, force_unit=args.force_unit)
    units = {k: v for k, v in units.items() if v is not None}
    common = dict(mu=args.mu, wall_mu=args.wall_mu, **units,
                  gap_tol=config.CONTACT_GAP_TOL if args.gap_tol is None else args.gap_tol)
    if not (common["gap_tol"] >= 0):
        raise InputError("command line", "--gap-tol", "must be a number >= 0", got=args.gap_tol)
    if args.format == "csv":
        inputs = [args.particles, args.contacts]
        check_output_file(args.output, inputs=inputs)
        packing = readers.read_csv_pair(args.particles, args.contacts, width=args.width,
                                        **common)
    elif args.format == "pegs":
        from ..io.readers.pegs import pegs_files
        inputs = list(pegs_files(args.particle_data).values())
        check_output_file(args.output, inputs=inputs)
        packing = readers.read_pegs(args.particle_data, pixel_scale=args.pixel_scale,
                                    edge_column=args.edge_column, y_down=not args.y_up,
                                    **common)
    elif args.format == "pegs2":
        inputs = [args.adjacency, args.positions]
        check_output_file(args.output, inputs=inputs)
        packing = readers.read_pegs2(args.adjacency, args.positions, frame=args.frame,
                                     pixel_scale=args.pixel_scale, y_down=not args.y_up,
                                     **common)
    else:
        inputs = [args.atoms, args.contacts]
        check_output_file(args.output, inputs=inputs)
        packing = readers.read_lammps_dump(args.atoms, args.contacts,
                                           keywords=args.keywords.split(),
                                           walls=_walls(args.wall), step=args.step, **common)
    with output_lock(args.output):
        write_packing(packing, args.output)
    m = packing.measurement
    print(f"{args.output}: {packing.n_disks} particles, {packing.n_contacts} contacts "
          f"({m.n_unknown} without a measured force), mu = {packing.mu:g}, from "
          f"{m.provenance['format']} ({', '.join(f['name'] for f in m.provenance['files'])})")
    return 0


def check_packing_file(args):
    """(packing, problem) of ``check``: the packing file and the region's problem."""
    from ..io.packing_file import read_packing
    from ..model.frame import Region, frame_problem
    from .space import check_seed

    check_seed(args.seed)
    if args.samples < 0:
        raise InputError("command line", "--samples", "must be an integer >= 0", got=args.samples)
    if args.wall_mu is not None and args.walls != "unknown":
        raise InputError("command line", "--wall-mu", "needs --walls unknown")
    region = Region.parse(args.region)
    if args.figure:
        from ..io.outputs import check_figure_file
        check_figure_file(args.figure, inputs=[args.packing])
    packing = read_packing(args.packing)
    problem = frame_problem(packing, region, walls=args.walls, wall_mu=args.wall_mu,
                            source=str(args.packing))
    return packing, problem


def cmd_check(args) -> int:
    import numpy as np

    from ..errors import NumericalError
    from ..space.measured import Measured

    packing, problem = check_packing_file(args)
    m = packing.measurement
    known = None if m is None else np.asarray(m.known, bool)[problem.contacts]
    sigma = None
    if args.weighted:
        if m is None or m.sigma is None:
            raise InputError(args.packing, "measured/sigma", "--weighted needs the "
                             "measurement's uncertainty (CSV sigma_fn, sigma_ft; PeGS' two "
                             "estimates per contact)")
        sigma = np.asarray(m.sigma, float)[problem.contacts]
    check = Measured(ranges=args.ranges, weighted=args.weighted, samples=args.samples,
                     seed=args.seed, progress=not args.quiet)
    check.compute(problem, sigma=sigma, known=known)
    if not check.success:
        raise NumericalError(check.message)
    out = {"packing": str(args.packing), **check.summary(packing)}
    if m is not None:
        out["measurement"] = m.summary()
    if args.figure:
        from ..io.figures import save_figure
        from ..plot import plot_measured
        fig = plot_measured(packing, check)
        save_figure(fig, args.figure)
        out["figure"] = str(args.figure)
    if args.json:
        print_json(out)
    else:
        brief = {k: v for k, v in out.items() if k not in ("disks", "contacts", "relaxation",
                                                           "infeasibility", "measurement")}
        print_result(brief, False)
        if out.get("feasible") is False:
            print("S is empty: the smallest relaxation (extra loads) is in --json "
                  "'relaxation'", file=sys.stderr)
    return 0
