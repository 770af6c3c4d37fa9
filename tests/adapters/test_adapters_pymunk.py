"""pymunk adapter (real pymunk) on small packings."""
import numpy as np
import pytest

from forcespace_adapters.distance import compare, make_problem
from forcespace_adapters.problem import soft_problem
from forcespace_adapters.pymunk_sim import PymunkOptions, PymunkScene, simulate
from cases import two_row_packing
from paths import QUICK


def test_dead_loads_match_closed_form():
    p = two_row_packing(4, mu=0.1)
    prob = soft_problem(p, top="loads")
    assert prob.rigid_residual() < 1e-12
    soft, info = simulate(prob, PymunkOptions(max_steps=5000))
    assert info["converged"]
    c = compare(p, soft, make_problem(p, "loads"))
    assert c["unmatched_contacts"] == 0 and c["lost_contacts"] == 0
    assert c["relative_distance"] < 1e-6          # measured 1.2e-7


def test_plate_and_periodic_twin():
    p = two_row_packing(4, mu=0.1)
    sc = PymunkScene(soft_problem(p, top="plate"), PymunkOptions(max_steps=5000))
    assert sc.twins                            # the disk at x = 0 has a twin
    info = sc.run()
    assert info["converged"]
    soft = sc.soft_packing(info)
    # one cross-boundary contact per period, seen exactly once
    assert (soft.image != 0).sum() == (p.image != 0).sum()
    top = soft.b == -2
    assert soft.fn[top].sum() == pytest.approx(p.top_force, rel=3e-7)   # measured 2.1e-8
    assert soft.equilibrium_residual() < 2e-6                          # measured 1.8e-7


def test_slice_has_frictional_loads():
    p = two_row_packing(4, mu=0.1)
    prob = soft_problem(p, y_range=(0.5, 1.5))
    assert prob.rigid_residual() < 1e-12
    soft, info = simulate(prob, PymunkOptions(max_steps=3000))
    assert info["converged"]


@pytest.fixture(scope="module")
def engine_packing():
    from forcespace.engine.protocol import build_packing
    from forcespace.model.scene import load_scene
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 20, "physics.mu": 0.1})
    return build_packing(scene, show_progress=False)


def test_engine_packing_plate_distance(engine_packing):
    p = engine_packing
    prob = soft_problem(p)                          # load-controlled plate, rattlers out
    assert prob.rigid_residual() < 1e-9
    soft, info = simulate(prob, PymunkOptions(max_steps=20000))
    assert info["converged"]
    force, torque, plate = soft.net_forces()
    assert np.abs(force).max() / prob.force_scale < 3e-6   # measured 2.5e-7
    assert abs(plate) / prob.force_scale < 2e-6            # measured 1.7e-7
    c = compare(p, soft, make_problem(p, "plate"))
    assert c["unmatched_contacts"] == 0
    assert c["relative_distance"] < 2e-4                   # measured 1.4e-5
