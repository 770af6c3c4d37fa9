"""Nonlinear Gauss-Seidel contact solver (Moreau-Jean, Unger's formulation).

Pure numba kernels, no I/O, behind the public functions :func:`solve`,
:func:`effective_masses` and :func:`add_contact_velocities`. Records, body layout,
contact convention and units: :mod:`forcespace.engine.records`.

Velocities are end-of-step velocities, always consistent with the current
forces: ``v = v_free + dt * M^-1 (sum of contact forces)``.

Single-contact update (science.md section 2): with U the relative velocity
without this contact's own force and g+ = max(gap, 0),
``U_n*dt + g+ > 0`` -> open (R = 0); else ``R_n = -(m_n/dt)(g+/dt + U_n)``,
``R_t = -(m_t/dt) U_t`` clipped to ``|R_t| <= mu R_n``. Contacts with
``mu == 0`` never touch the tangential code path; the kernel counts
tangential updates so that this is checkable.
"""
from __future__ import annotations

import numpy as np

from ..kernels import kernel
from .records import Contacts, Motion, SweepSettings, SweepStats
from .streams import order_state, shuffle


def _check_contacts(c: Contacts, nb: int) -> Contacts:
    """The contact record with contiguous arrays of the kernel dtypes; ValueError if a
    shape differs or a body index is out of range."""
    nc = np.shape(c.a)[0]
    out = Contacts(*(np.ascontiguousarray(v, dtype=np.int64 if name in ("a", "b", "keys")
                                          else float)
                     for name, v in zip(Contacts._fields, c)))
    for name, v in zip(Contacts._fields, out):
        if v.shape != (nc,) and not (name == "keys" and v.shape == (0,)):
            raise ValueError(f"contacts.{name} must have shape ({nc},), got {v.shape}")
    if nc and (min(out.a.min(), out.b.min()) < 0 or max(out.a.max(), out.b.max()) >= nb):
        raise ValueError(f"contact body indices must lie in [0, {nb})")
    return out


def _check_motion(m: Motion) -> Motion:
    nb = np.shape(m.vx)[0]
    for name, v in zip(Motion._fields, m):
        if not (isinstance(v, np.ndarray) and v.dtype == np.float64 and v.shape == (nb,)
                and v.flags.c_contiguous):
            raise ValueError(f"motion.{name} must be a contiguous float64 array of shape "
                             f"({nb},) (velocities are updated in place)")
    return m


def _check_forces(rn, rt, nc: int):
    for name, v in (("rn", rn), ("rt", rt)):
        if not (isinstance(v, np.ndarray) and v.dtype == np.float64 and v.shape == (nc,)
                and v.flags.c_contiguous):
            raise ValueError(f"{name} must be a contiguous float64 array of shape ({nc},) "
                             "(updated in place)")


def effective_masses(contacts: Contacts, motion: Motion):
    """Normal and tangential effective masses (Nc,) each [rho R^2] (see :func:`masses_kernel`)."""
    m = _check_motion(motion)
    return masses_kernel(_check_contacts(contacts, m.vx.shape[0]), m)


def add_contact_velocities(contacts: Contacts, rn, rt, motion: Motion, dt: float) -> None:
    """Add dt M^-1 (contact forces rn, rt (Nc,) [sigma]) to the velocities of ``motion``
    in place; dt [T]."""
    m = _check_motion(motion)
    c = _check_contacts(contacts, m.vx.shape[0])
    rn = np.ascontiguousarray(rn, dtype=float)
    rt = np.ascontiguousarray(rt, dtype=float)
    _check_forces(rn, rt, c.a.shape[0])
    velocities_kernel(c, rn, rt, m, float(dt))


def solve(contacts: Contacts, motion: Motion, rn, rt, settings: SweepSettings,
          seed: int) -> SweepStats:
    """Gauss-Seidel sweeps until the forces converge (see :func:`solve_kernel`).

    ``contacts``: :class:`~forcespace.engine.records.Contacts`; ``motion``: velocities
    (updated in place) and inverse masses; rn, rt (Nc,) [sigma]: the starting forces,
    updated in place; ``settings``: :class:`~forcespace.engine.records.SweepSettings`;
    ``seed`` >= 0: the sweep order's seed (:mod:`forcespace.engine.streams`).
    """
    m = _check_motion(motion)
    c = _check_contacts(contacts, m.vx.shape[0])
    _check_forces(rn, rt, c.a.shape[0])
    s = settings
    if not (s.dt > 0 and 0 <= s.tol and s.max_sweeps >= 0 and 0 < s.relaxation < 2
            and s.block >= 0):
        raise ValueError(f"invalid solver settings {s}")
    s = SweepSettings(float(s.dt), float(s.tol), int(s.max_sweeps), float(s.relaxation),
                      int(s.block), float(s.overlap_correction), float(s.overlap_slop),
                      int(s.relax_until))
    return solve_kernel(c, m, rn, rt, s, int(seed))


@kernel
def masses_kernel(c, m):
    """Normal and tangential effective masses, shape (Nc,) each.

    1/m_n = n.(M_a^-1 + M_b^-1).n, 1/m_t = t.(M_a^-1 + M_b^-1).t + ra^2/I_a + rb^2/I_b.
    A contact between two immovable bodies gets m = 0 (it never changes).
    """
    a, b, nx, ny, ra, rb = c.a, c.b, c.nx, c.ny, c.ra, c.rb
    inv_mx, inv_my, inv_i = m.inv_mx, m.inv_my, m.inv_i
    nc = a.shape[0]
    mn = np.zeros(nc)
    mt = np.zeros(nc)
    for k in range(nc):
        i = a[k]
        j = b[k]
        sx = inv_mx[i] + inv_mx[j]
        sy = inv_my[i] + inv_my[j]
        inn = nx[k] * nx[k] * sx + ny[k] * ny[k] * sy
        itt = ny[k] * ny[k] * sx + nx[k] * nx[k] * sy \
            + ra[k] * ra[k] * inv_i[i] + rb[k] * rb[k] * inv_i[j]
        mn[k] = 1.0 / inn if inn > 0.0 else 0.0
        mt[k] = 1.0 / itt if itt > 0.0 else 0.0
    return mn, mt


@kernel
def velocities_kernel(c, rn, rt, m, dt):
    """Add dt * M^-1 * (contact forces) to the velocities, in place."""
    a, b, nx, ny, ra, rb = c.a, c.b, c.nx, c.ny, c.ra, c.rb
    vx, vy, w, inv_mx, inv_my, inv_i = m.vx, m.vy, m.w, m.inv_mx, m.inv_my, m.inv_i
    for k in range(a.shape[0]):
        i = a[k]
        j = b[k]
        fx = rn[k] * nx[k] - rt[k] * ny[k]
        fy = rn[k] * ny[k] + rt[k] * nx[k]
        vx[j] += dt * fx * inv_mx[j]
        vy[j] += dt * fy * inv_my[j]
        vx[i] -= dt * fx * inv_mx[i]
        vy[i] -= dt * fy * inv_my[i]
        if rt[k] != 0.0:
            w[j] -= dt * rb[k] * rt[k] * inv_i[j]
            w[i] -= dt * ra[k] * rt[k] * inv_i[i]


@kernel(inline="always")
def _block_order(order, runs, block, state):
    """order = runs of ``block`` consecutive contacts in a fresh random run order."""
    state = shuffle(runs, runs.shape[0], state)
    nc = order.shape[0]
    c = 0
    for q in range(runs.shape[0]):
        for k in range(runs[q] * block, min(nc, runs[q] * block + block)):
            order[c] = k
            c += 1
    return state


@kernel
def solve_kernel(c, m, rn, rt, s, seed):
    """Iterate Gauss-Seidel sweeps until the forces converge.

    c: Contacts (Nc,); m: Motion (nb,), velocities updated in place; rn, rt (Nc,)
    [sigma] updated in place; s: SweepSettings; seed: sweep-order seed (int >= 0).

    Sweeps visit all contacts in a fresh random order (seeded by ``seed``):
    ``block = 0`` shuffles single contacts (the paper's rule); ``block = B > 0``
    cuts the contact list into runs of B consecutive contacts and shuffles the
    runs, each visited in list order -- with contacts listed in spatial order
    this keeps the memory access local and draws B times fewer random numbers.
    ``relaxation`` = omega in (0, 2): projected successive over-relaxation,
    R <- proj(R + omega (R_GS - R)), R_GS the unprojected single-contact
    solution; omega = 1 is plain Gauss-Seidel. Both leave the fixed points
    (the converged forces) unchanged. Over-relaxation can oscillate where the
    optimal omega is near 1 (small, strongly frictional systems), so a solve that
    has not converged by sweep ``relax_until`` (-1: half of ``max_sweeps``)
    finishes with omega = 1.
    ``overlap_correction`` = beta in [0, 1] and ``overlap_slop`` = s >= 0: a
    contact overlapping by more than s (gap < -s) aims at removing the fraction
    beta of the excess in this step (g+ -> beta*(g + s)); smaller overlaps are
    left alone, so a packing with all overlaps below s is at rest exactly under
    Unger's rule (beta = 0: overlaps are never pushed apart).
    Convergence: sum|dR| over a sweep <= tol * sum|R| after it.

    Returns SweepStats.
    """
    a, b, nx, ny, ra, rb, gap, mu = c.a, c.b, c.nx, c.ny, c.ra, c.rb, c.gap, c.mu
    vx, vy, w, inv_mx, inv_my, inv_i = m.vx, m.vy, m.w, m.inv_mx, m.inv_my, m.inv_i
    dt, tol, max_sweeps, relaxation, block = s.dt, s.tol, s.max_sweeps, s.relaxation, s.block
    overlap_correction, overlap_slop = s.overlap_correction, s.overlap_slop
    fallback = max_sweeps // 2 if s.relax_until < 0 else s.relax_until
    mn, mt = masses_kernel(c, m)
    nc = a.shape[0]
    order = np.arange(nc)
    runs = np.arange((nc + block - 1) // block) if block > 0 else np.zeros(0, np.int64)
    state = order_state(seed)
    inv_mn = np.zeros(nc)
    inv_mt = np.zeros(nc)
    for k in range(nc):
        if mn[k] > 0.0:
            inv_mn[k] = 1.0 / mn[k]
        if mt[k] > 0.0:
            inv_mt[k] = 1.0 / mt[k]
    rel = 0.0
    n_norm = 0
    n_tang = 0
    sweeps = 0
    for sweep in range(max_sweeps):
        sweeps = sweep + 1
        if sweep == fallback:
            relaxation = 1.0   # over-relaxation that has not converged: plain Gauss-Seidel
        if block > 0:
            state = _block_order(order, runs, block, state)
        else:
            state = shuffle(order, nc, state)
        dsum = 0.0
        for idx in range(nc):
            k = order[idx]
            if mn[k] == 0.0:
                continue
            i = a[k]
            j = b[k]
            ex = nx[k]
            ey = ny[k]
            dvx = vx[j] - vx[i]
            dvy = vy[j] - vy[i]
            un = dvx * ex + dvy * ey - dt * rn[k] * inv_mn[k]
            gp = gap[k]
            if gp < 0.0:
                gp = overlap_correction * (gp + overlap_slop) if gp < -overlap_slop else 0.0
            r_gs = -(mn[k] / dt) * (gp / dt + un)   # unprojected single-contact solution
            if relaxation != 1.0:
                new_n = max(rn[k] + relaxation * (r_gs - rn[k]), 0.0)
            elif un * dt + gp > 0.0:
                new_n = 0.0
            else:
                new_n = r_gs
            n_norm += 1
            dn = new_n - rn[k]
            if dn != 0.0:
                rn[k] = new_n
                vx[j] += dt * dn * ex * inv_mx[j]
                vy[j] += dt * dn * ey * inv_my[j]
                vx[i] -= dt * dn * ex * inv_mx[i]
                vy[i] -= dt * dn * ey * inv_my[i]
                dsum += abs(dn)
            if mu[k] > 0.0:
                n_tang += 1
                tx = -ey
                ty = ex
                ut = dvx * tx + dvy * ty - rb[k] * w[j] - ra[k] * w[i] - dt * rt[k] * inv_mt[k]
                new_t = -(mt[k] / dt) * ut
                if relaxation != 1.0:
                    new_t = rt[k] + relaxation * (new_t - rt[k])
                lim = mu[k] * new_n
                if new_t > lim:
                    new_t = lim
                elif new_t < -lim:
                    new_t = -lim
                dtg = new_t - rt[k]
                if dtg != 0.0:
                    rt[k] = new_t
                    vx[j] += dt * dtg * tx * inv_mx[j]
                    vy[j] += dt * dtg * ty * inv_my[j]
                    vx[i] -= dt * dtg * tx * inv_mx[i]
                    vy[i] -= dt * dtg * ty * inv_my[i]
                    w[j] -= dt * rb[k] * dtg * inv_i[j]
                    w[i] -= dt * ra[k] * dtg * inv_i[i]
                    dsum += abs(dtg)
        rsum = 0.0
        for k in range(nc):
            rsum += abs(rn[k]) + abs(rt[k])
        rel = dsum / rsum if rsum > 0.0 else (0.0 if dsum == 0.0 else np.inf)
        if rel <= tol:
            break
    return SweepStats(sweeps, rel, n_norm, n_tang)
