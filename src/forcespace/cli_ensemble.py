"""CLI commands of the force ensemble: ``analyze``, ``sample``, ``ensemble``."""
from __future__ import annotations

import sys
import time

import numpy as np

from .errors import InputError

SPREAD_FLOOR = 1e-8   # rms spread of samples per contact, in <Fn>, below which S is a point


def _scene_slice_height(packing):
    """``[analysis] slice_height`` of the packing's scene, or None (absent, 0 or unreadable)."""
    from .scene import parse_scene_text
    if not (packing.scene_text or "").strip():
        return None
    try:
        h = parse_scene_text(packing.scene_text)["analysis.slice_height"]
    except InputError:  # a scene text that does not validate just means "no default"
        return None
    return h if h > 0 else None


def load_problem(path, slice_height=None, full=False, gap_tol=float("inf"), mu=None):
    """Read a packing file and build the requested statics problem (``mu``: disk-disk
    friction instead of the packing's own)."""
    from .packing_file import read_packing
    from .statics import full_problem, slice_problem

    packing = read_packing(path)
    if full and slice_height is not None:
        raise InputError("command line", "--slice/--full", "give one of them, not both")
    if not full and slice_height is None:
        slice_height = _scene_slice_height(packing)
    if full or slice_height is None:
        problem = full_problem(packing, gap_tol=gap_tol, source=str(path), mu=mu)
    else:
        problem = slice_problem(packing, slice_height, gap_tol=gap_tol, source=str(path), mu=mu)
    return packing, problem


def _add_problem_args(p):
    g = p.add_mutually_exclusive_group()
    g.add_argument("--slice", type=float, metavar="H", default=None,
                   help="slice of height H [R] in the middle (default: the scene's "
                        "[analysis] slice_height, else --full)")
    g.add_argument("--full", action="store_true",
                   help="whole packing: bottom plate a support, top-plate forces fixed")
    p.add_argument("--gap-tol", type=float, default=float("inf"), metavar="G",
                   help="contacts with gap > G [R] are open and dropped (default: keep all)")
    p.add_argument("--mu", type=float, default=None, metavar="MU",
                   help="disk-disk friction of S instead of the packing's own (e.g. a "
                        "frictionless packing with friction switched on); walls keep plate_mu")


def cmd_analyze(args) -> int:
    from . import measures
    from .cli import print_result
    from .polytope import analyze

    t0 = time.perf_counter()
    packing, problem = load_problem(args.packing, args.slice, args.full, args.gap_tol, args.mu)
    an = analyze(problem, ranges=args.ranges, centre=True)
    out = {"packing": str(args.packing), "kind": problem.kind, "slice_height": problem.height,
           "packing_mu": packing.mu, "mu_override": args.mu}
    out.update(measures.summary(problem, an, packing=packing))
    out.update({k: v for k, v in an.summary().items() if k not in out})
    out["n_rattlers_excluded"] = int(problem.rattlers.size)
    out["load_inconsistency"] = problem.meta["load_inconsistency"]
    out["jammed_violation"] = problem.violation(problem.x_jammed)
    out["rattler_convention"] = ("Packing.rattlers(): a disk with no force-bearing contact "
                                 "(carries no load); rattlers and all their contacts dropped")
    if args.ranges and an.fn_range is not None:
        out["fn_range"] = an.fn_range
        out["ft_range"] = an.ft_range
    out["wall_time_s"] = time.perf_counter() - t0
    print_result(out, args.json)
    return 0


def cmd_sample(args) -> int:
    from .cli import print_json
    from .outputs import check_output_file, output_lock

    check_output_file(args.output, inputs=[args.packing])
    packing, problem = load_problem(args.packing, args.slice, args.full, args.gap_tol, args.mu)
    common = dict(packing_file=str(args.packing), scene_name=packing.scene_name,
                  scene_text=packing.scene_text, seed=args.seed, progress=not args.quiet,
                  checkpoint_every=args.checkpoint_every)
    with output_lock(args.output):
        if args.sampler == "relax":
            from . import relax_sampler as rs
            res = rs.sample(problem, args.n, args.output, tol=args.tol, **common)
        else:
            from . import hit_and_run as har
            res = har.sample(problem, args.n, args.output, chains=args.chains, thin=args.thin,
                             burn_in=args.burn_in, direction=args.direction, **common)
    res["output"] = str(args.output)
    if res.get("n_projected"):
        print(f"forcespace sample: warning: {res['n_projected']} of {res['n_samples']} relax "
              f"samples stalled in Gauss-Seidel (non-static fixed point) and were finished by "
              f"the exact projection onto S", file=sys.stderr)
    if args.json:
        print_json(res)
    else:
        print(f"{res['n_samples']} samples in {args.output} "
              f"(max violation {res['max_violation']:.2e} x <Fn>, "
              f"{res['wall_time_s']:.1f} s this run)", file=sys.stderr)
    return 0


def ensemble_summary(path) -> dict:
    from . import ensemble_file as ef
    from . import measures

    ens = ef.read(path)
    out = {"ensemble": str(path), "sampler": ens.sampler, "n_samples": ens.n_samples,
           "packing_file": ens.attrs.get("packing_file"), "scene_name": ens.attrs.get("scene_name"),
           "problem_kind": ens.attrs.get("problem_kind"),
           "mu_override": ens.attrs.get("mu_override"),
           "slice_height": ens.attrs.get("slice_height"),
           "n_contacts": int(ens.contacts.size), "force_scale": ens.force_scale,
           "max_violation": float(ens.violations.max(initial=0.0)),
           "max_violation_convention": "max over samples of the largest equilibrium/Coulomb "
                                       "violation divided by <Fn> (jammed mean normal force)",
           "tolerance": ens.attrs.get("tolerance_description"),
           "forcespace_version": ens.attrs.get("forcespace_version")}
    if ens.n_samples:
        out["eta"] = measures.eta(ens.samples)
        ell, l0, lbar = measures.distance_from_centre(ens.samples, ens.x_jammed)
        out["jammed_distance_from_centre"] = l0
        out["mean_sample_distance_from_centre"] = lbar
        rms_spread = lbar / (ens.force_scale * np.sqrt(max(ens.contacts.size, 1)))
        if rms_spread > SPREAD_FLOOR:
            out["jammed_distance_over_mean"] = l0 / lbar
        else:   # a ratio of two round-off numbers means nothing
            out["jammed_distance_over_mean"] = None
            out["jammed_distance_over_mean_reason"] = (
                f"samples differ only at the solver's accuracy (rms spread "
                f"{rms_spread:.1e} <Fn> <= {SPREAD_FLOOR:g}): S is numerically a point")
    else:
        out["eta"] = None
    if ens.sampler == "hit-and-run" and ens.n_samples >= 8:
        from .hit_and_run import diagnostics
        out.update(diagnostics(ens.samples, ens.chains))
    return out


def cmd_ensemble(args) -> int:
    from .cli import print_result

    out = ensemble_summary(args.ensemble)
    print_result(out, args.json)
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser("analyze", help="exact analysis of the force ensemble S (LPs)")
    p.add_argument("packing", metavar="PACK.h5")
    _add_problem_args(p)
    p.add_argument("--ranges", action="store_true",
                   help="also compute per-contact min/max of fn and ft (4 LPs per contact)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_analyze)

    p = subparsers.add_parser("sample", help="sample S (resumable: rerun to continue)")
    p.add_argument("packing", metavar="PACK.h5")
    _add_problem_args(p)
    p.add_argument("--sampler", choices=("relax", "hit-and-run"), required=True)
    p.add_argument("-n", type=int, required=True, help="total number of samples wanted")
    p.add_argument("-o", "--output", required=True, metavar="ENS.h5")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--tol", type=float, default=1e-9,
                   help="relax: max violation of S relative to <Fn> per sample (default 1e-9)")
    p.add_argument("--chains", type=int, default=None, help="hit-and-run chains (default 4)")
    p.add_argument("--thin", type=int, default=None,
                   help="hit-and-run steps between samples (default max(50, dim_S^2))")
    p.add_argument("--burn-in", type=int, default=None,
                   help="hit-and-run burn-in steps per chain (default max(500, 10 dim_S^2))")
    p.add_argument("--direction", choices=("hypersphere", "coordinate"), default=None,
                   help="hit-and-run directions (default coordinate, in the MVE-rounded frame)")
    p.add_argument("--checkpoint-every", type=int, default=10, metavar="K",
                   help="write samples and checkpoint every K samples")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=cmd_sample)

    p = subparsers.add_parser("ensemble", help="measures of a sampled ensemble (eta, ...)")
    p.add_argument("ensemble", metavar="ENS.h5")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_ensemble)
