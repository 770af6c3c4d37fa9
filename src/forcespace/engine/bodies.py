"""The engine's bodies for a setup: loose start, body arrays, the kernels' settings.

Everything here reads the records of :class:`~forcespace.model.setup.Setup` (made once
from the scene at the top of the protocol), never the scene's keys. Units: lengths in R,
masses in rho R^2, forces in the internal unit sigma (:attr:`Setup.force_unit`), time in
T = sqrt(rho R^3 / sigma). Body layout: :mod:`forcespace.engine.records`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, NumericalError
from ..model.radii import draw_radii
from ..model.setup import Boundary, Setup
from ..model.walls import N_WALL_SLOTS, SLOT_BOTTOM, SLOT_TOP
from .certificate import CertificateSettings
from .records import Box, Box3, StepSettings, SweepSettings


@dataclass
class Bodies:
    """Body arrays of the kernels, shape (n+4,) each (disks, then wall slots); the
    fields of :class:`~forcespace.engine.records.BodyArrays` (units there)."""

    x: np.ndarray
    y: np.ndarray
    th: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    w: np.ndarray
    r: np.ndarray          # (n,)
    inv_mx: np.ndarray
    inv_my: np.ndarray
    inv_i: np.ndarray
    fy_ext: np.ndarray
    contacts: tuple | None = None  # last step's ContactForces (sorted keys, rn, rt)

    dim = 2
    state_fields = ("x", "y", "th", "vx", "vy", "w")    # what a checkpoint saves

    @property
    def n(self) -> int:
        return self.r.shape[0]

    @property
    def vertical(self) -> np.ndarray:
        """Positions along the vertical axis (nb,) [R] (wall slots: the plates)."""
        return self.y

    @property
    def load(self) -> np.ndarray:
        """External force along the vertical (nb,) [sigma] (gravity, the plate load)."""
        return self.fy_ext

    @property
    def masses(self) -> np.ndarray:
        """Disk masses (n,) [rho R^2], read off the kernels' inverse masses."""
        return 1.0 / self.inv_mx[:self.n]


@dataclass
class SphereBodies:
    """Body arrays of the 3-D kernels: (n+4, 3) each (spheres, then the wall slots) but
    ``inv_i`` (n+4,) and ``r`` (n,); the fields of
    :class:`~forcespace.engine.records.BodyArrays3` (units there). The orchestration
    (compression, rest criterion, checkpoints) reads both kinds of bodies through
    ``n``, ``dim``, ``state_fields``, ``vertical`` and ``load``."""

    pos: np.ndarray
    th: np.ndarray
    v: np.ndarray
    w: np.ndarray
    r: np.ndarray          # (n,)
    inv_m: np.ndarray
    inv_i: np.ndarray      # (n+4,)
    f_ext: np.ndarray
    contacts: tuple | None = None  # last step's ContactForces (sorted keys, rn, rt (Nc, 3))

    dim = 3
    state_fields = ("pos", "th", "v", "w")

    @property
    def n(self) -> int:
        return self.r.shape[0]

    @property
    def vertical(self) -> np.ndarray:
        """Positions along z (nb,) [R] (a view; wall slots: the plates)."""
        return self.pos[:, 2]

    @property
    def load(self) -> np.ndarray:
        """External force along z (nb,) [sigma] (a view)."""
        return self.f_ext[:, 2]

    @property
    def masses(self) -> np.ndarray:
        """Sphere masses (n,) [rho R^3], read off the kernels' inverse masses."""
        return 1.0 / self.inv_m[:self.n, 0]


def random_radii(setup: Setup, rng) -> np.ndarray:
    """Radii (n,) [R] by the grains' distribution (:mod:`forcespace.model.radii`;
    the default "uniform" is ``rng.uniform(radius_min, radius_max, n)``, as always)."""
    return draw_radii(setup.grains, rng)


def loose_start(setup: Setup, rng) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Random sequential placement of non-overlapping disks.

    Returns x, y, r (n,) and the box height [R] at the scene's initial packing
    fraction. Disks are placed largest first; x is periodic if the boundary is.
    With ``solver.sweep_block`` > 0 the disks are then numbered row by row (rows
    one largest diameter high, x increasing), so that contacts sorted by disk
    index are near each other in space. ``rng``: :func:`forcespace.streams.
    placement_rng` (radii first, then the placement draws).
    """
    r = np.sort(random_radii(setup, rng))[::-1].copy()
    (width,), (periodic,) = setup.boundary.lateral, setup.boundary.periodic
    fraction = setup.jamming.initial_packing_fraction
    height = np.pi * (r**2).sum() / (width * fraction)
    height = max(height, 2.0 * r.max() + 1e-9)
    x = np.empty_like(r)
    y = np.empty_like(r)
    for i, ri in enumerate(r):
        for _ in range(100000):
            xi = rng.uniform(0, width) if periodic else rng.uniform(ri, width - ri)
            yi = rng.uniform(ri, height - ri)
            dx = x[:i] - xi
            if periodic:
                dx -= width * np.round(dx / width)
            if i == 0 or (np.hypot(dx, y[:i] - yi) - r[:i] - ri).min() > 0:
                x[i], y[i] = xi, yi
                break
        else:
            raise NumericalError(
                f"could not place disk {i} without overlap at initial packing fraction "
                f"{fraction}: lower box.initial_packing_fraction")
    if setup.solver.sweep_block > 0:   # number the disks row by row (local sweeps)
        order = row_order(x, y, r)
        x, y, r = x[order], y[order], r[order]
    return x, y, r, height


def row_order(x, y, r) -> np.ndarray:
    """Disk indices (n,) row by row: rows one largest diameter high (y = 0 at a row
    boundary), x increasing within a row (the numbering of ``solver.sweep_block`` > 0)."""
    return np.lexsort((x, np.floor(y / (2.0 * r.max()))))


def make_bodies(setup: Setup, x, y, r, height, density=None) -> Bodies:
    """Kernel body arrays for disks and walls; only the setup's physics is switched on.

    x, y, r (n,) [R]; height: the top plate's surface [R]. Forces are in the internal
    unit :attr:`Setup.force_unit`. ``density``: per-disk densities (n,) (default the
    grains' uniform density).
    """
    n = r.shape[0]
    nb = n + N_WALL_SLOTS
    sigma = setup.force_unit
    physics, top = setup.physics, setup.boundary.top
    rho = setup.grains.density if density is None else np.asarray(density, float)
    m = rho * np.pi * r**2
    inv_mx = np.zeros(nb)
    inv_my = np.zeros(nb)
    inv_i = np.zeros(nb)
    fy = np.zeros(nb)
    inv_mx[:n] = inv_my[:n] = 1.0 / m
    if physics.rotation:
        inv_i[:n] = 1.0 / (0.5 * m * r**2)
    if physics.gravity > 0:
        fy[:n] = -m * (physics.gravity / sigma)
    X = np.zeros(nb)
    Y = np.zeros(nb)
    X[:n], Y[:n] = x, y
    Y[n + SLOT_BOTTOM] = 0.0
    if top is not None:
        Y[n + SLOT_TOP] = height
        inv_my[n + SLOT_TOP] = 1.0 / top.mass
        fy[n + SLOT_TOP] = -top.force / sigma
    return Bodies(X, Y, np.zeros(nb), np.zeros(nb), np.zeros(nb), np.zeros(nb), r.copy(),
                  inv_mx, inv_my, inv_i, fy)


def loose_start3(setup: Setup, rng) -> tuple[np.ndarray, np.ndarray, float]:
    """Random sequential placement of non-overlapping spheres in the periodic box.

    Returns pos (n, 3), r (n,) [R] and the box height [R] at the scene's initial packing
    (volume) fraction; spheres are placed largest first, x and y periodic. With
    ``solver.sweep_block`` > 0 the spheres are numbered layer by layer (layers and rows
    one largest diameter thick), so that contacts sorted by index are near in space.
    ``rng``: the placement stream, radii drawn first (as in 2-D).
    """
    r = np.sort(random_radii(setup, rng))[::-1].copy()
    lx, ly = setup.boundary.lateral
    fraction = setup.jamming.initial_packing_fraction
    height = max(4.0 / 3.0 * np.pi * (r**3).sum() / (lx * ly * fraction), 2.0 * r.max() + 1e-9)
    size = np.array([lx, ly])
    pos = np.empty((r.size, 3))
    for i, ri in enumerate(r):
        for _ in range(100000):
            p = np.array([rng.uniform(0, lx), rng.uniform(0, ly),
                          rng.uniform(ri, height - ri)])
            d = pos[:i] - p
            d[:, :2] -= size * np.round(d[:, :2] / size)
            if i == 0 or (np.sqrt((d * d).sum(1)) - r[:i] - ri).min() > 0:
                pos[i] = p
                break
        else:
            raise NumericalError(
                f"could not place sphere {i} without overlap at initial packing fraction "
                f"{fraction}: lower box.initial_packing_fraction")
    if setup.solver.sweep_block > 0:   # number the spheres layer by layer (local sweeps)
        cell = 2.0 * r.max()
        order = np.lexsort((pos[:, 0], np.floor(pos[:, 1] / cell), np.floor(pos[:, 2] / cell)))
        pos, r = pos[order], r[order]
    return pos, r, height


def make_sphere_bodies(setup: Setup, pos, r, height, density=None) -> SphereBodies:
    """Kernel body arrays for spheres and plates (3-D :func:`make_bodies`): solid spheres,
    m = density 4/3 pi r^3, I = 2/5 m r^2 (rotation only when the physics asks for it);
    the top plate at ``height`` [R] moves along z only under its load."""
    n = r.shape[0]
    nb = n + N_WALL_SLOTS
    sigma = setup.force_unit
    physics, top = setup.physics, setup.boundary.top
    rho = setup.grains.density if density is None else np.asarray(density, float)
    m = rho * 4.0 / 3.0 * np.pi * r**3
    inv_m = np.zeros((nb, 3))
    inv_i = np.zeros(nb)
    f_ext = np.zeros((nb, 3))
    inv_m[:n] = (1.0 / m)[:, None]
    if physics.rotation:
        inv_i[:n] = 1.0 / (0.4 * m * r**2)
    if physics.gravity > 0:
        f_ext[:n, 2] = -m * (physics.gravity / sigma)
    pos_all = np.zeros((nb, 3))
    pos_all[:n] = pos
    if top is not None:
        pos_all[n + SLOT_TOP, 2] = height
        inv_m[n + SLOT_TOP, 2] = 1.0 / top.mass
        f_ext[n + SLOT_TOP, 2] = -top.force / sigma
    return SphereBodies(pos_all, np.zeros((nb, 3)), np.zeros((nb, 3)), np.zeros((nb, 3)),
                        r.copy(), inv_m, inv_i, f_ext)


def kernel_box(boundary: Boundary) -> Box | Box3:
    """The kernels' record of a container (:class:`~forcespace.model.setup.Boundary`): a
    Box in 2-D, a Box3 in 3-D (periodic in x and y)."""
    if boundary.dim == 3:
        if not all(boundary.periodic):
            raise InputError("setup", "boundary", "a 3-D box must be periodic in x and y",
                             got=boundary.periodic)
        return Box3(float(boundary.lateral[0]), float(boundary.lateral[1]),
                    bool(boundary.bottom), boundary.top is not None)
    if boundary.dim != 2:
        raise InputError("setup", "boundary", "the engine runs in 2-D (one lateral axis) "
                         "or 3-D (two)", got=boundary.dim)
    periodic = bool(boundary.periodic[0])
    return Box(float(boundary.lateral[0]), periodic, bool(boundary.bottom),
               boundary.top is not None, not periodic)


def velocity_scale(setup: Setup, bodies: Bodies | SphereBodies) -> float:
    """v0 = sqrt(F rbar / mbar) in internal units [R/T]: F the top-plate load, or the mean
    grain weight."""
    n = bodies.n
    m = bodies.masses
    f0 = -bodies.load[n + SLOT_TOP] if setup.boundary.top is not None \
        else float(-bodies.load[:n].mean())
    return float(np.sqrt(f0 * bodies.r.mean() / m.mean()))


def step_settings(setup: Setup, v0: float = 1.0) -> tuple[StepSettings, SweepSettings]:
    """The time stepper's settings for a setup; v0 [R/T]: :func:`velocity_scale` (the
    unit of ``solver.moving_speed``)."""
    s, physics = setup.solver, setup.physics
    sweeps = s.max_sweeps
    fallback = s.relaxation_fallback
    step = StepSettings(
        margin=float(s.contact_margin), mu_disk=float(physics.mu),
        mu_wall=float(physics.plate_mu), rotation=bool(physics.rotation),
        tol_moving=float(s.tolerance_moving), moving_speed=float(s.moving_speed * v0),
        sweeps_moving=int(s.max_sweeps_moving))
    sweep = SweepSettings(
        dt=float(s.dt), tol=float(s.tolerance), max_sweeps=int(sweeps),
        relaxation=float(s.relaxation), block=int(s.sweep_block),
        overlap_correction=float(s.overlap_correction), overlap_slop=float(s.overlap_slop),
        relax_until=-1 if fallback == 0.5 else int(fallback * sweeps))
    return step, sweep


def compacting_settings(setup: Setup, sweep: SweepSettings, v0: float = 1.0):
    """(the sweep settings of a compacting window: ``sweep`` with dt =
    ``solver.dt_compacting``, the window mean speed [R/T] above which the next window is
    one) or None when the scene keeps ``solver.dt`` throughout; v0 [R/T]:
    :func:`velocity_scale`."""
    s = setup.solver
    if s.dt_compacting <= 0:
        return None
    return sweep._replace(dt=float(s.dt_compacting)), float(s.compacting_speed * v0)


def certificate_settings(setup: Setup, v0: float = 1.0) -> CertificateSettings:
    """When a jam of the setup is ended by a static certificate; v0 [R/T]:
    :func:`velocity_scale` (the unit of ``jamming.certificate_speed``)."""
    j = setup.jamming
    return CertificateSettings(speed=float(j.certificate_speed * v0),
                               gap_tol=float(j.contact_gap_tol))


def check_setup(setup: Setup) -> None:
    """Refuse (InputError) a setup the time stepper cannot run faithfully, before any work.

    A load-controlled plate of mass M under its load F moves dt^2 F / M in one step from
    rest (dt is measured in the load's time unit, so that is ``solver.dt**2 /
    plates.top_mass`` [R]); beyond ``solver.contact_margin`` it can pass the margin
    between two contact detections and end in overlaps no step removes (top_mass = 1e-6
    kept 4.5e-3 R, 22 000 x the slop).
    """
    top, dt = setup.boundary.top, max(setup.solver.dt, setup.solver.dt_compacting)
    if top is None:
        return
    free_step = dt ** 2 / top.mass
    margin = setup.solver.contact_margin
    if free_step > margin:
        raise InputError(setup.source, "plates.top_mass",
                         f"must be >= dt^2 / solver.contact_margin = "
                         f"{dt ** 2 / margin:.3g} (the plate would move "
                         f"{free_step:.3g} R in one step from rest, more than the contact "
                         f"margin {margin:g} R: contacts are missed; dt the larger of "
                         "solver.dt and solver.dt_compacting); raise it or lower dt",
                         got=top.mass)
