"""Uniform sampling of S of spheres (circular Coulomb cones) through the sampling driver,
by hit-and-run (exact chords) and the billiard walk (reflections off the cones): uniform
marginals on a solid cone (with a planted error the test catches), files that resume bit
for bit, and the command line on a sphere packing."""
from pathlib import Path

import h5py
import numpy as np
import pytest
from cases import conic_problem, two_row_packing
from scipy.stats import kstest

from forcespace import full_problem
from forcespace.cli import main
from forcespace.errors import InputError
from forcespace.sampling import conic_walk
from forcespace.sampling.billiard import BilliardWalk
from forcespace.sampling.hit_and_run import HitAndRun

MU = 0.5


def solid_cone(mu=MU, F=1.0):
    """S = {(fn1, f1, f2): |f| <= mu fn1, 0 <= fn1 <= F} (a second frictionless contact
    takes F - fn1): a solid circular cone of height F, uniform law of fn1 with
    P(fn1 <= s) = (s / F)^3, of |f_t| / (mu fn1) with P(<= q) = q^2."""
    rows = np.zeros((1, 6))
    rows[0, [0, 3]] = 1.0
    return conic_problem(rows, [F], [mu, 0.0])


def marginal_pvalues(X):
    """KS p-values of fn1 against s^3 and of |f_t| / (mu fn1) against q^2."""
    fn = X[:, 0]
    q = np.hypot(X[:, 1], X[:, 2]) / (MU * fn)
    return (kstest(fn, lambda s: np.clip(s, 0, 1) ** 3).pvalue,
            kstest(q, lambda s: np.clip(s, 0, 1) ** 2).pvalue)


UNIFORM = [(HitAndRun, {"thin": 5, "direction": "coordinate"}),
           (HitAndRun, {"thin": 5, "direction": "hypersphere"}),
           (BilliardWalk, {})]


@pytest.mark.parametrize("cls, options", UNIFORM)
def test_the_walks_are_uniform_on_a_solid_cone(cls, options):
    prob = solid_cone()
    walk = cls(1200, seed=3, chains=4, **options).compute(prob)
    X = walk.ensemble.samples
    assert walk.dim == 3 and walk.ensemble.per_contact == 3
    assert walk.ensemble.violations.max() <= 1e-9
    assert min(marginal_pvalues(X)) > 1e-3
    assert walk.ensemble.diagnostics["max_rhat"] < 1.05


def test_the_billiard_is_uniform_with_the_large_problems_rounding(monkeypatch):
    # above config.MVE_MAX_ROWS pyramid rows: the Dikin ellipsoid at the analytic centre
    # (in the Dikin frame at the centre), not the exact MVE
    monkeypatch.setattr(conic_walk.config, "MVE_MAX_ROWS", 0)
    walk = BilliardWalk(1200, seed=3, chains=4).compute(solid_cone())
    assert walk.walk_info["rounding"]["method"] == "lewis"
    assert walk.ensemble.violations.max() <= 1e-9
    assert min(marginal_pvalues(walk.ensemble.samples)) > 1e-3


@pytest.mark.parametrize("cls, options", [UNIFORM[0], UNIFORM[2]])
def test_the_uniformity_test_catches_a_walk_in_a_narrower_cone(monkeypatch, cls, options):
    # planted error: chords and reflections off the cone of mu cos(pi/8) (the inscribed
    # octagon's inradius): every sample still in S, but |f_t| never reaches mu fn
    real = conic_walk.conic_frame

    def narrower(problem, analysis=None):
        fr, cone, mu, line = real(problem, analysis)
        return fr, cone, mu * np.cos(np.pi / 8), line
    monkeypatch.setattr(conic_walk, "conic_frame", narrower)
    walk = cls(1200, seed=3, chains=4, **options).compute(solid_cone())
    assert walk.ensemble.violations.max() <= 1e-9
    assert marginal_pvalues(walk.ensemble.samples)[1] < 1e-6


def test_a_reflection_off_a_cone_is_specular():
    # the billiard's reflection at (fn, f1, f2) = (1, 0.5, 0) on the cone mu = 0.5: normal
    # (-mu, 1, 0) / |.|; v = (0, 1, 0) (outward) -> v - 2 (v.n) n, |v| kept, q = T v
    T = np.eye(3)
    v = np.array([0.0, 1.0, 0.0])
    q = T @ v
    conic_walk.reflect(T, T @ T.T, np.array([1.0, 0.5, 0.0]), v, q, 0, 0, 0.5)
    n = np.array([-0.5, 1.0, 0.0]) / np.hypot(0.5, 1.0)
    np.testing.assert_allclose(v, np.array([0, 1.0, 0]) - 2 * n[1] * n, atol=1e-15)
    np.testing.assert_allclose(q, v)
    assert np.linalg.norm(v) == pytest.approx(1.0)
    assert v @ n < 0                                      # now inward


def test_a_reflection_keeps_q_by_the_gram_matrix_as_by_t_v():
    # q = T v after a reflection, kept by G = T T^T in O(m) (the default) or recomputed
    # in O(m d) (G empty: too large to keep): the same v and q to round-off, on a random
    # frame of 4 contacts in dim 5, off a cone and off fn >= 0
    rng = np.random.default_rng(1)
    T = rng.normal(size=(12, 5))
    x = np.tile([1.0, 0.3, -0.2], 4)
    for kind in (0, 1):
        v1 = rng.normal(size=5)
        v2, q1 = v1.copy(), T @ v1
        q2 = q1.copy()
        conic_walk.reflect(T, T @ T.T, x, v1, q1, 2, kind, 0.5)
        conic_walk.reflect(T, np.zeros((0, 0)), x, v2, q2, 2, kind, 0.5)
        np.testing.assert_allclose(v1, v2, atol=1e-13)
        np.testing.assert_allclose(q1, q2, atol=1e-12)
        np.testing.assert_allclose(q1, T @ v1, atol=1e-12)


def test_the_chord_of_a_cone_is_exact():
    cone_chords = conic_walk.cone_chords
    # along f1 from the axis point (1, 0, 0): |f1| <= mu = 0.5 -> t in [-0.5, 0.5]
    lo, hi = cone_chords([[1.0, 0, 0]], [[0.0, 1, 0]], [0.5])
    np.testing.assert_allclose([lo[0], hi[0]], [-0.5, 0.5])
    # along the axis: fn >= 0 only below, unbounded above
    lo, hi = cone_chords([[1.0, 0.2, 0]], [[1.0, 0, 0]], [0.5])
    assert lo[0] == pytest.approx(-0.6) and hi[0] == np.inf
    # a random chord's ends lie on the cone's surface
    rng = np.random.default_rng(0)
    for _ in range(20):
        p = np.r_[1.0, rng.uniform(-0.3, 0.3, 2)]
        q = rng.normal(size=3)
        lo, hi = cone_chords([p], [q], [0.5])
        for t in (lo[0], hi[0]):
            if np.isfinite(t):
                e = p + t * q
                assert 0.5 * e[0] - np.hypot(e[1], e[2]) == pytest.approx(0, abs=1e-12)
                assert e[0] >= -1e-12


@pytest.mark.parametrize("cls, options", [UNIFORM[0], UNIFORM[2]])
def test_a_sphere_ensemble_file_resumes_bit_for_bit(tmp_path, cls, options):
    prob = solid_cone()
    one, two = tmp_path / "one.h5", tmp_path / "two.h5"
    straight = cls(30, seed=5, checkpoint_every=4, **options).compute(prob, output=one)
    cls(13, seed=5, checkpoint_every=4, **options).compute(prob, output=two)
    resumed = cls(30, seed=5, checkpoint_every=4, **options).compute(prob, output=two)
    np.testing.assert_array_equal(straight.ensemble.samples, resumed.ensemble.samples)
    with h5py.File(two) as f:
        assert f["samples"].shape == (30, 2, 3)
        assert list(f["samples"].attrs["columns"]) == ["fn", "f1", "f2"]
    # the file says what it holds: eta over (fn, f1, f2) per contact
    from forcespace.sampling.diagnostics import read_ensemble
    back = read_ensemble(two)
    assert back.per_contact == 3 and back.eta == pytest.approx(resumed.ensemble.eta)


def test_sample_a_sphere_packing_from_the_command_line(tmp_path, capsys):
    packing = Path(__file__).parents[1] / "data" / "quick3d_mu0.3.h5"
    out = tmp_path / "e.h5"
    argv = ["sample", str(packing), "--full", "--sampler", "hit-and-run", "-n", "8",
            "--thin", "20", "--burn-in", "200", "-o", str(out), "--quiet"]
    assert main(argv) == 0
    with h5py.File(out) as f:
        assert f["samples"].shape[1:] == (f["problem/contacts"].shape[0], 3)
        assert f["sample_violation"][()].max() <= 1e-9
    assert main(["ensemble", str(out)]) == 0
    # no --sampler: spheres get the billiard walk (the faster per effective sample)
    default = tmp_path / "b.h5"
    assert main(argv[:3] + argv[5:7] + ["-o", str(default), "--quiet"]) == 0
    with h5py.File(default) as f:
        assert f.attrs["sampler"] == "billiard"
    assert main(argv[:4] + ["relax"] + argv[5:]) != 0        # polytopes only, one line
    err = capsys.readouterr().err
    assert "--sampler" in err and "disk packings only" in err and "Traceback" not in err


def test_the_pyramids_cross_check_samples_the_inscribed_pyramid_uniformly():
    # the cone of the solid cone replaced by an inscribed square pyramid (k = 4): fn is
    # still distributed as s^3 (cross-sections ~ fn^2), every sample inside the square
    # |f . e_i| <= mu cos(pi/4) fn, and the square's corners reached (|f_t| -> mu fn)
    walk = HitAndRun(1200, seed=3, chains=4, thin=5, pyramids=4).compute(solid_cone())
    X = walk.ensemble.samples
    assert walk.params["pyramids"] == 4 and walk.ensemble.violations.max() <= 1e-9
    assert kstest(X[:, 0], lambda s: np.clip(s, 0, 1) ** 3).pvalue > 1e-3
    theta = np.pi / 4 + np.pi / 2 * np.arange(4)            # the centre's f_t is 0: a = pi/4 + ..
    edges = X[:, 1:3] @ np.array([np.cos(theta), np.sin(theta)])
    assert (edges / (MU * np.cos(np.pi / 4) * X[:, [0]])).max() <= 1 + 1e-9
    q = np.hypot(X[:, 1], X[:, 2]) / (MU * X[:, 0])
    assert 0.9 < q.max() <= 1 + 1e-9
    with pytest.raises(InputError, match="spheres only"):
        HitAndRun(10, pyramids=4).compute(full_problem(two_row_packing()))


def test_a_polytope_only_sampler_refuses_spheres_naming_the_conic_samplers():
    class PolytopeOnly(HitAndRun):
        ConicWalk = None                          # a plug-in that walks polytopes only

    with pytest.raises(InputError, match="BilliardWalk or HitAndRun") as err:
        PolytopeOnly(10, seed=1).compute(solid_cone())
    assert "PolytopeOnly" in str(err.value) and "\n" not in str(err.value)


def solid_cones(k: int, mu=MU, heights=None):
    """S = k independent solid cones (:func:`solid_cone` k times, contacts 2i and 2i + 1,
    of ``heights`` (k,), default 1): the product, dim 3k."""
    rows = np.zeros((k, 6 * k))
    for i in range(k):
        rows[i, [6 * i, 6 * i + 3]] = 1.0
    return conic_problem(rows, np.ones(k) if heights is None else heights, [mu, 0.0] * k)


def test_the_conic_billiard_sets_tau_from_its_own_trajectories(tmp_path, capsys):
    # tau as the 2-D polytope billiard sets it, with no hit-and-run stage (that took
    # 10 d^2 + 8 d^2 steps per chain: ~1e8 at dim 1244, an hour silent): 2.5 x the rms
    # spread of the burn-in's third quarter, i.e. of S itself in the frame: within a
    # factor 1.5 of 2.5 x the rms distance of the uniform samples from their mean in w
    # (12 solid cones, dim 36; with the polytopes' guess tau_factor sqrt(d) r the
    # burn-in had not spread by its third quarter: tau 1/3 of that)
    out = tmp_path / "e.h5"
    n = 400
    walk = BilliardWalk(n, seed=1, progress=True).compute(solid_cones(12), output=out)
    err = capsys.readouterr().err
    assert "billiard burn-in (4 chains): 100%" in err and "hit-and-run" not in err
    with h5py.File(out) as f:
        T, xc = f["setup/T"][()], f["setup/x_centre"][()]
    W = np.linalg.lstsq(T, (walk.ensemble.samples.reshape(n, -1) - xc).T, rcond=None)[0].T
    spread = np.sqrt(((W - W.mean(0)) ** 2).sum(1).mean())
    assert 1 / 1.5 < walk.walk_info["tau"] / (2.5 * spread) < 1.5


def test_the_rounding_of_a_thin_s_converges_in_one_round():
    # S thin in some directions (as the 2000-sphere slice: a contact whose forces S fixes
    # to ~1e-7 <Fn>): five solid cones of height 1 and one of height 1e-6. The rounding
    # runs in the Dikin frame at the centre, where the thin cone is not ill-conditioned:
    # the exact MVE converges in its first round (it ran 120 iterations unconverged and
    # needed a second), and the ellipsoid's thin axis is the thin cone's scale (1e-6)
    prob = solid_cones(6, heights=[1.0] * 5 + [1e-6])
    fr, cone, mu, line = conic_walk.conic_frame(prob)
    y0, L, info = conic_walk.pyramid_rounding(fr, cone, prob, method="mve")
    assert info["converged"] == [True] and info["iterations"][0] < 40
    sv = np.linalg.svd(L, compute_uv=False)
    assert 0.5e-6 < sv.min() / sv.max() < 2e-6


def test_the_conic_billiards_chains_start_dispersed_inside_s():
    # over-dispersed starts (as the polytopes'): 0.9 of the way from the centre to S's
    # boundary along a random direction (exact: 1 / 0.9 of the way is on the cone)
    T, x0 = np.eye(3), np.array([0.6, 0.0, 0.0])
    cone, mu, line = np.array([0]), np.array([MU]), np.zeros(0, np.int64)
    W, t = conic_walk.conic_dispersed_starts(T, x0, np.zeros(3), cone, mu, line, 4, 7)
    assert len({tuple(w) for w in W}) == 4
    np.testing.assert_allclose(np.linalg.norm(W, axis=1), 0.9 * t)

    def margin(x):
        return MU * x[0] - np.hypot(x[1], x[2])
    for w in W:
        assert margin(x0 + w) > 0 and np.linalg.norm(w) > 0.01
        assert margin(x0 + w / 0.9) == pytest.approx(0, abs=1e-12)    # the boundary
