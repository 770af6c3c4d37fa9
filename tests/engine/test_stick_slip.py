"""Coulomb friction against hand-derived mechanics: a disk launched sliding on a floor.

A solid disk (I = m r^2 / 2) starts at v0 without spin on a frictional floor
under gravity g. While it slips, friction mu m g decelerates it (dv/dt = -mu g)
and spins it up (domega/dt = 2 mu g / r); at t* = v0 / (3 mu g) it rolls, and
from then on friction is zero. Angular momentum about the contact point is
conserved throughout, so the rolling speed is exactly 2/3 v0.
"""
import numpy as np
import pytest

from engine_cases import free_bodies
from forcespace.model.walls import SLOT_BOTTOM
from forcespace.engine.records import Box, ContactForces, StepSettings, SweepSettings
from forcespace.engine.step import run_steps


def launch(v0, mu, g, r, dt, nsteps):
    bodies = free_bodies([5.0], [r], [r], vx=[v0], gravity=g)
    bodies.y[1 + SLOT_BOTTOM] = 0.0
    history = []
    tangential_updates = 0
    contacts = ContactForces.empty()
    box = Box(width=100.0, periodic=False, has_bottom=True, has_top=False, has_sides=False)
    settings = StepSettings(margin=0.1, mu_disk=0.0, mu_wall=mu, rotation=True)
    sweep = SweepSettings(dt=dt, tol=1e-13, max_sweeps=1000)
    for _ in range(nsteps):
        contacts, stats = run_steps(bodies, box, settings, sweep, contacts, 1, 7)
        history.append((bodies.vx[0], bodies.w[0], contacts.rn[0], contacts.rt[0]))
        tangential_updates += stats.tangential_updates
    return np.array(history), tangential_updates


@pytest.mark.parametrize("mu", [0.1, 0.5, 2.0])
def test_sliding_disk_decelerates_at_mu_g_then_rolls_at_two_thirds_v0(mu):
    v0, g, r, dt = 1.0, 1.0, 1.0, 1e-3
    t_star = v0 / (3 * mu * g)
    n = int(2 * t_star / dt) + 5
    h, n_tangential = launch(v0, mu, g, r, dt, n)
    assert n_tangential > 0
    vx, w, fn, ft = h.T
    W = np.pi * r**2 * g
    slipping = np.arange(1, n + 1) * dt < t_star - 2 * dt
    rolling = np.arange(1, n + 1) * dt > t_star + 2 * dt
    # slip phase: kinetic Coulomb friction, exact deceleration and spin-up
    assert fn[slipping] == pytest.approx(W, rel=1e-12)
    # floor = body a, disk = body b, n = (0, 1), t = (-1, 0): friction along -x is ft > 0
    assert ft[slipping] == pytest.approx(mu * W, rel=1e-12)
    steps = np.arange(1, n + 1)[slipping] * dt
    assert vx[slipping] == pytest.approx(v0 - mu * g * steps, rel=1e-12)
    assert w[slipping] * r == pytest.approx(-2 * mu * g * steps, rel=1e-12)  # rolls to +x: w < 0
    # stick phase: rolling without slipping, no friction, speed 2/3 v0 exactly
    assert vx[rolling] == pytest.approx(2 * v0 / 3, rel=1e-12)
    assert vx[rolling] + w[rolling] * r == pytest.approx(0.0, abs=1e-12)
    assert ft[rolling] == pytest.approx(0.0, abs=1e-12)
    assert (np.abs(ft) <= mu * fn * (1 + 1e-12)).all()


def test_frictionless_floor_never_slows_a_sliding_disk():
    h, n_tangential = launch(1.0, 0.0, 1.0, 1.0, 1e-3, 200)
    assert n_tangential == 0  # a frictionless scene never runs the tangential solve
    assert h[:, 0] == pytest.approx(1.0, rel=1e-15)
    assert np.abs(h[:, 1]).max() == 0.0 and np.abs(h[:, 3]).max() == 0.0
