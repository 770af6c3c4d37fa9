"""forcespace: force indeterminacy in jammed packings of rigid disks.

Layers, in the order the data flows:
scene -> dynamics (contacts, nlgs, stepping) -> jamming -> packing
-> statics (slice, equilibrium matrix) -> ensemble (exact analysis, samplers)
-> measures -> studies.

The public API (``import forcespace as fs``)::

    load_scene(path)                  a validated scene (forcespace.scene.Scene)
    jam(scene, **overrides)           jam a packing by the scene's protocol -> Packing
    Packing                           a static packing: .load(path), .save(path),
                                      .from_arrays(x, y, r, a, b, ...), .plot(ax)
    slice_problem(packing, height)    the paper's slice: S of its interior contacts
    full_problem(packing)             the whole packing (bottom plate a support)
    plate_problem(packing)            the whole packing under a load-controlled plate
    ForceSpace(problem).compute()     exact analysis of S: dim, bounded, centre,
                                      radius, fn/ft ranges, domains, distance(x), plot
    HitAndRun(n, seed).run(problem)   uniform samples of S -> Ensemble (in memory)
    RelaxWalk(n, seed).run(problem)   the paper's perturb-and-relax walk -> Ensemble
    Ensemble                          samples: .forces (k, m, 2), .eta, .plot(packing)
    eta(samples)                      the paper's force ambiguity
    distance_from_centre(samples, x0) Fig. 3 distances
    difference_field(packing, problem, x1, x2)   a drawable difference of two networks
    plot_difference(packing, problem, x1, x2, domains, ax)   Fig. 2-style figure
    section(problem, x0, directions)  a 2-D cross-section of S (Fig. 3 inset) -> Section
    select(problem, kt_ratio, kn)     the network elastic springs select in S (minimum
                                      complementary energy) -> Selection (.x, .energy,
                                      .sliding_contacts, .displacement); also Selection(...)
    MemoryFile()                      an in-memory file for any output path
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
from .kernel_cache import use_versioned_cache  # noqa: E402

use_versioned_cache()   # before any kernel module imports numba (see kernel_cache)

# name -> module; imported on first use, so `import forcespace` (and the CLI) stays light
_LAZY = {
    "load_scene": "scene", "Scene": "scene",
    "jam": "jamming",
    "Packing": "packing",
    "slice_problem": "statics", "full_problem": "statics", "plate_problem": "statics",
    "StaticsProblem": "statics",
    "ForceSpace": "force_space",
    "HitAndRun": "hit_and_run", "RelaxWalk": "relax_sampler",
    "Ensemble": "ensemble_file",
    "eta": "measures", "distance_from_centre": "measures", "difference_field": "measures",
    "plot_difference": "draw", "plot_packing": "draw",
    "MemoryFile": "h5io",
    "section": "cross_section", "Section": "cross_section",
    "select": "selection", "Selection": "selection",
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
