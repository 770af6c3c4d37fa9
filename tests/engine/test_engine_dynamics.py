"""Contact dynamics against hand-derived statics and conservation laws."""
import numpy as np
import pytest

from engine_cases import free_bodies, step
from forcespace.engine.contacts import detect_contacts
from forcespace.engine.records import Box


# the paper's sweep (fresh random order, plain Gauss-Seidel) and the fast one (runs of
# contacts shuffled, over-relaxed): the same fixed point, so the same hand-derived statics
SWEEPS = [dict(), dict(relaxation=1.6, sweep_block=2)]


@pytest.mark.parametrize("sweep", SWEEPS)
def test_disk_in_a_groove_of_two_fixed_supports_carries_hand_derived_forces(sweep):
    # disk 0 (r = 1) settles onto fixed disks 1, 2 (r = 1) at (+-1.2, 0) under gravity g:
    # contact normals make angle th with the vertical, sin th = 1.2 / 2; frictionless
    # statics: each support pushes with N = W / (2 cos th).
    g, r = 1.0, 1.0
    bodies = free_bodies([0.0, -1.2, 1.2], [1.7, 0.0, 0.0], [r, r, r], fixed=(1, 2),
                         gravity=g, rotation=False)
    keys, rn, rt, _ = step(bodies, 400, dt=0.01, **sweep)
    W = np.pi * r**2 * g
    th = np.arcsin(1.2 / 2.0)
    assert bodies.y[0] == pytest.approx(np.sqrt(4 - 1.2**2), abs=1e-9)
    # contacts sorted by body pair: (0, 1), (0, 2), then the open pair of supports (1, 2)
    assert rn == pytest.approx([W / (2 * np.cos(th))] * 2 + [0.0], rel=1e-9)
    assert np.abs(rt).max() == 0.0
    assert abs(bodies.vx[0]) < 1e-12 and abs(bodies.vy[0]) < 1e-12


@pytest.mark.parametrize("sweep", SWEEPS)
def test_disk_in_groove_with_friction_is_in_equilibrium_and_symmetric(sweep):
    g, mu = 1.0, 0.3
    bodies = free_bodies([0.0, -1.2, 1.2], [1.7, 0.0, 0.0], [1, 1, 1], fixed=(1, 2),
                         gravity=g)
    keys, rn, rt, stats = step(bodies, 400, dt=0.01, mu=mu, **sweep)
    ints, floats = detect_contacts(bodies.x, bodies.y, bodies.r,
                                   Box(100.0, False, False, False, False), 0.5)
    n = floats[:, :2]
    t = np.column_stack([-n[:, 1], n[:, 0]])
    on_disk0 = -(rn[:, None] * n + rt[:, None] * t).sum(0)  # disk 0 is body a of both
    assert on_disk0 + [0.0, -np.pi * g] == pytest.approx([0, 0], abs=1e-9)
    assert rt.sum() == pytest.approx(0.0, abs=1e-12)  # torque balance: -r*(rt0 + rt1) = 0
    assert rn[0] == pytest.approx(rn[1], rel=1e-9)  # mirror symmetry
    assert rn[2] == 0.0 and rt[2] == 0.0  # the supports do not touch
    assert (np.abs(rt) <= mu * rn + 1e-15).all()
    assert stats.tangential_updates > 0  # the tangential solve ran
    assert np.hypot(bodies.vx[0], bodies.vy[0]) < 1e-12


def test_perfectly_inelastic_head_on_collision_conserves_momentum():
    m1, m2 = np.pi * 1.0**2, np.pi * 1.5**2
    bodies = free_bodies([0.0, 3.0], [0.0, 0.0], [1.0, 1.5], vx=[1.0, -0.5])
    p0 = m1 * 1.0 + m2 * -0.5
    step(bodies, 100, dt=0.01)
    assert m1 * bodies.vx[0] + m2 * bodies.vx[1] == pytest.approx(p0, rel=1e-12)
    # perfectly inelastic: both move with the centre-of-mass velocity afterwards
    assert bodies.vx[0] == pytest.approx(p0 / (m1 + m2), rel=1e-10)
    assert bodies.vx[1] - bodies.vx[0] == pytest.approx(0.0, abs=1e-12)
    gap = bodies.x[1] - bodies.x[0] - 2.5
    assert abs(gap) < 1e-10  # touching, not overlapping
    assert bodies.vy[:2] == pytest.approx([0, 0], abs=1e-15)


def test_collision_across_the_periodic_boundary():
    L = 10.0
    bodies = free_bodies([0.4, L - 1.7], [0.0, 0.0], [1.0, 1.0], vx=[-1.0, 1.0])
    ints, floats = detect_contacts(bodies.x, bodies.y, bodies.r,
                                   Box(L, True, False, False, False), 0.5)
    assert len(ints) == 1
    a, b, image = ints[0]
    assert (a, b) == (0, 1) and image == -1  # disk 1 seen at x - L, left of disk 0
    assert floats[0, 2] == pytest.approx(0.1)  # gap through the boundary
    assert floats[0, 0] == pytest.approx(-1.0)  # normal from 0 to 1 points to -x
    step(bodies, 100, dt=0.01, width=L, periodic=True)
    assert bodies.vx[:2] == pytest.approx([0.0, 0.0], abs=1e-12)  # equal masses stop
    dx = (bodies.x[0] - bodies.x[1]) % L
    assert dx == pytest.approx(2.0, abs=1e-10)
    assert ((0 <= bodies.x[:2]) & (bodies.x[:2] < L)).all()


def test_no_periodic_image_contacts_without_periodicity():
    bodies = free_bodies([0.4, 8.3], [0.0, 0.0], [1.0, 1.0])
    ints, _ = detect_contacts(bodies.x, bodies.y, bodies.r,
                              Box(10.0, False, False, False, False), 0.5)
    assert len(ints) == 0
