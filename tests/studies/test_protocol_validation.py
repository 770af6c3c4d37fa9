"""The protocol comparison tool: overrides reach the scene it jams, bad ones are named,
failed jams are counted."""
import pytest

from forcespace.errors import InputError
from forcespace_studies.protocol_validation import one, parse_overrides, table


def test_overrides_are_parsed_as_numbers_and_a_bad_one_is_named():
    assert parse_overrides("solver.tolerance=1e-8, solver.max_sweeps=2000") == {
        "solver.tolerance": 1e-8, "solver.max_sweeps": 2000}
    assert parse_overrides("") == {}
    assert parse_overrides("scene.name=x") == {"scene.name": "x"}
    assert parse_overrides("box.periodic_x=false") == {"box.periodic_x": False}
    with pytest.raises(SystemExit, match="'solver.tolerance' is not key=value"):
        parse_overrides("solver.tolerance")


def test_a_protocol_jams_with_its_own_overrides(tmp_path):
    from forcespace_studies import size
    from forcespace_studies.common import shared_packing
    # the same seed under a 200-step budget cannot jam: the override is in the scene
    row = one("candidate", 40, 1, mu=1.0, overrides={"solver.tolerance": 1e-8},
              keep=tmp_path)
    assert row["mu"] == 1.0 and row["steps"] > 200 and 3.0 < row["z"] < 4.0
    # the kept packing is the size study's own jam of (n, mu, seed) under that protocol:
    # the study reuses it (its scene check passes) and it has the row's coordination
    _, _, over = size.scaled_geometry("paper_fast", 40)
    over["solver__tolerance"] = 1e-8
    p, t_jam = shared_packing(tmp_path, "paper_fast", 1.0, 1, 40, overrides=over)
    assert t_jam == 0.0 and p.coordination() == row["z"] and p.meta["steps"] == row["steps"]
    # measured again from the kept packing, not jammed: the same row, untimed; a protocol
    # whose scene differs from the kept packing's is refused by key
    again = one("candidate", 40, 1, mu=1.0, overrides={"solver.tolerance": 1e-8},
                keep=tmp_path)
    assert again == dict(row, cpu_s=None)
    with pytest.raises(InputError, match="solver.tolerance = 1e-08"):
        one("candidate", 40, 1, mu=1.0, overrides={"solver.tolerance": 1e-7}, keep=tmp_path)
    # a jam that fails is a row of its protocol (counted, listed), not the end of the run
    failed = one("candidate", 40, 1, mu=1.0, overrides={"jamming.max_steps": 200})
    assert "not jammed after jamming.max_steps = 200" in failed["error"]
    assert failed["cpu_s"] > 0 and "z" not in failed
    def other(r, f, **kw):                  # a second seed's row: its measures scaled
        keys = ("z", "phi", "rattler_fraction", "dim_s_per_nc", "cpu_s", "steps", "updates")
        return {**r, **{k: r[k] * f for k in keys}, **kw}
    text = table([row, other(row, 1.01, seed=2), other(row, 1.02, protocol="reference"),
                  other(row, 0.97, protocol="reference", seed=2), failed], [40])
    assert "| 40 (2+2 seeds) | z |" in text
    assert "- candidate n = 40 seed 1" in text and "max_steps = 200" in text
