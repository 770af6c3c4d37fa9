"""Rounding ellipsoids: the exact MVE (interior point) and its Lewis-weight
approximation (john_ellipsoid) against hand-derived ellipsoids and each other."""
import numpy as np
import pytest

from forcespace.errors import InputError
from forcespace.sampling.rounding import john_ellipsoid, mve, mve_rounding


def _log_volume(E2):
    return 0.5 * np.linalg.slogdet(E2)[1]


def _inscribed(H, s, c, E2):
    """max_i |E2^{1/2} h_i| / (s_i - h_i c): <= 1 iff the ellipsoid is inside."""
    return float((np.sqrt(((H @ E2) * H).sum(1)) / (s - H @ c)).max())


@pytest.mark.parametrize("solver", [mve, john_ellipsoid])
def test_box_gives_its_axis_aligned_ellipse(solver):
    """Box |y_j| <= a_j, started off-centre: the MVE is centred, semi-axes a_j."""
    a = np.array([1.0, 3.0, 0.2, 7.0])
    H = np.vstack([np.eye(4), -np.eye(4)])
    s = np.r_[a, a]
    c, E2, ok, _ = solver(H, s, 0.3 * a)
    assert ok
    assert np.abs(c / a).max() < 1e-3               # centred to the solvers' tolerance
    assert np.allclose(E2, np.diag(a ** 2), rtol=0.05, atol=1e-3 * a.min() ** 2)


@pytest.mark.parametrize("d", [2, 5, 12])
def test_simplex_is_rounded_exactly_by_both(d):
    """Simplex {y >= 0, sum y <= 1}: the MVE is centred at 1/(d+1); the
    approximation must agree with the interior point (affine image of a regular
    simplex: equal Lewis weights are John's fixed point)."""
    H = np.vstack([-np.eye(d), np.ones((1, d))])
    s = np.r_[np.zeros(d), 1.0]
    y0 = np.full(d, 0.5 / d)
    c1, E1, ok1, _ = mve(H, s, y0)
    c2, E2, ok2, _ = john_ellipsoid(H, s, y0)
    assert ok1 and ok2
    assert np.allclose(c2, 1.0 / (d + 1), rtol=1e-3)
    assert np.allclose(c1, c2, rtol=1e-3)
    assert abs(_log_volume(E2) - _log_volume(E1)) / d < 1e-3
    assert _inscribed(H, s, c2, E2) <= 1 + 1e-9


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("shape", [(6, 40), (25, 300)])
def test_john_ellipsoid_is_inscribed_and_near_the_mve(seed, shape):
    """Random polytopes with row norms spread over 10x and an anisotropic axis
    scale (1 to 1e3): the approximation lies inside, is no larger than the MVE,
    and its axes are within a few per cent of the MVE's (geometric mean)."""
    d, p = shape
    rng = np.random.default_rng(seed)
    H = rng.normal(size=(p, d)) * (1 + 9 * rng.random((p, 1)))
    H = H @ np.diag(np.logspace(0, 3, d))
    s = 1 + 3 * rng.random(p)
    c1, E1, ok1, _ = mve(H, s, np.zeros(d))
    c2, E2, ok2, _ = john_ellipsoid(H, s, np.zeros(d))
    assert ok1 and ok2
    assert _inscribed(H, s, c2, E2) <= 1 + 1e-9
    gap = (_log_volume(E2) - _log_volume(E1)) / d
    assert -0.05 <= gap <= 1e-6


def test_rounding_refuses_an_exterior_start_and_an_unknown_method():
    H = np.vstack([np.eye(2), -np.eye(2)])
    s = np.ones(4)
    with pytest.raises(InputError, match="strictly inside"):
        john_ellipsoid(H, s, np.array([1.0, 0.0]))
    with pytest.raises(InputError, match="method"):
        mve_rounding(H, s, np.zeros(2), method="covariance")


@pytest.mark.parametrize("miss", [-4e-16, 0.0, 4e-16])
def test_a_round_whose_centre_sits_on_a_facet_is_rejected_whatever_the_sign(monkeypatch, miss):
    """An unconverged MVE round whose centre lies on a facet up to round-off (slack -3e-19
    or +3e-19 on the n = 400 slice, the sign set by the BLAS thread count): a centre at
    +3e-19 used to be accepted, the next round started on the facet and its ellipsoid was
    indefinite ("not positive definite"). Here the MVE of the box |y_j| <= a_j is shifted
    onto the facet y_0 = a_0 (slack: miss, two ulp of a_0 either side or 0): the round is rejected whatever the sign, John's
    rounding takes over, and the map sends the box's centre to w = 0 with its axes a_j."""
    from forcespace.sampling import rounding
    a = np.array([1.0, 3.0, 0.2])
    H = np.vstack([np.eye(3), -np.eye(3)])
    s = np.r_[a, a]

    def drifted(H_, s_, y0, **kw):
        c, E2, _, it = mve(H_, s_, y0, **kw)
        c = c.copy()
        c[0] = (s_[0] - miss) / H_[0, 0]
        return c, E2, False, it
    monkeypatch.setattr(rounding, "mve", drifted)
    shift, L, info = mve_rounding(H, s, np.full(3, 0.1), method="mve")
    assert info["fallback_from"]["rejected_round"] == 1
    assert info["fallback_from"]["rejected_clearance"] < 1e-3 and info["method"] == "john"
    assert np.abs(shift).max() < 1e-3 * a.min()
    assert np.allclose(np.sort(np.linalg.svd(L, compute_uv=False)), np.sort(a), rtol=0.05)


def test_a_round_with_an_indefinite_ellipsoid_is_rejected_not_raised(monkeypatch):
    """A later round whose solver hands back an indefinite or non-finite E2 (round-off in
    a start on a facet) is rejected: the earlier rounds are kept, no exception."""
    from forcespace.sampling import rounding
    H = np.vstack([np.eye(2), -np.eye(2)]) @ np.diag([1.0, 1e-4])
    s = np.ones(4)
    calls = []

    def second_bad(H_, s_, y0, **kw):
        calls.append(1)
        c, E2, ok, it = mve(H_, s_, y0, **kw)
        return (c, E2, False, it) if len(calls) == 1 else (c, np.diag([1.0, -1.0]), ok, it)
    monkeypatch.setattr(rounding, "mve", second_bad)
    shift, L, info = mve_rounding(H, s, np.zeros(2), ratio=1.0 + 1e-12, method="mve")
    assert info["rounds"] == 1 and info["rejected_round"] == 2
    assert np.allclose(np.sort(np.abs(np.linalg.eigvalsh(L @ L.T))), [1.0, 1e8], rtol=1e-3)


def test_lewis_rounding_proves_a_polytope_bounded_and_never_an_unbounded_one():
    """Issue 46: lewis_rounding's info["bounded"] (a Newton decrement of the barrier below
    1 at its centre: the barrier has a minimiser, so the polytope is bounded). A box and a
    simplex are proven bounded; {y >= -1} (every Newton direction meets no facet) is a
    NumericalError; a wedge {y1 >= -1, y2 >= -1, y1 - y2 <= 1, y2 - y1 <= 1} (unbounded
    along (1, 1), the Newton directions blocked) is never proven bounded."""
    from forcespace.errors import NumericalError
    from forcespace.sampling.rounding import lewis_rounding

    for H, s in ((np.vstack([np.eye(3), -np.eye(3)]), np.r_[1.0, 2.0, 0.5, 1.0, 2.0, 0.5]),
                 (np.vstack([-np.eye(4), np.ones((1, 4))]), np.r_[np.zeros(4), 1.0] + 0.1)):
        for updates, centred in ((0, 1e-2), (5, 1e-6)):
            _, _, info = lewis_rounding(H, s, np.zeros(H.shape[1]), max_updates=updates,
                                        centred=centred)
            assert info["bounded"] is True
    with pytest.raises(NumericalError, match="unbounded"):
        lewis_rounding(-np.eye(3), np.ones(3), np.zeros(3), max_updates=0)
    wedge = np.array([[-1.0, 0.0], [0.0, -1.0], [1.0, -1.0], [-1.0, 1.0]])
    try:
        _, _, info = lewis_rounding(wedge, np.ones(4), np.zeros(2), max_updates=0,
                                    max_newton=40, centred=1e-2)
    except NumericalError:
        return
    assert info["bounded"] is None


def test_lewis_rounding_maps_the_rows_it_rounds():
    """Issue 46: lewis_rounding(mapped=True) returns H Lc from its leverage pass (rows
    zero to round-off by a product): equal to the product to round-off."""
    from forcespace.sampling.rounding import lewis_rounding

    rng = np.random.default_rng(3)
    H = rng.normal(size=(60, 7))
    H[5] = 1e-20                                     # a row the rounding drops
    s = 1.0 + rng.random(60)
    c, Lc, info, HL = lewis_rounding(H, s, np.zeros(7), max_updates=2, mapped=True)
    c2, Lc2, _ = lewis_rounding(H, s, np.zeros(7), max_updates=2)
    assert np.array_equal(c, c2) and np.array_equal(Lc, Lc2)
    np.testing.assert_allclose(HL, H @ Lc, rtol=0, atol=1e-13 * np.abs(H @ Lc).max())
    assert HL.flags.c_contiguous and info["bounded"] is True
    # the frame rounded with them: T = N Lc by the triangular product, the same frame
    from forcespace.sampling.frame import Frame

    N = np.linalg.qr(rng.normal(size=(20, 7)))[0]
    fr = Frame(rng.normal(size=20), N, H, s, np.arange(60), None)
    ref, new = fr.rounded(c, Lc, 2.0), fr.rounded(c, Lc, 2.0, 2.0 * HL)
    for a, b in zip(ref, new):
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-13 * np.abs(a).max())
    assert new[1].flags.c_contiguous
