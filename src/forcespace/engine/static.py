"""The static solve of a jammed configuration: frozen contacts, NLGS to equilibrium.

Positions fixed, velocities zeroed, pairs with gap below ``jamming.contact_gap_tol``
taken as closed contacts (gap set to 0), NLGS until the relative equilibrium residual
of every disk and the top plate is at most ``jamming.static_tolerance``.
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..errors import NumericalError
from ..model.packing import Packing
from ..model.setup import Setup
from ..model.walls import (N_WALL_SLOTS, SLOT_BOTTOM, SLOT_TOP, kernel_body_index,
                           packing_body_code)
from ..progress import progress
from .bodies import Bodies, certificate_settings, kernel_box
from .certificate import Certificate, frozen_system, in_cones, least_change_network
from .contacts import detect_contacts
from .frozen import FrozenContacts, relax
from .interrupts import InterruptFlag
from .records import ContactForces, Contacts
from .step import contact_list, warm_start


class ResidualProgress:
    """Progress of a relaxation by its own measure: the residual on a log scale from the
    first one measured (0 %) to the tolerance (100 %), never moving back."""

    def __init__(self, tol: float, show: bool, desc: str = "static solve"):
        self.tol, self.first, self.done, self.sweeps = tol, None, 0.0, 0
        self.bar = progress(total=100.0, desc=desc, unit="%", disable=not show)
        self.bar.bar_format = ("{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}]"
                               "{postfix}")

    def __call__(self, sweeps: int, residual: float) -> None:
        self.sweeps += sweeps
        if self.first is None:
            self.first = residual
        if residual <= self.tol:
            frac = 1.0
        elif self.first > self.tol and residual > 0:
            frac = math.log(self.first / residual) / math.log(self.first / self.tol)
        else:
            frac = 0.0
        frac = min(max(frac, 0.0), 1.0)
        self.bar.set_postfix_str(f"{self.sweeps} sweeps, residual {residual:.2e}",
                                 refresh=False)
        self.bar.update(max(100.0 * frac - self.done, 0.0))     # 0: a timed refresh
        self.done = max(self.done, 100.0 * frac)

    def close(self) -> None:
        self.bar.close()


def static_solve(setup: Setup, bodies: Bodies, seed: int, show_progress=True,
                 interrupt: InterruptFlag | None = None):
    """Equilibrium forces on the frozen jammed configuration.

    Starts from the forces of the last dynamic step (warm start) when
    :func:`forcespace.engine.compress.compress` ran on ``bodies``: with friction S has
    many points and this keeps the one the dynamics realised. ``interrupt``: checked
    after every chunk of sweeps (raises Interrupted).

    Returns (packing, statistics). The packing's contacts are all pairs with
    gap at most ``jamming.contact_gap_tol``; their gaps are treated as closed
    in the solve (the recorded gaps are the real ones).
    """
    interrupt = interrupt or InterruptFlag()
    n = bodies.n
    jamming = setup.jamming
    ints, floats = detect_contacts(bodies.x, bodies.y, bodies.r, kernel_box(setup.boundary),
                                   jamming.contact_gap_tol)
    c = contact_list(ints, floats, bodies.r, setup.physics.mu, setup.physics.plate_mu)
    touched = np.zeros(n + N_WALL_SLOTS, dtype=bool)
    touched[c.a] = touched[c.b] = True
    loose = np.flatnonzero((bodies.fy_ext[:n] != 0) & ~touched[:n])
    if loose.size:
        raise NumericalError(f"disk {loose[0]} feels gravity but touches nothing: the "
                             "configuration is not static (raise jamming.window or lower "
                             "jamming.velocity_tol)")
    if bodies.contacts is not None:  # start from the forces the dynamics ended with
        rn, rt = warm_start(c.keys, bodies.contacts)
        rt[c.mu == 0.0] = 0.0
    else:
        rn = np.zeros(c.a.shape[0])
        rt = np.zeros(c.a.shape[0])
    nb = n + N_WALL_SLOTS
    system = FrozenContacts(c._replace(gap=np.zeros(c.a.shape[0])), bodies.inv_mx,
                            bodies.inv_my, bodies.inv_i,
                            (np.zeros(nb), bodies.fy_ext * bodies.inv_my, np.zeros(nb)))
    packing_of = packing_view(setup, bodies, c, ints[:, 2].copy())
    t0 = time.perf_counter()
    bar = ResidualProgress(jamming.static_tolerance, show_progress)

    def report(sweeps, residual):
        bar(sweeps, residual)
        interrupt.check()

    try:
        res = relax(
            system, rn, rt, lambda rn, rt: packing_of(rn, rt).equilibrium_residual(),
            jamming.static_tolerance, jamming.static_max_sweeps, seed,
            chunk=100, max_chunk=20000, on_chunk=report)
    finally:
        bar.close()
    stats = {"static_sweeps": res.sweeps, "static_tangential_updates": res.tangential_updates,
             "static_seconds": time.perf_counter() - t0, "static_residual": res.violation}
    return packing_of(rn, rt), stats


def certified_solve(setup: Setup, bodies: Bodies, seed: int, show_progress=True,
                    interrupt: InterruptFlag | None = None):
    """The static network of the frozen configuration by its certificate
    (:mod:`forcespace.engine.certificate`): the admissible network nearest to the
    dynamics' last forces in total change (L1: the contacts the dynamics left without
    force or at their Coulomb limit stay so unless equilibrium needs them; the Euclidean
    nearest network had none at the limit and more contacts bearing force than the sweeps'
    network, at n = 200), found by interior-point solves
    (:func:`~forcespace.engine.certificate.least_change_network`) on the contacts with gap
    at most ``jamming.contact_gap_tol``, clipped into the Coulomb cones and polished by
    :func:`static_solve` from there (an exact static network is a fixed point of its
    sweeps, so the polish only removes the solver's round-off). Returns
    ((packing, statistics) or None when the configuration is not static, the
    :class:`~forcespace.engine.certificate.Certificate`).
    """
    settings = certificate_settings(setup)
    c, _image, system, rn0, rt0 = frozen_system(
        bodies, kernel_box(setup.boundary), setup.physics.mu, setup.physics.plate_mu,
        settings.gap_tol, bodies.contacts)
    cert = least_change_network(system, rn0, rt0, settings.tol)
    if cert.status != "static":
        return None, cert
    dynamics = bodies.contacts
    bodies.contacts = ContactForces(c.keys, *in_cones(cert.rn, cert.rt, c.mu))
    try:
        packing, stats = static_solve(setup, bodies, seed, show_progress, interrupt)
    finally:
        bodies.contacts = dynamics
    stats.update(certificate_stats(cert))
    return (packing, stats), cert


def certificate_stats(cert: Certificate) -> dict:
    """The packing metadata of a certificate (``certificate_*``)."""
    return {"certificate_status": cert.status, "certificate_iterations": cert.iterations,
            "certificate_seconds": cert.seconds, "certificate_residual": cert.residual}


def restart_from_exact_point(setup: Setup, bodies: Bodies, seed: int, show_progress=True,
                             interrupt: InterruptFlag | None = None):
    """The static solve again, from an exact static network, for a configuration whose
    NLGS from the dynamics' forces stalled above ``jamming.static_tolerance``.

    The configuration's certificate (:func:`certified_solve`: interior point, Clarabel)
    decides whether any static network exists. If one does, NLGS restarts from the one
    nearest the dynamics' forces (and polishes it to the tolerance), else None: the
    configuration is not static (the case that asked for it: studies/field_notes.md).
    (Before issue 42 the exact point was HiGHS' feasibility LP on the plate
    problem: 2.1-4.6 CPU s at 2000 disks where the certificate takes 0.2-0.7 s.)
    Returns (packing, statistics) as :func:`static_solve`, or None.
    """
    done, _cert = certified_solve(setup, bodies, seed, show_progress, interrupt)
    return done


def packing_view(setup: Setup, bodies: Bodies, c: Contacts, image):
    """A function (rn, rt) -> Packing for the frozen configuration and contacts ``c``
    (their real gaps; ``image`` (Nc,) the periodic images). The packing carries
    ``setup`` and its provenance (scene name, text, seed)."""
    n = bodies.n
    a, b, nx, ny, gap = c.a, c.b, c.nx, c.ny, c.gap
    pa, pb = packing_body_code(a, n), packing_body_code(b, n)
    x, y, r = bodies.x[:n].copy(), bodies.y[:n].copy(), bodies.r
    normal = np.column_stack([nx, ny])
    # contact point: on a's surface pushed half the gap toward b; walls: on the disk
    point = np.empty((a.shape[0], 2))
    da = a < n
    point[da, 0] = x[a[da]] + (r[a[da]] + 0.5 * gap[da]) * nx[da]
    point[da, 1] = y[a[da]] + (r[a[da]] + 0.5 * gap[da]) * ny[da]
    wa = ~da  # a is a wall: b is a disk
    point[wa, 0] = x[b[wa]] - r[b[wa]] * nx[wa]
    point[wa, 1] = y[b[wa]] - r[b[wa]] * ny[wa]
    boundary, physics, grains = setup.boundary, setup.physics, setup.grains
    (width,), (periodic,) = boundary.lateral, boundary.periodic
    if periodic:
        point[:, 0] -= width * np.floor(point[:, 0] / width)
    sigma = setup.force_unit
    density = grains.density
    if grains.density_ratio != 1.0:     # per-disk densities, read off the masses
        density = 1.0 / (bodies.inv_mx[:n] * np.pi * r**2)
    top = boundary.top
    y_top = bodies.y[n + SLOT_TOP] if top is not None else np.nan
    y_bot = bodies.y[n + SLOT_BOTTOM] if boundary.bottom else np.nan

    def make(rn, rt) -> Packing:
        return Packing(x=x, y=y, r=r, width=width, periodic_x=periodic,
                       y_bottom=float(y_bot), y_top=float(y_top),
                       top_force=top.force if top is not None else 0.0,
                       gravity=physics.gravity, density=density,
                       mu=physics.mu, plate_mu=physics.plate_mu,
                       a=pa, b=pb, normal=normal, point=point, image=image, gap=gap,
                       fn=rn * sigma, ft=rt * sigma, seed=setup.seed,
                       scene_text=setup.text, scene_name=setup.name, setup=setup)
    return make


def settled_forces(packing: Packing, setup: Setup) -> ContactForces:
    """The packing's contact forces as the engine's warm start: keys a*nb + b of kernel
    body indices (sorted), rn, rt [sigma] = fn, ft [F0] / the setup's force unit."""
    n = packing.n_disks
    nb = n + N_WALL_SLOTS
    keys = kernel_body_index(packing.a, n) * nb + kernel_body_index(packing.b, n)
    order = np.argsort(keys, kind="stable")
    sigma = setup.force_unit
    return ContactForces(keys[order].astype(np.int64),
                         np.asarray(packing.fn, float)[order] / sigma,
                         np.asarray(packing.ft, float)[order] / sigma)
