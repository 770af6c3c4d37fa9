"""Moreau-Jean time stepping of rigid disks (implicit Euler + NLGS contacts).

Pure numba kernels; the orchestration (jamming detection, progress, files)
lives in :mod:`forcespace.jamming`. Body layout as in
:mod:`forcespace.contacts`: disks 0..n-1, then the wall slots. A body's
inverse masses ``inv_mx, inv_my, inv_i`` are zero in every direction it
cannot move (fixed walls: all; top plate: x and rotation; disks without
rotation: inv_i).

One step: detect contacts (gap < margin), warm-start their forces from the
previous step (matched by body pair), free velocities ``v + dt*F_ext/m``,
NLGS, then ``x += dt*v`` (implicit Euler). External forces are only those
the scene asks for: ``fy_ext`` holds gravity and the top-plate load.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from ..kernels import kernel

from ..model.walls import N_WALL_SLOTS, contact_mu
from .contacts import detect_contacts
from .nlgs import add_contact_velocities, effective_masses, nlgs_solve


@kernel
def warm_start(keys_new, keys_old, rn_old, rt_old):
    """Forces of the previous step for the contacts that persist (keys sorted)."""
    m = keys_new.shape[0]
    rn = np.zeros(m)
    rt = np.zeros(m)
    p = 0
    for k in range(m):
        while p < keys_old.shape[0] and keys_old[p] < keys_new[k]:
            p += 1
        if p < keys_old.shape[0] and keys_old[p] == keys_new[k]:
            rn[k] = rn_old[p]
            rt[k] = rt_old[p]
    return rn, rt


@kernel
def contact_arrays(ints, floats, r, n, mu_disk, mu_wall):
    """Split detection output into kernel arrays.

    Returns a, b, nx, ny, gap, ra, rb, mu, keys (all shape (Nc,)).
    """
    m = ints.shape[0]
    a = ints[:, 0].copy()
    b = ints[:, 1].copy()
    nx = floats[:, 0].copy()
    ny = floats[:, 1].copy()
    gap = floats[:, 2].copy()
    ra = np.zeros(m)
    rb = np.zeros(m)
    mu = np.empty(m)
    keys = np.empty(m, dtype=np.int64)
    nb = n + N_WALL_SLOTS
    for k in range(m):
        wall = False
        if a[k] < n:
            ra[k] = r[a[k]]
        else:
            wall = True
        if b[k] < n:
            rb[k] = r[b[k]]
        else:
            wall = True
        mu[k] = contact_mu(wall, mu_disk, mu_wall)
        keys[k] = a[k] * nb + b[k]
    return a, b, nx, ny, gap, ra, rb, mu, keys


@kernel
def _run_steps(x, y, th, vx, vy, w, r, n, inv_mx, inv_my, inv_i, fy_ext,
              width, periodic, has_bottom, has_top, has_sides, margin,
              dt, tol, max_sweeps, mu_disk, mu_wall, rotation,
              keys, rn, rt, nsteps, seed, overlap_correction=0.0, overlap_slop=0.0,
              relaxation=1.0, sweep_block=0):
    """The kernel of :func:`run_steps` (positional arrays; stats as an (8,) array
    in the order of :class:`StepStats`)."""
    stats = np.zeros(8)
    nb = n + N_WALL_SLOTS
    mass = np.zeros(nb)
    for i in range(n):
        if inv_mx[i] > 0.0:  # fixed disks (zero inverse mass) carry no momentum
            mass[i] = 1.0 / inv_mx[i]
    for step in range(nsteps):
        ints, floats = detect_contacts(x, y, r, n, width, periodic,
                                       has_bottom, has_top, has_sides, margin)
        a, b, nx, ny, gap, ra, rb, mu, new_keys = contact_arrays(ints, floats, r, n,
                                                                 mu_disk, mu_wall)
        rn, rt = warm_start(new_keys, keys, rn, rt)
        keys = new_keys
        mn, mt = effective_masses(a, b, nx, ny, ra, rb, inv_mx, inv_my, inv_i)
        for i in range(nb):
            if fy_ext[i] != 0.0:  # only the forces the scene asks for
                vy[i] += dt * fy_ext[i] * inv_my[i]
        add_contact_velocities(a, b, nx, ny, ra, rb, rn, rt, inv_mx, inv_my, inv_i, dt,
                               vx, vy, w)
        sw, rel, nn, ntg = nlgs_solve(a, b, nx, ny, ra, rb, gap, mu, mn, mt, rn, rt,
                                      vx, vy, w, inv_mx, inv_my, inv_i, dt, tol,
                                      max_sweeps, (seed + 7919 * step) % 2147483647,
                                      overlap_correction, overlap_slop, relaxation,
                                      sweep_block)
        stats[0] += sw
        stats[1] = max(stats[1], sw)
        stats[2] = max(stats[2], rel)
        stats[3] += nn
        stats[4] += ntg
        if sw >= max_sweeps and rel > tol:
            stats[7] += 1
        # speeds (for the log) of the disks that touch something or feel a body
        # force: a free-flying rattler in zero gravity keeps its speed forever
        loaded = np.zeros(nb, dtype=np.bool_)
        for i in range(n):
            loaded[i] = fy_ext[i] != 0.0  # a falling disk is not at rest
        for k in range(a.shape[0]):
            if rn[k] > 0.0:
                loaded[a[k]] = True
                loaded[b[k]] = True
        # with periodic x and frictionless walls a uniform horizontal drift is a zero
        # mode (momentum from rattlers keeps it going forever): measure speeds without it
        drift = 0.0
        if periodic and mu_wall == 0.0:
            px = 0.0
            ml = 0.0
            for i in range(n):
                if loaded[i]:
                    px += mass[i] * vx[i]
                    ml += mass[i]
            if ml > 0.0:
                drift = px / ml
        vmax = 0.0
        for i in range(n):
            x[i] += dt * vx[i]
            y[i] += dt * vy[i]
            if rotation:
                th[i] += dt * w[i]
            if loaded[i]:
                speed = np.sqrt((vx[i] - drift) ** 2 + vy[i] * vy[i]) + abs(w[i]) * r[i]
                vmax = max(vmax, speed)
            if periodic:
                x[i] -= width * np.floor(x[i] / width)
        y[n + 1] += dt * vy[n + 1]
        stats[5] = max(stats[5], vmax)
        stats[6] = max(stats[6], abs(vy[n + 1]))
    return keys, rn, rt, stats


class StepParams(NamedTuple):
    """What a scene asks the time stepper for (see :mod:`forcespace.scene`)."""

    width: float                 # box width [R]
    periodic: bool               # periodic x (else side walls if has_sides)
    has_bottom: bool             # fixed lower plate
    has_top: bool                # load-controlled upper plate
    has_sides: bool              # side walls at x = 0 and x = width
    margin: float                # pairs closer than this gap [R] are contacts
    dt: float                    # time step
    tol: float                   # NLGS relative force change that ends a step
    max_sweeps: int              # NLGS sweep cap per step
    mu_disk: float               # disk-disk Coulomb coefficient
    mu_wall: float               # disk-wall Coulomb coefficient
    rotation: bool               # integrate disk rotation
    overlap_correction: float = 0.0   # see forcespace.nlgs.nlgs_solve
    overlap_slop: float = 0.0         # [R]
    relaxation: float = 1.0           # NLGS over-relaxation omega (see nlgs_solve)
    sweep_block: int = 0              # NLGS sweep order: 0 single contacts, B runs of B


class ContactState(NamedTuple):
    """A step's contacts: sorted keys a*(n+4)+b (Nc,), forces rn, rt (Nc,) [F0]."""

    keys: np.ndarray
    rn: np.ndarray
    rt: np.ndarray

    @classmethod
    def empty(cls) -> "ContactState":
        return cls(np.zeros(0, np.int64), np.zeros(0), np.zeros(0))


class StepStats(NamedTuple):
    """Solver statistics of a run of steps."""

    sweeps_total: int            # NLGS sweeps over all steps
    sweeps_max_step: int         # the most sweeps one step needed
    max_rel_change: float        # largest final relative force change of a step's NLGS
    normal_updates: int          # single-contact normal updates
    tangential_updates: int      # single-contact friction updates (0 without friction)
    max_speed: float             # largest speed of a loaded disk (drift mode excluded)
    max_top_speed: float         # largest |v| of the top plate
    steps_at_sweep_cap: int      # steps whose NLGS hit max_sweeps unconverged


def run_steps(bodies, params: StepParams, contacts: ContactState, nsteps: int,
              seed: int) -> tuple[ContactState, StepStats]:
    """Advance ``nsteps`` steps in place; returns the last step's contacts and the stats.

    ``bodies``: arrays of shape (n+4,) (disks, then the wall slots) ``x, y, th,
    vx, vy, w, inv_mx, inv_my, inv_i, fy_ext`` [R, rad, R/t, 1/mass, force]
    and radii ``r`` (n,), e.g. :class:`forcespace.jamming.Bodies`; positions and
    velocities are updated in place. ``contacts``: the previous step's
    contacts, for warm starting.
    """
    b, p = bodies, params
    keys, rn, rt, st = _run_steps(
        b.x, b.y, b.th, b.vx, b.vy, b.w, b.r, b.r.shape[0], b.inv_mx, b.inv_my, b.inv_i,
        b.fy_ext, p.width, p.periodic, p.has_bottom, p.has_top, p.has_sides, p.margin, p.dt,
        p.tol, p.max_sweeps, p.mu_disk, p.mu_wall, p.rotation, contacts.keys, contacts.rn,
        contacts.rt, nsteps, seed, p.overlap_correction, p.overlap_slop, p.relaxation,
        p.sweep_block)
    return ContactState(keys, rn, rt), StepStats(
        int(st[0]), int(st[1]), float(st[2]), int(st[3]), int(st[4]), float(st[5]),
        float(st[6]), int(st[7]))
