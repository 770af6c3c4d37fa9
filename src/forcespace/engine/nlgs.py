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

Spheres (3-D): :func:`solve3` and :func:`add_contact_velocities3`, the same update with
a tangential 2-vector projected onto the Coulomb disc (the comment block below). Shared
by both dimensions (dimension as data): the sweep loop with its orders, over-relaxation
and convergence test (:func:`iterate_kernel`) and the contact records' scalars
(:func:`contact_scalars`). Twins where the physics or the layout differs: the effective
masses (one tangent direction in 2-D, the tangent plane's mean in 3-D), the sweeps (a
scalar R_t clipped to [-mu R_n, mu R_n] against a 3-vector projected on the disc, on
body records of 8 and 12 fields).
"""
from __future__ import annotations

import numpy as np

from ..kernels import kernel
from .records import Contacts, Contacts3, Motion, Motion3, SweepSettings, SweepStats
from ..streams import order_state, shuffle


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
    ``seed`` >= 0: the sweep order's seed (:mod:`forcespace.streams`).
    """
    m = _check_motion(motion)
    c = _check_contacts(contacts, m.vx.shape[0])
    _check_forces(rn, rt, c.a.shape[0])
    s = checked_sweep_settings(settings)
    return solve_kernel(c, m, rn, rt, s, int(seed))


def checked_sweep_settings(s: SweepSettings) -> SweepSettings:
    """``s`` with the field types the kernels take; ValueError if dt <= 0, tol < 0,
    max_sweeps < 0, relaxation outside (0, 2) or block < 0."""
    if not (s.dt > 0 and 0 <= s.tol and s.max_sweeps >= 0 and 0 < s.relaxation < 2
            and s.block >= 0):
        raise ValueError(f"invalid solver settings {s}")
    return SweepSettings(float(s.dt), float(s.tol), int(s.max_sweeps), float(s.relaxation),
                         int(s.block), float(s.overlap_correction), float(s.overlap_slop),
                         int(s.relax_until))


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


# Layout of the solver's working copies (one record per contact and per body, so that an
# update touches two body records and one or two contact cache lines):
# contact record (Nc, 16): the normal update reads the first 8 (one 64-byte line); in
# both dimensions the normal's d components come first, then the same scalars in the same
# order (:func:`contact_scalars` writes them for both)
_EX, _EY, _CN, _IMN, _GP, _GPDT, _MU, _CT = 0, 1, 2, 3, 4, 5, 6, 7
_IMT, _RA, _RB, _DTRA, _DTRB = 8, 9, 10, 11, 12
# body record (nb, 8): velocities, then inverse masses
_VX, _VY, _W, _IMX, _IMY, _II = 0, 1, 2, 3, 4, 5


@kernel(inline="always")
def contact_scalars(c, mn, mt, s, pairs, rec, first):
    """Body pairs (Nc, 2) and the scalar part of the solver's contact records (Nc, 16),
    the same in both dimensions after the normal's d components (``first`` = d): m_n/dt,
    1/m_n, the corrected gap g+ and g+/dt, mu, m_t/dt, 1/m_t, ra, rb, dt*ra, dt*rb. c: a
    Contacts or Contacts3 record; mn, mt (Nc,) the effective masses; s: SweepSettings."""
    dt = s.dt
    for k in range(mn.shape[0]):
        pairs[k, 0] = c.a[k]
        pairs[k, 1] = c.b[k]
        rec[k, first] = mn[k] / dt
        rec[k, first + 1] = 1.0 / mn[k] if mn[k] > 0.0 else 0.0
        gp = c.gap[k]
        if gp < 0.0:
            gp = s.overlap_correction * (gp + s.overlap_slop) if gp < -s.overlap_slop else 0.0
        rec[k, first + 2] = gp
        rec[k, first + 3] = gp / dt
        rec[k, first + 4] = c.mu[k]
        rec[k, first + 5] = mt[k] / dt
        rec[k, first + 6] = 1.0 / mt[k] if mt[k] > 0.0 else 0.0
        rec[k, first + 7] = c.ra[k]
        rec[k, first + 8] = c.rb[k]
        rec[k, first + 9] = dt * c.ra[k]
        rec[k, first + 10] = dt * c.rb[k]


@kernel
def records_kernel(c, m, s):
    """The solver's working copies: body pairs (Nc, 2) int64, contact records (Nc, 16) and
    body records (nb, 8) (layout above) with every per-contact factor precomputed:
    m_n/dt, 1/m_n, the corrected gap g+ and g+/dt, m_t/dt, 1/m_t, dt*ra, dt*rb. The
    values are those the update computed in place before (bit for bit)."""
    mn, mt = masses_kernel(c, m)
    nc = mn.shape[0]
    pairs = np.empty((nc, 2), np.int64)
    rec = np.zeros((nc, 16))
    for k in range(nc):
        rec[k, _EX] = c.nx[k]
        rec[k, _EY] = c.ny[k]
    contact_scalars(c, mn, mt, s, pairs, rec, _CN)
    nb = m.vx.shape[0]
    body = np.zeros((nb, 8))
    for i in range(nb):
        body[i, _VX] = m.vx[i]
        body[i, _VY] = m.vy[i]
        body[i, _W] = m.w[i]
        body[i, _IMX] = m.inv_mx[i]
        body[i, _IMY] = m.inv_my[i]
        body[i, _II] = m.inv_i[i]
    return pairs, rec, body


@kernel
def sweep_kernel(pairs, rec, body, rn, rt, order, runs, block, dt, relaxation):
    """One Gauss-Seidel sweep: the single-contact update (module docstring) of every
    contact, on the flattened records of :func:`records_kernel`; rn, rt (Nc,) and the
    body records in place. ``block`` = 0: contacts in the order ``order``; B > 0: runs
    of B consecutive contacts in the order ``runs``. Returns (sum |dR|, the change of
    sum |R|, an upper bound of the magnitudes in that change, normal updates,
    tangential updates)."""
    dsum = 0.0
    change = 0.0
    size = 0.0
    n_norm = 0
    n_tang = 0
    nc = rn.shape[0]
    count = runs.shape[0] if block > 0 else nc
    for pos in range(count):
        if block > 0:
            lo = runs[pos] * block
            hi = min(nc, lo + block)
        else:
            lo = order[pos]
            hi = lo + 1
        for k in range(lo, hi):
            q = 16 * k
            cn = rec[q + _CN]
            if cn == 0.0:
                continue
            i = 8 * pairs[2 * k]
            j = 8 * pairs[2 * k + 1]
            ex = rec[q + _EX]
            ey = rec[q + _EY]
            dvx = body[j + _VX] - body[i + _VX]
            dvy = body[j + _VY] - body[i + _VY]
            rnk = rn[k]
            un = dvx * ex + dvy * ey - dt * rnk * rec[q + _IMN]
            r_gs = -cn * (rec[q + _GPDT] + un)   # unprojected single-contact solution
            if relaxation != 1.0:
                new_n = max(rnk + relaxation * (r_gs - rnk), 0.0)
            elif un * dt + rec[q + _GP] > 0.0:
                new_n = 0.0
            else:
                new_n = r_gs
            dn = new_n - rnk
            d = 0.0
            c = 0.0
            z = 0.0
            if dn != 0.0:
                rn[k] = new_n
                px = dt * dn * ex
                py = dt * dn * ey
                body[j + _VX] += px * body[j + _IMX]
                body[j + _VY] += py * body[j + _IMY]
                body[i + _VX] -= px * body[i + _IMX]
                body[i + _VY] -= py * body[i + _IMY]
                d = abs(dn)
                c = abs(new_n) - abs(rnk)
                z = abs(new_n) + abs(rnk)
            mu = rec[q + _MU]
            if mu <= 0.0:
                n_norm += 1
                dsum += d
                change += c
                size += z
                continue
            rtk = rt[k]
            ut = dvx * -ey + dvy * ex - rec[q + _RB] * body[j + _W] \
                - rec[q + _RA] * body[i + _W] - dt * rtk * rec[q + _IMT]
            new_t = -rec[q + _CT] * ut
            if relaxation != 1.0:
                new_t = rtk + relaxation * (new_t - rtk)
            lim = mu * new_n
            if new_t > lim:
                new_t = lim
            elif new_t < -lim:
                new_t = -lim
            dtg = new_t - rtk
            if dtg != 0.0:
                rt[k] = new_t
                px = dt * dtg * -ey
                py = dt * dtg * ex
                body[j + _VX] += px * body[j + _IMX]
                body[j + _VY] += py * body[j + _IMY]
                body[i + _VX] -= px * body[i + _IMX]
                body[i + _VY] -= py * body[i + _IMY]
                body[j + _W] -= rec[q + _DTRB] * dtg * body[j + _II]
                body[i + _W] -= rec[q + _DTRA] * dtg * body[i + _II]
                d += abs(dtg)
                c += abs(new_t) - abs(rtk)
                z += abs(new_t) + abs(rtk)
            n_norm += 1
            n_tang += 1
            dsum += d
            change += c
            size += z
    return dsum, change, size, n_norm, n_tang


@kernel(inline="always")
def _exact_sum(rn, rt, tangential):
    """sum_k |rn_k| + |R_t,k| in index order (the convergence test's denominator); rt
    (tangential * Nc,): one component per contact in 2-D, three (|R_t| Euclidean) in 3-D."""
    rsum = 0.0
    if tangential == 1:
        for k in range(rn.shape[0]):
            rsum += abs(rn[k]) + abs(rt[k])
    else:
        for k in range(rn.shape[0]):
            t = 3 * k
            rsum += abs(rn[k]) + np.sqrt(rt[t] ** 2 + rt[t + 1] ** 2 + rt[t + 2] ** 2)
    return rsum


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

    The sweeps work on one record per body and per contact (:func:`records_kernel`);
    the velocities are copied back at the end. Returns SweepStats.
    """
    pairs, rec, body = records_kernel(c, m, s)
    stats = iterate_kernel(pairs.ravel(), rec.ravel(), body.ravel(), rn, rt, s, seed, 1)
    for i in range(m.vx.shape[0]):
        m.vx[i] = body[i, _VX]
        m.vy[i] = body[i, _VY]
        m.w[i] = body[i, _W]
    return stats


@kernel
def iterate_kernel(pairs, rec, body, rn, rt, s, seed, tangential):
    """The sweeps of :func:`solve_kernel` (2-D, ``tangential`` = 1) and
    :func:`solve3_kernel` (3-D, ``tangential`` = 3), dimension as data: sweep orders,
    over-relaxation and its fall-back, convergence test. pairs (2 Nc,) int64, rec (16 Nc,)
    and body (flattened records of :func:`records_kernel` / :func:`records3_kernel`), rn
    (Nc,) and rt (tangential * Nc,) [sigma] updated in place; s: SweepSettings; seed: the
    sweep order's seed. Returns SweepStats.

    2-D carries sum |R| through the sweeps (the exact sum only where the test might pass);
    3-D sums it exactly after every sweep (carrying |R_t| would cost two square roots per
    tangential update, more than the exact pass)."""
    nc = rn.shape[0]
    block = s.block
    relaxation = s.relaxation
    fallback = s.max_sweeps // 2 if s.relax_until < 0 else s.relax_until
    order = np.arange(nc) if block == 0 else np.zeros(0, np.int64)
    runs = np.arange((nc + block - 1) // block) if block > 0 else np.zeros(0, np.int64)
    state = order_state(seed)
    rel = 0.0
    n_norm = 0
    n_tang = 0
    sweeps = 0
    running = _exact_sum(rn, rt, tangential)   # sum |R|, carried by the sweeps' changes
    bound = 0.0                     # magnitudes added to ``running`` since it was exact
    for sweep in range(s.max_sweeps):
        sweeps = sweep + 1
        if sweep == fallback:
            relaxation = 1.0   # over-relaxation that has not converged: plain Gauss-Seidel
        if block > 0:
            state = shuffle(runs, runs.shape[0], state)
        else:
            state = shuffle(order, nc, state)
        if tangential == 1:
            dsum, change, size, nn, nt = sweep_kernel(pairs, rec, body, rn, rt, order, runs,
                                                      block, s.dt, relaxation)
        else:
            dsum, nn, nt = sweep3_kernel(pairs, rec, body, rn, rt, order, runs, block, s.dt,
                                         relaxation)
            change = 0.0
            size = 0.0
        n_norm += nn
        n_tang += nt
        if tangential == 1:
            running += change
            bound += size + abs(running)
            # the exact sum (index order, as always) decides the test wherever the carried
            # one might not: each of the Nc additions of a sweep, and the exact sum itself,
            # err by at most 2^-52 of the magnitudes summed (bounded by ``bound``)
            margin = 4.5e-16 * (nc + 2) * (bound + abs(running))
            if sweeps < s.max_sweeps and margin < 1e-6 * running \
                    and dsum > s.tol * (running + margin) * (1.0 + 1e-12):
                continue
        rsum = _exact_sum(rn, rt, tangential)
        running = rsum
        bound = 0.0
        rel = dsum / rsum if rsum > 0.0 else (0.0 if dsum == 0.0 else np.inf)
        if rel <= s.tol:
            break
    return SweepStats(sweeps, rel, n_norm, n_tang)


# ---- spheres (3-D): the same update with a tangential 2-vector on the Coulomb disc ----
#
# Contact k (Contacts3): force rn*n + rt on b (rt (3,) perpendicular to n), -(...) on a,
# lever arms ra*n from a and -rb*n from b, so the torque on both is -r n x rt and the
# relative velocity at the contact is V = v_b - v_a - (rb w_b + ra w_a) x n. For spheres
# (isotropic mass and inertia) the normal and tangential parts decouple, as for disks:
# 1/m_n = n.(M_a^-1 + M_b^-1).n, 1/m_t = 1/m_a + 1/m_b + ra^2/I_a + rb^2/I_b in every
# tangential direction (with per-direction inverse masses, their mean over the tangent
# plane: exact for spheres and for plates, which only move along their normal).
# Single-contact update: R_n as in 2-D; R_t = -(m_t/dt) U_t (a 3-vector in the tangent
# plane), projected radially onto the disc |R_t| <= mu R_n.

# contact record (Nc, 16): normal, m_n/dt, 1/m_n, g+, g+/dt, mu, m_t/dt, 1/m_t, ra, rb,
# dt*ra, dt*rb
_NX3, _NY3, _NZ3, _CN3, _IMN3, _GP3, _GPDT3, _MU3 = 0, 1, 2, 3, 4, 5, 6, 7
_CT3, _IMT3, _RA3, _RB3, _DTRA3, _DTRB3 = 8, 9, 10, 11, 12, 13
# body record (nb, 12): v (3), w (3), inverse masses (3), inverse moment of inertia
_V3, _W3, _IM3, _II3 = 0, 3, 6, 9
_BODY3 = 12


def _check_motion3(m: Motion3) -> Motion3:
    nb = np.shape(m.v)[0]
    for name, v in zip(Motion3._fields, m):
        want = (nb,) if name == "inv_i" else (nb, 3)
        if not (isinstance(v, np.ndarray) and v.dtype == np.float64 and v.shape == want
                and v.flags.c_contiguous):
            raise ValueError(f"motion.{name} must be a contiguous float64 array of shape "
                             f"{want} (velocities are updated in place)")
    return m


def _check_contacts3(c: Contacts3, nb: int) -> Contacts3:
    """The 3-D contact record with contiguous arrays of the kernel dtypes; ValueError if a
    shape differs or a body index is out of range."""
    nc = np.shape(c.a)[0]
    out = Contacts3(*(np.ascontiguousarray(v, dtype=np.int64 if name in ("a", "b", "keys")
                                           else float)
                      for name, v in zip(Contacts3._fields, c)))
    for name, v in zip(Contacts3._fields, out):
        want = (nc, 3) if name == "normal" else (nc,)
        if v.shape != want and not (name == "keys" and v.shape == (0,)):
            raise ValueError(f"contacts.{name} must have shape {want}, got {v.shape}")
    if nc and (min(out.a.min(), out.b.min()) < 0 or max(out.a.max(), out.b.max()) >= nb):
        raise ValueError(f"contact body indices must lie in [0, {nb})")
    return out


def _check_forces3(rn, rt, nc: int):
    for name, v, want in (("rn", rn, (nc,)), ("rt", rt, (nc, 3))):
        if not (isinstance(v, np.ndarray) and v.dtype == np.float64 and v.shape == want
                and v.flags.c_contiguous):
            raise ValueError(f"{name} must be a contiguous float64 array of shape {want} "
                             "(updated in place)")


def add_contact_velocities3(contacts, rn, rt, motion, dt: float) -> None:
    """Add dt M^-1 (contact forces rn (Nc,), rt (Nc, 3) [sigma]) to the velocities of a
    :class:`~forcespace.engine.records.Motion3` in place; dt [T]."""
    m = _check_motion3(motion)
    c = _check_contacts3(contacts, m.v.shape[0])
    rn = np.ascontiguousarray(rn, dtype=float)
    rt = np.ascontiguousarray(rt, dtype=float).reshape(-1, 3)
    _check_forces3(rn, rt, c.a.shape[0])
    velocities3_kernel(c, rn, rt, m, float(dt))


def solve3(contacts, motion, rn, rt, settings: SweepSettings, seed: int) -> SweepStats:
    """Gauss-Seidel sweeps on a 3-D contact list until the forces converge (see
    :func:`solve3_kernel`): ``contacts`` a Contacts3, ``motion`` a Motion3 (velocities
    updated in place), rn (Nc,), rt (Nc, 3) [sigma] the starting forces (updated in
    place), ``settings`` and ``seed`` as :func:`solve`."""
    m = _check_motion3(motion)
    c = _check_contacts3(contacts, m.v.shape[0])
    _check_forces3(rn, rt, c.a.shape[0])
    s = checked_sweep_settings(settings)
    return solve3_kernel(c, m, rn, rt, s, int(seed))


@kernel
def masses3_kernel(c, m):
    """Normal and tangential effective masses (Nc,) each [rho R^3] of a Contacts3 and a
    Motion3 (the comment above); 0 for a contact between two immovable bodies."""
    nc = c.a.shape[0]
    mn = np.zeros(nc)
    mt = np.zeros(nc)
    for k in range(nc):
        i = c.a[k]
        j = c.b[k]
        inn = 0.0
        itt = 0.0
        for d in range(3):
            s = m.inv_m[i, d] + m.inv_m[j, d]
            nd = c.normal[k, d]
            inn += nd * nd * s
            itt += 0.5 * (1.0 - nd * nd) * s
        itt += c.ra[k] * c.ra[k] * m.inv_i[i] + c.rb[k] * c.rb[k] * m.inv_i[j]
        mn[k] = 1.0 / inn if inn > 0.0 else 0.0
        mt[k] = 1.0 / itt if itt > 0.0 else 0.0
    return mn, mt


@kernel
def velocities3_kernel(c, rn, rt, m, dt):
    """Add dt * M^-1 * (contact forces rn (Nc,), rt (Nc, 3)) to the velocities, in place."""
    for k in range(c.a.shape[0]):
        i = c.a[k]
        j = c.b[k]
        for d in range(3):
            f = rn[k] * c.normal[k, d] + rt[k, d]
            m.v[j, d] += dt * f * m.inv_m[j, d]
            m.v[i, d] -= dt * f * m.inv_m[i, d]
        if rt[k, 0] != 0.0 or rt[k, 1] != 0.0 or rt[k, 2] != 0.0:
            nx, ny, nz = c.normal[k, 0], c.normal[k, 1], c.normal[k, 2]
            tx = ny * rt[k, 2] - nz * rt[k, 1]         # n x rt
            ty = nz * rt[k, 0] - nx * rt[k, 2]
            tz = nx * rt[k, 1] - ny * rt[k, 0]
            gj = -dt * c.rb[k] * m.inv_i[j]
            gi = -dt * c.ra[k] * m.inv_i[i]
            m.w[j, 0] += gj * tx
            m.w[j, 1] += gj * ty
            m.w[j, 2] += gj * tz
            m.w[i, 0] += gi * tx
            m.w[i, 1] += gi * ty
            m.w[i, 2] += gi * tz


@kernel
def records3_kernel(c, m, s):
    """The 3-D solver's working copies: body pairs (Nc, 2), contact records (Nc, 16) and
    body records (nb, 12) (layout above), every per-contact factor precomputed."""
    mn, mt = masses3_kernel(c, m)
    nc = mn.shape[0]
    pairs = np.empty((nc, 2), np.int64)
    rec = np.zeros((nc, 16))
    for k in range(nc):
        for d in range(3):
            rec[k, _NX3 + d] = c.normal[k, d]
    contact_scalars(c, mn, mt, s, pairs, rec, _CN3)
    nb = m.v.shape[0]
    body = np.zeros((nb, _BODY3))
    for i in range(nb):
        for d in range(3):
            body[i, _V3 + d] = m.v[i, d]
            body[i, _W3 + d] = m.w[i, d]
            body[i, _IM3 + d] = m.inv_m[i, d]
        body[i, _II3] = m.inv_i[i]
    return pairs, rec, body


@kernel(inline="always")
def _push3(body, i, j, px, py, pz):
    """Apply the impulse p to body j and -p to body i (velocities only)."""
    body[j + _V3] += px * body[j + _IM3]
    body[j + _V3 + 1] += py * body[j + _IM3 + 1]
    body[j + _V3 + 2] += pz * body[j + _IM3 + 2]
    body[i + _V3] -= px * body[i + _IM3]
    body[i + _V3 + 1] -= py * body[i + _IM3 + 1]
    body[i + _V3 + 2] -= pz * body[i + _IM3 + 2]


@kernel
def tangential3_update(body, rec, rt, q, k, i, j, dv, new_n, dt, relaxation):
    """The friction half of the 3-D single-contact update of contact k (record at q, bodies
    at offsets i, j; dv (3,) the relative centre velocity before the normal update):
    R_t = -(m_t/dt) U_t, over-relaxed if asked, projected radially onto the disc
    |R_t| <= mu new_n; rt (3 Nc,) and the body records in place. Returns |dR_t|."""
    ex, ey, ez = rec[q + _NX3], rec[q + _NY3], rec[q + _NZ3]
    ra, rb = rec[q + _RA3], rec[q + _RB3]
    sx = rb * body[j + _W3] + ra * body[i + _W3]
    sy = rb * body[j + _W3 + 1] + ra * body[i + _W3 + 1]
    sz = rb * body[j + _W3 + 2] + ra * body[i + _W3 + 2]
    vx = dv[0] - (sy * ez - sz * ey)            # V = dv - s x n
    vy = dv[1] - (sz * ex - sx * ez)
    vz = dv[2] - (sx * ey - sy * ex)
    vn = vx * ex + vy * ey + vz * ez
    t = 3 * k
    o0, o1, o2 = rt[t], rt[t + 1], rt[t + 2]
    own = dt * rec[q + _IMT3]
    ct = rec[q + _CT3]
    n0 = -ct * (vx - vn * ex - own * o0)
    n1 = -ct * (vy - vn * ey - own * o1)
    n2 = -ct * (vz - vn * ez - own * o2)
    if relaxation != 1.0:
        n0 = o0 + relaxation * (n0 - o0)
        n1 = o1 + relaxation * (n1 - o1)
        n2 = o2 + relaxation * (n2 - o2)
    size = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    lim = rec[q + _MU3] * new_n
    if size > lim:
        f = lim / size
        n0 *= f
        n1 *= f
        n2 *= f
    d0, d1, d2 = n0 - o0, n1 - o1, n2 - o2
    if d0 == 0.0 and d1 == 0.0 and d2 == 0.0:
        return 0.0
    rt[t], rt[t + 1], rt[t + 2] = n0, n1, n2
    _push3(body, i, j, dt * d0, dt * d1, dt * d2)
    tx = ey * d2 - ez * d1                      # n x dR_t
    ty = ez * d0 - ex * d2
    tz = ex * d1 - ey * d0
    gj = -rec[q + _DTRB3] * body[j + _II3]
    gi = -rec[q + _DTRA3] * body[i + _II3]
    body[j + _W3] += gj * tx
    body[j + _W3 + 1] += gj * ty
    body[j + _W3 + 2] += gj * tz
    body[i + _W3] += gi * tx
    body[i + _W3 + 1] += gi * ty
    body[i + _W3 + 2] += gi * tz
    return np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@kernel
def sweep3_kernel(pairs, rec, body, rn, rt, order, runs, block, dt, relaxation):
    """One Gauss-Seidel sweep over a 3-D contact list (the single-contact update of the
    comment above), on the flattened records of :func:`records3_kernel`; rn (Nc,), rt
    (3 Nc,) and the body records in place; ``order``/``runs``/``block`` as
    :func:`sweep_kernel`. Returns (sum |dR|, normal updates, tangential updates)."""
    dsum = 0.0
    n_norm = 0
    n_tang = 0
    nc = rn.shape[0]
    dv = np.empty(3)
    count = runs.shape[0] if block > 0 else nc
    for pos in range(count):
        if block > 0:
            lo = runs[pos] * block
            hi = min(nc, lo + block)
        else:
            lo = order[pos]
            hi = lo + 1
        for k in range(lo, hi):
            q = 16 * k
            cn = rec[q + _CN3]
            if cn == 0.0:
                continue
            i = _BODY3 * pairs[2 * k]
            j = _BODY3 * pairs[2 * k + 1]
            for d in range(3):
                dv[d] = body[j + _V3 + d] - body[i + _V3 + d]
            ex, ey, ez = rec[q + _NX3], rec[q + _NY3], rec[q + _NZ3]
            rnk = rn[k]
            un = dv[0] * ex + dv[1] * ey + dv[2] * ez - dt * rnk * rec[q + _IMN3]
            r_gs = -cn * (rec[q + _GPDT3] + un)   # unprojected single-contact solution
            if relaxation != 1.0:
                new_n = max(rnk + relaxation * (r_gs - rnk), 0.0)
            elif un * dt + rec[q + _GP3] > 0.0:
                new_n = 0.0
            else:
                new_n = r_gs
            dn = new_n - rnk
            if dn != 0.0:
                rn[k] = new_n
                _push3(body, i, j, dt * dn * ex, dt * dn * ey, dt * dn * ez)
                dsum += abs(dn)
            n_norm += 1
            if rec[q + _MU3] <= 0.0:
                continue
            dsum += tangential3_update(body, rec, rt, q, k, i, j, dv, new_n, dt, relaxation)
            n_tang += 1
    return dsum, n_norm, n_tang


@kernel
def solve3_kernel(c, m, rn, rt, s, seed):
    """Iterate Gauss-Seidel sweeps on a 3-D contact list until the forces converge.

    c: Contacts3 (Nc,); m: Motion3, velocities updated in place; rn (Nc,), rt (Nc, 3)
    [sigma] updated in place; s: SweepSettings; seed: sweep-order seed. The sweep orders,
    over-relaxation (with its fall-back to omega = 1 at ``relax_until``) and overlap
    correction are those of :func:`solve_kernel`; convergence: sum |dR| over a sweep <=
    tol * sum |R| after it, |R| = |rn| + |rt| (Euclidean). Returns SweepStats.
    """
    pairs, rec, body = records3_kernel(c, m, s)
    stats = iterate_kernel(pairs.ravel(), rec.ravel(), body.ravel(), rn, rt.reshape(-1), s,
                           seed, 3)
    for i in range(m.v.shape[0]):
        for d in range(3):
            m.v[i, d] = body[i, _V3 + d]
            m.w[i, d] = body[i, _W3 + d]
    return stats
