"""studies/accuracy_vs_time.py's measuring functions on a 20-disk engine packing (mu = 0.1).

Distances are to the plate S, rms per contact in units of <Fn>.
"""
import sys

import pytest

from paths import QUICK, ROOT

sys.path.insert(0, str(ROOT / "studies"))
import accuracy_vs_time as avt  # noqa: E402


@pytest.fixture(scope="module")
def case():
    from forcespace.engine.protocol import build_packing
    from forcespace.model.scene import load_scene
    from forcespace.model.problem import plate_problem
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 20, "physics.mu": 0.1})
    p = build_packing(scene, show_progress=False)
    return p, plate_problem(p)


def test_static_solve_approaches_S_as_the_sweep_cap_grows(case):
    p, S = case
    rows = avt.static_curve(p, S, (30, 300, 3000, 1_000_000))
    d = [r["distance"] for r in rows]
    assert d[0] > 1e-2                                   # cold start: far from S
    assert all(b < a for a, b in zip(d, d[1:]))          # measured 0.36, 0.054, 2.6e-3, 1.8e-13
    last = rows[-1]
    assert last["sweeps"] < last["cap"] and last["residual"] <= 1e-13   # converged
    assert last["distance"] < 1e-6


def test_pymunk_more_iterations_not_farther_from_S(case):
    p, S = case
    one, many = (avt.pymunk_curve(p, S, it, 0.01, 600, 3) for it in (1, 30))
    assert many["points"][-1]["distance"] <= one["points"][-1]["distance"]
    assert many["points"][-1]["distance"] < 1e-3         # measured 1.4e-5 (1 it: 8e-2)
    t = [r["seconds"] for r in many["points"]]
    assert t == sorted(t) and t[0] > 0


def test_cost_table_takes_the_first_time_within_reach():
    curves = {"a": [("x", [{"seconds": 1.0, "distance": 0.5},
                           {"seconds": 2.0, "distance": 1e-3}]),
                    ("y", [{"seconds": 1.5, "distance": 1e-3}])],
              "b": [("z", [{"seconds": 1.0, "distance": float("nan")}])]}
    t = avt.cost_table(curves, levels=(1.0, 1e-2, 1e-6))
    assert t["a"] == {"1": [1.0, "x"], "0.01": [1.5, "y"], "1e-06": None}
    assert t["b"] == {"1": None, "0.01": None, "1e-06": None}


def test_the_engine_bench_times_nlgs_and_pymunk_on_the_same_contacts(case):
    """bench_engine's per-update rates divide by the contacts each solver sweeps: NLGS
    those of the packing, pymunk those it detects itself (the same network up to tiny
    gaps); timings only, no order asserted (a loaded machine can reorder them)."""
    from forcespace_studies.bench_engine import new_timer, pymunk_timer, statics_arrays
    p, _ = case
    d = statics_arrays(p, 0.1)
    assert d["a"].size == p.n_contacts and d["mu"].size == p.n_contacts
    assert new_timer(d, 5, 0)() > 0
    t_it, t_one, n_pym = pymunk_timer(p, 0.1)()
    assert abs(n_pym - p.n_contacts) <= 0.2 * p.n_contacts and t_it > 0 and t_one > 0
