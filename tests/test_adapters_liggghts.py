"""LIGGGHTS adapter with the real binary on a small hand-built packing."""
import shutil

import numpy as np
import pytest

from forcespace_adapters import liggghts as L
from forcespace_adapters.distance import compare, make_problem
from forcespace_adapters.problem import soft_problem
from forcespace_adapters.toy import two_row_packing

pytestmark = pytest.mark.skipif(shutil.which("liggghts") is None,
                                reason="LIGGGHTS binary missing (apt-get install liggghts)")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    p = two_row_packing(4, mu=0.1)
    prob = soft_problem(p, top="loads")
    out = {}
    for K in (1e2, 1e3):
        d = tmp_path_factory.mktemp(f"k{K:g}")
        L.write_deck(prob, d / "deck", L.LiggghtsOptions(kn=K * prob.force_scale))
        st = L.run_deck(d / "deck")
        soft, info = L.read_result(d / "deck", p)
        out[K] = (st, soft, info)
    return p, prob, out


def test_exported_problem_balances():
    p = two_row_packing(4, mu=0.1)
    assert soft_problem(p, top="loads").rigid_residual() < 1e-12


def test_readback_in_equilibrium_to_tolerance(runs):
    p, prob, out = runs
    for K, (st, soft, info) in out.items():
        assert st["converged"]
        # per-disk residual below the run's tolerance (relative to <Fn>)
        assert info["max_residual_force"] <= info["tolerance_abs"]
        assert soft.equilibrium_residual() < 1e-6


def test_overlap_scales_and_distance_small(runs):
    p, prob, out = runs
    ov = {K: v[1].max_overlap() for K, v in out.items()}
    assert ov[1e3] == pytest.approx(ov[1e2] / 10, rel=0.05)
    S = make_problem(p, "loads")
    for K, (st, soft, info) in out.items():
        c = compare(p, soft, S)
        assert c["unmatched_contacts"] == 0 and c["lost_contacts"] == 0
        assert c["relative_distance"] < 1e-6


def test_refuses_frictional_loads_and_missing_binary(tmp_path):
    p = two_row_packing(3, mu=0.1)
    p.ft[p.b == -2] = 0.05                     # frictional top-plate force
    with pytest.raises(Exception, match="torque"):
        L.write_deck(soft_problem(p, top="loads"), tmp_path / "d")
    with pytest.raises(L.LiggghtsError, match="apt-get install liggghts"):
        L.find_binary("no-such-liggghts-binary")
