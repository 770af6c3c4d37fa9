"""Cross-checks of forcespace against soft-particle DEM codes (LIGGGHTS 3.8, pymunk 7).

Dimensions: LIGGGHTS runs disk packings in a 2-D slab (:mod:`.liggghts`) and sphere
packings natively in 3-D (:mod:`.liggghts3d`); pymunk is a 2-D engine and takes disks
only. ``export``, ``run``, ``import_run``, ``compare`` and ``distance`` take either kind.

A plug-in over forcespace's public API (forcespace never imports it); it adds the
``export``, ``run``, ``import`` and ``distance`` commands to the ``forcespace`` CLI.

Units (one convention in the options, the reports and the CLI): lengths in R, forces in
F0 in the files; soft-code parameters are measured with the rigid packing's mean normal
force <Fn> (force-bearing contacts): stiffness ``kn`` in <Fn>/R (a mean contact overlaps
by R/kn), tolerances in <Fn>, pymunk's ``dt`` in t0 = sqrt(m_min R/<Fn>); distances to S
are rms per contact in <Fn>.

The round trip in Python::

    import forcespace_adapters as fa

    deck = fa.export("liggghts", "p.h5", "deck", kn=1e6)          # or options={"kn": 1e6}
    status = fa.run("liggghts", deck)                              # {"converged": ..., "steps": ...}
    soft = fa.import_run("liggghts", deck, "soft.h5")             # soft network (a Packing)
    rigid = forcespace.read_packing("p.h5")
    report = fa.compare(rigid, soft, fa.make_problem(rigid))      # distance to S, verdict
    print(report["relative_distance"], report["verdict"]["text"])

In memory, without run directories: ``fa.simulate(fa.soft_problem(rigid),
fa.PymunkOptions(iterations=100))`` (pymunk), or ``liggghts.write_deck``,
``liggghts.run_deck``, ``liggghts.read_result`` (LIGGGHTS).

Public names:

    export(code, packing, directory, options=None, y_range=None, top="plate", **option_kw)
    run(code, directory, binary=None, timeout=None, progress=None, show_progress=False)
                                      -> status dict
    import_run(code, directory, out_path=None) -> soft Packing
    load_soft(code, directory) -> (soft Packing, rigid Packing)
    make_options(code, options=None, **kw) -> LiggghtsOptions | PymunkOptions
    LiggghtsOptions, PymunkOptions      run parameters (dataclasses, units above)
    soft_problem(packing, y_range=None, exclude_rattlers=True, top="plate") -> SoftProblem
    simulate(problem, options=None, progress=None) -> (soft Packing, info)   (pymunk)
    make_problem(rigid, top="plate")    the S distances are measured in
    compare(rigid, soft, problem=None) -> dict: relative_distance, matching, verdict
    verdict(relative_distance, soft) -> inside S at the soft code's accuracy?
    distance_between(rigid, soft1, soft2) -> rms difference of two soft networks / <Fn>
    match_contacts(rigid, soft) -> MatchResult
    liggghts (module): write_deck, run_deck, read_result, read_snapshots, precision_floor
    liggghts3d (module): write_deck3, read_result3 (spheres; run with liggghts.run_deck)
    LiggghtsError                       LIGGGHTS missing or failed
"""
from . import liggghts, liggghts3d
from .distance import compare, distance_between, make_problem, run_status, verdict
from .liggghts import LiggghtsError, LiggghtsOptions
from .matching import MatchResult, match_contacts
from .problem import SoftProblem, soft_problem
from .pymunk_sim import PymunkOptions, simulate
from .workflow import CODES, export, import_run, load_soft, make_options, run

__all__ = ["CODES", "LiggghtsError", "LiggghtsOptions", "MatchResult", "PymunkOptions",
           "SoftProblem", "compare", "distance_between", "export", "import_run",
           "liggghts", "liggghts3d", "load_soft", "make_options", "make_problem",
           "match_contacts", "run", "run_status", "simulate", "soft_problem", "verdict"]
