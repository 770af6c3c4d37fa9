"""``forcespace`` sub-commands of the DEM adapters (entry point ``forcespace.commands``).

    forcespace export liggghts|pymunk PACK.h5 -o DIR [options]
    forcespace run liggghts|pymunk DIR
    forcespace import liggghts|pymunk DIR -o SOFT.h5
    forcespace distance SOFT.h5 PACK.h5 [--json]

Units: --kn in <Fn>/R, --tolerance in <Fn>, pymunk --dt in sqrt(m_min R/<Fn>), <Fn> the
rigid packing's mean normal force. Uses only forcespace's public API: errors are raised
(InputError: exit 2, NumericalError: exit 3) and forcespace's CLI maps them.
"""
from __future__ import annotations

import sys

from forcespace.errors import NumericalError
from forcespace.extend import dumps


def print_json(obj) -> None:
    print(dumps(obj, indent=2))


def _liggghts_opts(args):
    from .liggghts import LiggghtsOptions
    opt = LiggghtsOptions(kn=args.kn, kt_ratio=args.kt_ratio, damping_ratio=args.damping_ratio,
                          dt_fraction=args.dt_fraction, tolerance=args.tolerance,
                          ramp_steps=args.ramp_steps, check_every=args.check_every,
                          max_steps=args.max_steps)
    opt.validate("command line")
    return opt


def _pymunk_opts(args):
    from .pymunk_sim import PymunkOptions
    opt = PymunkOptions(dt=args.dt, iterations=args.iterations, damping=args.damping,
                        slop=args.slop, tolerance=args.tolerance, ramp_steps=args.ramp_steps,
                        check_every=args.check_every, max_steps=args.max_steps)
    opt.validate("command line")
    return opt


def _cmd_export(args):
    from .workflow import export
    if args.code == "liggghts":
        opt, yr = _liggghts_opts(args), None
    else:
        opt, yr = _pymunk_opts(args), args.slice
    d = export(args.code, args.packing, args.output, opt, yr, top=args.top)
    print(f"wrote {args.code} run directory {d}")
    return 0


def _cmd_run(args):
    from .workflow import run

    def progress(step, res):
        print(f"  step {step}: max residual {res:.3e} <Fn>", file=sys.stderr)
    st = run(args.code, args.directory, binary=getattr(args, "binary", None),
             timeout=getattr(args, "timeout", None),
             progress=progress if args.code == "pymunk" and args.verbose else None,
             show_progress=args.code == "liggghts" and not args.quiet)
    print_json(st)
    if st.get("converged"):
        return 0
    raise NumericalError(f"{args.code} stopped before its tolerance (steps {st.get('steps')}); "
                         "the result is importable but flagged")


def _cmd_import(args):
    from .workflow import import_run
    soft = import_run(args.code, args.directory, args.output)
    print(f"wrote soft network {args.output} ({soft.n_contacts} contacts, "
          f"max overlap {soft.max_overlap():.3e} R)")
    return 0


def _cmd_distance(args):
    from forcespace import read_packing

    from .distance import check_made_from, compare, make_problem
    soft = read_packing(args.soft, kind="soft_network")
    rigid = read_packing(args.packing)
    check_made_from(rigid, soft)               # before any work
    out = compare(rigid, soft, make_problem(rigid, args.top))
    if not args.list:
        out.pop("unmatched")
        out.pop("lost")
    if args.json:
        print_json(out)
    else:
        print(f"relative distance to S: {out['relative_distance']:.3e} "
              f"(absolute {out['absolute_distance']:.3e} F0)")
        print(f"unmatched soft contacts: {out['unmatched_contacts']} (max force "
              f"{out['max_unmatched_force_rel']:.2e} <Fn>); lost rigid contacts: "
              f"{out['lost_contacts']} (max rigid force {out['max_lost_rigid_force_rel']:.2e} <Fn>)")
        print(f"max overlap: {out['max_overlap']:.3e} R")
        print(f"verdict: {out['verdict']['text']}")
    if out["soft_run_converged"] is False:
        raise NumericalError(f"the soft run {out['soft_run_reason']}; its distance to S is "
                             "not a converged result")
    return 0


def _common_run_opts(p, tol_default, ramp_default, check_default, max_default):
    p.add_argument("--tolerance", type=float, default=tol_default,
                   help="stop when the largest per-disk residual < TOL <Fn> (LIGGGHTS: the "
                        "static residual, raised to the run's precision floor; default "
                        f"{tol_default:g})")
    p.add_argument("--ramp-steps", type=int, default=ramp_default,
                   help=f"load ramp length in steps (default {ramp_default})")
    p.add_argument("--check-every", type=int, default=check_default,
                   help=f"steps between convergence checks (default {check_default})")
    p.add_argument("--max-steps", type=int, default=max_default,
                   help=f"give up after this many steps (default {max_default})")


def register(subparsers):
    """Add export / run / import / distance to the forcespace CLI."""
    from .liggghts import LiggghtsOptions
    from .pymunk_sim import PymunkOptions
    lo, po = LiggghtsOptions(), PymunkOptions()

    ex = subparsers.add_parser("export", help="write a LIGGGHTS deck or pymunk run directory")
    exs = ex.add_subparsers(dest="code", metavar="CODE")
    exs.required = True
    el = exs.add_parser("liggghts", help="LIGGGHTS deck (full packing, servo top plate; "
                        "disks in a 2-D slab, spheres in 3-D)")
    ep = exs.add_parser("pymunk", help="pymunk run directory (full packing or slice; "
                        "pymunk is 2-D: disks only)")
    for p in (el, ep):
        p.add_argument("packing", help="packing file (HDF5)")
        p.add_argument("--top", choices=("plate", "loads"), default="plate",
                       help="top plate load-controlled (plate, default) or replaced by its "
                            "rigid forces as dead loads (loads; unstable for real packings)")
        p.add_argument("-o", "--output", required=True, help="run directory to write")
        p.set_defaults(func=_cmd_export)
    el.add_argument("--kn", type=float, default=lo.kn,
                    help="normal stiffness K in <Fn>/R, <Fn> the packing's mean normal force "
                         f"(a mean contact overlaps by R/K; default {lo.kn:g})")
    el.add_argument("--kt-ratio", type=float, default=lo.kt_ratio, help="kt/kn (default 2/7)")
    el.add_argument("--damping-ratio", type=float, default=lo.damping_ratio,
                    help=f"damping ratio (default {lo.damping_ratio:g})")
    el.add_argument("--dt-fraction", type=float, default=lo.dt_fraction,
                    help="dt / t_c (default 1/50)")
    _common_run_opts(el, lo.tolerance, lo.ramp_steps, lo.check_every, lo.max_steps)
    ep.add_argument("--dt", type=float, default=po.dt,
                    help=f"time step in t0 = sqrt(m_min R/<Fn>) (default {po.dt:g})")
    ep.add_argument("--iterations", type=int, default=po.iterations,
                    help=f"solver iterations per step (default {po.iterations})")
    ep.add_argument("--damping", type=float, default=po.damping,
                    help=f"velocity fraction kept per t0 (default {po.damping:g})")
    ep.add_argument("--slop", type=float, default=po.slop,
                    help=f"allowed overlap [R] (default {po.slop:g})")
    ep.add_argument("--slice", type=float, nargs=2, metavar=("Y0", "Y1"), default=None,
                    help="simulate only the disks with centres in [Y0, Y1]; their outside "
                         "contacts become fixed (frictional) loads")
    _common_run_opts(ep, po.tolerance, po.ramp_steps, po.check_every, po.max_steps)

    ru = subparsers.add_parser("run", help="run LIGGGHTS or pymunk on a run directory")
    rus = ru.add_subparsers(dest="code", metavar="CODE")
    rus.required = True
    rl = rus.add_parser("liggghts", help="run the LIGGGHTS binary on a deck")
    rl.add_argument("--binary", default=None,
                    help="LIGGGHTS executable (default $FORCESPACE_LIGGGHTS or liggghts)")
    rl.add_argument("--timeout", type=float, default=None, help="seconds before giving up")
    rl.add_argument("--quiet", action="store_true", help="no progress bar")
    rp = rus.add_parser("pymunk", help="run the pymunk simulation")
    rp.add_argument("-v", "--verbose", action="store_true", help="print progress")
    for p in (rl, rp):
        p.add_argument("directory")
        p.set_defaults(func=_cmd_run)

    im = subparsers.add_parser("import", help="read a finished run as a soft-network file")
    ims = im.add_subparsers(dest="code", metavar="CODE")
    ims.required = True
    for code in ("liggghts", "pymunk"):
        p = ims.add_parser(code, help=f"read a finished {code} run")
        p.add_argument("directory")
        p.add_argument("-o", "--output", required=True, help="soft network file to write")
        p.set_defaults(func=_cmd_import)

    di = subparsers.add_parser("distance", help="distance of a soft network from S of a packing")
    di.add_argument("soft", help="soft network file (forcespace import ...)")
    di.add_argument("packing", help="the rigid packing file")
    di.add_argument("--json", action="store_true", help="print JSON")
    di.add_argument("--top", choices=("loads", "plate"), default="plate",
                    help="S with the TOP contacts unknown and the plate balance as a row "
                         "(plate, default: runs with a load-controlled plate) or with the TOP "
                         "contact forces fixed (loads: dead-load runs)")
    di.add_argument("--list", action="store_true",
                    help="include the lists of unmatched and lost contacts")
    di.set_defaults(func=_cmd_distance)
