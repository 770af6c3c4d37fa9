"""The billiard walk (sampling/billiard.py): exact uniformity on polytopes with known
distributions at dim >= 100, agreement with hit-and-run on a real slice, the target-ESS
stop, resume.

Uniformity: samples of the walk (through the rounding, as BilliardWalk runs it) are
compared with the exact law by Kolmogorov-Smirnov tests: coordinate marginals against
their exact CDFs, and two statistics with no closed form (|x - centre|^2 and a random
projection) against a large exact sample of the same polytope (two-sample KS). The
walk's samples are autocorrelated, so each statistic is thinned to its own ArviZ bulk
ESS before the test (every k-th draw, k = draws / ESS): the KS p-values then have
their nominal meaning. Each test must keep p > P_MIN; the same tests reject a walk
whose reflection is off by 5 % (coefficient 1.9 instead of 2 in the kernel: the
simplex, box, cross-polytope and product tests all fail; checked when they were
ported). The agreement with hit-and-run on the paper slice does not see that 5 %.
"""
import warnings

import numpy as np
import pytest
from scipy import stats

from ensemble_cases import grooves
from forcespace import config
from forcespace.io.ensemble_file import read_file
from forcespace.sampling.diagnostics import read_ensemble
from forcespace.measures import eta
from forcespace.sampling import billiard as bw
from forcespace.sampling.billiard import BilliardWalk
from forcespace.sampling.diagnostics import by_chain
from forcespace.sampling.hit_and_run import HitAndRun
from forcespace.sampling.rounding import lewis_rounding
from forcespace.streams import chain_states as seed_states

P_MIN = 1e-3


def _ess(v):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import arviz
        return float(arviz.ess(v, method="bulk"))


def _thinning(v):
    """Draws per effective sample of v (chains, draws): ceil(size / bulk ESS)."""
    return max(1, int(np.ceil(v.size / max(_ess(v), 1.0))))


def _ess_thinned(v):
    """v (chains, draws) -> pooled draws thinned to about one per effective sample."""
    return v[:, ::_thinning(v)].ravel()


def _walk(H, s, y0, n, seed, **kw):
    """Round {H y <= s}, walk, map back: samples (chains, n, d) in y, all inside."""
    Y, walk, _ = bw.walk_polytope(H, s, y0, n, seed=seed, **kw)
    assert walk.counts[:, bw.DISCARDED].sum() == 0 or "max_refl" in kw
    assert (Y.reshape(-1, H.shape[1]) @ H.T - s).max() <= 1e-9
    return Y, walk


def _ks_exact(v, cdf):
    return stats.kstest(_ess_thinned(v), cdf).pvalue


def _ks_two(v, ref):
    return stats.ks_2samp(_ess_thinned(v), ref).pvalue


def _simplex(d):
    """{y >= 0, sum y <= 1}"""
    return np.vstack([-np.eye(d), np.ones((1, d))]), np.r_[np.zeros(d), 1.0]


def _simplex_exact(d, n, rng):
    e = rng.exponential(size=(n, d + 1))
    return (e / e.sum(1, keepdims=True))[:, :d]


def _box(a):
    """{0 <= y_i <= a_i}"""
    d = len(a)
    return np.vstack([-np.eye(d), np.eye(d)]), np.r_[np.zeros(d), a]


def _check_statistics(Y, exact, centre, seed):
    """Two-sample KS of |y - centre|^2 and of a random projection against exact samples."""
    r = np.random.default_rng(seed).normal(size=Y.shape[2])
    return {"sqdist": _ks_two(((Y - centre) ** 2).sum(2), ((exact - centre) ** 2).sum(1)),
            "projection": _ks_two(Y @ r, exact @ r)}


def test_simplex_marginals_are_beta_1_d():
    """Simplex, d = 100: y_i ~ Beta(1, d); sum y ~ Beta(d, 1) (the volume law near the
    long facet, which a walk that under-samples corners gets wrong)."""
    d = 100
    H, s = _simplex(d)
    Y, _ = _walk(H, s, np.full(d, 0.5 / d), 1000, seed=1)
    ps = {f"y{i}": _ks_exact(Y[:, :, i], stats.beta(1, d).cdf) for i in (0, 37, 99)}
    ps["sum"] = _ks_exact(Y.sum(2), stats.beta(d, 1).cdf)
    ps.update(_check_statistics(Y, _simplex_exact(d, 20000, np.random.default_rng(2)),
                                np.full(d, 1.0 / (d + 1)), 3))
    assert min(ps.values()) > P_MIN, ps


def test_box_marginals_are_uniform():
    """Box with side lengths 1..30 (d = 120: the rounding must undo the stretch)."""
    d = 120
    a = np.linspace(1.0, 30.0, d)
    H, s = _box(a)
    Y, _ = _walk(H, s, a / 3, 1000, seed=4)
    ps = {f"y{i}": _ks_exact(Y[:, :, i] / a[i], stats.uniform.cdf) for i in (0, 60, 119)}
    exact = np.random.default_rng(5).random((20000, d)) * a
    ps.update(_check_statistics(Y, exact, a / 2, 6))
    assert min(ps.values()) > P_MIN, ps


def test_cross_polytope_marginals():
    """Cross-polytope {sum |y_i| <= 1}: its H-representation has 2^d rows, so d = 10
    (1024 rows), not 100. |y_i| ~ Beta(1, d), sign symmetric; exact samples
    y = l / (|l|_1 + E), l_i Laplace, E exponential (Barthe, Guedon, Mendelson & Naor)."""
    d = 10
    signs = np.array(np.meshgrid(*[[-1.0, 1.0]] * d)).reshape(d, -1).T
    H, s = signs, np.ones(signs.shape[0])
    Y, _ = _walk(H, s, np.zeros(d), 1500, seed=7)
    ps = {f"|y{i}|": _ks_exact(np.abs(Y[:, :, i]), stats.beta(1, d).cdf) for i in (0, 9)}
    y3 = _ess_thinned(Y[:, :, 3])
    ps["sign"] = stats.binomtest(int((y3 > 0).sum()), y3.size).pvalue
    rng = np.random.default_rng(8)
    lap = rng.laplace(size=(20000, d))
    exact = lap / (np.abs(lap).sum(1, keepdims=True) + rng.exponential(size=(20000, 1)))
    ps.update(_check_statistics(Y, exact, np.zeros(d), 9))
    assert min(ps.values()) > P_MIN, ps


def test_product_of_simplex_and_box():
    """Simplex (60) x box (60): the marginals of both factors, and independence (the box
    coordinate is uniform whether the simplex's sum is below or above its median)."""
    ds, db = 60, 60
    Hs, ss = _simplex(ds)
    Hb, sb = _box(np.ones(db))
    H = np.block([[Hs, np.zeros((Hs.shape[0], db))], [np.zeros((Hb.shape[0], ds)), Hb]])
    s = np.r_[ss, sb]
    Y, _ = _walk(H, s, np.r_[np.full(ds, 0.5 / ds), np.full(db, 0.5)], 1000, seed=10)
    ps = {"simplex y0": _ks_exact(Y[:, :, 0], stats.beta(1, ds).cdf),
          "simplex sum": _ks_exact(Y[:, :, :ds].sum(2), stats.beta(ds, 1).cdf),
          "box y0": _ks_exact(Y[:, :, ds], stats.uniform.cdf)}
    tot, u = Y[:, :, :ds].sum(2), Y[:, :, ds + 5]
    k = max(_thinning(u), _thinning(tot))
    u, tot = u[:, ::k].ravel(), tot[:, ::k].ravel()
    low = tot < np.median(tot)
    ps["box | low sum"] = stats.kstest(u[low], stats.uniform.cdf).pvalue
    ps["box | high sum"] = stats.kstest(u[~low], stats.uniform.cdf).pvalue
    rng = np.random.default_rng(11)
    exact = np.hstack([_simplex_exact(ds, 20000, rng), rng.random((20000, db))])
    ps.update(_check_statistics(Y, exact, np.r_[np.full(ds, 1 / (ds + 1)), np.full(db, 0.5)],
                                12))
    assert min(ps.values()) > P_MIN, ps


def test_discarding_long_trajectories_keeps_uniformity():
    """max_refl = 1: trajectories with 2 or more reflections are discarded (the chain
    stays); still uniform (Gryazina & Polyak's rule is reversible). Box [0, 1]^5."""
    d = 5
    H, s = _box(np.ones(d))
    Y, walk = _walk(H, s, np.full(d, 0.5), 3000, seed=13, max_refl=1, tau=1.0)
    c = walk.counts.sum(0)
    assert c[bw.DISCARDED] > 0.1 * c[bw.TRAJ]
    ps = {f"y{i}": _ks_exact(Y[:, :, i], stats.uniform.cdf) for i in range(d)}
    assert min(ps.values()) > P_MIN, ps


# ----------------------------------------------------------------------------
# kernel, rounding
# ----------------------------------------------------------------------------
def test_walk_on_the_fly_rows_equal_the_gram_rows():
    """Without K (rows H h_j computed per reflection) the walk is the same up to round-off
    (a few trajectories), and one call of n trajectories is n calls of one, bit for bit
    (the slacks are chain state: a resumed file continues the same walk)."""
    rng = np.random.default_rng(0)
    H = np.ascontiguousarray(rng.normal(size=(200, 30)))
    s = np.ones(200)
    ends = []
    for K in (bw.gram_matrix(H), np.zeros((0, 0))):
        walk = bw.Chains(H, s, np.zeros((1, 30)), seed_states(3, 1), K)
        walk.tau = 5.0
        walk.run(0, 3)
        ends.append(walk.W[0])
        assert walk.counts[0, bw.REFL] > 10
    assert np.abs(ends[0] - ends[1]).max() < 1e-9
    one, many = (bw.Chains(H, s, np.zeros((1, 30)), seed_states(3, 1)) for _ in range(2))
    one.run(0, 40)
    for _ in range(40):
        many.run(0, 1)
    assert np.array_equal(one.W, many.W) and np.array_equal(one.slack, many.slack)


def test_lewis_rounding_of_a_box_and_a_simplex():
    """The Lewis-weight ellipsoid of a box is its inscribed axis-aligned one (any number
    of updates); for the simplex, converged updates give John's ellipsoid (centroid)."""
    a = np.array([1.0, 4.0, 9.0])
    H, s = _box(a)
    c, Lc, _ = lewis_rounding(H, s, a / 4, max_updates=0)
    assert np.allclose(c, a / 2)
    assert np.allclose(Lc @ Lc.T, np.diag((a / 2) ** 2))
    d = 6
    H, s = _simplex(d)
    c, Lc, info = lewis_rounding(H, s, np.full(d, 0.1), max_updates=200, tol=1e-6)
    assert info["converged"]
    assert np.allclose(c, 1 / (d + 1), atol=1e-6)
    slack = s - H @ c        # inscribed and touching: the support of each row = its slack
    assert np.allclose(np.linalg.norm(H @ Lc, axis=1), slack, rtol=1e-5)


# ----------------------------------------------------------------------------
# on S: the driver's stops, resume, agreement with hit-and-run
# ----------------------------------------------------------------------------
THETAS, MU = [np.pi / 6, np.pi / 5], 0.3


def test_a_run_asked_for_a_target_ess_stops_there_or_says_it_fell_short():
    """Two grooves (dim 2): the billiard walk stops as soon as every tracked statistic
    has bulk and tail ESS >= 200 and R-hat <= 1.05 (not before
    config.BILLIARD_MIN_DRAWS_PER_CHAIN draws per chain),
    reproducibly; asked for an ESS its cap cannot reach, it stops at the cap with
    status 1 and says so; max_seconds = 0 stops it at once (status 1)."""
    _, prob = grooves(THETAS, MU)
    run = BilliardWalk(20000, seed=3, target_ess=200).compute(prob)
    d = run.ensemble.diagnostics
    assert run.success and "converged" in run.message
    assert d["min_ess"] >= 200 and d["max_rhat"] <= config.RHAT_MAX
    assert 4 * config.BILLIARD_MIN_DRAWS_PER_CHAIN <= run.ensemble.n_samples < 20000
    again = BilliardWalk(20000, seed=3, target_ess=200).compute(prob)
    assert np.array_equal(again.ensemble.samples, run.ensemble.samples)
    short = BilliardWalk(40, seed=3, target_ess=1e6).compute(prob)
    assert short.status == 1 and "short of the target ESS" in short.message
    assert short.ensemble.n_samples == 40
    capped = BilliardWalk(1000, seed=3, max_seconds=0.0).compute(prob)
    assert capped.status == 1 and "max_seconds" in capped.message
    assert run.ensemble.sampler == "billiard" and run.params["length"] == "rehmc"


def test_resume_continues_the_same_walk(tmp_path):
    _, prob = grooves(THETAS, MU)
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    BilliardWalk(30, seed=5, checkpoint_every=7).compute(prob, output=a)
    early = BilliardWalk(30, seed=5, checkpoint_every=7, max_seconds=0.0).compute(prob,
                                                                                 output=b)
    first = read_ensemble(b).n_samples                                   # "killed" early
    assert 0 < first < 30 and early.status == 1
    BilliardWalk(30, seed=5, checkpoint_every=7).compute(prob, output=b)  # rerun: continues
    Xa, Xb = read_ensemble(a).samples, read_ensemble(b).samples
    assert Xb.shape == (30, 8) and np.array_equal(Xa, Xb)
    ens = read_ensemble(a)
    assert ens.sampler == "billiard" and ens.params["tau_factor"] == 2.5
    setup = read_file(a).setup                   # self-describing: the walk's fixed values
    assert setup["tau"] > 0 and setup["max_refl"] >= 1000 and setup["T"].shape[1] == 2
    memory = BilliardWalk(30, seed=5).compute(prob).ensemble
    assert np.array_equal(memory.samples, Xa)


def _means_and_errors(Xc):
    """Per column of Xc (chains, draws, D): mean and its Monte-Carlo standard error
    sd / sqrt(bulk ESS)."""
    ess = np.array([_ess(Xc[:, :, j]) for j in range(Xc.shape[2])])
    flat = Xc.reshape(-1, Xc.shape[2])
    return flat.mean(0), flat.std(0) / np.sqrt(ess)


def _eta_and_error(Xc):
    """eta of all samples, and its standard error from 8 batches (chain halves)."""
    h = Xc.shape[1] // 2
    batches = [eta(x[k * h:(k + 1) * h]) for x in Xc for k in (0, 1)]
    return eta(Xc.reshape(-1, Xc.shape[2])), np.std(batches, ddof=1) / np.sqrt(len(batches))


def test_agrees_with_hit_and_run_on_a_paper_slice():
    """The paper packing at mu = 0.1, slice 28 R (dim S 48, 376 rows): per-contact mean
    forces, their spread, and eta of the billiard walk (target ESS 1000) and of
    coordinate hit-and-run (1200 samples, thinning d^2) agree within their Monte-Carlo
    errors."""
    from paths import PACKINGS
    from forcespace import read_packing, slice_problem

    prob = slice_problem(read_packing(PACKINGS / "paper_mu0.1.h5"), 28.0)
    bil = BilliardWalk(20000, seed=5, target_ess=1000).compute(prob)
    assert bil.dim == 48 and bil.success
    assert bil.ensemble.violations.max() <= config.SAMPLE_VIOLATION
    har = HitAndRun(1200, seed=6).compute(prob).ensemble
    Xb = by_chain(bil.ensemble.samples, bil.ensemble.chains)
    Xh = by_chain(har.samples, har.chains)
    mb, eb = _means_and_errors(Xb)
    mh, eh = _means_and_errors(Xh)
    vary = Xb.reshape(-1, Xb.shape[2]).std(0) > 1e-6 * prob.force_scale
    assert vary.sum() > 300                                   # 376 columns (188 contacts)
    z = (mb - mh)[vary] / np.hypot(eb, eh)[vary]
    assert np.abs(z).max() < 4.5, np.abs(z).max()     # independent z: P(max > 4.5) ~ 3e-3
    sb = Xb.reshape(-1, Xb.shape[2]).std(0)[vary]     # per-contact spread: within 10 %
    sh = Xh.reshape(-1, Xh.shape[2]).std(0)[vary]
    assert np.median(np.abs(sb / sh - 1)) < 0.1
    (eta_b, se_b), (eta_h, se_h) = _eta_and_error(Xb), _eta_and_error(Xh)
    assert abs(eta_b - eta_h) < 4 * np.hypot(se_b, se_h), (eta_b, se_b, eta_h, se_h)
    # Fig. 3's distances: the jammed network's l0 / lbar (centre = the sampler's own mean)
    # and the spread of l / lbar agree (the l0 / lbar of a uniform sampler is a property
    # of S; the relax walk's is 3x smaller, tests/studies)
    from forcespace import distance_from_centre
    x0 = prob.x_jammed
    lb = distance_from_centre(bil.ensemble.samples, x0)
    lh = distance_from_centre(har.samples, x0)
    assert lb[1] / lb[2] == pytest.approx(lh[1] / lh[2], rel=0.05)
    assert np.std(lb[0]) / lb[2] == pytest.approx(np.std(lh[0]) / lh[2], rel=0.1)


@pytest.mark.parametrize("cls", [BilliardWalk, HitAndRun])
def test_an_ensemble_read_back_carries_its_rhat_and_ess(cls, tmp_path):
    # issue 40: reading an ensemble file recomputed the diagnostics for hit-and-run only,
    # so a billiard ensemble read back had no R-hat and no ESS; now every sampler's file
    # reads back with the numbers the run had in memory
    _, prob = grooves([0.3, 0.5, 0.7], 0.4)
    out = tmp_path / "e.h5"
    run = cls(120, seed=3).compute(prob, output=out)
    mem, back = run.ensemble.diagnostics, read_ensemble(out).diagnostics
    assert run.ensemble.n_samples == 120 and run.dim >= 1
    for key in ("max_rhat", "min_ess", "rhat_sqdev", "ess_sqdev"):
        assert np.isfinite(back[key]) and back[key] == mem[key], key
    assert back["statistics"] == mem["statistics"]


@pytest.mark.parametrize("cls", [BilliardWalk, HitAndRun])
def test_an_ensemble_file_describes_its_frame(cls, tmp_path):
    # the frame's set-up arrays are written with their units and meaning (issue 40's
    # shared walk template once wrote each name as its own description, units '1')
    import h5py
    _, prob = grooves([0.3, 0.5, 0.7], 0.4)
    out = tmp_path / "e.h5"
    cls(20, seed=3).compute(prob, output=out)
    with h5py.File(out) as f:
        for name, ds in f["setup"].items():
            assert ds.attrs["description"] != name, name
        assert f["setup/T"].attrs["units"] == "F0"
        assert f["setup/s0"].attrs["units"] == "F0"


def test_float32_gram_walk_follows_the_float64_walk_and_stays_inside():
    """K kept in float32 (half the memory): its entries are the float64 ones rounded
    (relative error <= 2^-24 of |h_i| |h_j|), the hit rows are taken exactly, and the walk
    from the same state makes the same reflections, ending within 1e-6 of the float64
    walk, every end point inside the polytope (exact slacks >= 0)."""
    rng = np.random.default_rng(4)
    d = 30
    H = np.ascontiguousarray(np.vstack([np.eye(d), -np.eye(d), rng.normal(size=(140, d))]))
    s = np.r_[np.ones(2 * d), 3.0 * np.ones(140)]
    K64, K32 = bw.gram_matrix(H, form="float64"), bw.gram_matrix(H, form="float32")
    assert K32.dtype == np.float32 and bw.gram_form(K32) == "float32"
    nrm = np.linalg.norm(H, axis=1)
    assert np.abs(K32 - K64).max() / nrm.max() ** 2 <= 2.0 ** -24
    np.testing.assert_allclose(bw.gram_diagonal(H, K32), np.diag(K64), rtol=1e-15)
    assert bw.gram_diagonal(H, K64).size == 0             # float64: K's own diagonal
    ends, counts = [], []
    for K in (K64, K32):
        walk = bw.Chains(H, s, np.zeros((1, d)), seed_states(5, 1), K)
        walk.tau = 6.0
        out = np.zeros((20, d))
        walk.run(0, 20, out)
        assert (out @ H.T - s).max() <= 0.0
        ends.append(out)
        counts.append(walk.counts[0].copy())
    assert counts[0][bw.REFL] > 200 and np.array_equal(counts[0][:3], counts[1][:3])
    assert 0 < np.abs(ends[0] - ends[1]).max() < 1e-6


def test_float32_gram_samples_of_a_paper_slice_are_in_S_and_agree():
    """BilliardWalk(gram="float32") on the paper slice (dim S 48): every sample inside S
    to config.SAMPLE_VIOLATION, the same reflections as float64 and eta within 1e-9; the
    default ("auto") keeps K in float64 there."""
    from paths import PACKINGS
    from forcespace import read_packing, slice_problem

    prob = slice_problem(read_packing(PACKINGS / "paper_mu0.1.h5"), 28.0)
    runs = {g: BilliardWalk(300, seed=2, gram=g).compute(prob) for g in (None, "float32")}
    assert runs[None].walk_info["gram_form"] == "float64"
    assert runs["float32"].walk_info["gram_form"] == "float32"
    assert runs["float32"].ensemble.violations.max() <= config.SAMPLE_VIOLATION
    assert runs[None].counts == runs["float32"].counts
    e64, e32 = (eta(r.ensemble.samples) for r in runs.values())
    assert abs(e32 / e64 - 1) < 1e-9
    with pytest.raises(Exception, match="gram"):
        BilliardWalk(10, gram="float16")


def test_large_path_frame_starts_at_the_interior_point_or_falls_back_to_the_centre(
        monkeypatch):
    """Issue 46: on the large path (config.SWEEP_MIN_COLUMNS columns and up; lowered here
    so that the paper slice, dim S 48, takes it) the frame starts at the analysis'
    interior point (no Chebyshev-centre LP), strictly inside every moving row; an interior
    point on a facet (slack 0) is recentred (frame's Chebyshev centre in its own
    coordinates): the start then has the analysis' inscribed radius."""
    from paths import PACKINGS
    from forcespace import read_packing, slice_problem
    from forcespace.sampling.frame import frame
    from forcespace.space.force_space import ForceSpace

    prob = slice_problem(read_packing(PACKINGS / "paper_mu0.1.h5"), 28.0)
    monkeypatch.setattr(config, "SWEEP_MIN_COLUMNS", 0)
    f = frame(prob)
    assert f.analysis.centre is None and f.N.shape[1] == 48
    assert f.s0.min() > config.INTERIOR_STRICT * prob.force_scale
    np.testing.assert_allclose(f.xc, f.analysis.affine_point, atol=1e-12 * prob.force_scale)
    an = ForceSpace(ranges=False, centre=False, varying=False).compute(prob)
    G, _, _ = prob.inequalities()
    d = f.N @ np.random.default_rng(1).normal(size=f.N.shape[1])
    Gd, slack = G[f.free] @ d, -(G[f.free] @ an.affine_point)
    t = np.min(slack[Gd > 0] / Gd[Gd > 0])
    an._results["affine_point"] = an.affine_point + t * d          # on a facet
    g = frame(prob, an)
    assert g.s0.min() > 0 and g.widening == 0.0
    radius = np.min(g.s0 / np.linalg.norm(g.H0, axis=1))
    ref = ForceSpace(ranges=False, centre=True, varying=False).compute(prob).radius
    assert radius == pytest.approx(ref, rel=1e-3)


def test_large_path_ensemble_agrees_with_the_default_path(monkeypatch):
    """Issue 46: the large path (frame at the interior point, Dikin rounding at a looser
    centre, config.LEWIS_UPDATES_LARGE updates, a shorter burn-in) samples the same S: on the paper slice
    (dim S 48) per-contact mean forces and eta agree with the default path's within the
    chains' Monte-Carlo errors, every sample inside S."""
    from paths import PACKINGS
    from forcespace import read_packing, slice_problem

    prob = slice_problem(read_packing(PACKINGS / "paper_mu0.1.h5"), 28.0)
    old = BilliardWalk(20000, seed=5, target_ess=600).compute(prob)
    monkeypatch.setattr(config, "SWEEP_MIN_COLUMNS", 0)
    new = BilliardWalk(20000, seed=5, target_ess=600).compute(prob)
    assert new.walk_info["rounding"]["weight_updates"] == config.LEWIS_UPDATES_LARGE == 0
    assert new.params["burn_in"] == config.BILLIARD_BURN_IN_LARGE < old.params["burn_in"]
    assert old.walk_info["rounding"]["weight_updates"] == 5
    assert new.ensemble.violations.max() <= config.SAMPLE_VIOLATION
    Xo = by_chain(old.ensemble.samples, old.ensemble.chains)
    Xn = by_chain(new.ensemble.samples, new.ensemble.chains)
    (mo, eo), (mn, en) = _means_and_errors(Xo), _means_and_errors(Xn)
    vary = Xo.reshape(-1, Xo.shape[2]).std(0) > 1e-6 * prob.force_scale
    assert vary.sum() > 300
    z = (mo - mn)[vary] / np.hypot(eo, en)[vary]
    assert np.abs(z).max() < 4.5, np.abs(z).max()
    (eta_o, se_o), (eta_n, se_n) = _eta_and_error(Xo), _eta_and_error(Xn)
    assert abs(eta_o - eta_n) < 4 * np.hypot(se_o, se_n), (eta_o, se_o, eta_n, se_n)


def test_large_path_walk_proves_S_bounded_without_the_boundedness_LP(monkeypatch):
    """Issue 46: on the large path the frame's analysis skips its boundedness LP and the
    Lewis rounding proves S bounded (info["bounded"]): the same samples, bit for bit, as
    the walk given an analysis that ran the LP; an unbounded S (a lattice in a box, mu =
    0.3) is still refused, by the exact recession-cone LP."""
    from paths import PACKINGS
    from ensemble_cases import lattice_in_box
    from forcespace import read_packing, slice_problem
    from forcespace.errors import InputError
    from forcespace.space import force_space
    from forcespace.space.force_space import ForceSpace

    prob = slice_problem(read_packing(PACKINGS / "paper_mu0.1.h5"), 28.0)
    monkeypatch.setattr(config, "SWEEP_MIN_COLUMNS", 0)
    full = ForceSpace(ranges=False, centre=False, varying=False).compute(prob)
    assert full.bounded is True

    def boom(*args, **kw):
        raise AssertionError("the boundedness LP ran")
    with monkeypatch.context() as m:
        m.setattr(force_space, "interior_max_sum_fn", boom)
        m.setattr(force_space, "check_recession", boom)
        run = BilliardWalk(60, seed=4).compute(prob)
    assert run.walk_info["rounding"]["bounded"] is True
    ref = BilliardWalk(60, seed=4).compute(prob, analysis=full)
    assert np.array_equal(run.ensemble.samples, ref.ensemble.samples)
    _, unbounded = lattice_in_box(0.3)
    with pytest.raises(InputError, match="unbounded"):
        BilliardWalk(5).compute(unbounded)


def test_the_billiard_walk_checks_its_ess_from_its_own_floor():
    """Issue 46: a target-ESS run of the billiard walk checks its ESS from
    config.BILLIARD_MIN_DRAWS_PER_CHAIN draws per chain (the other walks from
    config.MIN_DRAWS_PER_CHAIN): two grooves, target 100, stop before 100 draws per chain
    with ESS >= 100, its samples the first ones of the same walk run longer."""
    _, prob = grooves(THETAS, MU)
    run = BilliardWalk(20000, seed=3, target_ess=100).compute(prob)
    n = run.ensemble.n_samples
    assert "converged" in run.message and run.ensemble.diagnostics["min_ess"] >= 100
    assert 4 * config.BILLIARD_MIN_DRAWS_PER_CHAIN <= n < 4 * config.MIN_DRAWS_PER_CHAIN
    longer = BilliardWalk(n + 40, seed=3).compute(prob)
    assert np.array_equal(longer.ensemble.samples[:n], run.ensemble.samples)
