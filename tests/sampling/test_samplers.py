"""Both samplers: every sample in S, extremes reach the LP ranges, uniformity, resume, refusal."""
import numpy as np
import pytest
from scipy import stats

from ensemble_cases import groove_interval, grooves, lattice_in_box, lattice_rows
from forcespace import config
from forcespace.errors import InputError
from forcespace.sampling.diagnostics import read_ensemble
from forcespace.sampling import hit_and_run as har
from forcespace.sampling.frame import frame
from forcespace.sampling.hit_and_run import HitAndRun
from forcespace.sampling.relax_walk import RelaxWalk
from forcespace.space.force_space import ForceSpace

THETAS, MU = [np.pi / 6, np.pi / 5], 0.3


def _in_S(prob, X, tol):
    G, _, _ = prob.inequalities()
    for x in X:
        assert np.abs(prob.A @ x - prob.b).max() <= tol * prob.force_scale
        assert (G @ x).max() <= tol * prob.force_scale          # Coulomb (implies fn >= 0)
        assert x[0::2].min() >= -tol * prob.force_scale


@pytest.mark.parametrize("max_rows", [config.MVE_MAX_ROWS, 0])
def test_hit_and_run_is_uniform_on_a_rectangle(tmp_path, monkeypatch, max_rows):
    """Two independent grooves: S is a rectangle in (s1, s2) (dim 2). Marginals
    must be uniform, and u1 + u2 triangular (joint uniformity); with either
    rounding (max_rows 0: the Lewis-weight one of big slices)."""
    monkeypatch.setattr(config, "MVE_MAX_ROWS", max_rows)
    _, prob = grooves(THETAS, MU)
    out = tmp_path / "h.h5"
    res = HitAndRun(600, seed=11, thin=20).compute(prob, output=out).summary()
    assert res["params"]["rounding"] == ("john" if max_rows == 0 else "mve")
    X = read_ensemble(out).samples
    assert res["max_violation"] <= config.SAMPLE_VIOLATION
    _in_S(prob, X, 1e-9)
    u = []
    for k, th in enumerate(THETAS):
        lo, hi = groove_interval(th, MU)
        u.append((X[:, 4 * k + 1] - lo) / (hi - lo))
        assert stats.kstest(u[-1], "uniform").pvalue > 0.01
    z = u[0] + u[1]
    tri = lambda v: np.where(v <= 1, v**2 / 2, 1 - (2 - v) ** 2 / 2)  # noqa: E731
    assert stats.kstest(z, tri).pvalue > 0.01
    assert res["rhat_sqdev"] < 1.1


def test_the_uniformity_test_rejects_the_relax_walk_on_the_same_rectangle():
    """The statistic above can fail: the paper's perturb-and-relax walk, run on the same
    two grooves, is not uniform (its samples pile up where Gauss-Seidel stops, at the
    Coulomb limits), and the same KS test says so for at least one groove."""
    _, prob = grooves(THETAS, MU)
    X = RelaxWalk(600, seed=11).compute(prob).ensemble.samples
    _in_S(prob, X, 1e-9)
    p = []
    for k, th in enumerate(THETAS):
        lo, hi = groove_interval(th, MU)
        p.append(stats.kstest((X[:, 4 * k + 1] - lo) / (hi - lo), "uniform").pvalue)
    assert min(p) < 1e-3


@pytest.mark.parametrize("sampler", ["hit-and-run", "relax"])
def test_samples_in_S_and_extremes_reach_lp_ranges(tmp_path, sampler):
    _, prob = lattice_rows(4, 2, 0.5)                # dim S = 17
    an = ForceSpace(ranges=True).compute(prob)
    assert an.dim == 17
    out = tmp_path / "e.h5"
    if sampler == "relax":
        res = RelaxWalk(150, seed=1, tol=1e-9).compute(prob, output=out).summary()
        tol = 1e-9
    else:
        res = HitAndRun(300, seed=1).compute(prob, output=out).summary()
        tol = config.SAMPLE_VIOLATION
    X = read_ensemble(out).samples
    assert res["max_violation"] <= tol
    _in_S(prob, X, tol)
    lo, hi = an.fn_range[:, 0], an.fn_range[:, 1]
    # inside the LP ranges, and covering a good part of them
    assert np.all(X[:, 0::2] >= lo - 1e-9) and np.all(X[:, 0::2] <= hi + 1e-9)
    cover = (X[:, 0::2].max(0) - X[:, 0::2].min(0)) / (hi - lo)
    assert np.median(cover) > 0.3


def test_relax_reaches_both_ends_of_a_groove(tmp_path):
    _, prob = grooves(THETAS, MU)
    an = ForceSpace(ranges=True).compute(prob)
    out = tmp_path / "r.h5"
    RelaxWalk(200, seed=3).compute(prob, output=out).summary()
    X = read_ensemble(out).samples
    _in_S(prob, X, 1e-9)
    w = an.ft_range[:, 1] - an.ft_range[:, 0]
    assert np.all((X[:, 1::2].min(0) - an.ft_range[:, 0]) / w < 0.02)
    assert np.all((an.ft_range[:, 1] - X[:, 1::2].max(0)) / w < 0.02)


@pytest.mark.parametrize("cls", [HitAndRun, RelaxWalk])
def test_resume_continues_the_same_walk(tmp_path, cls):
    _, prob = grooves(THETAS, MU)
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    cls(30, seed=5, checkpoint_every=7).compute(prob, output=a)
    early = cls(30, seed=5, checkpoint_every=7, max_seconds=0.0).compute(prob, output=b)
    first = read_ensemble(b).n_samples                                   # "killed" early
    assert 0 < first < 30 and early.status == 1 and "max_seconds" in early.message
    cls(30, seed=5, checkpoint_every=7).compute(prob, output=b)          # rerun: continues
    Xa, Xb = read_ensemble(a).samples, read_ensemble(b).samples
    assert Xb.shape == (30, 8)
    assert np.array_equal(Xa, Xb)
    memory = cls(30, seed=5).compute(prob).ensemble                    # in memory: the same
    assert np.array_equal(memory.samples, Xa) and memory.path is None


def test_resume_refuses_another_run(tmp_path):
    _, prob = grooves(THETAS, MU)
    out = tmp_path / "a.h5"
    HitAndRun(5, seed=5).compute(prob, output=out).summary()
    with pytest.raises(InputError, match="another"):
        HitAndRun(10, seed=6).compute(prob, output=out).summary()


@pytest.mark.parametrize("cls", [HitAndRun, RelaxWalk])
def test_unbounded_S_is_never_sampled(tmp_path, cls):
    _, prob = lattice_in_box(0.3)
    with pytest.raises(InputError, match="unbounded"):
        cls(5).compute(prob, output=tmp_path / "u.h5")
    assert not (tmp_path / "u.h5").exists()


def test_rows_constant_on_the_affine_hull_are_dropped_from_the_frame(monkeypatch):
    """A row orthogonal to S's affine hull with a slack of -1e-13 <Fn> (an implicit
    equality the LP test missed, as on an 800-disk mu = 1 slice) must leave the
    hit-and-run frame: kept, its slack stops the rounding, and the frame has to widen S
    by round-off (sampling.frame._widening) to start."""
    import scipy.sparse as sp

    _, prob = grooves(THETAS, MU)
    an = ForceSpace(ranges=False).compute(prob)
    G, owner, kind = prob.inequalities()
    i, j = np.flatnonzero(np.abs(prob.b) > 0)[:2]
    g = prob.b[j] * prob.A[i] - prob.b[i] * prob.A[j]     # g.x = 0 on the affine hull
    g = g / sp.linalg.norm(g)
    shift = 1e-13 * prob.force_scale / np.linalg.norm(an.affine_point)
    row = sp.csr_matrix(g + shift * an.affine_point / np.linalg.norm(an.affine_point))
    G2 = sp.vstack([G, row]).tocsr()
    monkeypatch.setattr(prob, "_inequalities", (G2, np.append(owner, 0), np.append(kind, 0)))
    f = frame(prob, an)
    assert G.shape[0] not in f.free and np.abs(G2[-1] @ f.N).max() <= config.FLAT_ROW
    assert f.widening == 0
    y0, L, _ = har.rounding(f.H0, f.s0, prob.force_scale)
    assert np.all(f.H0 @ (prob.force_scale * y0) <= f.s0)    # a strictly interior start
    monkeypatch.setattr(config, "FLAT_ROW", -1.0)     # keep the row: the frame must widen S
    f = frame(prob, an)
    assert G.shape[0] in f.free and f.widening >= config.FRAME_MARGIN
    raw = f.s0 - f.widening * prob.force_scale
    assert raw[-1] < 0
    with pytest.raises(InputError, match="strictly inside"):
        har.rounding(f.H0, raw, prob.force_scale)


def test_burn_in_in_chunks_is_the_same_walk(monkeypatch):
    """The burn-in runs in chunks (for its progress bar): any chunk size that is a
    multiple of the slack refresh interval (64 at this dim) must leave every chain
    bit for bit where one call would."""
    _, prob = lattice_rows(4, 2, 0.5)
    runs = []
    for chunk in (64, 64 * 3, 10 ** 9):
        monkeypatch.setattr(har, "BURN_IN_CHUNK", chunk)
        runs.append(HitAndRun(4, seed=5, burn_in=1000).compute(prob).ensemble.samples)
    assert np.array_equal(runs[0], runs[2]) and np.array_equal(runs[1], runs[2])


def test_a_run_asked_for_a_target_ess_stops_there_or_says_it_fell_short():
    """Two grooves (dim 2): hit-and-run stops as soon as every tracked statistic has bulk
    and tail ESS >= 100 and R-hat <= 1.05, well before its cap; asked for an ESS its cap
    cannot reach, it stops at the cap with status 1 and says so."""
    _, prob = grooves(THETAS, MU)
    har = HitAndRun(4000, seed=3, target_ess=100).compute(prob)
    d = har.ensemble.diagnostics
    assert har.success and "converged" in har.message
    assert d["min_ess"] >= 100 and d["max_rhat"] <= config.RHAT_MAX
    assert har.ensemble.n_samples < 4000
    short = HitAndRun(40, seed=3, target_ess=1e6).compute(prob)
    assert short.status == 1 and "short of the target ESS" in short.message
    assert short.ensemble.n_samples == 40


def test_relax_walk_in_chains_gives_r_hat_and_one_chain_is_the_walk_of_before():
    _, prob = grooves(THETAS, MU)
    four = RelaxWalk(40, seed=2, chains=4).compute(prob).ensemble
    assert sorted(set(four.chains.tolist())) == [0, 1, 2, 3]
    assert np.isfinite(four.diagnostics["max_rhat"]) and four.diagnostics["n_chains"] == 4
    one = RelaxWalk(10, seed=2).compute(prob).ensemble
    again = RelaxWalk(10, seed=2, chains=1).compute(prob).ensemble
    assert np.array_equal(one.samples, again.samples) and "chains" not in one.params
    assert not np.array_equal(four.samples[:10], one.samples)   # other streams


def test_the_progress_total_follows_the_ess_measured_so_far():
    # ESS grows about linearly with the draws: 50 after 400 samples with target 100 means
    # about 800 samples in all (a multiple of the chains, never before the next check,
    # never beyond the cap); without a target or a measurement the total is the cap n
    from forcespace.sampling.driver import Stop
    stop = Stop(n=10_000, target_ess=100.0, chains=4)
    assert stop.expected_total() == 10_000
    stop.last, stop.next_check = {"min_ess": 50.0, "max_rhat": 1.1, "k": 400}, 500
    assert stop.expected_total() == 800
    stop.last["min_ess"] = 30.0                      # 1333.3 -> 1336 (4 chains)
    assert stop.expected_total() == 1336
    stop.last["min_ess"] = 99.0                      # nearly there: the next check
    assert stop.expected_total() == 500
    stop.last["min_ess"] = 1.0
    assert stop.expected_total() == 10_000           # the cap
    assert Stop(n=300).expected_total() == 300
