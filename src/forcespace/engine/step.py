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

Spheres (3-D): :func:`run_steps3`, the same step on the 3-D records (a periodic box in x
and y, plates normal to z) with the kernels of :mod:`~forcespace.engine.contacts` and
:mod:`~forcespace.engine.nlgs` for spheres. Shared by both: the step's solver settings
(:func:`step_sweep_settings`), the solves' tally (:func:`tally`, :func:`step_stats`) and
:func:`contact_list` (the dimension read from the detection's columns); the body layouts
differ (x, y, theta arrays against (n, 3) positions and rotation vectors), so the step
kernels, warm starts and moves stay twins.
"""
from __future__ import annotations

import numpy as np

from ..kernels import kernel
from ..model.walls import N_WALL_SLOTS, contact_mu
from .contacts import detect3_kernel, detect_kernel
from .nlgs import (checked_sweep_settings, solve3_kernel, solve_kernel,
                   velocities3_kernel, velocities_kernel)
from .records import (BodyArrays, BodyArrays3, Box, Box3, ContactForces, Contacts,
                      Contacts3, Motion, Motion3, StepSettings, StepStats, SweepSettings)
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


def contact_list(ints, floats, r, mu_disk: float, mu_wall: float):
    """The contact record of a detection result, its dimension read from the columns:
    (Nc, 3) each from :func:`~forcespace.engine.contacts.detect_contacts` -> Contacts
    (:func:`contacts_kernel`), (Nc, 4) each from
    :func:`~forcespace.engine.contacts.detect_contacts3` -> Contacts3
    (:func:`contacts3_kernel`)."""
    ints = np.ascontiguousarray(ints, dtype=np.int64)
    floats = np.ascontiguousarray(floats, dtype=float)
    if ints.ndim != 2 or ints.shape[1] not in (3, 4) or floats.shape != ints.shape:
        raise ValueError("ints and floats must have the same shape, (Nc, 3) for disks or "
                         "(Nc, 4) for spheres")
    make = contacts_kernel if ints.shape[1] == 3 else contacts3_kernel
    return make(ints, floats, np.ascontiguousarray(r, dtype=float), float(mu_disk),
                float(mu_wall))


@kernel
def step_sweep_settings(step, sweep, moving):
    """The SweepSettings of one step: ``sweep``, or while the plate moves faster than
    ``step.moving_speed`` (``moving``) the looser tolerance ``step.tol_moving`` with the
    cap ``step.sweeps_moving`` (0: ``sweep.max_sweeps``; with a cap, over-relaxation
    falls back to omega = 1 at half of it)."""
    if not moving:
        return sweep
    cap = step.sweeps_moving if step.sweeps_moving > 0 else sweep.max_sweeps
    return SweepSettings(sweep.dt, step.tol_moving, cap, sweep.relaxation, sweep.block,
                         sweep.overlap_correction, sweep.overlap_slop,
                         sweep.relax_until if step.sweeps_moving <= 0 else -1)


@kernel(inline="always")
def tally(totals, max_rel, st, settings):
    """Add one solve's SweepStats ``st`` (run with ``settings``) to ``totals`` (5,) int64
    = (sweeps, largest sweeps of a step, normal updates, tangential updates, steps that
    hit the sweep cap unconverged); returns the largest relative change so far."""
    totals[0] += st.sweeps
    totals[1] = max(totals[1], st.sweeps)
    totals[2] += st.normal_updates
    totals[3] += st.tangential_updates
    if st.sweeps >= settings.max_sweeps and st.relative_change > settings.tol:
        totals[4] += 1
    return max(max_rel, st.relative_change)


@kernel(inline="always")
def step_stats(totals, max_rel, max_speed, max_top):
    """The StepStats of a run of steps from its tally (:func:`tally`) and maxima."""
    return StepStats(totals[0], totals[1], max_rel, totals[2], totals[3], max_speed,
                     max_top, totals[4])


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
    dt = sweep.dt
    keys, rn, rt = prev.keys, prev.rn, prev.rt
    totals = np.zeros(5, np.int64)     # the solves' tally (see :func:`tally`)
    max_rel = 0.0
    max_speed = 0.0
    max_top = 0.0
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
        settings = step_sweep_settings(step, sweep, moving)
        st = solve_kernel(c, motion, rn, rt, settings, step_seed(seed, step0 + s))
        max_rel = tally(totals, max_rel, st, settings)
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
    return ContactForces(keys, rn, rt), step_stats(totals, max_rel, max_speed, max_top)


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
    step, sweep, prev = _kernel_arguments(step, sweep, contacts, nsteps, seed, step0, 1)
    return steps_kernel(rec, box, step, sweep, prev, int(nsteps), int(seed), int(step0))


def _kernel_arguments(step: StepSettings, sweep: SweepSettings, contacts: ContactForces,
                      nsteps: int, seed: int, step0: int, tangential: int):
    """The settings and previous contacts as the step kernels take them (typed fields,
    contiguous arrays; rt (Nc,) in 2-D, (Nc, 3) in 3-D: ``tangential`` components);
    ValueError if nsteps, seed or step0 is negative."""
    if nsteps < 0 or seed < 0 or step0 < 0:
        raise ValueError("nsteps, seed and step0 must be >= 0")
    step = StepSettings(float(step.margin), float(step.mu_disk), float(step.mu_wall),
                        bool(step.rotation), float(step.tol_moving), float(step.moving_speed),
                        int(step.sweeps_moving))
    rt = np.ascontiguousarray(contacts.rt, dtype=float)
    prev = ContactForces(np.ascontiguousarray(contacts.keys, dtype=np.int64),
                         np.ascontiguousarray(contacts.rn, dtype=float),
                         rt if tangential == 1 else rt.reshape(-1, tangential))
    return step, checked_sweep_settings(sweep), prev


# ---- spheres (3-D): the same step with vectors --------------------------------------

@kernel
def warm_start3_kernel(keys_new, keys_old, rn_old, rt_old, normal):
    """Forces rn (Nc,), rt (Nc, 3) of the previous step's contacts that persist (matched
    by key as :func:`warm_start_kernel`); a persisting tangential force is projected onto
    the new tangent plane (normal (Nc, 3)), new contacts start at 0."""
    m = keys_new.shape[0]
    rn = np.zeros(m)
    rt = np.zeros((m, 3))
    p = 0
    for k in range(m):
        while p < keys_old.shape[0] and keys_old[p] < keys_new[k]:
            p += 1
        if p < keys_old.shape[0] and keys_old[p] == keys_new[k]:
            rn[k] = rn_old[p]
            along = (rt_old[p, 0] * normal[k, 0] + rt_old[p, 1] * normal[k, 1]
                     + rt_old[p, 2] * normal[k, 2])
            for d in range(3):
                rt[k, d] = rt_old[p, d] - along * normal[k, d]
    return rn, rt


def warm_start3(keys, normal, previous: ContactForces):
    """3-D :func:`warm_start`: forces rn (Nc,), rt (Nc, 3) [sigma] for the contacts
    ``keys`` (sorted) with unit normals ``normal`` (Nc, 3), from ``previous`` (rt (k, 3))."""
    keys = np.ascontiguousarray(keys, dtype=np.int64)
    old = np.ascontiguousarray(previous.keys, dtype=np.int64)
    if np.any(np.diff(keys) <= 0) or np.any(np.diff(old) <= 0):
        raise ValueError("contact keys must be sorted ascending and unique")
    return warm_start3_kernel(keys, old, np.ascontiguousarray(previous.rn, dtype=float),
                              np.ascontiguousarray(previous.rt, dtype=float).reshape(-1, 3),
                              np.ascontiguousarray(normal, dtype=float).reshape(-1, 3))


@kernel
def contacts3_kernel(ints, floats, r, mu_disk, mu_wall):
    """3-D detection output (``ints`` (Nc, 4), ``floats`` (Nc, 4) of
    :func:`forcespace.engine.contacts.detect_contacts3`) -> a Contacts3 record; r (n,)
    radii [R]; the Coulomb coefficient by the wall rule of :mod:`forcespace.model.walls`."""
    n = r.shape[0]
    m = ints.shape[0]
    a = ints[:, 0].copy()
    b = ints[:, 1].copy()
    normal = floats[:, :3].copy()
    gap = floats[:, 3].copy()
    ra = np.zeros(m)
    rb = np.zeros(m)
    mu = np.empty(m)
    keys = np.empty(m, dtype=np.int64)
    nb = n + N_WALL_SLOTS
    for k in range(m):
        wall = a[k] >= n or b[k] >= n
        if a[k] < n:
            ra[k] = r[a[k]]
        if b[k] < n:
            rb[k] = r[b[k]]
        mu[k] = contact_mu(wall, mu_disk, mu_wall)
        keys[k] = a[k] * nb + b[k]
    return Contacts3(a, b, normal, gap, ra, rb, mu, keys)


@kernel
def loaded3_kernel(bodies, c, rn):
    """Mask (nb,) of the spheres that feel an external force or carry a contact force (the
    loaded grains of the speed log and the rest criterion)."""
    n = bodies.r.shape[0]
    loaded = np.zeros(bodies.inv_i.shape[0], dtype=np.bool_)
    for i in range(n):
        loaded[i] = bodies.f_ext[i, 0] != 0.0 or bodies.f_ext[i, 1] != 0.0 \
            or bodies.f_ext[i, 2] != 0.0
    for k in range(c.a.shape[0]):
        if rn[k] > 0.0:
            loaded[c.a[k]] = True
            loaded[c.b[k]] = True
    return loaded


@kernel
def move3_kernel(bodies, box, step, loaded, dt):
    """Implicit Euler positions x += dt v (x, y wrapped into the box, rotation vectors
    integrated when ``step.rotation``, the top plate along z); returns the largest speed
    |v - drift| + r |w| of a loaded sphere (drift: the loaded spheres' mean lateral
    velocity when the plates are frictionless, a zero mode of the periodic box)."""
    pos, v, w, r = bodies.pos, bodies.v, bodies.w, bodies.r
    n = r.shape[0]
    drift = np.zeros(3)
    if step.mu_wall == 0.0:
        ml = 0.0
        for i in range(n):
            if loaded[i] and bodies.inv_m[i, 0] > 0.0:
                mi = 1.0 / bodies.inv_m[i, 0]
                drift[0] += mi * v[i, 0]
                drift[1] += mi * v[i, 1]
                ml += mi
        if ml > 0.0:
            drift /= ml
    vmax = 0.0
    for i in range(n):
        for d in range(3):
            pos[i, d] += dt * v[i, d]
        if step.rotation:
            for d in range(3):
                bodies.th[i, d] += dt * w[i, d]
        if loaded[i]:
            speed = np.sqrt((v[i, 0] - drift[0]) ** 2 + (v[i, 1] - drift[1]) ** 2
                            + v[i, 2] ** 2) \
                + r[i] * np.sqrt(w[i, 0] ** 2 + w[i, 1] ** 2 + w[i, 2] ** 2)
            vmax = max(vmax, speed)
        pos[i, 0] -= box.lx * np.floor(pos[i, 0] / box.lx)
        pos[i, 1] -= box.ly * np.floor(pos[i, 1] / box.ly)
    pos[n + 1, 2] += dt * v[n + 1, 2]
    return vmax


@kernel
def steps3_kernel(bodies, box, step, sweep, prev, nsteps, seed, step0):
    """``nsteps`` 3-D time steps in place; the kernel of :func:`run_steps3` (arguments and
    results as :func:`steps_kernel`, with BodyArrays3, Box3 and rt (Nc, 3))."""
    motion = Motion3(bodies.v, bodies.w, bodies.inv_m, bodies.inv_i)
    v, f_ext, inv_m = bodies.v, bodies.f_ext, bodies.inv_m
    n = bodies.r.shape[0]
    dt = sweep.dt
    keys, rn, rt = prev.keys, prev.rn, prev.rt
    totals = np.zeros(5, np.int64)     # the solves' tally (see :func:`tally`)
    max_rel = 0.0
    max_speed = 0.0
    max_top = 0.0
    for s in range(nsteps):
        ints, floats = detect3_kernel(bodies.pos, bodies.r, box, step.margin)
        c = contacts3_kernel(ints, floats, bodies.r, step.mu_disk, step.mu_wall)
        rn, rt = warm_start3_kernel(c.keys, keys, rn, rt, c.normal)
        keys = c.keys
        moving = step.tol_moving > 0.0 and abs(v[n + 1, 2]) > step.moving_speed
        for i in range(n + N_WALL_SLOTS):
            for d in range(3):
                if f_ext[i, d] != 0.0:  # only the forces the scene asks for
                    v[i, d] += dt * f_ext[i, d] * inv_m[i, d]
        velocities3_kernel(c, rn, rt, motion, dt)
        settings = step_sweep_settings(step, sweep, moving)
        st = solve3_kernel(c, motion, rn, rt, settings, step_seed(seed, step0 + s))
        max_rel = tally(totals, max_rel, st, settings)
        loaded = loaded3_kernel(bodies, c, rn)
        max_speed = max(max_speed, move3_kernel(bodies, box, step, loaded, dt))
        max_top = max(max_top, abs(v[n + 1, 2]))
    return ContactForces(keys, rn, rt), step_stats(totals, max_rel, max_speed, max_top)


def body_arrays3(bodies) -> BodyArrays3:
    """The BodyArrays3 record of any object with its fields (views, not copies);
    ValueError if a shape or dtype would make the kernel copy."""
    rec = BodyArrays3(*(getattr(bodies, f) for f in BodyArrays3._fields))
    n = np.shape(rec.r)[0]
    for name, v in zip(BodyArrays3._fields, rec):
        want = {"r": (n,), "inv_i": (n + N_WALL_SLOTS,)}.get(name, (n + N_WALL_SLOTS, 3))
        if not (isinstance(v, np.ndarray) and v.dtype == np.float64 and v.shape == want
                and v.flags.c_contiguous):
            raise ValueError(f"bodies.{name} must be a contiguous float64 array of shape {want}")
    return rec


def run_steps3(bodies, box: Box3, step: StepSettings, sweep: SweepSettings,
               contacts: ContactForces, nsteps: int, seed: int,
               step0: int = 0) -> tuple[ContactForces, StepStats]:
    """3-D :func:`run_steps`: ``bodies`` with the fields of
    :class:`~forcespace.engine.records.BodyArrays3` (updated in place), ``box`` a Box3,
    ``contacts`` the previous step's (rt (Nc, 3); an empty record of either shape)."""
    rec = body_arrays3(bodies)
    box = Box3(float(box.lx), float(box.ly), bool(box.has_bottom), bool(box.has_top))
    step, sweep, prev = _kernel_arguments(step, sweep, contacts, nsteps, seed, step0, 3)
    return steps3_kernel(rec, box, step, sweep, prev, int(nsteps), int(seed), int(step0))
