"""Moreau-Jean time stepping of rigid disks (implicit Euler + NLGS contacts).

Pure numba kernels behind :func:`run_steps`; the orchestration (jamming detection,
progress, files) lives in :mod:`forcespace.engine.protocol`. Records, body layout and
units: :mod:`forcespace.engine.records`. A body's inverse masses ``inv_mx, inv_my,
inv_i`` are zero in every direction it cannot move (fixed walls: all; top plate: x and
rotation; disks without rotation: inv_i).

One step: detect contacts (gap < margin), warm-start their forces from the
previous step (matched by body pair), free velocities ``v + dt*F_ext/m``,
NLGS, then ``x += dt*v`` (implicit Euler). External forces are only those
the scene asks for: ``fy_ext`` holds gravity and the top-plate load.
"""
from __future__ import annotations

import numpy as np

from ..kernels import kernel
from ..model.walls import N_WALL_SLOTS, contact_mu
from .contacts import detect_kernel
from .nlgs import solve_kernel, velocities_kernel
from .records import (BodyArrays, Box, ContactForces, Contacts, Motion, StepSettings,
                      StepStats, SweepSettings)
from ..streams import step_seed


def warm_start(keys, previous: ContactForces):
    """Forces rn, rt (Nc,) [sigma] for the contacts ``keys`` (Nc,) int64 (sorted
    ascending) taken from ``previous`` (its keys sorted too) where a contact persists;
    new contacts start at 0."""
    keys = np.ascontiguousarray(keys, dtype=np.int64)
    old = np.ascontiguousarray(previous.keys, dtype=np.int64)
    if np.any(np.diff(keys) <= 0) or np.any(np.diff(old) <= 0):
        raise ValueError("contact keys must be sorted ascending and unique")
    return warm_start_kernel(keys, old, np.ascontiguousarray(previous.rn, dtype=float),
                             np.ascontiguousarray(previous.rt, dtype=float))


@kernel
def warm_start_kernel(keys_new, keys_old, rn_old, rt_old):
    """Forces (Nc_new,) each of the previous step's contacts that persist: contacts are
    matched by key (both key arrays (Nc,) int64 sorted ascending; rn_old, rt_old
    [sigma]); new contacts start at 0."""
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
def contacts_kernel(ints, floats, r, mu_disk, mu_wall):
    """Detection output (``ints`` (Nc, 3), ``floats`` (Nc, 3) of
    :func:`forcespace.engine.contacts.detect_contacts`) -> a Contacts record; r (n,)
    radii [R]; the Coulomb coefficient by the wall rule of :mod:`forcespace.model.walls`."""
    n = r.shape[0]
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
    return Contacts(a, b, nx, ny, gap, ra, rb, mu, keys)


def contact_list(ints, floats, r, mu_disk: float, mu_wall: float) -> Contacts:
    """The Contacts record of a detection result (see :func:`contacts_kernel`)."""
    ints = np.ascontiguousarray(ints, dtype=np.int64)
    floats = np.ascontiguousarray(floats, dtype=float)
    if ints.ndim != 2 or ints.shape[1] != 3 or floats.shape != ints.shape:
        raise ValueError("ints and floats must have the same shape (Nc, 3)")
    return contacts_kernel(ints, floats, np.ascontiguousarray(r, dtype=float),
                           float(mu_disk), float(mu_wall))


@kernel
def steps_kernel(bodies, box, step, sweep, prev, nsteps, seed, step0):
    """``nsteps`` time steps in place; the kernel of :func:`run_steps`.

    bodies: BodyArrays (positions and velocities updated in place); box: Box; step:
    StepSettings; sweep: SweepSettings; prev: ContactForces of the previous step (warm
    start); seed: the window's seed; step0: index of the first step within its window
    (step s sweeps with :func:`forcespace.streams.step_seed` (seed, step0 + s)).
    Returns (ContactForces of the last step, StepStats).
    """
    x, y, th, vx, vy, w, r = bodies.x, bodies.y, bodies.th, bodies.vx, bodies.vy, bodies.w, \
        bodies.r
    inv_mx, inv_my, fy_ext = bodies.inv_mx, bodies.inv_my, bodies.fy_ext
    motion = Motion(vx, vy, w, inv_mx, inv_my, bodies.inv_i)
    n = r.shape[0]
    width, periodic = box.width, box.periodic
    dt, max_sweeps = sweep.dt, sweep.max_sweeps
    keys, rn, rt = prev.keys, prev.rn, prev.rt
    sweeps_total = 0
    sweeps_max = 0
    max_rel = 0.0
    n_norm = 0
    n_tang = 0
    max_speed = 0.0
    max_top = 0.0
    capped = 0
    nb = n + N_WALL_SLOTS
    mass = np.zeros(nb)
    for i in range(n):
        if inv_mx[i] > 0.0:  # fixed disks (zero inverse mass) carry no momentum
            mass[i] = 1.0 / inv_mx[i]
    for s in range(nsteps):
        ints, floats = detect_kernel(x, y, r, box, step.margin)
        c = contacts_kernel(ints, floats, r, step.mu_disk, step.mu_wall)
        rn, rt = warm_start_kernel(c.keys, keys, rn, rt)
        keys = c.keys
        moving = step.tol_moving > 0.0 and abs(vy[n + 1]) > step.moving_speed
        for i in range(nb):
            if fy_ext[i] != 0.0:  # only the forces the scene asks for
                vy[i] += dt * fy_ext[i] * inv_my[i]
        velocities_kernel(c, rn, rt, motion, dt)
        settings = sweep
        if moving:     # the plate moved faster than moving_speed in the last step
            cap = step.sweeps_moving if step.sweeps_moving > 0 else max_sweeps
            settings = SweepSettings(dt, step.tol_moving, cap, sweep.relaxation,
                                     sweep.block, sweep.overlap_correction,
                                     sweep.overlap_slop,
                                     sweep.relax_until if step.sweeps_moving <= 0 else -1)
        st = solve_kernel(c, motion, rn, rt, settings, step_seed(seed, step0 + s))
        sweeps_total += st.sweeps
        sweeps_max = max(sweeps_max, st.sweeps)
        max_rel = max(max_rel, st.relative_change)
        n_norm += st.normal_updates
        n_tang += st.tangential_updates
        if st.sweeps >= settings.max_sweeps and st.relative_change > settings.tol:
            capped += 1
        a, b = c.a, c.b
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
        if periodic and step.mu_wall == 0.0:
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
            if step.rotation:
                th[i] += dt * w[i]
            if loaded[i]:
                speed = np.sqrt((vx[i] - drift) ** 2 + vy[i] * vy[i]) + abs(w[i]) * r[i]
                vmax = max(vmax, speed)
            if periodic:
                x[i] -= width * np.floor(x[i] / width)
        y[n + 1] += dt * vy[n + 1]
        max_speed = max(max_speed, vmax)
        max_top = max(max_top, abs(vy[n + 1]))
    return ContactForces(keys, rn, rt), StepStats(sweeps_total, sweeps_max, max_rel, n_norm,
                                                  n_tang, max_speed, max_top, capped)


def body_arrays(bodies) -> BodyArrays:
    """The BodyArrays record of any object with the fields of
    :class:`~forcespace.engine.records.BodyArrays` (views, not copies); ValueError if a
    shape or dtype would make the kernel copy (in-place updates would be lost)."""
    rec = BodyArrays(*(getattr(bodies, f) for f in BodyArrays._fields))
    n = np.shape(rec.r)[0]
    for name, v in zip(BodyArrays._fields, rec):
        want = (n,) if name == "r" else (n + N_WALL_SLOTS,)
        if not (isinstance(v, np.ndarray) and v.dtype == np.float64 and v.shape == want
                and v.flags.c_contiguous):
            raise ValueError(f"bodies.{name} must be a contiguous float64 array of shape {want}")
    return rec


def run_steps(bodies, box: Box, step: StepSettings, sweep: SweepSettings,
              contacts: ContactForces, nsteps: int, seed: int,
              step0: int = 0) -> tuple[ContactForces, StepStats]:
    """Advance ``nsteps`` steps in place; returns the last step's contacts and the stats.

    ``bodies``: the body arrays (:class:`~forcespace.engine.records.BodyArrays` fields,
    e.g. :class:`forcespace.engine.protocol.Bodies`); positions and velocities are
    updated in place. ``contacts``: the previous step's contacts, for warm starting.
    ``seed``: the window seed; ``step0``: index of the first step in its window (a
    window run in several calls sweeps as in one, see :func:`steps_kernel`).
    """
    rec = body_arrays(bodies)
    box = Box(float(box.width), bool(box.periodic), bool(box.has_bottom), bool(box.has_top),
              bool(box.has_sides))
    step = StepSettings(float(step.margin), float(step.mu_disk), float(step.mu_wall),
                        bool(step.rotation), float(step.tol_moving), float(step.moving_speed),
                        int(step.sweeps_moving))
    sweep = SweepSettings(float(sweep.dt), float(sweep.tol), int(sweep.max_sweeps),
                          float(sweep.relaxation), int(sweep.block),
                          float(sweep.overlap_correction), float(sweep.overlap_slop),
                          int(sweep.relax_until))
    prev = ContactForces(np.ascontiguousarray(contacts.keys, dtype=np.int64),
                         np.ascontiguousarray(contacts.rn, dtype=float),
                         np.ascontiguousarray(contacts.rt, dtype=float))
    if nsteps < 0 or seed < 0 or step0 < 0:
        raise ValueError("nsteps, seed and step0 must be >= 0")
    return steps_kernel(rec, box, step, sweep, prev, int(nsteps), int(seed), int(step0))
