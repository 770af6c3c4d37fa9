"""The extension surface: what a plug-in may import from forcespace besides the public API.

forcespace's plug-ins (the DEM adapters, ``forcespace_adapters``; the research studies,
``forcespace_studies``; their scripts under ``studies/``; and yours) import from four
places only, which ``tests/test_house_rules.py`` enforces on every plug-in file:

* ``forcespace``         the public API (its ``__all__``: scenes, packings, problems, S,
                         samplers, measures, figures)
* ``forcespace.extend``  this module's ``__all__``, listed below by stage
* ``forcespace.errors``  the errors the library raises
* ``forcespace.config``  every tolerance and threshold, named once

No other module, no private (underscore) name, and no dynamic import of either. Names are
imported on first use (``import forcespace.extend`` stays light); each is documented where
it is defined. The groups, in the order of the data's path:

* model      boundary and scene records; wall codes of a packing's contacts; what a
             measured network carries (``Measurement``)
* engine     the protocol below ``jam``: a static solve or the dynamics of a given
             configuration, a point force on a settled layer
* kernels    the engine's numba kernels and their records, for the engine's benchmarks
             only (they change with the kernels)
* space      exact questions about S beyond ``ForceSpace``: clusters and domains,
             projections and distances, the elastic selection, point-force limits
* sampling   chains of an ensemble
* measures   the point-force rearrangement
* io         atomic files, locks, output directories, JSON, the code version stamp;
             writers of forcespace's packings as measured frames (CSV pair, PeGS, LAMMPS)
* figures    saving figures; the axis labels of the quantities
"""
from importlib import import_module

# name -> (module, attribute), by group
_SURFACE = {
    # model
    "Setup": ("model.setup", "Setup"), "Boundary": ("model.setup", "Boundary"),
    "parse_scene_text": ("model.scene", "parse_scene_text"),
    "BOTTOM": ("model.walls", "BOTTOM"), "TOP": ("model.walls", "TOP"),
    "LEFT": ("model.walls", "LEFT"), "RIGHT": ("model.walls", "RIGHT"),
    "WALL": ("model.walls", "WALL"), "Measurement": ("model.measurement", "Measurement"),
    # engine
    "build_packing": ("engine.protocol", "build_packing"),
    "make_bodies": ("engine.protocol", "make_bodies"),
    "static_solve": ("engine.protocol", "static_solve"),
    "push": ("engine.push", "push"),
    # kernels (the engine's benchmarks)
    "nlgs_solve": ("engine.nlgs", "solve"),
    "add_contact_velocities": ("engine.nlgs", "add_contact_velocities"),
    "Contacts": ("engine.records", "Contacts"), "Motion": ("engine.records", "Motion"),
    "SweepSettings": ("engine.records", "SweepSettings"),
    "row_order": ("engine.bodies", "row_order"),
    "frozen_contacts": ("engine.frozen", "frozen_contacts"),
    "frozen_contacts3": ("engine.frozen", "frozen_contacts3"),
    "N_WALL_SLOTS": ("model.walls", "N_WALL_SLOTS"), "SLOT_TOP": ("model.walls", "SLOT_TOP"),
    "kernel_body_index": ("model.walls", "kernel_body_index"),
    # space
    "implicit_equalities": ("space.questions", "implicit_equalities"),
    "chebyshev_centre": ("space.questions", "chebyshev_centre"),
    "ClusterDecomposition": ("space.structure", "ClusterDecomposition"),
    "decompose": ("space.structure", "decompose"), "domains": ("space.structure", "domains"),
    "extreme_pair": ("space.structure", "extreme_pair"),
    "percolates": ("space.structure", "percolates"),
    "distance_to_S": ("space.projection", "distance_to_S"),
    "packing_overlaps": ("space.selection", "packing_overlaps"),
    "unit_problem": ("space.lp", "unit_problem"), "eq_system": ("space.lp", "eq_system"),
    "interior_strict_rows": ("space.questions", "interior_strict_rows"),
    "interior_max_sum_fn": ("space.questions", "interior_max_sum_fn"),
    "centre_and_radius": ("space.questions", "centre_and_radius"),
    "max_point_force": ("space.loads", "max_point_force"),
    "affine_hull": ("linalg", "affine_hull"), "rank": ("linalg", "rank"),
    "sphere_problem_for": ("model.sphere_problem", "sphere_problem_for"),
    "pyramid_fn_ranges": ("space.conic", "pyramid_fn_ranges"),
    "conic_fn_range": ("space.conic", "fn_range"), "conic_ft_range": ("space.conic", "ft_range"),
    "conic_ft_range_ascent": ("space.conic", "ft_range_ascent"),
    # sampling
    "by_chain": ("sampling.diagnostics", "by_chain"),
    "tracked_statistics": ("sampling.diagnostics", "tracked_statistics"),
    "summarize": ("sampling.diagnostics", "summarize"),
    # measures
    "rearrangement_depth": ("measures", "rearrangement_depth"),
    "surface_disk": ("measures", "surface_disk"),
    # io
    "atomic_path": ("io.h5", "atomic_path"), "code_version": ("io.h5", "code_version"),
    "check_output_dir": ("io.outputs", "check_output_dir"),
    "check_output_file": ("io.outputs", "check_output_file"),
    "mark_run_dir": ("io.outputs", "mark_run_dir"), "file_lock": ("io.outputs", "file_lock"),
    "recording_new_entries": ("io.outputs", "recording_new_entries"),
    "writing_run_dir": ("io.outputs", "writing_run_dir"),
    "check_name_length": ("io.outputs", "check_name_length"),
    "probe_writable": ("io.outputs", "probe_writable"),
    "clean_stale_temps": ("io.outputs", "clean_stale_temps"),
    "dumps": ("io.jsonfile", "dumps"), "jsonable": ("io.jsonfile", "jsonable"),
    "write_json": ("io.jsonfile", "write_json"),
    "write_csv_pair": ("io.readers", "write_csv_pair"),
    "write_pegs": ("io.readers", "write_pegs"), "write_pegs2": ("io.readers", "write_pegs2"),
    "write_lammps_dump": ("io.readers", "write_lammps_dump"),
    "progress": ("progress", "progress"),
    # figures
    "save_figure": ("io.figures", "save_figure"), "LABELS": ("plot", "LABELS"),
}

__all__ = sorted(_SURFACE)


def __getattr__(name):
    if name in _SURFACE:
        module, attr = _SURFACE[name]
        value = getattr(import_module(f"forcespace.{module}"), attr)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'forcespace.extend' has no attribute {name!r} (the "
                         "extension surface: forcespace.extend.__all__)")


def __dir__():
    return sorted(set(globals()) | set(_SURFACE))
