"""Nonlinear Gauss-Seidel contact solver (Moreau-Jean, Unger's formulation).

Pure numba kernels over arrays, no I/O. Bodies are indexed 0..nb-1 (disks
first, then walls); a wall has zero inverse mass in the directions it cannot
move. Contact k joins body ``a[k]`` and ``b[k]`` with unit normal (nx, ny)
from a to b; the force ``rn*n + rt*t`` (t = (-ny, nx)) acts on b, its negative
on a. Lever arms are ``ra*n`` from a's centre and ``-rb*n`` from b's centre
(ra, rb = radii; 0 for walls), so a tangential force rt exerts the torque
``-r*rt`` on both bodies.

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


@kernel
def effective_masses(a, b, nx, ny, ra, rb, inv_mx, inv_my, inv_i):
    """Normal and tangential effective masses, shape (Nc,) each.

    1/m_n = n.(M_a^-1 + M_b^-1).n, 1/m_t = t.(M_a^-1 + M_b^-1).t + ra^2/I_a + rb^2/I_b.
    A contact between two immovable bodies gets m = 0 (it never changes).
    """
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
def add_contact_velocities(a, b, nx, ny, ra, rb, rn, rt, inv_mx, inv_my, inv_i, dt,
                           vx, vy, w):
    """Add dt * M^-1 * (contact forces) to the velocities, in place."""
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
def _shuffle(order, m, state):
    """Fisher-Yates shuffle of order[:m] in place (xorshift64* generator); new state."""
    for s in range(m - 1, 0, -1):
        state ^= state >> np.uint64(12)
        state ^= state << np.uint64(25)
        state ^= state >> np.uint64(27)
        q = np.int64((state * np.uint64(0x2545F4914F6CDD1D)) >> np.uint64(33)) % (s + 1)
        tmp = order[s]
        order[s] = order[q]
        order[q] = tmp
    return state


@kernel(inline="always")
def _block_order(order, runs, block, state):
    """order = runs of ``block`` consecutive contacts in a fresh random run order."""
    state = _shuffle(runs, runs.shape[0], state)
    nc = order.shape[0]
    c = 0
    for q in range(runs.shape[0]):
        for k in range(runs[q] * block, min(nc, runs[q] * block + block)):
            order[c] = k
            c += 1
    return state


@kernel
def nlgs_solve(a, b, nx, ny, ra, rb, gap, mu, mn, mt, rn, rt, vx, vy, w,
               inv_mx, inv_my, inv_i, dt, tol, max_sweeps, seed, overlap_correction=0.0,
               overlap_slop=0.0, relaxation=1.0, block=0):
    """Iterate Gauss-Seidel sweeps until the forces converge.

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
    has not converged after half of ``max_sweeps`` finishes with omega = 1.
    ``overlap_correction`` = beta in [0, 1] and ``overlap_slop`` = s >= 0: a
    contact overlapping by more than s (gap < -s) aims at removing the fraction
    beta of the excess in this step (g+ -> beta*(g + s)); smaller overlaps are
    left alone, so a packing with all overlaps below s is at rest exactly under
    Unger's rule (beta = 0: overlaps are never pushed apart).
    Convergence: sum|dR| over a sweep <= tol * sum|R| after it.
    ``rn, rt, vx, vy, w`` are updated in place.

    Returns (sweeps, relative_change, normal_updates, tangential_updates).
    """
    nc = a.shape[0]
    order = np.arange(nc)
    runs = np.arange((nc + block - 1) // block) if block > 0 else np.zeros(0, np.int64)
    state = np.uint64(seed) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(0x632BE59BD9B4E019)
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
        if sweep == max_sweeps // 2:
            relaxation = 1.0   # over-relaxation that has not converged: plain Gauss-Seidel
        if block > 0:
            state = _block_order(order, runs, block, state)
        else:
            state = _shuffle(order, nc, state)
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
    return sweeps, rel, n_norm, n_tang
