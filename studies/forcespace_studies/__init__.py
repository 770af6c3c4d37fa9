"""The research studies of forcespace: a plug-in over its public API.

``forcespace study NAME`` (registered through the ``forcespace.commands`` entry point)
runs a study's tasks with :mod:`forcespace_studies.runner`.

Each study module has ``tasks(quick: bool) -> list[Task]`` and
``summarize(results, out) -> dict`` (tables and figures under ``out``).
"""
STUDIES = {"fig1": "forcespace_studies.fig1", "fig2": "forcespace_studies.fig2",
           "fig3": "forcespace_studies.fig3", "pointforce": "forcespace_studies.pointforce",
           "selection": "forcespace_studies.selection", "size": "forcespace_studies.size",
           "measured": "forcespace_studies.measured"}
