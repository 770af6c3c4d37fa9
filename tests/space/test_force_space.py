"""Exact LP analysis of S against hand-derived sets."""
import numpy as np
import pytest

from ensemble_cases import _packing, groove, groove_interval, grooves, lattice_in_box, pyramid
from forcespace.space.force_space import ForceSpace
from forcespace.space.projection import distance_to_S
from forcespace.model.problem import build_problem


@pytest.mark.parametrize("theta,mu", [(np.pi / 6, 0.3), (np.pi / 4, 0.05), (0.3, 1.5)])
def test_groove_interval_exact(theta, mu):
    W = 1.7
    _, prob = groove(theta, mu, W)
    an = ForceSpace(ranges=True).compute(prob)
    lo, hi = groove_interval(theta, mu, W)
    assert an.feasible and an.bounded
    assert an.dim == 1 and an.degree_of_indeterminacy == 1 and an.n_sliding == 0
    assert np.allclose(an.ft_range[0], [lo, hi], rtol=1e-9)
    assert np.allclose(an.ft_range[1], [-hi, -lo], rtol=1e-9)
    N = lambda s: (W - 2 * s * np.sin(theta)) / (2 * np.cos(theta))  # noqa: E731
    assert np.allclose(an.fn_range[0], [N(hi), N(lo)], rtol=1e-9)
    # Chebyshev centre of a segment: its midpoint
    assert np.isclose(an.centre[1], 0.5 * (lo + hi), rtol=1e-8)


def test_frictionless_groove_is_a_point():
    th = np.pi / 5
    _, prob = groove(th, 0.0)
    an = ForceSpace(ranges=True).compute(prob)
    assert an.dim == 0 and an.bounded
    assert an.degree_of_indeterminacy == 0      # 2 unknown fn, ft fixed; rank 2
    assert np.allclose(an.fn_range, 1 / (2 * np.cos(th)))


def test_wedged_groove_is_unbounded_with_a_recession_direction():
    th, mu = np.pi / 3, 1.0                      # mu > cot(60 deg) = 0.577: self-locking
    _, prob = groove(th, mu)
    an = ForceSpace(ranges=True).compute(prob)
    assert an.feasible and an.bounded is False
    d = an.recession_direction
    G, _, _ = prob.inequalities()
    assert np.abs(prob.A @ d).max() < 1e-9 and (G @ d).max() < 1e-9 and d[0::2].sum() > 0
    # by hand: growing N with ft1 = -ft2 = s, s/N = -cot(th) (within the cone: cot < mu)
    assert np.isclose(d[1] / d[0], -1 / np.tan(th), rtol=1e-6)


def test_confined_hexagon_is_unbounded():
    _, prob = lattice_in_box(0.3)
    assert ForceSpace(ranges=True).compute(prob).bounded is False


def test_infeasible_cluster_reports_the_unbalanced_disks():
    p, _ = pyramid(4, 0.5)
    p.mu = 0.1                                   # too little friction to hold the pyramid
    n = p.n_disks
    prob = build_problem(p, np.ones(n, bool), (-1,), "test", rattlers=np.zeros(n, bool))
    an = ForceSpace(ranges=True).compute(prob)
    assert not an.feasible
    info = an.infeasibility
    assert info["min_total_imbalance"] > 0.1 and len(info["unbalanced_disks"]) >= 1


def test_load_along_one_normal_forces_the_other_contact_to_zero():
    """Groove loaded through its centre along contact 2's normal (by a fixed
    load contact from an outside disk): contact 1 must carry zero force, s = 0."""
    th = np.pi / 6
    L = 1.0
    n2 = np.array([-np.sin(th), np.cos(th)])     # normal of contact 2 (support 2 -> disk)
    # outside disk 3 at disk0 + 2 n2 pushes disk 0 along -n2 (towards support 2)
    x = [0.0, -2 * np.sin(th), 2 * np.sin(th), 2 * n2[0]]
    y = [2 * np.cos(th), 0.0, 0.0, 2 * np.cos(th) + 2 * n2[1]]
    p = _packing(x, y, np.ones(4), [1, 2, 3], [0, 0, 0], [0.0, L, L], [0.0, 0.0, 0.0],
                 0.4, gravity=0.0)
    interior = np.array([True, False, False, False])
    support = np.array([False, True, True, False])
    prob = build_problem(p, interior, (), "test", support_mask=support,
                         rattlers=np.zeros(4, bool))
    assert list(prob.load_contacts) == [2]
    an = ForceSpace(ranges=True).compute(prob)
    assert an.dim == 0 and an.n_zero == 1 and list(an.zero_contacts) == [0]
    assert np.allclose(an.fn_range[1], L) and np.allclose(an.ft_range, 0.0, atol=1e-12)


def test_projection_onto_groove_segment_is_exact():
    th, mu, W = np.pi / 6, 0.3, 1.0
    _, prob = groove(th, mu, W)
    lo, hi = groove_interval(th, mu, W)
    s_, c_ = np.sin(th), np.cos(th)
    # S = {p0 + s q, s in [lo, hi]}: fn = (W - 2 s sin)/(2 cos) on both, ft = (s, -s)
    p0 = np.array([W / (2 * c_), 0, W / (2 * c_), 0])
    q = np.array([-s_ / c_, 1, -s_ / c_, -1])
    rng = np.random.default_rng(3)
    for _ in range(5):
        xh = p0 + rng.normal(scale=0.5, size=4)
        s = np.clip(q @ (xh - p0) / (q @ q), lo, hi)
        exact = p0 + s * q
        res = distance_to_S(prob, xh)
        assert np.allclose(res.nearest, exact, atol=1e-12)
        assert np.isclose(res.absolute, np.linalg.norm(xh - exact), rtol=1e-10)
        assert np.isclose(res.relative, res.absolute / (prob.force_scale * np.sqrt(2)))
    inside = p0 + 0.5 * (lo + hi) * q
    assert distance_to_S(prob, inside).absolute < 1e-12
    text = repr(res)                    # its numbers, not the nearest network's entries
    assert f"relative={res.relative:.3e} <Fn>" in text and "nearest=<4 forces>" in text
    assert "[" not in text and len(text) < 300     # before: every entry of nearest


def test_projection_in_a_14_dimensional_S_satisfies_kkt():
    _, prob = pyramid(4, 0.5)
    rng = np.random.default_rng(0)
    xh = prob.x_jammed + rng.normal(scale=prob.force_scale, size=prob.n_columns)
    res = distance_to_S(prob, xh)
    assert res.max_violation < 1e-9 and res.kkt_residual < 1e-9
    # no feasible point is closer: compare with points of S on segments to the projection
    c = ForceSpace().compute(prob).centre
    for t in np.linspace(0, 1, 11):
        y = (1 - t) * res.nearest + t * c        # convex combination stays in S
        assert np.linalg.norm(y - xh) >= res.absolute - 1e-12


def test_two_grooves_have_product_structure():
    _, prob = grooves([0.4, 0.6], 0.2)
    an = ForceSpace(ranges=True).compute(prob)
    assert an.dim == 2 and an.degree_of_indeterminacy == 2 * 4 - 3 * 2


def test_l1_nearest_network_on_the_groove_segment_is_exact():
    from forcespace.space.projection import l1_nearest
    th, mu, W = np.pi / 6, 0.3, 1.0
    _, prob = groove(th, mu, W)
    lo, hi = groove_interval(th, mu, W)
    p0 = np.array([W / (2 * np.cos(th)), 0, W / (2 * np.cos(th)), 0])
    q = np.array([-np.tan(th), 1, -np.tan(th), -1])
    s_grid = np.linspace(lo, hi, 200001)
    rng = np.random.default_rng(5)
    for _ in range(4):
        xh = p0 + rng.normal(scale=0.5, size=4)
        y = l1_nearest(prob, xh)
        assert prob.violation(y) <= 1e-12                     # exactly in S ...
        best = np.abs(p0 + s_grid[:, None] * q - xh).sum(1).min()
        assert np.abs(y - xh).sum() == pytest.approx(best, abs=1e-5)   # ... and L1-nearest
