"""Statics of spheres: hand-derived 3-D networks, solved by the conic program (Clarabel) and
by the engine's frozen Gauss-Seidel relaxation, and the equilibrium matrix against the
force sums it must agree with."""
import numpy as np
import pytest
from cases import sphere_on_supports

from forcespace.engine.frozen import frozen_contacts3, relax
from forcespace.errors import InputError
from forcespace.model.sphere_packing import SpherePacking
from forcespace.model.sphere_problem import (build_sphere_problem, sphere_full_problem,
                                             sphere_plate_problem, tangent_frame)
from forcespace.model.walls import BOTTOM, TOP
from forcespace.space.conic import nearest_admissible

P = 3.0          # the vertical load on the top sphere [F0]


def on_supports(pos, r, top, mu):
    """Sphere ``top`` (the last) resting on the others, which are fixed supports; a
    downward load P on it (b = -(loads): +P in its z row)."""
    return sphere_on_supports(pos, r, mu, (0.0, 0.0, -P))


def relaxed(prob, tol=1e-12, seed=0):
    """The frozen network of ``prob`` relaxed by Gauss-Seidel sweeps from zero forces to
    ``tol`` of its violation; returns the problem vector x (3m,)."""
    system = frozen_contacts3(prob)
    m = prob.n_contacts
    rn, rt = np.zeros(m), np.zeros((m, 3))

    def as_x(rn, rt):
        x = np.empty(3 * m)
        x[0::3] = rn
        x[1::3] = (rt * prob.frame[:, 1]).sum(1)
        x[2::3] = (rt * prob.frame[:, 2]).sum(1)
        return x
    res = relax(system, rn, rt, lambda rn, rt: prob.violation(as_x(rn, rt)), tol, 200000,
                seed, chunk=50)
    assert res.converged, res.message
    return as_x(rn, rt)


def three_below(r=1.0):
    d = 2 * r / np.sqrt(3)                     # base centres on a circle of radius d
    base = [(d * np.cos(a), d * np.sin(a), r) for a in np.deg2rad([90, 210, 330])]
    top = (0.0, 0.0, r + np.sqrt(4 * r * r - d * d))
    return np.array(base + [top]) + (25.0, 25.0, 0.0), np.full(4, r)


def test_a_sphere_on_three_carries_its_load_by_symmetry():
    # three contacts, normals at sin(theta) = sqrt(2/3) to the horizontal: 3 fn n_z = P
    pos, r = three_below()
    _, prob = on_supports(pos, r, 3, mu=0.0)
    assert prob.A.shape == (6, 9)            # 6 equations per sphere, 3 unknowns per contact
    want = P / np.sqrt(6)
    x = nearest_admissible(prob).x
    np.testing.assert_allclose(x[0::3], want, rtol=1e-9)
    np.testing.assert_allclose(x[1::3], 0.0, atol=0)
    x = relaxed(prob)
    np.testing.assert_allclose(x[0::3], want, rtol=1e-10)


def test_with_friction_the_symmetric_network_is_one_point_of_a_larger_S():
    pos, r = three_below()
    _, prob = on_supports(pos, r, 3, mu=0.5)
    sym = np.zeros(9)
    sym[0::3] = P / np.sqrt(6)
    assert prob.violation(sym) <= 1e-15
    # 9 unknowns, 6 independent equations: S is 3-dimensional, and Gauss-Seidel from
    # zero forces ends on another admissible point (friction used)
    assert np.linalg.matrix_rank(prob.A.toarray()) == 6
    x = relaxed(prob)
    assert prob.violation(x) <= 1e-12
    assert np.abs(x[1::3]).max() + np.abs(x[2::3]).max() > 1e-3


def square_pyramid(r=1.0):
    base = [(sx * r, sy * r, r) for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
    top = (0.0, 0.0, r + np.sqrt(2.0) * r)     # 2r from each base centre
    return np.array(base + [top]) + (25.0, 25.0, 0.0), np.full(5, r)


def test_a_square_pyramid_of_five_is_indeterminate_along_one_line():
    # frictionless: x and y balance give f1 = f3, f2 = f4; z balance (f1+f2+f3+f4)/sqrt2 = P
    pos, r = square_pyramid()
    _, prob = on_supports(pos, r, 4, mu=0.0)
    for x in (nearest_admissible(prob).x, relaxed(prob, seed=1), relaxed(prob, seed=5)):
        f = x[0::3]
        assert f[0] == pytest.approx(f[2], abs=1e-10)
        assert f[1] == pytest.approx(f[3], abs=1e-10)
        assert f[0] + f[1] == pytest.approx(P / np.sqrt(2), rel=1e-10)
        assert f.min() >= 0
    # the smallest network of that line (nearest to 0) is the symmetric one
    x = nearest_admissible(prob, target=np.zeros(prob.n_columns)).x
    np.testing.assert_allclose(x[0::3], P / (2 * np.sqrt(2)), rtol=1e-8)
    # the extreme networks f1 = 0 and f2 = 0 are admissible, beyond them not
    edge = np.zeros(12)
    edge[[0, 6]] = P / np.sqrt(2)
    assert prob.violation(edge) <= 1e-15
    edge[[0, 6]] *= 1.001
    edge[[3, 9]] = -0.001 * P / np.sqrt(2)
    assert prob.violation(edge) > 1e-4


def column(radii, gravity, mu, load=P):
    """A vertical column of spheres between the plates, the top plate loaded."""
    z = np.cumsum(radii) + np.cumsum(np.r_[0.0, radii[:-1]])
    pos = np.column_stack([np.full(len(radii), 5.0), np.full(len(radii), 5.0), z])
    n = len(radii)
    a = [BOTTOM] + list(range(n - 1)) + [n - 1]
    b = [0] + list(range(1, n)) + [TOP]
    return SpherePacking.from_arrays(pos, radii, a, b, fn=np.ones(n + 1), lateral=(10, 10),
                                     z_bottom=0.0, z_top=2 * radii.sum(), top_force=load,
                                     gravity=gravity, density=1.0, mu=mu, plate_mu=mu)


@pytest.mark.parametrize("mu", [0.0, 0.7])
def test_a_column_between_plates_carries_the_load_and_the_weight_above_each_contact(mu):
    radii = np.array([1.0, 1.6, 1.2, 1.9, 1.4])
    p = column(radii, gravity=0.3, mu=mu)
    weight = 0.3 * 4.0 / 3.0 * np.pi * radii**3
    # contact k supports the plate and every sphere above it; no tangential force (a
    # sphere's x balance and torque balance give ft_below = ft_above = -ft_above)
    want = P + np.r_[np.cumsum(weight[::-1])[::-1], 0.0]
    prob = sphere_plate_problem(p)
    assert prob.n_contacts == 6 and prob.A.shape == (31, 18)
    assert np.linalg.matrix_rank(prob.A.toarray()) == 18     # determinate: S is one point
    for x in (nearest_admissible(prob).x, relaxed(prob)):
        np.testing.assert_allclose(x[0::3], want, rtol=1e-10)
        np.testing.assert_allclose(x[1::3], 0.0, atol=1e-10 * P)
        np.testing.assert_allclose(x[2::3], 0.0, atol=1e-10 * P)


def test_the_equilibrium_matrix_is_the_force_and_torque_sums():
    # an independent assembly: A x - b is the net force and torque/r of every interior
    # sphere computed by SpherePacking.net_forces for the same (random) forces
    rng = np.random.default_rng(3)
    pos, r = square_pyramid()
    pos = np.vstack([pos, pos[4] + (0.0, 0.0, 2.0)])       # a sixth sphere on the top one
    r = np.append(r, 1.0)
    a, b = [0, 1, 2, 3, 4, BOTTOM, BOTTOM], [4, 4, 4, 4, 5, 0, 1]
    p = SpherePacking.from_arrays(pos, r, a, b, lateral=(50, 50), mu=0.5, plate_mu=0.5,
                                  z_bottom=0.0, gravity=0.2)
    t1, t2 = tangent_frame(p.normal)
    fn = rng.uniform(0.5, 2, 7)
    ft = rng.normal(size=(7, 1)) * t1 + rng.normal(size=(7, 1)) * t2
    p = p.with_forces(fn, ft)
    prob = sphere_full_problem(p)
    assert prob.n_interior == 6
    x = prob.forces_from_packing(fn, ft)
    force, torque, _ = p.net_forces()
    want = np.concatenate([force, torque / r[:, None]], axis=1).ravel()
    np.testing.assert_allclose(prob.A @ x - prob.b, want, atol=1e-13)
    back_fn, back_ft = prob.to_packing_forces(x)
    np.testing.assert_allclose(back_ft, ft, atol=1e-15)
    np.testing.assert_array_equal(back_fn, fn)


def test_a_sphere_packing_is_refused_by_the_disks_problem_in_one_line():
    from forcespace.model.problem import full_problem
    pos, r = three_below()
    p, _ = on_supports(pos, r, 3, mu=0.0)
    with pytest.raises(InputError, match="dimension"):
        full_problem(p)


def rotation(seed):
    """A random proper rotation matrix (3, 3)."""
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


@pytest.mark.parametrize("seed", [1, 2])
def test_a_rotated_pyramid_under_the_rotated_load_carries_the_same_normal_forces(seed):
    # statics has no preferred direction: turn the pyramid and its load by any rotation,
    # the contact forces (magnitudes along their own normals) are the same, by the conic
    # program and by the engine's Gauss-Seidel relaxation (3-D kernels)
    pos, r = square_pyramid()
    centre = pos.mean(0)
    R = rotation(seed)
    turned = (pos - centre) @ R.T + centre
    _, upright = on_supports(pos, r, 4, mu=0.0)
    _, prob = on_supports(turned, r, 4, mu=0.0)
    prob.b[:3] += R @ np.array([0.0, 0.0, P]) - np.array([0.0, 0.0, P])   # the load turned
    # the symmetric network (nearest to zero) is unique
    want = nearest_admissible(upright, target=np.zeros(12)).x[0::3]
    got = nearest_admissible(prob, target=np.zeros(12)).x[0::3]
    np.testing.assert_allclose(got, want, rtol=1e-8)
    x = relaxed(prob, seed=seed)
    f = x[0::3]
    assert prob.violation(x) <= 1e-12
    assert f[0] == pytest.approx(f[2], abs=1e-10) and f[1] == pytest.approx(f[3], abs=1e-10)
    assert f[0] + f[1] == pytest.approx(P / np.sqrt(2), rel=1e-10)
