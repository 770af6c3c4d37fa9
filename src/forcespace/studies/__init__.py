"""Study definitions for ``forcespace study NAME`` (see :mod:`forcespace.study`).

Each study module has ``tasks(quick: bool) -> list[Task]`` and
``summarize(results, out) -> dict`` (tables and figures under ``out``).
"""
STUDIES = {"fig1": "forcespace.studies.fig1", "fig2": "forcespace.studies.fig2",
           "fig3": "forcespace.studies.fig3", "pointforce": "forcespace.studies.pointforce",
           "selection": "forcespace.studies.selection", "size": "forcespace.studies.size"}
