"""The static solve of a jammed configuration: frozen contacts, NLGS to equilibrium.

Positions fixed, velocities zeroed, pairs with gap below ``jamming.contact_gap_tol``
taken as closed contacts (gap set to 0), NLGS until the relative equilibrium residual
of every disk and the top plate is at most ``jamming.static_tolerance``.
"""
from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from ..errors import NumericalError
from ..model.packing import Packing
from ..model.setup import Setup
from ..model.walls import (N_WALL_SLOTS, SLOT_BOTTOM, SLOT_TOP, kernel_body_index,
                           packing_body_code)
from ..progress import progress
from ..model.sphere_packing import SpherePacking
from .bodies import Bodies, SphereBodies, certificate_settings, kernel_box
from .certificate import (Certificate, certify_spheres, frozen_system, in_cones,
                          least_change_network, least_change_spheres)
from .contacts import detect_contacts, detect_contacts3
from .frozen import FrozenContacts, FrozenContacts3, relax
from .interrupts import InterruptFlag
from .records import ContactForces, Contacts, Contacts3
from .step import contact_list, warm_start, warm_start3


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
    jamming = setup.jamming
    frozen = frozen_disks if bodies.dim == 2 else frozen_spheres
    system, rn, rt, packing_of = frozen(setup, bodies)
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


def _check_none_loose(loaded, c, noun: str) -> None:
    """NumericalError if a body with a load (``loaded``, (n,) bool) is in no contact of
    the frozen list ``c``: the configuration is not static."""
    touched = np.zeros(loaded.shape[0] + N_WALL_SLOTS, dtype=bool)
    touched[c.a] = touched[c.b] = True
    loose = np.flatnonzero(loaded & ~touched[:loaded.shape[0]])
    if loose.size:
        raise NumericalError(f"{noun} {loose[0]} feels gravity but touches nothing: the "
                             "configuration is not static (raise jamming.window or lower "
                             "jamming.velocity_tol)")


def frozen_disks(setup: Setup, bodies: Bodies):
    """The frozen network of the disks' configuration: (FrozenContacts, rn, rt warm
    started from the dynamics' last forces, the function (rn, rt) -> Packing); pairs with
    gap at most ``jamming.contact_gap_tol`` are closed contacts (gaps set to 0)."""
    n = bodies.n
    ints, floats = detect_contacts(bodies.x, bodies.y, bodies.r, kernel_box(setup.boundary),
                                   setup.jamming.contact_gap_tol)
    c = contact_list(ints, floats, bodies.r, setup.physics.mu, setup.physics.plate_mu)
    _check_none_loose(bodies.fy_ext[:n] != 0, c, "disk")
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
    return system, rn, rt, packing_of


def frozen_spheres(setup: Setup, bodies: SphereBodies):
    """The frozen network of the spheres' configuration (3-D :func:`frozen_disks`):
    (FrozenContacts3, rn (Nc,), rt (Nc, 3) warm started, (rn, rt) -> SpherePacking)."""
    n = bodies.n
    ints, floats = detect_contacts3(bodies.pos, bodies.r, kernel_box(setup.boundary),
                                    setup.jamming.contact_gap_tol)
    c = contact_list(ints, floats, bodies.r, setup.physics.mu, setup.physics.plate_mu)
    _check_none_loose(bodies.load[:n] != 0, c, "sphere")
    if bodies.contacts is not None:  # start from the forces the dynamics ended with
        rn, rt = warm_start3(c.keys, c.normal, bodies.contacts)
        rt[c.mu == 0.0] = 0.0
    else:
        rn, rt = np.zeros(c.a.shape[0]), np.zeros((c.a.shape[0], 3))
    v_ext = (bodies.f_ext * bodies.inv_m, np.zeros_like(bodies.w))
    system = FrozenContacts3(c._replace(gap=np.zeros(c.a.shape[0])), bodies.inv_m,
                             bodies.inv_i, v_ext)
    return system, rn, rt, sphere_packing_view(setup, bodies, c, ints[:, 2:4].copy())


def sphere_packing_view(setup: Setup, bodies: SphereBodies, c: Contacts3, image):
    """A function (rn, rt) -> SpherePacking for the frozen 3-D configuration and contacts
    ``c`` (their real gaps; ``image`` (Nc, 2) the periodic images), carrying ``setup``."""
    n = bodies.n
    a, b, normal, gap = c.a, c.b, c.normal, c.gap
    pos, r = bodies.pos[:n].copy(), bodies.r
    # contact point: on a's surface pushed half the gap toward b; plates: on the sphere
    point = np.empty((a.shape[0], 3))
    sa = a < n
    point[sa] = pos[a[sa]] + (r[a[sa]] + 0.5 * gap[sa])[:, None] * normal[sa]
    point[~sa] = pos[b[~sa]] - r[b[~sa], None] * normal[~sa]
    lateral = np.asarray(setup.boundary.lateral, float)
    point[:, :2] -= lateral * np.floor(point[:, :2] / lateral)
    boundary, physics, grains = setup.boundary, setup.physics, setup.grains
    density = grains.density
    if grains.density_ratio != 1.0:     # per-sphere densities, read off the masses
        density = 1.0 / (bodies.inv_m[:n, 0] * 4.0 / 3.0 * np.pi * r**3)
    top = boundary.top
    z_top = bodies.pos[n + SLOT_TOP, 2] if top is not None else np.nan
    z_bot = bodies.pos[n + SLOT_BOTTOM, 2] if boundary.bottom else np.nan
    sigma = setup.force_unit
    pa, pb = packing_body_code(a, n), packing_body_code(b, n)

    def make(rn, rt) -> SpherePacking:
        return SpherePacking(
            pos=pos, r=r, lateral=tuple(float(v) for v in lateral), z_bottom=float(z_bot),
            z_top=float(z_top), top_force=top.force if top is not None else 0.0,
            gravity=physics.gravity, density=density, mu=physics.mu,
            plate_mu=physics.plate_mu, a=pa, b=pb, normal=normal, point=point, image=image,
            gap=gap, fn=rn * sigma, ft=np.asarray(rt).reshape(-1, 3) * sigma,
            seed=setup.seed, scene_text=setup.text, scene_name=setup.name, setup=setup)
    return make


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
    :class:`~forcespace.engine.certificate.Certificate`). Spheres:
    :func:`_certified_spheres`.
    """
    if bodies.dim == 3:
        return _certified_spheres(setup, bodies, seed, show_progress, interrupt)
    settings = certificate_settings(setup)
    c, _image, system, rn0, rt0 = frozen_system(
        bodies, kernel_box(setup.boundary), setup.physics.mu, setup.physics.plate_mu,
        settings.gap_tol, bodies.contacts)
    cert = least_change_network(system, rn0, rt0, settings.tol)
    if cert.status != "static":
        return None, cert
    start = ContactForces(c.keys, *in_cones(cert.rn, cert.rt, c.mu))
    return polished(setup, bodies, seed, start, cert, show_progress, interrupt), cert


def polished(setup: Setup, bodies, seed: int, start: ContactForces, cert: Certificate,
             show_progress=True, interrupt=None):
    """:func:`static_solve` from the network ``start`` (a certificate's) instead of the
    dynamics' forces (restored after); (packing, statistics with the certificate's)."""
    dynamics = bodies.contacts
    bodies.contacts = start
    try:
        packing, stats = static_solve(setup, bodies, seed, show_progress, interrupt)
    finally:
        bodies.contacts = dynamics
    stats.update(certificate_stats(cert))
    return packing, stats


def certificate_stats(cert: Certificate) -> dict:
    """The packing metadata of a certificate (``certificate_*``)."""
    return {"certificate_status": cert.status, "certificate_iterations": cert.iterations,
            "certificate_seconds": cert.seconds, "certificate_residual": cert.residual}


def restart_from_exact_point(setup: Setup, bodies: Bodies | SphereBodies, seed: int,
                             show_progress=True, interrupt: InterruptFlag | None = None):
    """The static solve again, from an exact static network, for a configuration whose
    NLGS from the dynamics' forces stalled above ``jamming.static_tolerance``.

    The configuration's certificate (:func:`certified_solve`: interior point, Clarabel)
    decides whether any static network exists. If one does, NLGS restarts from the one
    nearest the dynamics' forces (and polishes it to the tolerance), else None: the
    configuration is not static (the case that asked for it: studies/field_notes.md).
    (Before issue 42 the exact point was HiGHS' feasibility LP on the plate
    problem: 2.1-4.6 CPU s at 2000 disks where the certificate takes 0.2-0.7 s.)
    Spheres: the nearest point of S by the second-order-cone program
    (:func:`exact_sphere_network`). Returns (packing, statistics) as
    :func:`static_solve`, or None.
    """
    if bodies.dim == 3:
        _, rn, rt, packing_of = frozen_spheres(setup, bodies)
        packing = packing_of(rn, rt)
        fn, ft = exact_sphere_network(setup, packing)
        if fn is None:
            return None
        bodies.contacts = settled_forces(replace(packing, fn=fn, ft=ft), setup)
        return static_solve(setup, bodies, seed, show_progress, interrupt)
    done, _cert = certified_solve(setup, bodies, seed, show_progress, interrupt)
    return done


def exact_sphere_network(setup: Setup, packing: SpherePacking):
    """An exact static network of a frozen sphere configuration: the point of S (the
    plate problem under a load-controlled plate, else the full one) nearest to the
    packing's forces, by the second-order-cone program of
    :func:`forcespace.space.conic.nearest_admissible` (Clarabel); (fn (Nc,), ft (Nc, 3))
    [F0], or (None, None) when S is empty."""
    from ..space.conic import nearest_admissible

    problem = sphere_problem_of(setup, packing)
    res = nearest_admissible(problem, target=problem.x_jammed)
    if not res.feasible:
        return None, None
    return problem.to_packing_forces(res.x)


def sphere_problem_of(setup: Setup, packing: SpherePacking, rattlers=None):
    """S of a frozen sphere configuration as the setup loads it: the plate problem under a
    load-controlled plate, else the full one, on the contacts with gap at most
    ``jamming.contact_gap_tol`` (a SphereStaticsProblem; ``rattlers`` (n,) bool: the
    spheres left out, default the packing's)."""
    from ..model.sphere_problem import sphere_full_problem, sphere_plate_problem

    build = sphere_plate_problem if setup.boundary.top is not None else sphere_full_problem
    return build(packing, gap_tol=setup.jamming.contact_gap_tol, rattlers=rattlers)


def untouched_spheres(setup: Setup, packing: SpherePacking) -> np.ndarray:
    """(n,) bool: spheres in no contact with gap <= ``jamming.contact_gap_tol`` (the only
    ones a geometric certificate may leave out: no force can reach them)."""
    closed = np.asarray(packing.gap) <= setup.jamming.contact_gap_tol
    touched = np.zeros(packing.n_spheres, bool)
    for ends in (np.asarray(packing.a)[closed], np.asarray(packing.b)[closed]):
        touched[ends[ends >= 0]] = True
    return ~touched


def sphere_certificate(setup: Setup, bodies: SphereBodies, forces: ContactForces,
                       tol: float) -> Certificate:
    """Whether the spheres' frozen configuration admits a static network: the
    second-order-cone certificate (:func:`~forcespace.engine.certificate.certify_spheres`,
    the network nearest to the dynamics' ``forces``) on every sphere that touches
    anything (a sphere touching nothing needs no force when it feels no load; one that
    feels a load is refused: "not static")."""
    dynamics, bodies.contacts = bodies.contacts, forces
    try:
        _, rn, rt, packing_of = frozen_spheres(setup, bodies)
    except NumericalError:          # a loaded sphere touches nothing
        return Certificate("not static", None, None, np.inf, 0, 0.0)
    finally:
        bodies.contacts = dynamics
    packing = packing_of(rn, rt)
    problem = sphere_problem_of(setup, packing, untouched_spheres(setup, packing))
    return certify_spheres(problem, tol)[0]


def _certified_spheres(setup: Setup, bodies: SphereBodies, seed: int, show_progress,
                       interrupt):
    """:func:`certified_solve` for spheres: the least-change network of the
    second-order-cone program (:func:`~forcespace.engine.certificate.least_change_spheres`)
    polished by :func:`static_solve`."""
    _, rn, rt, packing_of = frozen_spheres(setup, bodies)
    packing = packing_of(rn, rt)
    problem = sphere_problem_of(setup, packing, untouched_spheres(setup, packing))
    cert, x = least_change_spheres(problem, certificate_settings(setup).tol)
    if x is None:
        return None, cert
    fn, ft = problem.to_packing_forces(x)
    start = settled_forces(replace(packing, fn=np.maximum(fn, 0.0), ft=ft), setup)
    return polished(setup, bodies, seed, start, cert, show_progress, interrupt), cert


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
