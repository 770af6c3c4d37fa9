"""The engine's bodies for a scene: loose start, body arrays, the kernels' settings.

Units: lengths in R, masses in rho R^2, forces in the internal unit sigma
(:func:`force_unit`), time in T = sqrt(rho R^3 / sigma). Body layout:
:mod:`forcespace.engine.records`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, NumericalError
from ..model.radii import draw_radii
from ..model.scene import Scene
from ..model.walls import N_WALL_SLOTS, SLOT_BOTTOM, SLOT_TOP
from .records import Box, StepSettings, SweepSettings


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

    @property
    def n(self) -> int:
        return self.r.shape[0]


def random_radii(scene: Scene, rng) -> np.ndarray:
    """Radii (n,) [R] by the scene's ``disks.distribution`` (:mod:`forcespace.model.radii`;
    the default "uniform" is ``rng.uniform(radius_min, radius_max, n)``, as always)."""
    return draw_radii(scene, rng)


def loose_start(scene: Scene, rng) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Random sequential placement of non-overlapping disks.

    Returns x, y, r (n,) and the box height [R] at the scene's initial packing
    fraction. Disks are placed largest first; x is periodic if the scene says so.
    With ``solver.sweep_block`` > 0 the disks are then numbered row by row (rows
    one largest diameter high, x increasing), so that contacts sorted by disk
    index are near each other in space. ``rng``: :func:`forcespace.streams.
    placement_rng` (radii first, then the placement draws).
    """
    r = np.sort(random_radii(scene, rng))[::-1].copy()
    width = scene["box.width"]
    periodic = scene["box.periodic_x"]
    height = np.pi * (r**2).sum() / (width * scene["box.initial_packing_fraction"])
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
                f"{scene['box.initial_packing_fraction']}: lower box.initial_packing_fraction")
    if scene["solver.sweep_block"] > 0:   # number the disks row by row (local sweeps)
        order = row_order(x, y, r)
        x, y, r = x[order], y[order], r[order]
    return x, y, r, height


def row_order(x, y, r) -> np.ndarray:
    """Disk indices (n,) row by row: rows one largest diameter high (y = 0 at a row
    boundary), x increasing within a row (the numbering of ``solver.sweep_block`` > 0)."""
    return np.lexsort((x, np.floor(y / (2.0 * r.max()))))


def force_unit(scene: Scene) -> float:
    """The engine's internal force unit sigma [F0]: the top-plate load, else rho g R^2.

    The kernels run with every force divided by sigma, so a scene whose loads
    are all multiplied by k gives the same trajectory (positions bit for bit)
    and forces exactly k times larger. Time is therefore measured in
    sqrt(rho R^3 / sigma): ``solver.dt`` is in that unit (for the default
    top_force = 1 F0 the two agree).
    """
    if scene["plates.top"] == "load":
        return float(scene["plates.top_force"])
    return float(scene["disks.density"] * scene["physics.gravity"])


def make_bodies(scene: Scene, x, y, r, height, density=None) -> Bodies:
    """Kernel body arrays for disks and walls; only the scene's physics is switched on.

    x, y, r (n,) [R]; height: the top plate's surface [R]. Forces are in the internal
    unit :func:`force_unit`. ``density``: per-disk densities (n,) (default the
    scene's uniform density).
    """
    n = r.shape[0]
    nb = n + N_WALL_SLOTS
    sigma = force_unit(scene)
    rho = scene["disks.density"] if density is None else np.asarray(density, float)
    m = rho * np.pi * r**2
    inv_mx = np.zeros(nb)
    inv_my = np.zeros(nb)
    inv_i = np.zeros(nb)
    fy = np.zeros(nb)
    inv_mx[:n] = inv_my[:n] = 1.0 / m
    if scene.rotation:
        inv_i[:n] = 1.0 / (0.5 * m * r**2)
    if scene["physics.gravity"] > 0:
        fy[:n] = -m * (scene["physics.gravity"] / sigma)
    X = np.zeros(nb)
    Y = np.zeros(nb)
    X[:n], Y[:n] = x, y
    Y[n + SLOT_BOTTOM] = 0.0
    if scene["plates.top"] == "load":
        Y[n + SLOT_TOP] = height
        inv_my[n + SLOT_TOP] = 1.0 / scene["plates.top_mass"]
        fy[n + SLOT_TOP] = -scene["plates.top_force"] / sigma
    return Bodies(X, Y, np.zeros(nb), np.zeros(nb), np.zeros(nb), np.zeros(nb), r.copy(),
                  inv_mx, inv_my, inv_i, fy)


def scene_box(scene: Scene) -> Box:
    """The container of a scene."""
    periodic = bool(scene["box.periodic_x"])
    return Box(float(scene["box.width"]), periodic, scene["plates.bottom"] == "fixed",
               scene["plates.top"] == "load", not periodic)


def velocity_scale(scene: Scene, bodies: Bodies) -> float:
    """v0 = sqrt(F rbar / mbar) in internal units [R/T]: F the top-plate load, or the mean
    disk weight."""
    n = bodies.n
    m = 1.0 / bodies.inv_mx[:n]
    f0 = -bodies.fy_ext[n + SLOT_TOP] if scene["plates.top"] == "load" \
        else float(-bodies.fy_ext[:n].mean())
    return float(np.sqrt(f0 * bodies.r.mean() / m.mean()))


def step_settings(scene: Scene, v0: float = 1.0) -> tuple[StepSettings, SweepSettings]:
    """The time stepper's settings for a scene; v0 [R/T]: :func:`velocity_scale` (the
    unit of ``solver.moving_speed``)."""
    sweeps = scene["solver.max_sweeps"]
    fallback = scene["solver.relaxation_fallback"]
    step = StepSettings(
        margin=float(scene["solver.contact_margin"]), mu_disk=float(scene["physics.mu"]),
        mu_wall=float(scene["physics.plate_mu"]), rotation=bool(scene.rotation),
        tol_moving=float(scene["solver.tolerance_moving"]),
        moving_speed=float(scene["solver.moving_speed"] * v0),
        sweeps_moving=int(scene["solver.max_sweeps_moving"]))
    sweep = SweepSettings(
        dt=float(scene["solver.dt"]), tol=float(scene["solver.tolerance"]),
        max_sweeps=int(sweeps), relaxation=float(scene["solver.relaxation"]),
        block=int(scene["solver.sweep_block"]),
        overlap_correction=float(scene["solver.overlap_correction"]),
        overlap_slop=float(scene["solver.overlap_slop"]),
        relax_until=-1 if fallback == 0.5 else int(fallback * sweeps))
    return step, sweep


def check_scene(scene: Scene) -> None:
    """Refuse (InputError) a scene the time stepper cannot run faithfully, before any work.

    A load-controlled plate of mass M under its load F moves dt^2 F / M in one step from
    rest (dt is measured in the load's time unit, so that is ``solver.dt**2 /
    plates.top_mass`` [R]); beyond ``solver.contact_margin`` it can pass the margin
    between two contact detections and end in overlaps no step removes (top_mass = 1e-6
    kept 4.5e-3 R, 22 000 x the slop).
    """
    if scene["plates.top"] != "load":
        return
    free_step = scene["solver.dt"] ** 2 / scene["plates.top_mass"]
    margin = scene["solver.contact_margin"]
    if free_step > margin:
        raise InputError(scene.source, "plates.top_mass",
                         f"must be >= solver.dt^2 / solver.contact_margin = "
                         f"{scene['solver.dt'] ** 2 / margin:.3g} (the plate would move "
                         f"{free_step:.3g} R in one step from rest, more than the contact "
                         f"margin {margin:g} R: contacts are missed); raise it or lower "
                         "solver.dt", got=scene["plates.top_mass"])
