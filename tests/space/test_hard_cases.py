"""Hard cases: extreme size and mass ratios, friction, force scales, degenerate geometry.

Each case either converges to its stated tolerance, checked against the exact LP
answer (S is non-empty for the packing's own forces), or ends with one clear
error. Measured numbers are in the issue note; the asserts are the contract.
"""

import numpy as np
import pytest

from forcespace.cli import main
from forcespace.errors import InputError, NumericalError
from forcespace.engine.protocol import build_packing
from forcespace.space.force_space import ForceSpace
from forcespace.model.scene import validate
import forcespace as fs
from forcespace.model.problem import full_problem, plate_problem, slice_problem

from paths import DATA  # noqa: E402

pytestmark = pytest.mark.hard


def scene(**kw):
    base = {"disks.n": 20, "box.width": 20.0, "solver.dt": 0.05}
    base.update(kw)
    return validate(base, "hard-case")


def jam_and_check(sc, tol=None):
    """Jam, then check the packing against the scene's tolerance and the exact S."""
    p = build_packing(sc, show_progress=False)
    tol = sc["jamming.static_tolerance"] if tol is None else tol
    assert p.equilibrium_residual() <= tol
    assert p.max_overlap() < 1e-5
    rat = p.rattlers()
    assert (~rat).sum() >= 1 and p.n_contacts >= 1
    prob = plate_problem(p) if np.isfinite(p.y_top) else full_problem(p)
    an = ForceSpace(ranges=False).compute(prob)
    assert an.feasible, an.infeasibility
    assert prob.violation(prob.x_jammed) <= 1e-8
    if np.isfinite(p.y_top):   # the plate is carried by the packing
        top = p.b == -2
        assert p.fn[top].sum() == pytest.approx(p.top_force, rel=1e-8)
    return p, an


def test_radius_ratio_1_to_20():
    p, _ = jam_and_check(scene(**{"disks.n": 24, "disks.radius_max": 20.0, "box.width": 50.0,
                                  "box.periodic_x": False}))
    assert p.r.max() / p.r.min() > 10


def test_mass_ratio_1e6_ends_with_an_explicit_report():
    # densities log-uniform over six decades: the light disks are 1e6 times lighter than
    # the heavy ones. Gauss-Seidel converges badly on such mass ratios and the light disks
    # keep jittering (mean speed ~3e-2 vs tolerance 2e-7 after 1e5 steps, measured): the
    # run must say so, naming what it reached, not return a packing that is not at rest
    sc = scene(**{"disks.density": 1e-6, "disks.density_ratio": 1e6,
                  "jamming.max_steps": 4000})
    with pytest.raises(NumericalError, match=r"not jammed after jamming.max_steps = 4000 "
                                             r"steps \(last mean speed over a window"):
        build_packing(sc, show_progress=False)


def test_mass_ratio_1e6_static_solve_converges():
    # masses only precondition the static solve: a groove whose supports are 1e6 times
    # heavier than the loaded disk gives the hand-derived forces to the solver tolerance
    from ensemble_cases import groove
    from forcespace.sampling.relax_walk import Relaxer
    th = np.pi / 6
    p, prob = groove(th, 0.3)
    prob.mass[:] = 1e-6 * prob.mass
    x, res, projected = Relaxer(prob).relax(np.zeros(prob.n_columns), tol=1e-12)
    assert res.converged and not projected and prob.violation(x) <= 1e-12


@pytest.mark.parametrize("mu", [1e-9, 1e3])
def test_extreme_friction(mu):
    p, an = jam_and_check(scene(**{"physics.mu": mu}))
    assert np.all(np.abs(p.ft) <= mu * p.fn * (1 + 1e-9) + 1e-12)


@pytest.mark.parametrize("seed", [6, 9])
def test_mu_1e_minus_9_full_problem_is_analysed_and_sampled(seed):
    """Coulomb cones 1e-9 wide: HiGHS' presolve called these S empty (seed 9) and
    the implicit-equality LP infeasible (seed 6), exit 3; the jammed network is in S
    to 1e-10 <Fn>, so S is non-empty and every LP that starts from a point of S is
    feasible."""
    p = build_packing(scene(**{"physics.mu": 1e-9, "scene.seed": seed}), show_progress=False)
    prob = full_problem(p)
    assert prob.violation(prob.x_jammed) < 1e-10
    an = ForceSpace().compute(prob)
    assert an.success and an.feasible and an.bounded and an.dim is not None
    assert prob.violation(an.centre) <= 1e-9
    ens = fs.HitAndRun(n=6, seed=1).compute(prob).ensemble
    assert ens.violations.max() <= 1e-9


def test_load_scale_1e_minus_12_and_1e12_give_the_same_packing():
    ref = build_packing(scene(**{"physics.mu": 0.3}), show_progress=False)
    ref_an = ForceSpace(ranges=False).compute(plate_problem(ref))
    for F in (1e-12, 1e12):
        p, an = jam_and_check(scene(**{"physics.mu": 0.3, "plates.top_force": F}))
        assert np.array_equal(p.x, ref.x) and np.array_equal(p.y, ref.y)
        assert np.array_equal(p.a, ref.a) and np.array_equal(p.b, ref.b)
        assert p.fn == pytest.approx(ref.fn * F, rel=1e-12, abs=1e-300)
        assert p.coordination() == ref.coordination()
        assert an.dim == ref_an.dim


def test_gaps_of_1e_minus_14_are_contacts_of_the_packing():
    from forcespace.engine.contacts import detect_contacts
    from forcespace.engine.records import Box
    r = np.array([1.0, 1.0])
    x = np.array([5.0, 5.0 + 2.0 + 1e-14, 0, 0, 0, 0])
    y = np.array([1.0, 1.0, 0.0, 0, 0, 0])
    ints, floats = detect_contacts(x, y, r, Box(20.0, False, True, False, False), 1e-6)
    pairs = {tuple(row[:2]) for row in ints}
    assert (0, 1) in pairs
    gap = floats[[tuple(row[:2]) for row in ints].index((0, 1)), 2]
    assert abs(gap) < 1e-13


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_gravity_column_of_60_disks_comes_to_rest(mu):
    # 60 disks in a walled channel 10 R wide (about 12 disks high). Force relaxes
    # diffusively through the column: with the default sweep cap (1000) truncated sweeps
    # leave it creeping (mean speed 2e-6 vs tolerance 1.2e-7 after 4e5 steps, measured);
    # with a cap that lets each step converge it rests within a few hundred steps
    sc = validate({"disks.n": 60, "disks.radius_min": 1.0, "disks.radius_max": 2.0,
                   "box.width": 10.0, "box.periodic_x": False, "physics.gravity": 1.0,
                   "plates.top": "none", "physics.mu": mu, "physics.plate_mu": mu,
                   "solver.dt": 0.1, "solver.max_sweeps": 20000, "solver.tolerance": 1e-9,
                   "box.initial_packing_fraction": 0.5}, "column")
    p, _ = jam_and_check(sc)
    assert (~p.rattlers()).all()                  # under gravity every disk carries load
    W = p.mass.sum() * sc["physics.gravity"]
    bottom = p.a == -1
    # the floor carries the column's weight, less what frictional side walls hold
    if mu == 0:
        assert p.fn[bottom].sum() == pytest.approx(W, rel=1e-8)
    else:
        side = (p.a == -3) | (p.b == -4)
        held = p.fn[bottom].sum() + (p.ft[side] * np.where(p.a[side] == -3, 1, -1)).sum()
        assert abs(held) == pytest.approx(W, rel=1e-8)


def test_wedged_geometry_is_unbounded_and_refused_for_sampling(tmp_path):
    from ensemble_cases import groove
    th = np.pi / 5
    p, prob = groove(th, 1.2 / np.tan(th))        # mu > cot(theta): self-locking
    an = ForceSpace(ranges=False).compute(prob)
    assert an.feasible and an.bounded is False
    with pytest.raises(InputError, match="unbounded"):
        from forcespace.sampling.hit_and_run import HitAndRun
        HitAndRun(5).compute(prob, output=tmp_path / "h.h5").summary()


def test_slice_without_interior_contacts_is_one_clear_error(tmp_path, capsys):
    from forcespace.io.packing_file import write_packing
    p = build_packing(scene(), show_progress=False)
    write_packing(p, tmp_path / "p.h5")
    assert main(["analyze", str(tmp_path / "p.h5"), "--slice", "0.01"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and ("no unknown contact" in err[0] or "no non-rattler" in err[0])


@pytest.mark.parametrize("n", [2, 3])
def test_two_and_three_disks(n):
    p, an = jam_and_check(scene(**{"disks.n": n, "box.width": 8.5}))
    assert p.n_disks == n


def test_periodic_box_narrower_than_the_minimum_image_limit_is_refused():
    with pytest.raises(InputError, match="minimum-image"):
        scene(**{"box.width": 5.0})                 # 2 r_max < width < 4 r_max + 2 margin
    jam_and_check(scene(**{"disks.n": 6, "box.width": 8.2}))   # the narrowest allowed


def test_projection_on_a_slice_with_near_dependent_equilibrium_rows():
    """A relax-walk stall on a 100-disk mu = 1 slice (paper_fast scaled, seed 2) whose 165
    equilibrium rows on 152 columns have rank 151 up to one singular value at round-off
    level: the full-space KKT check could not decide the rank and refused the projection
    (the size study lost the packing). The null-space LDP point is verified in its own
    coordinates: it is admissible, and no admissible network sampled from S (dim 2) nor
    the Chebyshev centre is closer."""
    import forcespace as fs
    from forcespace.space.questions import chebyshev_centre
    from forcespace.space.projection import distance_to_S

    p = fs.read_packing(DATA / "paper_fast_n100_mu1_seed2.h5")
    prob = fs.slice_problem(p, 28.0 * np.sqrt(100 / 200))     # the scaled slice
    x = np.load(DATA / "paper_fast_n100_mu1_seed2_stall.npy")
    assert prob.violation(x) > 1e-2                      # the stalled state is outside S
    r = distance_to_S(prob, x)
    assert r.max_violation <= 1e-9 and r.kkt_residual <= 1e-9
    assert distance_to_S(prob, r.nearest).absolute <= 1e-9 * prob.force_scale
    others = fs.HitAndRun(n=100, seed=3).compute(prob).ensemble.samples
    others = np.vstack([others, chebyshev_centre(prob)[0]])
    assert np.linalg.norm(others - x, axis=1).min() >= r.absolute * (1 - 1e-9)


def test_a_chebyshev_lp_that_highs_cannot_settle_is_solved_in_the_hull():
    """Size study, n = 400, mu = 1, seed 2 (slice 39.6 R, dim S 2): every HiGHS attempt at
    the full-space Chebyshev-centre LP ended with model status Unknown; in the affine
    hull's own coordinates (3 unknowns) it is solved, and both uniform samplers start."""
    prob = slice_problem(fs.read_packing(DATA / "paper_fast_n400_mu1_s2.h5"),
                         39.59797974644666)
    an = ForceSpace().compute(prob)
    assert an.success and an.dim == 2
    assert an.radius > 1e-3 * prob.force_scale and prob.violation(an.centre) <= 1e-9
    eta = [fs.BilliardWalk(20000, seed=2, target_ess=100).compute(prob, analysis=an).eta,
           fs.HitAndRun(3000, seed=2, chains=4, target_ess=100).compute(prob,
                                                                       analysis=an).eta]
    assert eta[0] == pytest.approx(eta[1], rel=0.1)


def _rectangle_centred_outside():
    """(problem, analysis, the analysis with its centre at a vertex of S pushed 1e-10 <Fn>
    outside): the two-groove rectangle (S a product of two intervals)."""
    from types import SimpleNamespace

    from ensemble_cases import grooves
    from forcespace.space.loads import extreme_point
    _, prob = grooves([np.pi / 6, np.pi / 5], 0.3)
    an = ForceSpace().compute(prob)
    vertex = extreme_point(prob, an.affine_basis @ np.array([1.0, 0.7]))
    G, _, _ = prob.inequalities()
    out = vertex + 1e-10 * prob.force_scale * np.asarray(G[int(np.argmax(G @ vertex))]
                                                         .todense()).ravel()
    fake = SimpleNamespace(**{k: getattr(an, k) for k in (
        "success", "feasible", "bounded", "implicit_rows", "affine_basis", "affine_point")},
        centre=out, message="")
    return prob, an, fake


@pytest.mark.parametrize("jitter_seed", [None, 6])
def test_an_mve_round_whose_centre_drifts_onto_a_facet_is_redone_by_john(jitter_seed):
    """Size study, n = 400, mu = 0.01, seed 3 (slice 39.6 R, dim S 189, 916 rows): the
    MVE interior point stopped unconverged after 119 iterations with its centre on a
    facet (slack -3e-19), and hit-and-run's next round refused that start. The round is
    rejected, the rounding is John's, and the walk starts strictly inside. The slack's
    sign is round-off: with 2 BLAS threads on another machine it came out +3e-19, the
    round was accepted and the next one's ellipsoid was indefinite; ``jitter_seed``
    multiplies the rows by 1 + 1e-15 N(0, 1), which flips it here too (before the
    clearance check, one BLAS thread: slack +3e-19, then "MVE rounding: ellipsoid not
    positive definite"; two threads: that round accepted, no John fallback)."""
    from forcespace.sampling import hit_and_run as har
    from forcespace.sampling.frame import frame as frame_of
    prob = slice_problem(fs.read_packing(DATA / "paper_fast_n400_mu0.01_s3.h5"),
                         39.59797974644666)
    f = frame_of(prob)
    assert f.H0.shape == (916, 189) and har.rounding_method(916) == "mve"
    H0 = f.H0
    if jitter_seed is not None:
        H0 = H0 * (1 + 1e-15 * np.random.default_rng(jitter_seed).standard_normal(H0.shape))
    y0, L, info = har.rounding(H0, f.s0, prob.force_scale)
    assert info["fallback_from"]["rejected_round"] == 1 and info["method"] == "john"
    assert info["fallback_from"]["rejected_clearance"] < 1e-6
    assert (f.s0 - prob.force_scale * f.H0 @ y0).min() > 1e-3 * f.s0.min()
    assert info["axis_ratio"][-1] < 6 and all(info["converged"])


def test_a_centre_a_round_off_outside_a_facet_is_recentred_in_the_frame():
    """Size study, n = 800, mu = 1: the Chebyshev centre, projected onto the affine hull,
    lay 1e-10 <Fn> outside a facet and the billiard walk's rounding refused it. Here the
    centre handed to the frame is a vertex of the two-groove rectangle pushed 1e-10 <Fn>
    outside: the frame recentres in its own coordinates, at the rectangle's centre line
    (slack half the shorter side on the two nearest facets), and the walk starts."""
    from forcespace.sampling.frame import frame
    prob, an, fake = _rectangle_centred_outside()
    f = frame(prob, fake)
    assert f.s0.min() > 0 and prob.violation(f.xc) <= 1e-12 and f.widening == 0
    assert (f.s0 / np.linalg.norm(f.H0, axis=1)).min() == pytest.approx(an.radius, rel=1e-6)
    b = fs.BilliardWalk(2000, seed=1, target_ess=100).compute(prob, analysis=fake)
    assert b.success and b.ensemble.violations.max() <= 1e-9


def _missing_centre(miss):
    """A stand-in for space.lp.inner_ball whose centre lies ``miss`` <Fn> outside a facet
    of {H y <= s} (at a vertex, pushed out along one of its rows): HiGHS' answer on a
    polytope thinner than its tolerances."""
    from scipy.optimize import linprog

    def inner_ball(H, s, r_max):
        v = linprog(-np.ones(H.shape[1]), A_ub=H, b_ub=s, bounds=[(None, None)] * H.shape[1],
                    method="highs").x
        i = int(np.argmax(H @ v - s))
        return v + miss * r_max * H[i] / (H[i] @ H[i]), 1e-3 * r_max
    return inner_ball


def test_a_frame_whose_centre_misses_a_thin_S_is_widened_by_the_miss(monkeypatch, tmp_path):
    """Size study, n = 5000, mu = 1, seed 4: S (dim 38 of 3799 contacts) is ~1e-8 <Fn>
    thick in one direction and ~1 <Fn> wide in the others; with its implicit rows held
    exactly no point of the hull is strictly inside, HiGHS' Chebyshev centre in the frame
    missed a row by 1.6e-8 <Fn>, and the billiard walk refused to start (the task
    failed). Here that miss (2e-8 <Fn>) is put on the two-groove rectangle: the frame
    moves every free row out by the miss plus FRAME_MARGIN, the walks start inside the
    widened frame, every sample lies within the widening of S, and both samplers give
    the eta of the run without the miss."""
    from forcespace import config
    from forcespace.sampling import frame as frame_module
    prob, _, an = _rectangle_centred_outside()
    exact = fs.HitAndRun(4000, seed=1, target_ess=200).compute(prob).ensemble.eta
    monkeypatch.setattr(frame_module, "inner_ball", _missing_centre(2e-8))
    f = frame_module.frame(prob, an)
    assert f.widening == pytest.approx(2e-8 + config.FRAME_MARGIN, rel=1e-6)
    assert f.s0.min() == pytest.approx(config.FRAME_MARGIN * prob.force_scale, rel=1e-6)
    assert prob.violation(f.xc) == pytest.approx(2e-8, rel=1e-3)
    runs = [fs.BilliardWalk(4000, seed=2, target_ess=200),
            fs.HitAndRun(4000, seed=3, target_ess=200)]
    for k, r in enumerate(runs):
        r.compute(prob, output=tmp_path / f"{k}.h5", analysis=an)
        assert r.success and r.frame_widening == f.widening
        assert r.ensemble.violations.max() <= f.widening + config.SAMPLE_VIOLATION
        assert f"widening {f.widening:.3g} <Fn>" in \
            fs.read_ensemble(tmp_path / f"{k}.h5").summary()["tolerance"]
        assert r.ensemble.eta == pytest.approx(exact, rel=0.1)


def test_a_frame_whose_centre_lp_has_no_optimum_starts_from_the_analysis_centre(monkeypatch):
    """Size study, n = 2000, mu = 1, seed 10 (dim S 19): every HiGHS attempt at the
    frame's Chebyshev-centre LP ended without an optimum and the billiard task failed.
    The frame now keeps the analysis' centre (here 1.1e-10 <Fn> outside a facet, 2e-11 in
    the hull) and widens by its miss: the start has exactly FRAME_MARGIN of slack."""
    from forcespace import config
    from forcespace.sampling import frame as frame_module
    prob, _, an = _rectangle_centred_outside()
    monkeypatch.setattr(frame_module, "inner_ball", lambda H, s, r_max: None)
    f = frame_module.frame(prob, an)
    miss = prob.violation(an.centre)
    assert 1e-10 < miss < 2e-10
    # the frame's miss is the centre's, projected onto the hull: no larger, not zero
    assert 0 < f.widening - config.FRAME_MARGIN <= miss
    assert 0 < prob.violation(f.xc) <= f.widening
    assert f.s0.min() == pytest.approx(config.FRAME_MARGIN * prob.force_scale, rel=1e-6)


def test_a_frame_missing_S_by_more_than_round_off_is_refused(monkeypatch):
    """A miss beyond FRAME_MAX_WIDENING is not round-off: the frame refuses, naming the
    row and the miss, before any sampling."""
    from forcespace.sampling import frame as frame_module
    prob, _, an = _rectangle_centred_outside()
    monkeypatch.setattr(frame_module, "inner_ball", _missing_centre(1e-6))
    with pytest.raises(NumericalError, match=r"misses inequality row \d+ by 1e-06 <Fn>"):
        fs.BilliardWalk(100, seed=2).compute(prob, analysis=an)


def test_a_near_mechanism_counted_as_null_does_not_fail_the_relax_walk():
    # The slice of this mu = 10 packing (fig1, seed 5; dim S = 1) has an equality
    # singular value of 5.5e-9 sigma_max: far below the rank cut, five decades below the
    # smallest one kept, so the analysis counts it as null, and S's one direction is
    # that near-mechanism. A point moved along it by y misses equilibrium by up to
    # 5.5e-9 |y|: the relax walk's exact projection of a stalled sample missed by
    # 1.8e-9 <Fn> and was refused against the flat 1e-9 (the fig1 run lost this walk).
    # Verified against the floor the null directions leave (as the billiard walk's),
    # the walk runs, and every sample stays within a few 1e-9 <Fn> of equilibrium.
    import scipy.linalg as sla
    from forcespace import config
    from forcespace.space.projection import eq_system
    prob = slice_problem(fs.read_packing(DATA / "paper_mu10_seed5.h5"), 28.0)
    C = eq_system(prob)[0].toarray()
    s = sla.svdvals(C)
    kept = s > config.RANK_TOL * s.max() * max(C.shape)     # linalg.rank's rule
    assert s[~kept].max() > 1e-9 * s.max() and s[kept].min() > 1e-4 * s.max()
    walk = fs.RelaxWalk(n=50, seed=5, chains=4)
    ens = walk.compute(prob).ensemble
    assert ens.n_samples == 50 and walk.projected.size > 0
    assert ens.violations.max() <= 5e-9
    assert np.ptp(ens.samples, axis=0).max() > 1e-3     # the walk moves along S
