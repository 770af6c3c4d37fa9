"""S of real (engine-built) packings, the projection polish regression, MVE rounding."""
import numpy as np

from forcespace import config
import pytest

from ensemble_cases import grooves, lattice_rows
from forcespace.io.ensemble_file import read_file
from forcespace.sampling.diagnostics import read_ensemble
from forcespace.sampling.hit_and_run import HitAndRun
from forcespace.sampling.relax_walk import RelaxWalk
from forcespace.measures import eta
from forcespace.space.projection import Projector, _polish, distance_to_S
from forcespace.space.force_space import ForceSpace
from forcespace.sampling.rounding import mve
from forcespace.model.problem import full_problem, plate_problem, slice_problem


@pytest.fixture(scope="module")
def quick_packing():
    from forcespace.engine.protocol import build_packing
    from forcespace.model.scene import load_scene
    scene = load_scene("quick")
    return build_packing(scene.with_overrides(**{"disks.n": 20}), show_progress=False)


def test_polish_with_an_empty_active_set_does_not_fail():
    _, prob = grooves([np.pi / 6, np.pi / 5], 0.3)
    an = ForceSpace(ranges=True).compute(prob)
    x = an.centre                                   # interior: nothing active
    xn, kkt, ok = _polish(prob, x, x, active=[])
    assert ok and kkt <= 1e-9 and np.linalg.norm(xn - x) < 1e-12 * prob.force_scale
    # a start whose active set is wrong must not raise either
    _polish(prob, x + 0.3 * prob.force_scale, x, active=[])


@pytest.mark.parametrize("pert", [0.0, 1e-6, 1e-2])
def test_projection_on_the_plate_balance_problem(quick_packing, pert):
    prob = plate_problem(quick_packing)
    rng = np.random.default_rng(1)
    x = prob.x_jammed + pert * prob.force_scale * rng.normal(size=prob.n_columns)
    d = distance_to_S(prob, x)
    assert d.kkt_residual <= 1e-9 and d.max_violation <= 1e-9
    # no farther than the jammed network (which is in S up to round-off)
    bound = np.linalg.norm(x - prob.x_jammed) / (prob.force_scale * np.sqrt(prob.n_contacts))
    assert d.relative <= bound + 1e-8


def test_one_projector_gives_every_point_its_own_verified_projection():
    # the relax walk projects all stalled samples of a slice with one Projector: its
    # frame, computed once, must carry nothing from one point to the next (the same bits
    # as a fresh projection, in another order), and each answer is the projection: in S,
    # no farther than the Chebyshev centre (a point of S), the centre itself fixed
    from forcespace.io.packing_file import read_packing
    from paths import DATA
    prob = slice_problem(read_packing(DATA / "paper_mu10_seed3.h5"), 28.0)    # dim S 3
    an = ForceSpace().compute(prob)
    rng = np.random.default_rng(3)
    xs = [an.centre + a * prob.force_scale * rng.uniform(-1, 1, prob.n_columns)
          for a in (0.3, 0.0, 3.0)]
    proj = Projector(prob)
    mine = [proj(x) for x in xs]
    fresh = [distance_to_S(prob, x) for x in reversed(xs)][::-1]
    for x, a, b in zip(xs, mine, fresh):
        np.testing.assert_array_equal(a.nearest, b.nearest)
        assert a.max_violation <= 1e-9 and a.kkt_residual <= 1e-9
        assert a.absolute <= np.linalg.norm(x - an.centre) + 1e-9 * prob.force_scale
    assert 0 < mine[0].absolute < mine[2].absolute
    np.testing.assert_allclose(mine[1].nearest, an.centre, atol=1e-9 * prob.force_scale)


def test_frictionless_jammed_packing_is_determinate(quick_packing, tmp_path):
    """dim S = 0 for the slice and the full packing; relax eta at the solver floor."""
    for prob in (slice_problem(quick_packing, 10.0), full_problem(quick_packing)):
        an = ForceSpace(ranges=False).compute(prob)
        assert an.feasible and an.bounded
        assert an.dim == 0, prob.kind
        # isostatic: the equilibrium equations fix every unknown, S is one point
        assert an.degree_of_indeterminacy == 0 and an.rank_A == an.n_unknowns
        assert an.radius == 0.0
        assert np.linalg.norm(an.centre - prob.x_jammed) <= 1e-8 * prob.force_scale * \
            np.sqrt(prob.n_contacts)
    prob = slice_problem(quick_packing, 10.0)
    out = tmp_path / "r.h5"
    res = RelaxWalk(20, seed=0, tol=1e-9).compute(prob, output=out).summary()
    assert res["max_violation"] <= 1e-9
    assert eta(read_ensemble(out).samples) <= 1e-8


def test_mve_of_a_box_and_of_a_triangle():
    a = np.array([1.0, 1e-3, 30.0])
    H = np.vstack([np.eye(3), -np.eye(3)])
    s = np.concatenate([a, a])
    c, E2, ok, _ = mve(H, s, np.array([0.5, 0.0, -10.0]))
    assert ok
    assert np.allclose(c, 0, atol=1e-6 * a)
    assert np.allclose(np.sqrt(np.linalg.eigvalsh(E2)), np.sort(a), rtol=1e-5)
    # equilateral triangle: the MVE is the incircle (radius 1 about the origin)
    ang = np.pi / 2 + 2 * np.pi * np.arange(3) / 3
    H = np.c_[np.cos(ang), np.sin(ang)]
    c, E2, ok, _ = mve(H, np.ones(3), np.array([0.2, -0.1]))
    assert ok and np.allclose(c, 0, atol=1e-6) and np.allclose(E2, np.eye(2), atol=1e-5)


def test_hit_and_run_mixes_on_a_17_dimensional_S(tmp_path):
    _, prob = lattice_rows(4, 2, 0.5)
    res = HitAndRun(200, seed=3).compute(prob, output=tmp_path / "h.h5").summary()
    assert res["dim_S"] == 17 and res["max_violation"] <= config.SAMPLE_VIOLATION
    assert res["rhat_sqdev"] < 1.1 and res["rhat_projections_max"] < 1.1
    assert res["ess_projections_min"] > 50
    assert read_file(tmp_path / "h.h5").setup["mve_axis_ratio"][-1] < 6


@pytest.mark.parametrize("name,height", [("paper_mu1_seed2.h5", 28.0),
                                         ("paper_mu10_seed3.h5", 28.0)])
def test_varying_contacts_by_few_lps_match_the_full_range_table(name, height, monkeypatch):
    # the varying mask decided with LPs only where no known point of S already shows a
    # spread above VARY_TOL must equal the one from min and max of every force; the
    # widths returned are exact where the contact's own LPs ran, lower bounds above the
    # tolerance elsewhere
    from forcespace.io.packing_file import read_packing
    from forcespace.space import questions as Q
    from forcespace.space.lp import unit_problem
    from paths import DATA
    prob = slice_problem(read_packing(DATA / name), height)
    full = ForceSpace(ranges=True).compute(prob)
    calls = []
    real = Q.solve_lp
    monkeypatch.setattr(Q, "solve_lp", lambda *a, **k: calls.append(1) or real(*a, **k))
    fast = ForceSpace().compute(prob)
    assert fast.success and full.success
    np.testing.assert_array_equal(fast.varying, full.varying)
    P, s = unit_problem(prob)
    every = np.arange(P.n_contacts)
    exact = np.maximum(np.ptp(full.fn_range, axis=1), np.ptp(full.ft_range, axis=1)) / s
    # in 2m unknowns from the centre, and in the affine hull's d coordinates (the LPs of
    # analyses with dim S <= REDUCED_LP_MAX_DIM) from the affine point and the centre
    for points, hull in (((full.centre / s,), None),
                         ((full.affine_point / s, full.centre / s), full.affine_basis)):
        calls.clear()
        w = Q.lp_widths(P, every, config.VARY_TOL, points=points, hull=hull)
        assert len(calls) < 4 * P.n_contacts              # fewer than the full table
        ran = w <= config.VARY_TOL
        # a trusted point misses S by <= TRUSTED_POINT * VARY_TOL and moved constant
        # contacts by about as much (1.06e-8 at mu = 10): widths agree to 10x that,
        # decisions exactly
        slack = 10 * config.TRUSTED_POINT * config.VARY_TOL
        np.testing.assert_allclose(w[ran], exact[ran], atol=slack)
        assert np.all(exact[~ran] >= w[~ran] - slack) and np.all(w[~ran] > config.VARY_TOL)
        np.testing.assert_array_equal(w > config.VARY_TOL, exact > config.VARY_TOL)


def test_an_analysis_without_the_varying_test_gives_the_same_frame():
    """ForceSpace(varying=False) (the samplers' frame) skips the per-contact LPs: the same
    dimension, hull and centre, ``varying`` refused, the summary without domains."""
    from paths import PACKINGS
    from forcespace.io.packing_file import read_packing
    from forcespace.sampling.frame import frame
    prob = slice_problem(read_packing(PACKINGS / "paper_mu0.1.h5"), 28.0)
    full, lean = ForceSpace().compute(prob), ForceSpace(varying=False).compute(prob)
    assert lean.success and lean.dim == full.dim == 48
    np.testing.assert_array_equal(lean.affine_basis, full.affine_basis)
    np.testing.assert_array_equal(lean.centre, full.centre)
    with pytest.raises(AttributeError, match="varying=False"):
        lean.varying
    assert "n_domains" not in lean.summary() and full.summary()["n_domains"] > 0
    a, b = frame(prob), frame(prob, full)
    for x, y in zip(a[:5], b[:5]):
        np.testing.assert_array_equal(x, y)
