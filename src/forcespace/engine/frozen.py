"""Quasi-static relaxation: NLGS on a frozen contact network until forces balance.

Used for the final static solve of the packing protocol and for the paper's
perturb-and-relax sampler. Positions are fixed, gaps count as closed, dt = 1;
masses act only as preconditioner weights. Velocities are recomputed from the
forces before every chunk of sweeps (``v = dt M^-1 (F_ext + contact forces)``,
so round-off never accumulates) and the caller's ``violation(rn, rt)`` decides
when the network is admissible. Spheres: :class:`FrozenContacts3` (the same two methods
on the 3-D records), which :func:`relax` runs alike.
"""
from __future__ import annotations

from dataclasses import dataclass
import numpy as np

from ..errors import NumericalError
from ..model.problem import StaticsProblem
from ..model.sphere_problem import PLATE
from .nlgs import add_contact_velocities, add_contact_velocities3, solve, solve3
from .records import Contacts, Contacts3, Motion, Motion3, SweepSettings, SweepStats
from ..streams import chunk_seed


@dataclass
class FrozenContacts:
    """A frozen contact network as the solver sees it (dt = 1, gaps closed).

    contacts: :class:`~forcespace.engine.records.Contacts` (gaps 0, keys unused);
    inv_mx, inv_my, inv_i (nb,): inverse masses (zero for fixed bodies); v_ext: three
    arrays (nb,), the velocities dt M^-1 F_ext of the external loads (forces and
    torques) over dt = 1.
    """

    contacts: Contacts
    inv_mx: np.ndarray
    inv_my: np.ndarray
    inv_i: np.ndarray
    v_ext: tuple

    @property
    def mu(self) -> np.ndarray:
        """Coulomb coefficients (Nc,)."""
        return self.contacts.mu

    def velocities(self, rn, rt) -> Motion:
        """Velocities of the loads and the contact forces rn, rt (Nc,) applied from rest
        over dt = 1 (statics: masses only precondition), with the inverse masses."""
        m = Motion(*(np.array(v, dtype=float) for v in self.v_ext),
                   self.inv_mx, self.inv_my, self.inv_i)
        add_contact_velocities(self.contacts, rn, rt, m, 1.0)
        return m

    def sweep(self, rn, rt, motion: Motion, max_sweeps: int, seed: int) -> SweepStats:
        """Up to ``max_sweeps`` Gauss-Seidel sweeps on rn, rt (in place), gaps closed,
        dt = 1 (:func:`forcespace.engine.nlgs.solve`)."""
        return solve(self.contacts, motion, rn, rt, SweepSettings(1.0, 0.0, int(max_sweeps)),
                     seed)


@dataclass
class FrozenContacts3:
    """A frozen 3-D contact network as the solver sees it (dt = 1, gaps closed).

    contacts: :class:`~forcespace.engine.records.Contacts3` (gaps 0); inv_m (nb, 3),
    inv_i (nb,): inverse masses (zero for fixed bodies); v_ext: two arrays (nb, 3), the
    velocities dt M^-1 F_ext and dt I^-1 T_ext of the external loads over dt = 1.
    """

    contacts: Contacts3
    inv_m: np.ndarray
    inv_i: np.ndarray
    v_ext: tuple

    @property
    def mu(self) -> np.ndarray:
        """Coulomb coefficients (Nc,)."""
        return self.contacts.mu

    def velocities(self, rn, rt) -> Motion3:
        """Velocities of the loads and the contact forces rn (Nc,), rt (Nc, 3) applied from
        rest over dt = 1, with the inverse masses."""
        m = Motion3(np.array(self.v_ext[0], dtype=float), np.array(self.v_ext[1], dtype=float),
                    self.inv_m, self.inv_i)
        add_contact_velocities3(self.contacts, rn, rt, m, 1.0)
        return m

    def sweep(self, rn, rt, motion: Motion3, max_sweeps: int, seed: int) -> SweepStats:
        """Up to ``max_sweeps`` Gauss-Seidel sweeps on rn, rt (in place), dt = 1
        (:func:`forcespace.engine.nlgs.solve3`)."""
        return solve3(self.contacts, motion, rn, rt, SweepSettings(1.0, 0.0, int(max_sweeps)),
                      seed)


@dataclass(frozen=True)
class RelaxResult:
    """Outcome of :func:`relax` (in the spirit of scipy's ``OptimizeResult``).

    sweeps: Gauss-Seidel sweeps done; violation: the caller's measure at the
    end (e.g. equilibrium residual / <Fn>); tangential_updates: friction
    updates done (0 without friction); converged: violation <= tol;
    status: "converged", "stalled" (a non-static fixed point: the violation
    stopped dropping, bodies keep moving, e.g. sliding) or "max_sweeps";
    message: one line for reports.
    """

    sweeps: int
    violation: float
    tangential_updates: int
    converged: bool
    status: str
    message: str


def relax(system: FrozenContacts, rn, rt, violation, tol, max_sweeps, seed=0, chunk=200,
          max_chunk=None, stall_sweeps=None, on_chunk=None) -> RelaxResult:
    """Sweep until ``violation(rn, rt) <= tol``; ``rn, rt`` (Nc,) are updated in place.

    ``chunk`` sweeps run between checks; it doubles up to ``max_chunk`` if given.
    ``stall_sweeps``: stop (status "stalled") when the violation has not dropped
    by 1 % for that many sweeps. ``on_chunk(sweeps_done, violation)`` reports
    progress. Stops at ``max_sweeps`` (status "max_sweeps").

    Returns a :class:`RelaxResult`; the caller decides what non-convergence
    means. Raises NumericalError only when the forces turn non-finite.
    """
    s = system
    sweeps = n_tang = 0
    best, since = np.inf, 0
    while True:
        done = s.sweep(rn, rt, s.velocities(rn, rt), min(chunk, max_sweeps - sweeps),
                       chunk_seed(seed, sweeps))
        sw = done.sweeps
        sweeps += sw
        n_tang += done.tangential_updates
        viol = violation(rn, rt)
        if on_chunk is not None:
            on_chunk(sw, viol)
        if not np.isfinite(viol):
            raise NumericalError("non-finite forces in the NLGS relaxation")
        if viol <= tol:
            return RelaxResult(sweeps, viol, n_tang, True, "converged",
                               f"violation {viol:.2e} <= {tol:.1e} in {sweeps} sweeps")
        if viol < 0.99 * best:
            best, since = viol, 0
        else:
            since += sw
        if stall_sweeps is not None and since >= stall_sweeps:
            return RelaxResult(sweeps, viol, n_tang, False, "stalled",
                               f"NLGS relaxation stalled at violation {viol:.2e} (no progress "
                               f"in {since} sweeps): a non-static solution of the contact "
                               f"problem (bodies keep moving, e.g. sliding)")
        if sweeps >= max_sweeps:
            return RelaxResult(sweeps, viol, n_tang, False, "max_sweeps",
                               f"NLGS relaxation did not reach violation {tol:.1e} in "
                               f"{sweeps} sweeps (reached {viol:.2e})")
        if max_chunk is not None:
            chunk = min(2 * chunk, max_chunk)


def frozen_contacts(p: StaticsProblem) -> FrozenContacts:
    """The solver view of a statics problem, derived from its H-representation.

    Kernel bodies: the interior disks 0..n-1 (mass and inertia of the disk),
    one fixed ground n for every support (walls, support disks: they never
    move, so one body stands for all), and for the plate problem the plate
    n+1, which moves vertically only, pressed down by the plate row's load
    b[-1] = top_force. Contacts, normals and loads are read off A and b
    (:meth:`StaticsProblem.contact_geometry`); masses only precondition.
    """
    n = p.n_interior
    ground = n
    a, b, nx, ny = p.contact_geometry()
    plate = p.kind == "full_plate" and p.A.shape[0] > 3 * n
    nb = n + (2 if plate else 1)
    ka = np.where(a >= 0, a, ground)
    if plate:
        on_plate = np.zeros(p.n_contacts, bool)
        on_plate[p.A[3 * n].indices // 2] = True
        ka[on_plate & (a < 0)] = n + 1
    radius = np.append(p.radius, 0.0)
    inv_m = np.zeros(nb)
    inv_m[:n] = 1.0 / p.mass
    inv_my = inv_m.copy()
    inv_i = np.zeros(nb)
    inv_i[:n] = 1.0 / (0.5 * p.mass * p.radius ** 2)
    v_ext = (np.zeros(nb), np.zeros(nb), np.zeros(nb))
    v_ext[0][:n] = p.load_force[:, 0] / p.mass
    v_ext[1][:n] = p.load_force[:, 1] / p.mass
    v_ext[2][:n] = p.load_torque * inv_i[:n]
    if plate:   # the plate's mass only preconditions too
        m_plate = float(p.mass.mean())
        inv_my[n + 1] = 1.0 / m_plate
        v_ext[1][n + 1] = -p.b[3 * n] / m_plate
    nc = ka.shape[0]
    contacts = Contacts(a=ka.astype(np.int64), b=np.asarray(b, np.int64),
                        nx=np.array(nx, float), ny=np.array(ny, float), gap=np.zeros(nc),
                        ra=radius[np.where(a >= 0, a, n)], rb=radius[b],
                        mu=p.mu.astype(float), keys=np.zeros(nc, np.int64))
    return FrozenContacts(contacts, inv_m, inv_my, inv_i, v_ext)


def frozen_contacts3(p) -> FrozenContacts3:
    """The solver view of a :class:`~forcespace.model.sphere_problem.SphereStaticsProblem`
    (the 3-D :func:`frozen_contacts`): interior spheres 0..n-1 (solid spheres: mass and
    I = 2/5 m r^2), one fixed ground n for every support, and for the plate problem the
    plate n+1, moving along z only under the plate row's load. Contacts, normals and
    loads are read off the problem (``ends``, ``frame``, b); masses only precondition.
    The tangential forces rt (Nc, 3) of the solver are ``f1 t1 + f2 t2`` of the problem's
    columns (:meth:`SphereStaticsProblem.to_packing_forces` maps them back)."""
    n = p.n_interior
    plate = p.kind == "full_plate"
    nb = n + (2 if plate else 1)
    ends = np.where(p.ends >= 0, p.ends, n)
    ends[p.ends == PLATE] = n + 1
    radius = np.append(p.radius, 0.0)
    arm = np.where(p.ends >= 0, radius[np.maximum(p.ends, 0)], 0.0)
    inv_m = np.zeros((nb, 3))
    inv_m[:n] = (1.0 / p.mass)[:, None]
    inv_i = np.zeros(nb)
    inv_i[:n] = 1.0 / (0.4 * p.mass * p.radius ** 2)
    v_ext = (np.zeros((nb, 3)), np.zeros((nb, 3)))
    v_ext[0][:n] = p.load_force * inv_m[:n]
    v_ext[1][:n] = p.load_torque * inv_i[:n, None]
    if plate:   # the plate's mass only preconditions too
        m_plate = float(p.mass.mean())
        inv_m[n + 1, 2] = 1.0 / m_plate
        v_ext[0][n + 1, 2] = -p.b[6 * n] / m_plate
    nc = p.n_contacts
    contacts = Contacts3(a=ends[:, 0].astype(np.int64), b=ends[:, 1].astype(np.int64),
                         normal=np.ascontiguousarray(p.frame[:, 0]), gap=np.zeros(nc),
                         ra=arm[:, 0], rb=arm[:, 1], mu=p.mu.astype(float),
                         keys=np.zeros(nc, np.int64))
    return FrozenContacts3(contacts, inv_m, inv_i, v_ext)
