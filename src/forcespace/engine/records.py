"""Named state of the engine's numba kernels.

Every kernel of :mod:`forcespace.engine` takes these records instead of loose
positional arrays. They are ``typing.NamedTuple`` classes of numpy arrays and
scalars, which numba passes and returns in nopython mode (and caches). Units:
lengths in R (the smallest radius of the scene's range), masses in rho R^2, forces in
the engine's internal force unit sigma (:attr:`forcespace.model.setup.Setup.force_unit`),
time in T = sqrt(rho R^3 / sigma).

Body layout (every per-body array): disks 0..n-1, then the four wall slots of
:mod:`forcespace.model.walls`: bottom (n), top (n+1), left (n+2), right (n+3); nb = n+4.
A body's inverse masses are zero in every direction it cannot move.

Contact convention: contact k joins bodies ``a[k]`` and ``b[k]`` with unit normal
(nx, ny) from a to b; the force ``rn*n + rt*t`` (t = (-ny, nx)) acts on b, its negative
on a; lever arms ``ra*n`` from a's centre and ``-rb*n`` from b's centre (ra, rb the
radii, 0 for walls), so a tangential force rt exerts the torque ``-r*rt`` on both.

Spheres (3-D) have records of their own where the state differs (``*3`` below): vectors
are rows of (.., 3) arrays (x, y lateral, z vertical), masses in rho R^3; the same body
layout (spheres 0..n-1, then the four wall slots, of which bottom and top are used: a
3-D box is periodic in x and y), the same contact convention with the normal n (a -> b)
a 3-vector and the tangential force a 3-vector ``rt`` perpendicular to n, so that the
force on b is ``rn*n + rt`` and the torque on both bodies ``-r n x rt``.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


class BodyArrays(NamedTuple):
    """State of every body, arrays of shape (nb,) (float64) except ``r`` (n,).

    x, y: centre [R] (wall slots: ``y[n]`` is the lower plate's surface, ``y[n+1]``
    the upper plate's; side walls sit at x = 0 and x = width); th: rotation [rad];
    vx, vy [R/T], w [rad/T]: end-of-step velocities; inv_mx, inv_my [1/(rho R^2)],
    inv_i [1/(rho R^4)]: inverse mass per direction and inverse moment of inertia;
    fy_ext: external force along y [sigma] (gravity, the top-plate load); r: disk
    radii [R]. Positions and velocities are updated in place by the kernels.
    """

    x: np.ndarray
    y: np.ndarray
    th: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    w: np.ndarray
    inv_mx: np.ndarray
    inv_my: np.ndarray
    inv_i: np.ndarray
    fy_ext: np.ndarray
    r: np.ndarray


class Motion(NamedTuple):
    """What the contact solver reads and writes of the bodies, arrays (nb,) float64:
    velocities vx, vy [R/T], w [rad/T] (updated in place) and inverse masses inv_mx,
    inv_my [1/(rho R^2)], inv_i [1/(rho R^4)]."""

    vx: np.ndarray
    vy: np.ndarray
    w: np.ndarray
    inv_mx: np.ndarray
    inv_my: np.ndarray
    inv_i: np.ndarray


class Box(NamedTuple):
    """The container: width [R] along x; periodic x (minimum image) or side walls at
    x = 0 and x = width (has_sides); a fixed lower plate (has_bottom) and a
    load-controlled upper plate (has_top)."""

    width: float
    periodic: bool
    has_bottom: bool
    has_top: bool
    has_sides: bool


class Contacts(NamedTuple):
    """A contact list, arrays of shape (Nc,): bodies a, b (int64); unit normal nx, ny
    (a -> b); gap [R] (negative = overlap); lever arms ra, rb [R] (0 for walls);
    Coulomb coefficient mu; keys a*nb + b (int64, sorted ascending: warm starts match
    contacts of consecutive steps by key)."""

    a: np.ndarray
    b: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    gap: np.ndarray
    ra: np.ndarray
    rb: np.ndarray
    mu: np.ndarray
    keys: np.ndarray


class ContactForces(NamedTuple):
    """Forces of a contact list: sorted keys a*nb + b (Nc,) int64 and normal and
    tangential forces rn, rt (Nc,) [sigma] (the warm start of the next step)."""

    keys: np.ndarray
    rn: np.ndarray
    rt: np.ndarray

    @classmethod
    def empty(cls) -> "ContactForces":
        return cls(np.zeros(0, np.int64), np.zeros(0), np.zeros(0))


class SweepSettings(NamedTuple):
    """Settings of the nonlinear Gauss-Seidel solver (:func:`forcespace.engine.nlgs.solve`).

    dt [T]: time step (1 in statics, where masses only precondition); tol: relative
    force change per sweep, sum|dR| / sum|R|, that ends the solve; max_sweeps: sweep
    cap; relaxation: over-relaxation omega in (0, 2) (1 = plain Gauss-Seidel);
    block: sweep order, 0 = single contacts in a fresh random order (the paper's), B > 0
    = runs of B consecutive contacts, the runs shuffled; overlap_correction: fraction
    beta in [0, 1] of an overlap's excess over ``overlap_slop`` [R] removed per step.
    relax_until: the sweep (counted from 0) from which omega falls back to 1 when the
    solve has not converged (-1: half of max_sweeps, the historical rule).
    """

    dt: float
    tol: float
    max_sweeps: int
    relaxation: float = 1.0
    block: int = 0
    overlap_correction: float = 0.0
    overlap_slop: float = 0.0
    relax_until: int = -1


class SweepStats(NamedTuple):
    """What a run of Gauss-Seidel sweeps did."""

    sweeps: int                  # sweeps done
    relative_change: float       # sum |dR| / sum |R| of the last sweep
    normal_updates: int          # single-contact normal updates
    tangential_updates: int      # single-contact friction updates (0 without friction)


class StepSettings(NamedTuple):
    """What a time step needs besides the solver settings: margin [R] (pairs closer than
    this gap are contacts), Coulomb coefficients mu_disk (disk-disk) and mu_wall
    (disk-wall), rotation (integrate disk rotation), tol_moving: the solver tolerance
    while the top plate moves faster than ``moving_speed`` [R/T] (0: always ``tol``),
    sweeps_moving: the sweep cap then (0: ``max_sweeps``)."""

    margin: float
    mu_disk: float
    mu_wall: float
    rotation: bool
    tol_moving: float = 0.0
    moving_speed: float = 0.0
    sweeps_moving: int = 0


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

    @classmethod
    def zero(cls) -> "StepStats":
        return cls(0, 0, 0.0, 0, 0, 0.0, 0.0, 0)

    def merged(self, other: "StepStats") -> "StepStats":
        """The statistics of this run followed by ``other``."""
        return StepStats(self.sweeps_total + other.sweeps_total,
                         max(self.sweeps_max_step, other.sweeps_max_step),
                         max(self.max_rel_change, other.max_rel_change),
                         self.normal_updates + other.normal_updates,
                         self.tangential_updates + other.tangential_updates,
                         max(self.max_speed, other.max_speed),
                         max(self.max_top_speed, other.max_top_speed),
                         self.steps_at_sweep_cap + other.steps_at_sweep_cap)


class BodyArrays3(NamedTuple):
    """State of every body in 3-D: arrays (nb, 3) float64 pos [R] (wall slots: the plate
    surfaces in ``pos[n, 2]`` and ``pos[n+1, 2]``), th [rad] (accumulated rotation
    vector, the integral of w: only its changes are used, to measure rolling), v [R/T],
    w [rad/T], inv_m [1/(rho R^3)] (inverse mass per direction), f_ext [sigma] (gravity,
    the top-plate load); inv_i (nb,) [1/(rho R^5)] inverse moment of inertia (a sphere:
    5 / (2 m r^2)); r (n,) radii [R]. Positions and velocities updated in place."""

    pos: np.ndarray
    th: np.ndarray
    v: np.ndarray
    w: np.ndarray
    inv_m: np.ndarray
    inv_i: np.ndarray
    f_ext: np.ndarray
    r: np.ndarray


class Motion3(NamedTuple):
    """What the 3-D contact solver reads and writes of the bodies: v (nb, 3) [R/T], w (nb,
    3) [rad/T] (updated in place), inv_m (nb, 3) [1/(rho R^3)], inv_i (nb,) [1/(rho R^5)]."""

    v: np.ndarray
    w: np.ndarray
    inv_m: np.ndarray
    inv_i: np.ndarray


class Box3(NamedTuple):
    """A 3-D container: periodic extents lx, ly [R] along x and y (minimum image); a fixed
    lower plate (has_bottom) and a load-controlled upper plate (has_top) normal to z."""

    lx: float
    ly: float
    has_bottom: bool
    has_top: bool


class Contacts3(NamedTuple):
    """A 3-D contact list: a, b (Nc,) int64; normal (Nc, 3) unit a -> b; gap, ra, rb, mu,
    keys (Nc,) as :class:`Contacts` (keys a*nb + b sorted ascending)."""

    a: np.ndarray
    b: np.ndarray
    normal: np.ndarray
    gap: np.ndarray
    ra: np.ndarray
    rb: np.ndarray
    mu: np.ndarray
    keys: np.ndarray
