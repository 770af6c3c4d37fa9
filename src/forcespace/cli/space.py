"""CLI commands of the force ensemble: ``analyze``, ``sample``, ``section``, ``ensemble``."""
from __future__ import annotations

import sys
import time



MU_MAX = 1e6          # as the scene's physics.mu
SEED_MAX = 2 ** 63 - 1    # numpy takes any integer >= 0; files store int64
DOMAINS_CONVENTION = (
    "a domain: contacts whose forces vary together, independently of every other contact "
    "(domain_dims: its degrees of freedom); n_domains_of_dim_1: domains that are one "
    "elementary cluster; clusters.n_elementary (--clusters): every elementary cluster (a "
    "self-stress of one degree of freedom), also those inside larger domains")


def check_problem_args(mu=None, gap_tol=float("inf"), slice_height=None) -> None:
    """The options that shape the problem, refused before any file is read."""
    import math

    from ..errors import InputError
    if mu is not None and not (0 <= mu <= MU_MAX):
        raise InputError("command line", "--mu", f"must be a number in [0, {MU_MAX:g}] "
                         "(a Coulomb coefficient, as the scene's physics.mu)", got=mu)
    if math.isnan(gap_tol) or gap_tol < 0:
        raise InputError("command line", "--gap-tol", "must be a number >= 0 [R] (or inf: "
                         "keep every contact)", got=gap_tol)
    if slice_height is not None and not (math.isfinite(slice_height) and slice_height > 0):
        raise InputError("command line", "--slice", "must be a finite number > 0 [R]",
                         got=slice_height)


def check_seed(seed, option: str = "--seed") -> int:
    """A seed as numpy takes it (and files store it): an integer in [0, 2**63 - 1]."""
    from ..errors import InputError
    if seed is None:
        return seed
    if not 0 <= seed <= SEED_MAX:
        raise InputError("command line", option, f"must be an integer in [0, {SEED_MAX}]",
                         got=seed)
    return seed


def load_problem(path, slice_height=None, full=False, gap_tol=float("inf"), mu=None,
                 spheres: bool = False):
    """Read a packing file and build the problem the options ask for
    (:func:`forcespace.model.problem.problem_for`; with ``spheres``, a sphere packing's
    :func:`forcespace.model.sphere_problem.sphere_problem_for`, else it is refused)."""
    from ..io.packing_file import read_packing
    from ..model.problem import problem_for
    from ..model.sphere_problem import sphere_problem_for

    check_problem_args(mu, gap_tol, slice_height)
    packing = read_packing(path)
    build = sphere_problem_for if spheres and getattr(packing, "dim", 2) == 3 else problem_for
    return packing, build(packing, slice_height, full, gap_tol, mu, source=str(path))


def add_problem_args(p):
    """--slice/--full (a mutually exclusive group, returned), --gap-tol, --mu."""
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
    return g


def analysed(problem, ranges: bool = False, progress: bool = False):
    """ForceSpace(ranges).compute(problem); NumericalError (exit 3) if an LP failed."""
    from ..errors import NumericalError
    from ..space.force_space import ForceSpace

    S = ForceSpace(ranges=ranges, centre=True, progress=progress).compute(problem)
    if not S.success:
        raise NumericalError(S.message)
    return S


def cmd_analyze(args) -> int:
    from .printing import print_result

    t0 = time.perf_counter()
    packing, problem = load_problem(args.packing, args.slice, args.full, args.gap_tol, args.mu,
                                    spheres=True)
    if args.clusters and problem.dim == 3:
        from ..errors import InputError
        raise InputError(str(args.packing), "--clusters", "is answered for disks only so far "
                         "(S of spheres has curved faces); analyze without it")
    S = analysed(problem, ranges=args.ranges, progress=not args.quiet)
    out = {"packing": str(args.packing), "kind": problem.kind, "slice_height": problem.height,
           "packing_mu": packing.mu, "mu_override": args.mu, **S.summary(),
           "z": packing.coordination()}
    out["n_rattlers_excluded"] = int(problem.rattlers.size)
    out["load_inconsistency"] = problem.meta.get("load_inconsistency")
    out["jammed_violation"] = problem.violation(problem.x_jammed)
    grain = "sphere" if problem.dim == 3 else "disk"
    out["rattler_convention"] = (f"a {grain} with no force-bearing contact (carries no "
                                 "load); rattlers and all their contacts dropped")
    if problem.dim == 2:
        out["domains_convention"] = DOMAINS_CONVENTION
    if args.ranges and S.fn_range is not None:
        out["fn_range"] = S.fn_range
        out["ft_range"] = S.ft_range
    if args.clusters and S.feasible and S.dim:
        from ..space.structure import decompose
        out["clusters"] = decompose(problem, S, packing).summary()
    out["wall_time_s"] = time.perf_counter() - t0
    out["units"] = dict(out.pop("units", {}), slice_height="R", fn_range="F0", ft_range="F0",
                        load_inconsistency="<Fn>", jammed_violation="<Fn>",
                        z=f"contacts per non-rattler {grain}", wall_time_s="s (wall clock)")
    if problem.dim == 3:
        out["units"]["ft_range"] = "F0 (|f_t|, the tangential force's magnitude)"
    print_result(out, args.json)
    return 0


def cmd_sample(args) -> int:
    from .printing import print_json
    from ..errors import NumericalError
    from ..io.outputs import check_output_file

    check_seed(args.seed)
    check_problem_args(args.mu, args.gap_tol, args.slice)
    check_output_file(args.output, inputs=[args.packing])
    common = dict(seed=args.seed, progress=not args.quiet,
                  checkpoint_every=args.checkpoint_every, target_ess=args.target_ess)
    if args.sampler is None:
        args.sampler = default_sampler(args.packing)
    if args.sampler == "relax":
        from ..sampling.relax_walk import RelaxWalk
        sampler = RelaxWalk(args.n, tol=args.tol, chains=args.chains or 1, **common)
    elif args.sampler == "billiard":
        from ..sampling.billiard import BilliardWalk
        sampler = BilliardWalk(args.n, chains=args.chains, thin=args.thin,
                               burn_in=args.burn_in, **common)
    else:
        from ..sampling.hit_and_run import HitAndRun
        sampler = HitAndRun(args.n, chains=args.chains, thin=args.thin, burn_in=args.burn_in,
                            direction=args.direction, **common)
    packing, problem = load_problem(args.packing, args.slice, args.full, args.gap_tol, args.mu,
                                    spheres=True)
    if args.sampler == "relax" and getattr(packing, "dim", 2) == 3:
        from ..errors import InputError
        raise InputError(str(args.packing), "--sampler", "relax (the paper's walk, through the "
                         "disk engine) takes disk packings only; a sphere packing takes "
                         "billiard (default) or hit-and-run")
    if not args.quiet:
        from ..kernels import compile_notice
        compile_notice(("forcespace.sampling", "forcespace.engine") if args.sampler == "relax"
                       else ("forcespace.sampling",))
    res = sampler.compute(problem, output=args.output).summary()
    res["output"] = str(args.output)
    if res.get("n_projected"):
        print(f"forcespace sample: warning: {res['n_projected']} of {res['n_samples']} relax "
              f"samples stalled in Gauss-Seidel (non-static fixed point) and were finished by "
              f"the exact projection onto S", file=sys.stderr)
    if args.json:
        print_json(res)
    else:
        # a target-ESS run says how it ended (converged, or short of the target: exit 3)
        ended = f"; {sampler.message}" if args.target_ess is not None else ""
        print(f"{res['n_samples']} samples in {args.output} "
              f"(max violation {res['max_violation']:.2e} x <Fn>, "
              f"{res['wall_time_s']:.1f} s this run){ended}", file=sys.stderr)
    if not sampler.success:
        raise NumericalError(sampler.message)
    return 0


def default_sampler(path) -> str:
    """The sampler of ``forcespace sample`` without --sampler: "billiard" for a sphere
    packing (its ESS per CPU s was ~10x hit-and-run's on 100-sphere slices); disks must
    choose (InputError)."""
    from ..errors import InputError
    from ..io.packing_file import read_packing

    if getattr(read_packing(path), "dim", 2) != 3:
        raise InputError("command line", "--sampler", "is required for a disk packing: "
                         "relax, hit-and-run or billiard")
    return "billiard"


def cmd_ensemble(args) -> int:
    from .printing import print_result
    from ..sampling.diagnostics import read_ensemble
    from ..io.outputs import check_figure_file

    if args.output is not None:
        check_figure_file(args.output, inputs=[args.ensemble] + ([args.packing] if args.packing
                                                                  else []))
    ens = read_ensemble(args.ensemble)
    out = ens.summary()
    packing = None
    if args.packing is not None:
        packing, problem = ensemble_problem(ens, args.packing)
        out.update(ens.network_measures(packing, problem))
    if args.output is not None:
        ensemble_figure(ens, packing, args.output)
        out["figure"] = str(args.output)
    if not args.json:       # one line for the arrays (all of them: --json)
        fd = out.pop("force_distribution", None)
        if fd is not None:
            out["force_distribution"] = (f"mean f: ensemble {fd['mean_f_ensemble']:.4f}, "
                                         f"jammed {fd['mean_f_jammed']:.4f} (--json: P(f))")
    print_result(out, args.json)
    return 0


def ensemble_problem(ens, packing_path):
    """(packing, problem) the ensemble was sampled in, rebuilt from ``packing_path`` and the
    ensemble's recorded problem (kind, slice height, mu override); InputError naming
    --packing when it is another packing or another problem."""
    import numpy as np

    from ..errors import InputError
    from ..io.packing_file import read_packing
    from ..model.problem import problem_for

    packing = read_packing(packing_path)
    ens.check_packing(packing, f"--packing {packing_path}")
    a = ens.attrs
    height, mu = a.get("slice_height"), a.get("mu_override")
    full = a.get("problem_kind") == "full"
    problem = problem_for(packing, None if full else height, full,
                          mu=None if mu is None or not np.isfinite(mu) else float(mu),
                          source=str(packing_path))
    if not np.array_equal(problem.contacts, ens.contacts):
        raise InputError(f"--packing {packing_path}", "problem", "does not rebuild the "
                         "ensemble's problem (its contacts differ: sampled with --gap-tol "
                         "or another kind of problem)")
    return packing, problem


def ensemble_figure(ens, packing, path) -> None:
    """The ensemble's figure: P(f) against the jammed network's; with the packing, the
    ensemble drawn on it beside (mean fn as width, its spread as colour)."""
    from matplotlib.figure import Figure
    from ..plot import plot_force_distribution, save_figure

    ci = ens.eta_interval()
    eta = rf"$\eta = {ci['eta']:.4f}$" + ("" if ci["se"] is None else
                                           rf" $\pm$ {ci['high'] - ci['eta']:.4f} (95 %)")
    fig = Figure(figsize=(12.0, 5.2) if packing is not None else (5.6, 4.2))
    if packing is not None:
        left, right = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.4, 1.0]})
        ens.plot(packing, ax=left)
    else:
        right = fig.add_subplot()
    plot_force_distribution(right, ens.force_distribution(),
                            f"{ens.sampler}, {ens.n_samples} samples: {eta}")
    save_figure(fig, path, tight=True)


def cmd_section(args) -> int:
    from .printing import print_result
    from ..io.outputs import check_figure_file
    from ..space.section import Section

    check_seed(args.seed)
    check_problem_args(args.mu, args.gap_tol, args.slice)
    check_figure_file(args.output, inputs=[args.packing])
    packing, problem = load_problem(args.packing, args.slice, args.full, args.gap_tol, args.mu)
    sec = Section(n=args.n, seed=args.seed).compute(problem)
    from pathlib import Path
    name = packing.scene_name or Path(args.packing).stem
    ax = sec.plot(title=rf"$S$ of {name} ({problem.kind}) through the jammed network, "
                        f"random directions (seed {args.seed})")
    ax.figure.tight_layout()
    from ..io.figures import save_figure
    save_figure(ax.figure, args.output)
    print_result({"figure": str(args.output), "inside_fraction": sec.inside_fraction,
                  "s_range": list(sec.s_range), "t_range": list(sec.t_range),
                  "jammed_state_violation": sec.x0_violation}, args.json)
    return 0


def cmd_select(args) -> int:
    import math

    from .printing import print_result
    from ..errors import InputError
    from ..io.outputs import check_output_file, output_lock
    from ..io.packing_file import read_packing, write_packing
    from ..space.selection import Selection
    from ..model.problem import plate_problem, problem_for

    # beyond these ranges the QP's scaling fails (kn 1e15 with --initial-overlaps, kt/kn
    # 1e-12) or overflows (kn 1e308), where the physics has nothing to gain
    for name, v, lo, hi, what in (
            ("--kt-ratio", args.kt_ratio, 1e-6, 1e6, "kt/kn; elastic disks have 0.1 to 1"),
            ("--kn", args.kn, 1e-12, 1e12, "[F0/R]; soft codes use 1e3 to 1e8")):
        if not (math.isfinite(v) and lo <= v <= hi):
            raise InputError("command line", name, f"must be a number > 0, in [{lo:g}, {hi:g}] "
                             f"({what})", got=v)
    check_problem_args(args.mu, args.gap_tol, args.slice)
    check_output_file(args.output, inputs=[args.packing])
    t0 = time.perf_counter()
    packing = read_packing(args.packing)
    if args.plate:
        problem = plate_problem(packing, args.gap_tol, source=str(args.packing), mu=args.mu)
    else:
        problem = problem_for(packing, args.slice, args.full, args.gap_tol, args.mu,
                              source=str(args.packing))
    overlap = None
    if args.initial_overlaps:
        from ..space.selection import packing_overlaps
        overlap = packing_overlaps(packing, problem)
    sel = Selection(kt_ratio=args.kt_ratio, kn=args.kn, overlap=overlap).compute(problem)
    soft = sel.to_packing(packing)
    with output_lock(args.output):
        write_packing(soft, args.output, kind="soft_network",
                      extra_attrs={f"run_{k}": v for k, v in soft.meta.items()})
    out = {"packing": str(args.packing), "output": str(args.output), **sel.summary(),
           "jammed_violation": problem.violation(problem.x_jammed),
           "wall_time_s": time.perf_counter() - t0}
    print_result(out, args.json)
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser("analyze", help="exact analysis of the force ensemble S (LPs)")
    p.add_argument("packing", metavar="PACK.h5")
    add_problem_args(p)
    p.add_argument("--clusters", action="store_true",
                   help="decompose the indeterminacy into elementary clusters (sizes, density "
                        "rho per interior disk, percolating domains)")
    p.add_argument("--ranges", action="store_true",
                   help="also compute per-contact min/max of fn and ft (4 LPs per contact)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_analyze)

    _register_sample(subparsers)

    p = subparsers.add_parser("section", help="a 2-D cross-section of S through the jammed "
                              "network (white inside S, grey by Coulomb violation)")
    p.add_argument("packing", metavar="PACK.h5")
    add_problem_args(p)
    p.add_argument("-n", type=int, default=201, help="grid points per axis (default 201)")
    p.add_argument("--seed", type=int, default=0, help="seed of the two random directions")
    p.add_argument("-o", "--output", required=True, help="figure (.png also writes .pdf)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_section)

    p = subparsers.add_parser(
        "select", help="the network linear springs select in S (minimum complementary "
        "energy, a QP over S) -> soft-network file for `forcespace distance`")
    p.add_argument("packing", metavar="PACK.h5")
    g = add_problem_args(p)
    g.add_argument("--plate", action="store_true",
                   help="whole packing under its load-controlled top plate (the S of the "
                        "LIGGGHTS/pymunk runs and of `forcespace distance`)")
    p.add_argument("--kt-ratio", type=float, default=2.0 / 7.0, metavar="R",
                   help="tangential / normal contact stiffness kt/kn (default 2/7, as the "
                        "LIGGGHTS adapter); the network depends on kn only through it")
    p.add_argument("--kn", type=float, default=1.0, metavar="K",
                   help="normal stiffness [F0/R] (default 1; without --initial-overlaps it "
                        "scales the reported energy only)")
    p.add_argument("--initial-overlaps", action="store_true",
                   help="springs start at the packing's own contact overlaps/gaps (a soft "
                        "code started from this packing); kn then matters in absolute terms")
    p.add_argument("-o", "--output", required=True, metavar="SEL.h5",
                   help="soft-network file to write")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_select)

    _register_ensemble(subparsers)


def _register_sample(subparsers) -> None:
    p = subparsers.add_parser("sample", help="sample S (resumable: rerun to continue)")
    p.add_argument("packing", metavar="PACK.h5")
    add_problem_args(p)
    p.add_argument("--sampler", choices=("relax", "hit-and-run", "billiard"), default=None,
                   help="hit-and-run (uniform, the reference; spheres: exact chords "
                        "through the Coulomb cones), billiard (uniform, fast at large dim "
                        "S; spheres: reflections off the cones, the default for spheres) "
                        "or relax (the paper's walk); required for disks")
    p.add_argument("-n", type=int, required=True, help="total number of samples wanted")
    p.add_argument("-o", "--output", required=True, metavar="ENS.h5")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--tol", type=float, default=1e-9,
                   help="relax: max violation of S relative to <Fn> per sample (default 1e-9)")
    p.add_argument("--chains", type=int, default=None,
                   help="independent chains (hit-and-run and billiard default 4, relax default 1)")
    p.add_argument("--target-ess", type=float, default=None, metavar="E",
                   help="stop as soon as every tracked statistic has bulk and tail ESS >= E "
                        "and split R-hat <= 1.05 (-n is then the cap; exit 3 if reached first)")
    p.add_argument("--thin", type=int, default=None,
                   help="hit-and-run steps between samples (default max(50, dim_S^2)); billiard: "
                        "trajectories between samples (default 1)")
    p.add_argument("--burn-in", type=int, default=None,
                   help="hit-and-run burn-in steps per chain (default max(500, 10 dim_S^2)); "
                        "billiard: trajectories per chain (default 50)")
    p.add_argument("--direction", choices=("hypersphere", "coordinate"), default=None,
                   help="hit-and-run directions (default coordinate, in the rounded frame: "
                        "MVE, or its Lewis-weight approximation above 1500 rows)")
    p.add_argument("--checkpoint-every", type=int, default=10, metavar="K",
                   help="write samples and checkpoint every K samples")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=cmd_sample)


def _register_ensemble(subparsers) -> None:
    p = subparsers.add_parser("ensemble", help="measures of a sampled ensemble (eta with its "
                              "interval, P(f), with --packing stress and fabric tensors)")
    p.add_argument("ensemble", metavar="ENS.h5")
    p.add_argument("--packing", metavar="PACK.h5", default=None,
                   help="the packing it was sampled from: adds the stress and fabric tensors "
                        "and draws the ensemble on it")
    p.add_argument("-o", "--output", metavar="FIG.png", default=None,
                   help="figure: P(f) of the ensemble against the jammed network's (and the "
                        "ensemble on the packing with --packing); .png also writes .pdf")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_ensemble)
