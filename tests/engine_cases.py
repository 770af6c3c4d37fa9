"""Small hand-built systems for the engine tests, driven through the numba kernels."""
import numpy as np

from forcespace.model.walls import N_WALL_SLOTS
from forcespace.engine.bodies import Bodies
from forcespace.engine.records import Box, ContactForces, StepSettings, SweepSettings
from forcespace.engine.step import run_steps


def free_bodies(x, y, r, vx=None, vy=None, fixed=(), density=1.0, rotation=True,
                gravity=0.0):
    """Body arrays for disks (walls present but immovable); ``fixed`` disks never move."""
    x, y, r = (np.asarray(v, float) for v in (x, y, r))
    n = len(r)
    nb = n + N_WALL_SLOTS
    m = density * np.pi * r**2
    inv_mx = np.zeros(nb)
    inv_my = np.zeros(nb)
    inv_i = np.zeros(nb)
    inv_mx[:n] = inv_my[:n] = 1 / m
    if rotation:
        inv_i[:n] = 1 / (0.5 * m * r**2)
    for i in fixed:
        inv_mx[i] = inv_my[i] = inv_i[i] = 0.0
    fy = np.zeros(nb)
    fy[:n] = -m * gravity
    fy[list(fixed)] = 0.0
    X, Y = np.zeros(nb), np.zeros(nb)
    X[:n], Y[:n] = x, y
    VX, VY = np.zeros(nb), np.zeros(nb)
    if vx is not None:
        VX[:n] = vx
    if vy is not None:
        VY[:n] = vy
    return Bodies(X, Y, np.zeros(nb), VX, VY, np.zeros(nb), r, inv_mx, inv_my, inv_i, fy)


def step(bodies, nsteps, dt=0.01, width=100.0, periodic=False, mu=0.0, margin=0.5,
         tol=1e-12, max_sweeps=1000, seed=1, state=None, relaxation=1.0, sweep_block=0):
    """Advance free disks (no walls) ``nsteps``; returns (keys, rn, rt, stats)."""
    box = Box(width, periodic, has_bottom=False, has_top=False, has_sides=False)
    settings = StepSettings(margin=margin, mu_disk=mu, mu_wall=0.0,
                            rotation=bool(bodies.inv_i.any()))
    sweep = SweepSettings(dt=dt, tol=tol, max_sweeps=max_sweeps, relaxation=relaxation,
                          block=sweep_block)
    contacts = ContactForces(*state) if state is not None else ContactForces.empty()
    (keys, rn, rt), stats = run_steps(bodies, box, settings, sweep, contacts, nsteps, seed)
    return keys, rn, rt, stats
