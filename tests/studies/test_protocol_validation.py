"""The protocol comparison tool: overrides reach the scene it jams, and bad ones are named."""
import pytest

from forcespace.errors import NumericalError
from forcespace_studies.protocol_validation import one, parse_overrides


def test_overrides_are_parsed_as_numbers_and_a_bad_one_is_named():
    assert parse_overrides("solver.tolerance=1e-8, solver.max_sweeps=2000") == {
        "solver.tolerance": 1e-8, "solver.max_sweeps": 2000}
    assert parse_overrides("") == {}
    assert parse_overrides("scene.name=x") == {"scene.name": "x"}
    assert parse_overrides("box.periodic_x=false") == {"box.periodic_x": False}
    with pytest.raises(SystemExit, match="'solver.tolerance' is not key=value"):
        parse_overrides("solver.tolerance")


def test_a_protocol_jams_with_its_own_overrides():
    # the same seed under a 200-step budget cannot jam: the override is in the scene
    row = one("candidate", 40, 1, mu=1.0, overrides={"solver.tolerance": 1e-8})
    assert row["mu"] == 1.0 and row["steps"] > 200 and 3.0 < row["z"] < 4.0
    with pytest.raises(NumericalError, match="not jammed after jamming.max_steps = 200"):
        one("candidate", 40, 1, mu=1.0, overrides={"jamming.max_steps": 200})
