"""Distance of a soft force network from the rigid packing's force ensemble S.

Uses only forcespace's public statics API and ``forcespace.polytope.distance_to_S``
(exact Euclidean projection). Two ensembles of the full packing:

* ``top="plate"`` (default, matches the soft runs with a load-controlled top
  plate): :func:`plate_problem` -- TOP contacts are unknowns too (friction
  plate_mu) and one extra row holds the plate's vertical balance
  sum(fn_top) = top_force. This is S of the paper's protocol.
* ``top="loads"``: ``forcespace.statics.full_problem`` -- TOP contact forces
  held fixed at their jammed values (a subset of the above).

relative_distance = ||x - P_S(x)|| / (<Fn> sqrt(m)): the rms per-contact
distance in units of the rigid mean normal force.
"""
from __future__ import annotations

import numpy as np

from forcespace.packing import Packing

from .matching import MatchResult, match_contacts


def plate_problem(rigid: Packing):
    """S of the full packing with the TOP plate's contacts unknown and its balance as a row."""
    import dataclasses

    import scipy.sparse as sp
    from forcespace.packing import BOTTOM, TOP
    from forcespace.statics import build_problem
    prob = build_problem(rigid, np.ones(rigid.n_disks, dtype=bool), unknown_walls=(BOTTOM, TOP),
                         kind="full_plate", source="plate_problem")
    top_cols = 2 * np.flatnonzero(rigid.b[prob.contacts] == TOP)
    row = sp.csr_matrix((np.ones(top_cols.size), (np.zeros(top_cols.size, dtype=int), top_cols)),
                        shape=(1, prob.n_columns))
    return dataclasses.replace(prob, A=sp.vstack([prob.A, row]).tocsr(),
                               b=np.append(prob.b, rigid.top_force))


def make_problem(rigid: Packing, top: str = "plate"):
    """The statics problem (S) to measure distances in; see the module docstring."""
    if top == "plate":
        return plate_problem(rigid)
    from forcespace.statics import full_problem
    return full_problem(rigid)


def soft_vector(rigid: Packing, soft: Packing, problem=None):
    """(problem, x, match): the soft forces as a vector of the rigid statics problem."""
    prob = problem if problem is not None else make_problem(rigid)
    m = match_contacts(rigid, soft)
    return prob, prob.forces_from_packing(m.fn, m.ft), m


def project_to_S(prob, x):
    """Euclidean projection of ``x`` (2m,) onto S = {A y = b, Coulomb cones, fn >= 0}.

    Fallback used when ``forcespace.polytope.distance_to_S`` cannot verify its
    projection. Cone coordinates z >= 0 make every cone a pair of bounds
    (frictional contact: fn = (u+v)/(2 mu), ft = (v-u)/2; frictionless: fn = z,
    ft = 0); a non-negative least-squares solve (scipy ``nnls``, Lawson-Hanson) with the
    equalities as heavily weighted rows finds the active set, then the
    projection restricted to that face is solved exactly (KKT system, least
    squares). Returns (y (2m,), violation of y relative to <Fn>, note).
    """
    import scipy.sparse as sp
    x = np.asarray(x, float)
    m = prob.n_contacts
    mu = np.broadcast_to(np.asarray(prob.mu, float), (m,))
    rows, cols, vals = [], [], []
    nz = 0
    for k in range(m):
        if mu[k] > 0:
            rows += [2 * k, 2 * k, 2 * k + 1, 2 * k + 1]
            cols += [nz, nz + 1, nz, nz + 1]
            vals += [0.5 / mu[k], 0.5 / mu[k], -0.5, 0.5]
            nz += 2
        else:
            rows.append(2 * k); cols.append(nz); vals.append(1.0)
            nz += 1
    T = sp.csr_matrix((vals, (rows, cols)), shape=(2 * m, nz)).toarray()
    A = prob.A.toarray()
    b = np.asarray(prob.b, float)
    scale = max(prob.force_scale, 1e-300)
    AT = A @ T
    w = 1e4
    from scipy.optimize import nnls
    z, _ = nnls(np.vstack([T, w * AT]) / scale, np.concatenate([x, w * b]) / scale,
                maxiter=50 * nz)
    y_pen = T @ z
    free = z > 1e-10 * scale
    best = None
    for _ in range(60):       # primal-dual active-set refinement, one change per pass
        TF, AF = T[:, free], AT[:, free]
        nf, ne = TF.shape[1], AF.shape[0]
        K = np.block([[TF.T @ TF, AF.T], [AF, np.zeros((ne, ne))]])
        rhs = np.concatenate([TF.T @ x, b])
        sol = np.linalg.lstsq(K, rhs, rcond=1e-13)[0]
        zf, nu = sol[:nf], sol[nf:]
        y = TF @ zf
        # KKT: bound multipliers of the fixed z (gradient T^T (y - x) + (AT)^T nu) >= 0
        g = T[:, ~free].T @ (y - x) + AT[:, ~free].T @ nu
        kkt = max(0.0, -g.min(initial=0.0)) / scale
        neg = zf.min(initial=0.0) < -1e-12 * scale
        if not neg and (best is None or kkt < best[1]):
            best = (y, kkt)
        if neg:
            idx = np.flatnonzero(free)[int(np.argmin(zf))]
            free[idx] = False
        elif kkt > 1e-10:
            idx = np.flatnonzero(~free)[int(np.argmin(g))]
            free[idx] = True
        else:
            break
    if best is None or prob.violation(best[0]) > max(prob.violation(y_pen), 1e-12):
        return y_pen, prob.violation(y_pen), "cone-coordinate NNLS with weighted equalities"
    y, kkt = best
    return y, prob.violation(y), ("cone-coordinate NNLS active set + exact face projection, "
                                  f"KKT multiplier violation {kkt:.1e} <Fn> (0: exact projection; "
                                  "else an upper bound)")


def compare(rigid: Packing, soft: Packing, problem=None, match: MatchResult | None = None,
            projector: str = "auto") -> dict:
    """Distance to S and matching report of ``soft`` against ``rigid`` (JSON-ready dict).

    Keys: relative_distance, absolute_distance [F0], unmatched_contacts,
    lost_contacts, max_unmatched_force(_rel), max_lost_rigid_force(_rel),
    max_overlap [R], soft_equilibrium_residual (soft geometry), n_unknown_contacts,
    force_scale [F0], plus the soft run's parameters.

    ``projector``: "polytope" (forcespace.polytope.distance_to_S, verified KKT),
    "adapters" (:func:`project_to_S`, faster on 200-disk packings: ~15 s vs ~45 s),
    "auto" (polytope, falling back to adapters when it cannot verify).
    """
    if projector not in ("auto", "polytope", "adapters"):
        raise ValueError(f"projector must be 'auto', 'polytope' or 'adapters', got {projector!r}")
    from forcespace.polytope import distance_to_S
    prob, x, m = soft_vector(rigid, soft, problem)
    viol = prob.violation(x)
    try:
        if projector == "adapters":
            raise RuntimeError("adapters projector requested")
        d = distance_to_S(prob, x)
        rel, ab, method = d.relative, d.absolute, d.method
    except Exception as exc:
        if projector == "polytope":
            raise
        # forcespace.polytope's active-set polish can fail (argmin of an empty active
        # set, or an unverified KKT check) on the plate S; use our own projection
        y, yviol, note = project_to_S(prob, x)
        ab = float(np.linalg.norm(y - x))
        rel = ab / (prob.force_scale * np.sqrt(prob.n_contacts))
        method = f"{note} (polytope.distance_to_S failed: {type(exc).__name__}); " \
                 f"projection violates S by {yviol:.1e} <Fn>"
    out = {"relative_distance": rel, "absolute_distance": ab, "max_violation_rel": viol,
           **m.summary(prob.force_scale),
           "max_overlap": soft.max_overlap(),
           "soft_equilibrium_residual": soft.equilibrium_residual(),
           "n_unknown_contacts": prob.n_contacts, "force_scale": prob.force_scale,
           "projection_method": method}
    out["unmatched"] = m.unmatched
    out["lost"] = m.lost
    out["run"] = {k: v for k, v in soft.meta.items() if isinstance(v, (int, float, str, bool))}
    return out


def distance_between(rigid: Packing, soft1: Packing, soft2: Packing, problem=None) -> float:
    """rms per-contact difference of two soft networks on the rigid contacts, / <Fn>."""
    prob = problem if problem is not None else make_problem(rigid)
    _, x1, _ = soft_vector(rigid, soft1, prob)
    _, x2, _ = soft_vector(rigid, soft2, prob)
    return float(np.linalg.norm(x1 - x2) / (prob.force_scale * np.sqrt(prob.n_contacts)))
