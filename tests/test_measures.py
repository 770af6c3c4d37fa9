"""eta, indeterminacy domains, elementary clusters, difference fields, CLI."""
import json

import numpy as np
import pytest

from ensemble_cases import grooves, pyramid
from forcespace import measures
from forcespace.space.structure import domains
from forcespace.errors import InputError
from forcespace.space.force_space import ForceSpace


def test_eta_by_hand():
    # one contact, two samples (1, 0) and (1, 0.2): mean (1, 0.1), dF = 0.1
    X = np.array([[1.0, 0.0], [1.0, 0.2]])
    mag = (1.0 + np.sqrt(1.04)) / 2
    assert np.isclose(measures.eta(X), 0.1 / mag)
    # two contacts: the second never moves; eta averages dF and |F| over contacts
    X2 = np.array([[1.0, 0.0, 3.0, 0.0], [1.0, 0.2, 3.0, 0.0]])
    assert np.isclose(measures.eta(X2), (0.1 / 2) / ((mag + 3.0) / 2))
    assert measures.eta(np.tile(X2[:1], (5, 1))) == 0.0
    with pytest.raises(InputError):
        measures.eta(np.array([[np.nan, 0.0]]))


def test_grooves_are_two_elementary_clusters():
    p, prob = grooves([0.4, 0.6, 0.5], 0.2)
    an = ForceSpace(ranges=False).compute(prob)
    doms = domains(prob, an)
    assert len(doms) == 3 and all(d.elementary and d.dim == 1 for d in doms)
    assert sorted(tuple(d.contacts) for d in doms) == [(0, 1), (2, 3), (4, 5)]
    assert sorted(int(d.disks[0]) for d in doms) == [0, 3, 6]


def test_frictionless_grooves_have_no_domains():
    _, prob = grooves([0.4, 0.6], 0.0)
    an = ForceSpace(ranges=False).compute(prob)
    assert an.dim == 0 and domains(prob, an) == []
    assert an.varying_contacts.size == 0


def test_pyramid_is_one_domain_with_dim_S():
    _, prob = pyramid(4, 0.5)
    an = ForceSpace(ranges=False).compute(prob)
    doms = domains(prob, an)
    assert sum(d.dim for d in doms) == an.dim == 14
    assert len(doms) == 1 and not doms[0].elementary


def test_difference_field_and_centre_distance():
    p, prob = grooves([0.4], 0.2)
    an = ForceSpace(ranges=True).compute(prob)
    x1 = an.centre
    x2 = x1.copy()
    x2[1] += 0.01
    x2[3] -= 0.01
    f = measures.difference_field(p, prob, x1, x2)
    assert f["segments"].shape == (2, 2, 2) and np.allclose(f["dft"], [0.01, -0.01])
    assert np.allclose(np.linalg.norm(f["dF"], axis=1), 0.01)
    ell, l0, lbar = measures.distance_from_centre(np.array([x1, x2]), x1)
    assert np.isclose(l0, np.linalg.norm(x2 - x1) / 2) and np.isclose(lbar, l0)


def test_cli_analyze_sample_ensemble(tmp_path, capsys):
    from forcespace.cli import main
    from forcespace.io.packing_file import write_packing

    p, prob = pyramid(3, 0.6)
    pack = tmp_path / "p.h5"
    write_packing(p, pack)
    assert main(["analyze", str(pack), "--full", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for k in ("n_interior", "n_contacts", "degree_of_indeterminacy", "dim_S", "bounded",
              "feasible", "n_sliding", "n_domains", "n_domains_of_dim_1"):
        assert k in out
    assert out["n_interior"] == 6 and out["feasible"] and out["bounded"]
    assert out["degree_of_indeterminacy"] == 2 * out["n_contacts"] - 3 * 6
    ens = tmp_path / "har.h5"
    args = ["sample", str(pack), "--full", "--sampler", "hit-and-run", "-n", "12",
            "-o", str(ens), "--quiet"]
    assert main(args) == 0
    assert main(args[:6] + ["24"] + args[7:]) == 0          # rerun with more: continues
    assert main(["ensemble", str(ens), "--json"]) == 0
    e = json.loads(capsys.readouterr().out)
    assert e["n_samples"] == 24 and e["sampler"] == "hit-and-run" and e["eta"] > 0
    assert e["max_violation"] <= 1e-9
    # with its packing: stress and fabric, and the figure. By hand (sum over disks of the
    # contact arms' a (x) f = the floor contacts' p (x) f + sum_i x_i (x) w_i, floor at y = 0,
    # overall torque balance): sigma_yy V = -W sum_i y_i = -(6 + 4 sqrt 3) (W = 1 per disk),
    # sigma_xy = sigma_yx = 0, the same in every network of S; sigma_xx (the floor's
    # friction) varies over S
    fig = tmp_path / "e.png"
    assert main(args[:6] + ["40"] + args[7:]) == 0          # 10 per chain: 5 batches of 2
    assert main(["ensemble", str(ens), "--packing", str(pack), "-o", str(fig), "--json"]) == 0
    e = json.loads(capsys.readouterr().out)
    s = {k: np.array(e["stress"][k]) for k in ("jammed", "min", "max")}
    for k in s:
        assert s[k][1, 1] == pytest.approx(-(6 + 4 * np.sqrt(3)) / e["area_R2"], rel=1e-12)
        assert np.abs(s[k][[0, 1], [1, 0]]).max() < 1e-15
    assert s["max"][0, 0] - s["min"][0, 0] > 1e-4
    assert np.trace(e["fabric"]["jammed"]) == pytest.approx(1.0)
    ci, pf = e["eta_interval"], e["force_distribution"]
    assert ci["low"] < e["eta"] < ci["high"] and ci["batches"] == 20    # 4 chains x 5
    assert pf["mean_f_jammed"] == pytest.approx(1.0)                    # f = fn / <Fn>
    for P in (pf["ensemble"], pf["jammed"]):                            # densities
        assert np.dot(P, np.diff(pf["edges"])) == pytest.approx(1.0)
    assert fig.stat().st_size > 10_000 and fig.with_suffix(".pdf").exists()
    other, _ = pyramid(4, 0.6)
    write_packing(other, tmp_path / "other.h5")
    assert main(["ensemble", str(ens), "--packing", str(tmp_path / "other.h5")]) == 2
    # a pyramid on a floor is a mechanism (its base can roll apart): after a kick the
    # Gauss-Seidel relaxation settles on a moving solution; the walk finishes those
    # samples by the exact projection onto S, counts them, and every sample is in S
    assert main(["sample", str(pack), "--full", "--sampler", "relax", "-n", "5",
                 "-o", str(tmp_path / "r.h5"), "--quiet", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["n_samples"] == 5 and r["max_violation"] <= 1e-9
    assert 1 <= r["n_projected"] <= 5
    assert main(["analyze", str(tmp_path / "missing.h5")]) == 2


def test_eta_of_identical_samples_is_exactly_zero():
    """A determinate S (dim S = 0): every sample is the same network; the mean of k equal
    floats is not always that float, which gave eta ~ 1e-16 instead of 0."""
    from forcespace.measures import eta
    X = np.tile([0.1, 0.7, 0.3, 1 / 3.0], (7, 1))
    assert eta(X) == 0.0


def test_hit_and_run_on_a_determinate_S_reports_eta_0_and_dim_0():
    import forcespace as fs
    from ensemble_cases import grooves
    _, prob = grooves([0.3, 0.5, 0.7], mu=0.0)
    har = fs.HitAndRun(n=20, seed=1).compute(prob)
    assert har.summary()["dim_S"] == 0 and har.ensemble.eta == 0.0


def _column():
    """Ten unit disks stacked on the floor at x = 5 (y = 1, 3, ..., 19; disk 9 on top),
    touching, and a remote disk 10 on the floor at x = 15, touching nothing else."""
    from forcespace.model.packing import BOTTOM, Packing
    x = np.r_[np.full(10, 5.0), 15.0]
    y = np.r_[1.0 + 2.0 * np.arange(10), 1.0]
    a = np.r_[BOTTOM, np.arange(9), BOTTOM]
    b = np.r_[0, np.arange(1, 10), 10]
    return Packing.from_arrays(x, y, np.ones(11), a, b, width=30.0, periodic_x=True,
                               y_bottom=0.0, gravity=1.0)


def test_rearrangement_is_the_connected_displaced_region():
    p = _column()
    d = np.zeros(11)
    d[[7, 8, 9, 10]] = 0.5                  # the top three and the remote disk
    r = measures.rearrangement_depth(p, 9, d)
    assert r.region.tolist() == [7, 8, 9] and r.size == 3 and r.displaced == 4
    assert r.depth == pytest.approx(4.0) and r.floor_gap == pytest.approx(14.0)
    assert not r.reaches_floor
    # the pushed disk did not move: its displaced contact neighbours seed the region
    d[9] = 0.0
    assert measures.displaced_region(p, 9, d).tolist() == [7, 8]
    # a gap in the chain ends the region; displaced disks below it are not part of it
    d = np.zeros(11)
    d[[9, 8, 6, 5]] = 0.3
    r = measures.rearrangement_depth(p, 9, d)
    assert r.region.tolist() == [8, 9] and r.depth == pytest.approx(2.0)
    # only the remote disk moved: no rearrangement around the push (the old measure
    # took its depth, 18 R); at the threshold itself a disk has not moved
    d = np.zeros(11)
    d[10], d[8] = 3.0, 0.1
    r = measures.rearrangement_depth(p, 9, d)
    assert r.size == 0 and r.depth == 0.0 and r.displaced == 1 and not r.reaches_floor
    # the whole column moved: the region reaches the floor (censored), depth 18 R
    d = np.r_[np.full(10, 0.2), 0.0]
    r = measures.rearrangement_depth(p, 9, d)
    assert r.size == 10 and r.depth == pytest.approx(18.0) and r.reaches_floor
    assert r.floor_gap == pytest.approx(0.0)
    # the lowest disk of the region 1.5 R above the floor is in the bottom layer
    p.y[:] += np.r_[np.full(10, 1.5), 0.0]
    d = np.r_[np.full(10, 0.2), 0.0]
    assert measures.rearrangement_depth(p, 9, d).reaches_floor
    assert not measures.rearrangement_depth(p, 9, d, floor_layer=1.0).reaches_floor
    with pytest.raises(InputError):
        measures.rearrangement_depth(p, 9, np.zeros(3))


def _paper_problems():
    import forcespace as fs
    from paths import PACKINGS
    p = fs.read_packing(PACKINGS / "paper_mu0.1.h5")
    return p, fs.full_problem(p), fs.slice_problem(p, 28.0)


def test_stress_tensor_of_the_paper_box_is_its_load_and_the_same_across_S():
    """sigma = (1/V) sum a (x) f over the disks: in the plate-loaded box (zero gravity) the
    vertical stress is the top load per width, -top_force / width, and torque balance
    makes sigma symmetric. Every network of S carries the same loads, so sigma_yy and
    sigma_xy are the same at the Chebyshev centre as in the jammed network (1e-10); the
    lateral stress sigma_xx is not (periodic x: no wall sets it) and changes."""
    p, full, sl = _paper_problems()
    for prob in (full, sl):
        area = measures.region_area(p, prob)
        arms, F, n, fn = measures.network_arms_and_forces(p, prob, prob.x_jammed)
        assert np.abs(np.linalg.norm(arms, axis=1) - 1.5).max() <= 0.5 + 1e-6   # radii in [1, 2]
        sigma = measures.stress_tensor(arms, F, area)
        assert sigma[0, 1] == pytest.approx(sigma[1, 0], abs=1e-9 * np.abs(sigma).max())
        centre = ForceSpace().compute(prob).centre
        other = measures.stress_tensor(*measures.network_arms_and_forces(p, prob, centre)[:2],
                                       area)
        assert np.abs(other[1] - sigma[1]).max() < 1e-10 and abs(other[0, 0] - sigma[0, 0]) > 1e-6
    sigma = measures.stress_tensor(*measures.network_arms_and_forces(p, full, full.x_jammed)[:2],
                                   measures.region_area(p, full))
    assert sigma[1, 1] == pytest.approx(-p.top_force / p.width, rel=1e-6)   # overlaps 2e-7 R


def test_fabric_tensor_and_force_distribution_by_hand():
    n = np.array([[1.0, 0.0], [0.0, 1.0]])
    assert np.allclose(measures.fabric_tensor(n), np.eye(2) / 2)
    th = np.array([0.0, 2 * np.pi / 3, 4 * np.pi / 3])            # three-fold: isotropic
    assert np.allclose(measures.fabric_tensor(np.c_[np.cos(th), np.sin(th)]), np.eye(2) / 2)
    assert np.allclose(measures.fabric_tensor(n, [3.0, 1.0]), np.diag([0.75, 0.25]))
    fn = np.random.default_rng(1).exponential(2.0, 20000)          # <Fn> = 2: P(f) = e^-f
    edges = np.linspace(0, 3, 16)
    P = measures.force_pdf(fn, 2.0, edges)
    assert np.allclose(P, np.histogram(fn / 2.0, edges)[0] / (fn.size * np.diff(edges)))
    mid = 0.5 * (edges[1:] + edges[:-1])
    assert np.abs(P - np.exp(-mid)).max() < 0.05
    with pytest.raises(InputError, match="edges"):
        measures.force_pdf(fn, 2.0, [1.0, 0.5])


@pytest.mark.parametrize("rho", [0.0, 0.6])
def test_eta_interval_covers_the_true_eta(rho):
    """m contacts with fn_i = 1 + a_i u_i, u_i uniform on [-1, 1] (stationary law), ft = 0:
    dF_i = a_i / sqrt(3), |F_i| = 1, so eta = mean(a) / sqrt(3) exactly. 4 chains of 100
    draws, independent (rho = 0) or AR(1)-correlated (rho = 0.6, through a Gaussian copula
    that keeps the uniform law): the 95 % interval covers the true eta in >= 88 % of 200
    runs (batch means absorb the correlation; a naive iid interval would not)."""
    from scipy.stats import norm
    rng = np.random.default_rng(7)
    a = np.linspace(0.1, 0.5, 6)
    true = a.mean() / np.sqrt(3)
    hits = 0
    for _ in range(200):
        z = np.empty((4, 100, a.size))
        z[:, 0] = rng.standard_normal((4, a.size))
        for t in range(1, 100):
            z[:, t] = rho * z[:, t - 1] + np.sqrt(1 - rho ** 2) * rng.standard_normal((4, a.size))
        u = 2 * norm.cdf(z) - 1
        X = np.zeros((400, 2 * a.size))
        X[:, 0::2] = (1 + a * u).reshape(400, a.size)
        ci = measures.eta_interval(X, np.repeat(np.arange(4), 100))
        hits += ci["low"] <= true <= ci["high"]
    assert 0.88 * 200 <= hits <= 200
