"""S of spheres analysed exactly (circular Coulomb cones, Clarabel): hand-made cases with S
known in closed form (ranges, dim, the inscribed ball), friction going to zero, contacts at
a cone's apex or on one ray of it, S a single point, empty or unbounded."""
import numpy as np
import pytest
from cases import conic_problem, sphere_on_supports

from forcespace.errors import InputError
from forcespace.space import conic
from forcespace.space.force_space import ForceSpace

P, H = 3.0, 2.0      # vertical and horizontal loads [F0]


abstract = conic_problem


def lens(shift, mu=1.0):
    """Two contacts with fn = 1 each and tangential forces summing to (shift, 0): f_t of
    the first lies in the lens of the discs |f| <= mu and |f - (shift, 0)| <= mu."""
    rows = np.zeros((4, 6))
    rows[0, 0] = rows[1, 3] = 1.0
    rows[2, [1, 4]] = rows[3, [2, 5]] = 1.0
    return abstract(rows, [1.0, 1.0, shift, 0.0], [mu, mu])


def analysed(prob, **kw):
    S = ForceSpace(ranges=True, **kw).compute(prob)
    assert S.success, S.message
    return S


def test_a_disc_one_normal_force_fixed():
    prob = abstract([[1.0, 0, 0]], [2.0], [0.4])
    S = analysed(prob)
    assert S.feasible and S.bounded and S.dim == 2
    np.testing.assert_allclose(S.fn_range, [[2.0, 2.0]], atol=1e-8)
    np.testing.assert_allclose(S.ft_range, [[0.0, 0.8]], atol=1e-7)
    assert S.radius == pytest.approx(0.8, abs=1e-7)          # the disc itself
    np.testing.assert_allclose(S.centre, [2.0, 0.0, 0.0], atol=1e-7)
    d = S.distance(np.array([2.0, 1.6, 0.0]))
    assert d.absolute == pytest.approx(0.8, abs=1e-7)
    np.testing.assert_allclose(d.nearest, [2.0, 0.8, 0.0], atol=1e-7)


def test_a_lens_of_two_cones():
    S = analysed(lens(1.5))
    assert S.dim == 2 and S.n_sliding == 0 and S.n_zero == 0
    # |f_t| of either contact: nearest point of the lens (0.5, 0), farthest its arc at 1
    np.testing.assert_allclose(S.ft_range, [[0.5, 1.0], [0.5, 1.0]], atol=1e-7)
    np.testing.assert_allclose(S.fn_range, [[1.0, 1.0], [1.0, 1.0]], atol=1e-8)
    # the largest disc in the lens: radius 0.25 about (0.75, 0); a move y in the hull
    # moves f_t of each contact by y / sqrt 2, so the radius in x is 0.25 sqrt 2
    assert S.radius == pytest.approx(0.25 * np.sqrt(2), abs=1e-7)
    np.testing.assert_allclose(S.centre[[1, 2, 4, 5]], [0.75, 0, 0.75, 0], atol=1e-7)


def test_two_cones_touching_make_s_one_point_with_both_contacts_on_a_ray():
    # |f| <= 1 and |f - (2, 0)| <= 1 meet in one point: both cones are entered on one ray
    # only, two linear equalities each; the equilibrium rows alone would leave dim 2
    S = analysed(lens(2.0))
    assert S.dim == 0
    assert S.implicit == [(0, "ray"), (1, "ray")]
    np.testing.assert_array_equal(S.sliding_contacts, [0, 1])
    np.testing.assert_allclose(S.affine_point, [1, 1, 0, 1, 1, 0], atol=1e-4)
    assert S.radius == 0.0
    assert not analysed(lens(2.1)).feasible


def test_the_empty_s_names_the_rows_that_need_a_load():
    S = ForceSpace().compute(lens(2.5))
    assert S.success and not S.feasible
    assert S.infeasibility["min_total_imbalance"] == pytest.approx(0.5, abs=1e-6)


def with_supports(pos, r, mu, load):
    """Sphere ``len(r) - 1`` held by the others (fixed supports) under ``load`` (3,) [F0]."""
    return sphere_on_supports(pos, r, mu, load)[1]


def corner(mu, horizontal=H):
    """A sphere on a floor sphere and against a wall sphere (normals +z and +x), pressed
    down by P and into the wall by ``horizontal``. Its balance leaves one free number tau,
    the floor's friction along x = the wall's along z: fn_floor = P - tau,
    fn_wall = horizontal - tau, with |tau| <= mu fn at both."""
    pos = np.array([[25.0, 25.0, 1.0], [23.0, 25.0, 3.0], [25.0, 25.0, 3.0]])
    return with_supports(pos, np.ones(3), mu, np.array([-horizontal, 0.0, -P]))


def test_a_sphere_in_a_corner_closed_form_ranges():
    mu = 0.5
    S = analysed(corner(mu))
    # tau in [-mu H / (1 - mu), mu H / (1 + mu)] = [-2, 2/3] (the wall's cone, H < P)
    lo, hi = -mu * H / (1 - mu), mu * H / (1 + mu)
    assert S.dim == 1 and S.bounded
    np.testing.assert_allclose(S.fn_range, [[P - hi, P - lo], [H - hi, H - lo]], atol=1e-7)
    np.testing.assert_allclose(S.ft_range, [[0, -lo], [0, -lo]], atol=1e-7)
    assert S.max_sum_fn == pytest.approx(P + H - 2 * lo, abs=1e-7)
    assert S.contains(S.centre) and 0 < S.radius <= 2 * (hi - lo) / 2 + 1e-9


@pytest.mark.parametrize("mu", [0.0, 1e-3, 1e-6])
def test_without_friction_s_is_the_frictionless_point(mu):
    S = analysed(corner(mu))
    assert S.dim == (0 if mu == 0 else 1)
    np.testing.assert_allclose(S.fn_range[:, 0], [P, H], atol=2 * mu * H + 1e-8)
    width = np.ptp(S.fn_range, axis=1)
    # the range of fn shrinks as mu: 2 mu H / (1 - mu^2), a point at mu = 0
    np.testing.assert_allclose(width, 2 * mu * H / (1 - mu ** 2), atol=1e-8)
    np.testing.assert_allclose(S.ft_range[:, 1], mu * H / (1 - mu), atol=1e-8)


def test_a_contact_at_the_apex_makes_s_one_point():
    # no horizontal load: the wall can push only by friction below mu = 1, so tau = 0
    # and the wall contact carries nothing on all of S (three equalities: dim 0, where
    # the balance rows alone leave a line)
    prob = corner(0.5, horizontal=0.0)
    S = analysed(prob)
    assert S.dim == 0 and S.implicit == [(1, "apex")]
    np.testing.assert_array_equal(S.zero_contacts, [1])
    assert S.summary()["contacts_at_the_apex"] == [1] and S.summary()["n_zero_force"] == 1
    np.testing.assert_allclose(S.affine_point, [P, 0, 0, 0, 0, 0], atol=1e-6)
    assert S.degree_of_indeterminacy == 1


def test_a_wedged_sphere_is_unbounded():
    # between two walls (normals +x, -x) under a vertical load: fn >= P / (2 mu), no top
    pos = np.array([[23.0, 25.0, 5.0], [27.0, 25.0, 5.0], [25.0, 25.0, 5.0]])
    prob = with_supports(pos, np.ones(3), 0.5, np.array([0.0, 0.0, -P]))
    S = analysed(prob, centre=True)
    assert not S.bounded and S.dim == 1
    d = S.recession_direction
    assert d[0] == pytest.approx(d[3]) and d[0] > 0
    np.testing.assert_allclose(S.fn_range, [[P, np.inf], [P, np.inf]], atol=1e-7)


def test_spheres_refuse_what_is_still_two_dimensional():
    S = analysed(lens(1.5))
    with pytest.raises(InputError, match="disks only"):
        S.domains


def test_a_jammed_sphere_packing_its_s_holds_the_jammed_network():
    from pathlib import Path

    from forcespace.io.packing_file import read_packing
    from forcespace.model.sphere_problem import sphere_full_problem
    p = read_packing(Path(__file__).parents[1] / "data" / "quick3d_mu0.3.h5")
    prob = sphere_full_problem(p)
    S = ForceSpace().compute(prob)
    assert S.success and S.feasible and S.bounded
    assert 0 < S.dim <= S.degree_of_indeterminacy
    assert S.dim == S.degree_of_indeterminacy - 2 * S.n_sliding - 3 * S.n_zero
    assert S.contains(prob.x_jammed) and S.contains(S.centre) and S.radius > 0
    # every network of S lies in its affine hull: the jammed one too
    xa, N = S.affine_point, S.affine_basis
    off = prob.x_jammed - xa - N @ (N.T @ (prob.x_jammed - xa))
    assert np.abs(off).max() <= 1e-8 * prob.force_scale
    assert S.distance(prob.x_jammed).absolute == 0.0
    # a network pushed out of S: its nearest point is in S and no farther than the jammed
    x = prob.x_jammed.copy()
    x[0::3] *= 1.1
    d = S.distance(x)
    assert S.contains(d.nearest) and 0 < d.absolute < np.linalg.norm(x - prob.x_jammed)
    assert d.absolute == pytest.approx(np.linalg.norm(x - d.nearest))


def test_inscribed_pyramids_converge_to_the_cones_ranges():
    # the corner sphere's fn ranges, each cone replaced by an inscribed k-sided pyramid:
    # inside the conic range, short of it by about 1 - cos(pi / k) of its width
    prob = corner(0.5)
    exact = analysed(prob).fn_range
    gaps = []
    for k in (8, 16, 32):
        rng = conic.pyramid_fn_ranges(prob, k)
        assert np.all(rng[:, 0] >= exact[:, 0] - 1e-9) and np.all(rng[:, 1] <= exact[:, 1] + 1e-9)
        gap = np.abs(rng - exact).max() / np.ptp(exact, axis=1).max()
        assert gap <= 3 * (1 - np.cos(np.pi / k))
        gaps.append(gap)
    assert gaps[0] > gaps[1] > gaps[2] > 0


def tilted_ellipse():
    """Two contacts: f_t of the second in its unit disc (fn = 1, mu = 1), f_t of the first
    = c + M f_t(second) (fn = 10, its cone never binding): the projection of S onto the
    first's tangent plane is the ellipse c + M (unit disc), M a rotation by 30 degrees of
    diag(2, 0.5), c = (0.2, 0.1). Returns the problem and max |f_t| of the first by dense
    sampling of the ellipse's boundary (independent of the SOCPs)."""
    rot = np.array([[np.cos(np.pi / 6), -np.sin(np.pi / 6)], [np.sin(np.pi / 6), np.cos(np.pi / 6)]])
    M, c = rot @ np.diag([2.0, 0.5]), np.array([0.2, 0.1])
    rows = np.zeros((4, 6))
    rows[0, 0] = rows[1, 3] = 1.0
    rows[2, 1], rows[2, [4, 5]] = 1.0, -M[0]
    rows[3, 2], rows[3, [4, 5]] = 1.0, -M[1]
    t = np.linspace(0, 2 * np.pi, 2_000_001)
    edge = c[:, None] + M @ np.vstack([np.cos(t), np.sin(t)])
    return abstract(rows, [10.0, 1.0, *c], [1.0, 1.0]), float(np.hypot(*edge).max())


def test_max_tangential_force_over_an_ellipse_none_of_the_start_directions_reaches():
    # the farthest point of the ellipse is at no multiple of 90 degrees: the bounds must
    # refine towards it (after the 4 starting support points alone it is missed by > 0.01)
    prob, truth = tilted_ellipse()
    unit = prob.scaled(1.0)
    faces, _ = conic.facial_reduction(unit)
    lo, hi = conic.ft_range(unit, faces, 0)
    assert lo == pytest.approx(0.0, abs=1e-7)       # the origin is inside the ellipse
    assert hi == pytest.approx(truth, abs=2e-7)
    assert conic.ft_range(unit, faces, 0, max_socps=4)[1] < truth - 0.01
    # the upper bound mu fn_max closes the range at once where a known point reaches it
    assert conic.ft_range(unit, faces, 1, fn_max=1.0, points=[np.array([0.6, 0.8])]) \
        == pytest.approx((0.0, 1.0), abs=1e-7)


def test_outer_polygon_of_four_support_lines_is_the_square():
    v = conic.outer_vertices(np.arange(4) * np.pi / 2, np.ones(4))
    np.testing.assert_allclose(v, [[1, 1], [-1, 1], [-1, -1], [1, -1]], atol=1e-12)


def test_max_tangential_force_bounds_agree_with_the_support_ascent_on_a_packing():
    # the certified bounds against the first method (a local ascent from 4 directions) on
    # a jammed packing's contacts: equal to FT_MAX_TOL, never below it by more
    from pathlib import Path

    from forcespace.io.packing_file import read_packing
    from forcespace.model.sphere_problem import sphere_full_problem
    prob = sphere_full_problem(read_packing(Path(__file__).parents[1] / "data"
                                            / "quick3d_mu0.3.h5"))
    unit = prob.scaled(1.0 / prob.force_scale)
    faces, _ = conic.facial_reduction(unit)
    S = ForceSpace().compute(prob)
    moving = np.flatnonzero(np.linalg.norm(S.affine_basis.reshape(prob.n_contacts, 3, -1),
                                           axis=(1, 2)) > 1e-9)
    for j in np.random.default_rng(1).choice(moving, 4, replace=False):
        points = []
        fn = conic.fn_range(unit, faces, j, points)
        new = conic.ft_range(unit, faces, j, fn[1], points)
        old = conic.ft_range_ascent(unit, faces, j)
        assert new[0] == old[0]
        assert new[1] == pytest.approx(old[1], abs=conic.FT_MAX_TOL)
