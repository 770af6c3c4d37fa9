"""Quasi-static relaxation: NLGS on a frozen contact network until forces balance.

Used for the final static solve of the packing protocol and for the paper's
perturb-and-relax sampler. Positions are fixed, gaps count as closed, dt = 1;
masses act only as preconditioner weights. Velocities are recomputed from the
forces before every chunk of sweeps (``v = dt M^-1 (F_ext + contact forces)``,
so round-off never accumulates) and the caller's ``violation(rn, rt)`` decides
when the network is admissible.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import NumericalError
from .nlgs import add_contact_velocities, effective_masses, nlgs_solve


@dataclass
class FrozenContacts:
    """Kernel arrays of a frozen contact network (see :mod:`forcespace.nlgs`).

    a, b (Nc,) int body indices; nx, ny (Nc,) unit normal a -> b; ra, rb (Nc,)
    lever arms [R]; mu (Nc,) Coulomb coefficients; inv_mx, inv_my, inv_i (nb,)
    inverse masses (zero for fixed bodies); v_ext: three arrays (nb,), the
    velocities dt M^-1 F_ext of the external loads (forces and torques).
    """

    a: np.ndarray
    b: np.ndarray
    nx: np.ndarray
    ny: np.ndarray
    ra: np.ndarray
    rb: np.ndarray
    mu: np.ndarray
    inv_mx: np.ndarray
    inv_my: np.ndarray
    inv_i: np.ndarray
    v_ext: tuple
    mn: np.ndarray = field(init=False)
    mt: np.ndarray = field(init=False)

    def __post_init__(self):
        self.mn, self.mt = effective_masses(self.a, self.b, self.nx, self.ny, self.ra, self.rb,
                                            self.inv_mx, self.inv_my, self.inv_i)
        self.closed = np.zeros(self.a.shape[0])


def relax(system: FrozenContacts, rn, rt, violation, tol, max_sweeps, seed=0, chunk=200,
          max_chunk=None, stall_sweeps=None, on_chunk=None, raise_at_cap=True):
    """Sweep until ``violation(rn, rt) <= tol``; ``rn, rt`` (Nc,) are updated in place.

    ``chunk`` sweeps run between checks; it doubles up to ``max_chunk`` if given.
    ``stall_sweeps``: raise if the violation has not dropped by 1 % for that
    many sweeps (a non-static fixed point: bodies keep sliding).
    ``on_chunk(sweeps_done, violation)`` reports progress.

    Returns (sweeps, violation, tangential_updates). Raises NumericalError when
    the forces turn non-finite, the relaxation stalls or ``max_sweeps`` pass
    (with ``raise_at_cap=False`` it returns the unconverged state instead).
    """
    s = system
    sweeps = n_tang = 0
    best, since = np.inf, 0
    while True:
        vx, vy, w = (v.copy() for v in s.v_ext)
        add_contact_velocities(s.a, s.b, s.nx, s.ny, s.ra, s.rb, rn, rt, s.inv_mx, s.inv_my,
                               s.inv_i, 1.0, vx, vy, w)
        sw, _rel, _nn, ntg = nlgs_solve(s.a, s.b, s.nx, s.ny, s.ra, s.rb, s.closed, s.mu, s.mn,
                                        s.mt, rn, rt, vx, vy, w, s.inv_mx, s.inv_my, s.inv_i,
                                        1.0, 0.0, min(chunk, max_sweeps - sweeps),
                                        (seed * 1_000_003 + sweeps) % (2**31 - 1))
        sweeps += sw
        n_tang += ntg
        viol = violation(rn, rt)
        if on_chunk is not None:
            on_chunk(sw, viol)
        if not np.isfinite(viol):
            raise NumericalError("non-finite forces in the NLGS relaxation")
        if viol <= tol:
            return sweeps, viol, n_tang
        if viol < 0.99 * best:
            best, since = viol, 0
        else:
            since += sw
        if stall_sweeps is not None and since >= stall_sweeps:
            raise NumericalError(f"NLGS relaxation stalled at violation {viol:.2e} x <Fn> "
                                 f"(no progress in {since} sweeps): it converged to a "
                                 f"non-static solution of the contact problem (bodies keep "
                                 f"moving, e.g. sliding)")
        if sweeps >= max_sweeps:
            if not raise_at_cap:
                return sweeps, viol, n_tang
            raise NumericalError(f"NLGS relaxation did not reach violation {tol:.1e} x <Fn> "
                                 f"in {sweeps} sweeps (reached {viol:.2e})")
        if max_chunk is not None:
            chunk = min(2 * chunk, max_chunk)
