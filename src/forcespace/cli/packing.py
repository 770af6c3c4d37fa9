"""CLI commands for packings: ``pack``, ``info``, ``draw``."""
from __future__ import annotations

from pathlib import Path

from .printing import print_result
from ..errors import InputError


def register(sub):
    p = sub.add_parser("pack", help="build a jammed packing from a scene file",
                       description="Jam a packing by the scene's protocol. The compression "
                       "checkpoints to OUTPUT.checkpoint.h5 every 30 s and on Ctrl-C; rerunning the same "
                       "command after a kill resumes from it.")
    p.add_argument("scene", help="scene file (TOML), e.g. inputs/paper.toml")
    p.add_argument("-o", "--output", required=True, help="packing file to write (HDF5)")
    p.add_argument("--mu", type=float, help="override physics.mu")
    p.add_argument("--seed", type=int, help="override scene.seed")
    p.add_argument("--n", type=int, help="override disks.n (spheres in a 3-D scene)")
    p.add_argument("--scale-box", action="store_true",
                   help="with --n: scale box.width and the slice height by sqrt(n / n_scene) "
                        "(spheres: the lateral extents by (n / n_scene)^(1/3)), so the box "
                        "keeps its shape (without it a larger n makes a taller column)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_pack)

    p = sub.add_parser("info", help="summary of a packing file")
    p.add_argument("packing")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("draw", help="draw a packing and its force network (spheres: a "
                       "slice and a view from above), or (with --difference) the paper's "
                       "Fig. 2")
    p.add_argument("packing")
    p.add_argument("-o", "--output", required=True, help="figure file (.png also writes .pdf)")
    p.add_argument("--difference", action="store_true",
                   help="draw the difference of two admissible networks of S (two vertices "
                        "of S far apart), domains outlined in colour, elementary clusters "
                        "dashed (the paper's Fig. 2)")
    p.add_argument("--seed", type=int, default=0,
                   help="with --difference: seed of the random direction picking the vertices")
    from .space import add_problem_args
    add_problem_args(p)
    p.set_defaults(func=cmd_draw)


def cmd_pack(args) -> int:
    from ..engine.protocol import build_packing
    from ..kernels import compile_notice
    from ..io.outputs import check_output_file, output_lock
    from ..io.packing_file import write_packing
    from ..model.scene import load_scene

    check_output_file(args.output, inputs=[args.scene])
    scene = load_scene(args.scene)
    scaled = None
    if args.scale_box:
        if args.n is None:
            raise InputError("command line", "--scale-box", "needs --n (the new number of disks)")
        scene, scaled = scene.scaled_to(args.n)
    scene = scene.with_overrides(
        **{"physics.mu": args.mu, "scene.seed": args.seed, "disks.n": args.n})
    checkpoint = Path(str(args.output) + ".checkpoint.h5")
    with output_lock(args.output):
        if checkpoint.exists() and not args.quiet:
            print(f"resuming from {checkpoint}")
        if not args.quiet:
            compile_notice(("forcespace.engine", "forcespace.model"))
        packing = build_packing(scene, show_progress=not args.quiet, checkpoint=checkpoint)
        if scaled:
            packing.meta["scaled_box"] = scaled
        write_packing(packing, args.output)
    s = packing.summary()
    grains = f"{s['n_spheres']} spheres" if "n_spheres" in s else f"{s['n_disks']} disks"
    print(f"{Path(args.output)}: {grains}, {s['n_contacts']} contacts, "
          f"z = {s['z']:.3f} ({s['n_rattlers']} rattlers), mu = {s['mu']:g}, "
          f"residual = {s['equilibrium_residual']:.2e}, max overlap = {s['max_overlap']:.2e} R, "
          f"{s['steps']} steps, {s['wall_seconds']:.1f} s")
    return 0


def cmd_info(args) -> int:
    from ..io.packing_file import read_packing

    s = read_packing(args.packing).summary()
    print_result(s, args.json)
    return 0


def cmd_draw(args) -> int:
    from ..plot import draw_packing
    from ..io.outputs import check_figure_file
    from ..io.packing_file import read_packing
    from .space import check_problem_args, check_seed

    check_seed(args.seed)
    check_problem_args(args.mu, args.gap_tol, args.slice)
    check_figure_file(args.output, inputs=[args.packing])
    if not args.difference:
        packing = read_packing(args.packing)
        if getattr(packing, "dim", 2) == 3:
            from ..plot import draw_sphere_packing
            draw_sphere_packing(packing, args.output)
        else:
            draw_packing(packing, args.output)
        print(f"wrote {args.output}")
        return 0
    from .space import load_problem
    from ..space.structure import decompose, extreme_pair
    from ..io.figures import save_figure
    from ..plot import plot_difference
    from .space import analysed
    from ..model.problem import slice_bounds

    packing, problem = load_problem(args.packing, args.slice, args.full, args.gap_tol, args.mu)
    an = analysed(problem)
    if not (an.feasible and an.bounded and an.dim):
        raise InputError(args.packing, "S", "must be non-empty, bounded and of dimension >= 1 "
                         "for a difference of two networks", got=f"feasible={an.feasible}, "
                         f"bounded={an.bounded}, dim S={an.dim}")
    dec = decompose(problem, an, packing)
    x1, x2 = extreme_pair(problem, an, args.seed)
    mu = packing.mu if args.mu is None else args.mu
    edges = None if problem.height is None else slice_bounds(packing, problem.height)
    ax = plot_difference(packing, problem, x1, x2, dec.domains, clusters=dec.clusters,
                         slice_edges=edges,
                         title=rf"$\mu = {mu:g}$: $\Delta f_n = f_n^{{(2)}} - f_n^{{(1)}}$ "
                               rf"between two far-apart vertices of $S$; dim $S$ = {an.dim}, "
                               f"{dec.n_elementary} elementary clusters")
    ax.figure.tight_layout()
    save_figure(ax.figure, args.output)
    print_result({"figure": str(args.output), **dec.summary()}, False)
    return 0
