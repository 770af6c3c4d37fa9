"""The static certificate of a jam: does the frozen configuration admit a static network?

While the disks still creep, the time stepper's forces only approximate a static
network. Here the geometry is frozen and the question asked exactly: is there a contact
force network on the current closed contacts (gap <= a tolerance, taken as closed) that
balances every movable body under its loads and keeps every contact inside its Coulomb
cone? Equations (the engine's convention, :mod:`forcespace.engine.records`): for every
body direction with a non-zero inverse mass one row -- the x and y force and, for a
rotating disk, the torque divided by the radius -- ``A f = -F_ext``, unknowns
``f[2k] = rn_k``, ``f[2k+1] = rt_k`` [sigma]; Coulomb ``|rt_k| <= mu_k rn_k`` (two
linear rows; ``rt_k = 0`` when mu_k = 0). The answer comes from an interior-point
solver (Clarabel, sparse LDL^T): the point of the set nearest to the dynamics' forces
(a convex QP), or a certificate of infeasibility (Farkas: no such network exists).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from .contacts import detect_contacts
from .records import Box, ContactForces, Contacts
from .step import contact_list, warm_start


class CertificateSettings(NamedTuple):
    """When and how a jam is ended by a static certificate.

    speed [R/T]: a certificate is tried after a window whose mean speed (the rest
    criterion's measure) is at most this (0: never); gap_tol [R]: pairs closer than
    this are closed contacts; tol [1]: the interior-point solver's relative
    feasibility and gap tolerance; every [windows]: windows between two attempts.
    """

    speed: float
    gap_tol: float
    tol: float = 1e-10
    every: int = 1


class StaticSystem(NamedTuple):
    """The equilibrium equations of a frozen contact network.

    A (rows, 2 Nc) CSR: one row per movable body direction (x force, y force, torque /
    radius), columns (rn_k, rt_k) [sigma] per contact k; b (rows,) [sigma]: minus the
    external loads of those rows; mu (Nc,) Coulomb coefficients; body (rows,) and
    direction (rows,) (0 x, 1 y, 2 torque) of each row.
    """

    A: sp.csr_matrix
    b: np.ndarray
    mu: np.ndarray
    body: np.ndarray
    direction: np.ndarray


def static_system(c: Contacts, inv_mx, inv_my, inv_i, fy_ext, radius) -> StaticSystem:
    """The equations of the contacts ``c`` (gaps ignored: every listed contact closed).

    inv_mx, inv_my, inv_i, fy_ext (nb,): inverse masses [1/(rho R^2)], [1/(rho R^4)] and
    the external force along y [sigma] of every body; radius (nb,) [R] (0 for walls: a
    body's torque row is divided by its radius). A direction gets a row where its inverse
    mass is non-zero (walls: none; the load-controlled plate: y).
    """
    nb = inv_mx.shape[0]
    movable = np.stack([inv_mx > 0, inv_my > 0, (inv_i > 0) & (radius > 0)], axis=1)
    row_of = -np.ones((nb, 3), np.int64)
    body, direction = np.nonzero(movable)
    row_of[body, direction] = np.arange(body.size)
    nc = c.a.shape[0]
    nx, ny = c.nx, c.ny
    rows, cols, vals = [], [], []
    for ends, sign, lever in ((c.b, 1.0, c.rb), (c.a, -1.0, c.ra)):
        safe_r = np.where(radius[ends] > 0, radius[ends], 1.0)
        # (row direction, column offset, value): fn along n, ft along t = (-ny, nx),
        # torque -lever*ft on both ends (divided by the body's radius)
        for d, off, val in ((0, 0, sign * nx), (1, 0, sign * ny), (0, 1, -sign * ny),
                            (1, 1, sign * nx), (2, 1, -lever / safe_r)):
            r = row_of[ends, d]
            keep = (r >= 0) & (val != 0.0)
            rows.append(r[keep])
            cols.append(2 * np.flatnonzero(keep) + off)
            vals.append(val[keep])
    A = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(body.size, 2 * nc))
    A.sum_duplicates()
    b = np.where(direction == 1, -fy_ext[body], 0.0)
    return StaticSystem(A, b, np.asarray(c.mu, float), body, direction)


class Certificate(NamedTuple):
    """What :func:`certify` found.

    status: "static" (a network exists; ``rn, rt`` (Nc,) [sigma] is the point nearest to
    the start), "not static" (primal infeasibility certificate: no network exists) or
    "undecided" (the solver stopped otherwise); residual: largest equation residual /
    mean |rn|; iterations: interior-point iterations; seconds: solver CPU seconds.
    """

    status: str
    rn: np.ndarray | None
    rt: np.ndarray | None
    residual: float
    iterations: int
    seconds: float


def cone_rows(mu):
    """The Coulomb conditions of Nc contacts as rows over f = (rn_k, rt_k): (Z, G), Z f = 0
    and G f <= 0, sparse with 2 Nc columns. mu (Nc,): a frictionless contact gets rt = 0
    and -rn <= 0, a frictional one rt - mu rn <= 0 and -rt - mu rn <= 0."""
    nc = mu.shape[0]
    k = np.arange(nc)
    kf, k0 = k[mu > 0], k[mu == 0]
    z = np.arange(k0.size)
    Z = sp.csr_matrix((np.ones(k0.size), (z, 2 * k0 + 1)), shape=(k0.size, 2 * nc))
    m, r = kf.size, np.arange(kf.size)
    G = sp.csr_matrix((np.concatenate([-mu[kf], np.ones(m), -mu[kf], -np.ones(m),
                                       -np.ones(k0.size)]),
                       (np.concatenate([r, r, m + r, m + r, 2 * m + z]),
                        np.concatenate([2 * kf, 2 * kf + 1, 2 * kf, 2 * kf + 1, 2 * k0]))),
                      shape=(2 * m + k0.size, 2 * nc))
    return Z, G


def certify(system: StaticSystem, rn0, rt0, tol: float = 1e-10, max_iter: int = 200,
            norm: str = "l2") -> Certificate:
    """Decide whether ``system`` admits a static network, by Clarabel.

    Finds the network f over {A f = b, Coulomb} nearest to f0 = (rn0, rt0) (the
    dynamics' forces [sigma]; the Coulomb rows of :func:`cone_rows`): ``norm`` "l2" the Euclidean projection (a QP, the
    cheaper existence test), "l1" the least total change sum |f - f0| (an LP: most
    contacts keep the dynamics' force exactly, so its zero forces and its contacts at the
    Coulomb limit stay so unless equilibrium needs them to change -- as the sweeps of
    the static solve keep them). Units of the largest load, so ``tol`` (Clarabel's
    feasibility and gap tolerances) is relative.
    """
    import time

    import clarabel

    A, b, mu = system.A, system.b, system.mu
    nc = mu.shape[0]
    scale = float(np.abs(b).max(initial=0.0))
    f0 = np.empty(2 * nc)
    f0[0::2], f0[1::2] = rn0, rt0
    if scale == 0.0:
        scale = max(float(np.abs(f0).max(initial=0.0)), 1.0)
    Z, G = cone_rows(mu)
    E = sp.vstack([A, Z])
    rhs = np.concatenate([b / scale, np.zeros(Z.shape[0])])
    if norm == "l1":      # x = (f, u, v), f - u + v = f0, u, v >= 0, minimise sum(u + v)
        m2 = 2 * nc
        eye = sp.identity(m2, format="csr")
        E = sp.vstack([sp.hstack([E, sp.csr_matrix((E.shape[0], 2 * m2))]),
                       sp.hstack([eye, -eye, eye])])
        G = sp.vstack([sp.hstack([G, sp.csr_matrix((G.shape[0], 2 * m2))]),
                       sp.hstack([sp.csr_matrix((2 * m2, m2)), -sp.identity(2 * m2)])])
        rhs = np.concatenate([rhs, f0 / scale])
        P = sp.csc_matrix((3 * m2, 3 * m2))
        q = np.concatenate([np.zeros(m2), np.ones(2 * m2)])
    else:
        P, q = sp.identity(2 * nc, format="csc"), -f0 / scale
    s = clarabel.DefaultSettings()
    s.verbose = False
    s.max_iter = max_iter
    s.tol_feas = s.tol_gap_abs = s.tol_gap_rel = tol
    s.max_threads = 1
    t0 = time.process_time()
    sol = clarabel.DefaultSolver(P, q, sp.vstack([E, G]).tocsc(),
                                 np.concatenate([rhs, np.zeros(G.shape[0])]),
                                 [clarabel.ZeroConeT(E.shape[0]),
                                  clarabel.NonnegativeConeT(G.shape[0])], s).solve()
    seconds = time.process_time() - t0
    status = str(sol.status)
    if status in ("Solved", "AlmostSolved"):
        f = np.asarray(sol.x)[:2 * nc] * scale
        res = float(np.abs(A @ f - b).max(initial=0.0))
        mean = float(np.abs(f[0::2]).mean()) if nc else 0.0
        return Certificate("static", f[0::2].copy(), f[1::2].copy(),
                           res / mean if mean > 0 else res, sol.iterations, seconds)
    if status in ("PrimalInfeasible", "AlmostPrimalInfeasible"):
        return Certificate("not static", None, None, np.inf, sol.iterations, seconds)
    return Certificate("undecided", None, None, np.inf, sol.iterations, seconds)


def least_change_network(system: StaticSystem, rn0, rt0, tol: float = 1e-10,
                         support_tol: float = 1e-7) -> Certificate:
    """The static network that changes the dynamics' forces (rn0, rt0) (Nc,) [sigma]
    least in total, to the accuracy ``tol`` (relative), in two interior-point solves:
    the L1-nearest network (:func:`certify`, norm "l1", to 1e-8: an LP whose optimal
    face the solver reaches fast but converges on slowly), then, on its support (the
    contacts bearing more than ``support_tol`` x the mean normal force; the others set
    exactly to zero, not left at the interior point's small positive values, which would
    count as force-bearing), the Euclidean projection of that point to ``tol`` (a QP,
    fast and exact). Falls back to the L1 point where the support admits no network."""
    first = certify(system, rn0, rt0, max(tol, 1e-8), norm="l1")
    if first.status != "static":
        return first
    on = first.rn > support_tol * np.abs(first.rn).mean()
    cols = np.stack([2 * np.flatnonzero(on), 2 * np.flatnonzero(on) + 1], 1).ravel()
    sub = system._replace(A=system.A[:, cols], mu=system.mu[on])
    exact = certify(sub, first.rn[on], first.rt[on], tol, norm="l2")
    if exact.status != "static":
        return first
    rn, rt = np.zeros_like(first.rn), np.zeros_like(first.rt)
    rn[on], rt[on] = exact.rn, exact.rt
    return exact._replace(rn=rn, rt=rt, iterations=first.iterations + exact.iterations,
                          seconds=first.seconds + exact.seconds)


def frozen_system(bodies, box: Box, mu_disk: float, mu_wall: float, gap_tol: float,
                  forces: ContactForces | None):
    """The closed contacts of the bodies' current configuration (gap <= ``gap_tol`` [R])
    and their equations: (Contacts, images (Nc,), StaticSystem, rn0, rt0), rn0, rt0 (Nc,)
    [sigma] the ``forces`` of the dynamics on them (0 where none). ``bodies``: the fields
    of :class:`~forcespace.engine.records.BodyArrays`."""
    ints, floats = detect_contacts(bodies.x, bodies.y, bodies.r, box, gap_tol)
    c = contact_list(ints, floats, bodies.r, mu_disk, mu_wall)
    if forces is None:
        rn0, rt0 = np.zeros(c.a.shape[0]), np.zeros(c.a.shape[0])
    else:
        rn0, rt0 = warm_start(c.keys, forces)
    radius = np.concatenate([bodies.r, np.zeros(bodies.x.shape[0] - bodies.r.shape[0])])
    system = static_system(c, bodies.inv_mx, bodies.inv_my, bodies.inv_i, bodies.fy_ext,
                           radius)
    return c, ints[:, 2].copy(), system, rn0, rt0


def in_cones(rn, rt, mu):
    """The forces clipped into their Coulomb cones (rn >= 0, |rt| <= mu rn): an
    interior-point solution meets them only to its tolerance."""
    rn = np.maximum(rn, 0.0)
    lim = mu * rn
    return rn, np.clip(rt, -lim, lim)


def _clarabel(P, q, A, b, cones, tol: float):
    """Clarabel's solution of min x'Px/2 + q'x over {A x + s = b, s in cones} to the
    relative tolerance ``tol``: (status, x or None, iterations, CPU seconds)."""
    import time

    import clarabel

    s = clarabel.DefaultSettings()
    s.verbose = False
    s.max_threads = 1
    for name in ("tol_feas", "tol_gap_abs", "tol_gap_rel", "tol_infeas_abs",
                 "tol_infeas_rel"):
        setattr(s, name, tol)
    t0 = time.process_time()
    sol = clarabel.DefaultSolver(P, q, A.tocsc(), b, cones, s).solve()
    seconds = time.process_time() - t0
    status = str(sol.status).split(".")[-1]
    if status in ("Solved", "AlmostSolved"):
        status = "static"
    elif status in ("PrimalInfeasible", "AlmostPrimalInfeasible"):
        status = "not static"
    else:
        status = "undecided"
    x = np.asarray(sol.x, float) if status == "static" else None
    return status, x, int(sol.iterations), seconds


def certify_spheres(problem, tol: float = 1e-10, norm: str = "l2", zero=None):
    """:func:`certify` for spheres: does the frozen sphere network ``problem`` (a
    :class:`~forcespace.model.sphere_problem.SphereStaticsProblem`, S of the plate
    problem: equilibrium rows, Coulomb as second-order cones, :func:`forcespace.space.conic
    .cone_constraints`) admit a static network? The point of S nearest to the dynamics'
    forces ``problem.x_jammed``: ``norm`` "l2" Euclidean (a second-order-cone QP), "l1"
    the least total change sum |x - x_jammed| over the columns (fn, f1, f2) (linear
    objective); ``zero`` (columns) held at 0. Solved in units of <Fn> (``tol``
    relative). Returns (Certificate with rn, rt None, x (3m,) [F0] or None)."""
    import clarabel

    from ..space.conic import cone_constraints

    scale = problem.force_scale if problem.force_scale > 0 else 1.0
    unit = problem.scaled(1.0 / scale)
    m = unit.n_columns
    A, b, cones = cone_constraints(unit)
    if zero is not None and len(zero):
        A = sp.vstack([A, sp.identity(m, format="csr")[np.asarray(zero)]])
        b = np.concatenate([b, np.zeros(len(zero))])
        cones = cones + [clarabel.ZeroConeT(len(zero))]
    if norm == "l1":      # y = (x, u, v): x - u + v = x_jammed, u, v >= 0, min sum(u + v)
        eye = sp.identity(m, format="csr")
        A = sp.vstack([sp.hstack([A, sp.csr_matrix((A.shape[0], 2 * m))]),
                       sp.hstack([eye, -eye, eye]),
                       sp.hstack([sp.csr_matrix((2 * m, m)), -sp.identity(2 * m)])])
        b = np.concatenate([b, unit.x_jammed, np.zeros(2 * m)])
        cones = cones + [clarabel.ZeroConeT(m), clarabel.NonnegativeConeT(2 * m)]
        P, q = sp.csc_matrix((3 * m, 3 * m)), np.concatenate([np.zeros(m), np.ones(2 * m)])
    else:
        P, q = sp.identity(m, format="csc"), -unit.x_jammed
    status, y, iterations, seconds = _clarabel(P, q, A, b, cones, tol)
    if y is None:
        return Certificate(status, None, None, np.inf, iterations, seconds), None
    x = y[:m] * scale
    x[problem.fixed_columns()] = 0.0
    eq = np.abs(problem.A @ x - problem.b).max(initial=0.0)
    return Certificate(status, None, None, float(eq / scale), iterations, seconds), x


def least_change_spheres(problem, tol: float = 1e-10, support_tol: float = 1e-7):
    """:func:`least_change_network` for spheres: the static network of ``problem`` (a
    SphereStaticsProblem) that changes the dynamics' forces ``x_jammed`` least in total
    (L1, to 1e-8), then the Euclidean projection of that point to ``tol`` with the
    contacts off its support (fn <= ``support_tol`` <Fn>) held at exactly zero; falls back
    to the L1 point where the support admits no network. Returns (Certificate, x (3m,)
    [F0] or None)."""
    first, x1 = certify_spheres(problem, max(tol, 1e-8), norm="l1")
    if x1 is None:
        return first, None
    scale = problem.force_scale if problem.force_scale > 0 else 1.0
    off = np.flatnonzero(x1[0::3] <= support_tol * scale)
    zero = np.concatenate([3 * off, 3 * off + 1, 3 * off + 2])
    exact, x2 = certify_spheres(_with_target(problem, x1), tol, "l2", zero)
    if x2 is None:
        return first, x1
    return exact._replace(iterations=first.iterations + exact.iterations,
                          seconds=first.seconds + exact.seconds), x2


def _with_target(problem, x):
    """``problem`` with its target forces x_jammed replaced by ``x`` (3m,) [F0]."""
    import dataclasses

    return dataclasses.replace(problem, x_jammed=np.asarray(x, float))
