"""forcespace: force indeterminacy in jammed packings of rigid disks.

The data flows one way, one sub-package per stage::

    scene (model.scene) -> engine (contact dynamics) -> packing (model.packing)
    -> statics problem (model.problem) -> S (space: exact analysis)
    -> samples of S (sampling) -> measures -> figures (plot), files (io)

The public API (``import forcespace as fs``)::

    scenes()                          the bundled scenes {name: description}
    load_scene(name_or_path)          a validated Scene (every key in model.scene.SCHEMA)
    jam(scene, **overrides)           jam a packing by the scene's protocol -> Packing
                                      (a SpherePacking for a 3-D scene: box.dimension = 3)
    Packing                           a static packing and its force network
    SpherePacking                     the same for spheres (paper3d, quick3d)
    read_packing(path), write_packing(packing, path)
    slice_problem(packing, height)    the paper's slice: S of its interior contacts
    full_problem(packing)             the whole packing (bottom plate a support)
    plate_problem(packing)            the whole packing under a load-controlled plate
    read_csv_pair, read_pegs, read_pegs2, read_lammps_dump   a measured frame (another
                                      code, an experiment) -> Packing with its measurement
    frame_problem(packing, region)    S of a frame's region ("rim=1", "all", Region(...))
    Measured(...).compute(problem)    a measured network against S: imbalance, Coulomb,
                                      distance, nearest network, ranges, empty S relaxed
    sphere_plate_problem(packing), sphere_full_problem(packing), sphere_slice_problem(
        packing, height)              the statics of spheres: 6 equations per sphere, 3
                                      unknowns per contact, Coulomb second-order cones
    nearest_admissible(problem, target)   a point of S for spheres (Clarabel's SOCP)
    ForceSpace(...).compute(problem)  exact analysis of S: dim, bounded, centre, radius,
                                      ranges, domains, distance(x), plot; of a sphere
                                      problem too (SOCPs: dim S by facial reduction,
                                      contacts on one ray of their cone or at its apex,
                                      ranges of fn and |f_t|; no domains, samplers yet)
    HitAndRun(n, seed).compute(problem)   uniform samples of S (coordinate hit-and-run,
                                      the reference)
    BilliardWalk(n, seed).compute(problem)  uniform samples of S (billiard walk: the fast
                                      sampler at large dim S, e.g. target_ess=100)
    RelaxWalk(n, seed).compute(problem)   the paper's perturb-and-relax walk
    Ensemble, read_ensemble(path)     samples of S: .forces (k, m, 2), .eta, diagnostics
    eta(samples)                      the paper's force ambiguity
    distance_from_centre(samples, x0) Fig. 3 distances
    Section(n, seed).compute(problem, x0, directions)   a 2-D cross-section of S (Fig. 3)
    Selection(kt_ratio, kn).compute(problem)   the network elastic springs select in S
    plot_packing, plot_difference, plot_measured   figures
    InputError, NumericalError        what the library raises (CLI exit 2 and 3)

Units: lengths in R, forces in F0, force vectors in problem column order
(x[2j] = fn, x[2j+1] = ft of unknown contact j). See README.md.
"""
from importlib import import_module
from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("forcespace")
except PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0+unknown"

from .errors import ForcespaceError, InputError, NumericalError  # noqa: E402

# name -> module; imported on first use, so `import forcespace` (and the CLI) stays light
_LAZY = {
    "load_scene": "model.scene", "scenes": "model.scene", "Scene": "model.scene",
    "Packing": "model.packing", "SpherePacking": "model.sphere_packing",
    "SphereStaticsProblem": "model.sphere_problem",
    "sphere_full_problem": "model.sphere_problem",
    "sphere_plate_problem": "model.sphere_problem",
    "sphere_slice_problem": "model.sphere_problem",
    "nearest_admissible": "space.conic",
    "slice_problem": "model.problem", "full_problem": "model.problem",
    "plate_problem": "model.problem", "StaticsProblem": "model.problem",
    "frame_problem": "model.frame", "Region": "model.frame",
    "read_csv_pair": "io.readers", "read_pegs": "io.readers", "read_pegs2": "io.readers",
    "read_lammps_dump": "io.readers", "Measured": "space.measured",
    "jam": "engine.protocol",
    "ForceSpace": "space.force_space",
    "Section": "space.section", "Selection": "space.selection",
    "HitAndRun": "sampling.hit_and_run", "BilliardWalk": "sampling.billiard",
    "RelaxWalk": "sampling.relax_walk",
    "Ensemble": "model.ensemble",
    "read_packing": "io.packing_file", "write_packing": "io.packing_file",
    "read_ensemble": "sampling.diagnostics",
    "eta": "measures", "distance_from_centre": "measures", "difference_field": "measures",
    "plot_difference": "plot", "plot_packing": "plot", "plot_measured": "plot",
}

__all__ = ["__version__", "ForcespaceError", "InputError", "NumericalError", *_LAZY]


def __getattr__(name):
    if name in _LAZY:
        value = getattr(import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'forcespace' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
