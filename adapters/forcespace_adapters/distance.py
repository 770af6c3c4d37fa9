"""Distance of a soft force network from the rigid packing's force ensemble S.

Uses only forcespace's public statics API and ``forcespace.extend.distance_to_S``
(exact Euclidean projection). Two ensembles of the full packing:

* ``top="plate"`` (default, matches the soft runs with a load-controlled top
  plate): ``forcespace.plate_problem`` -- TOP contacts are unknowns too (friction
  plate_mu) and one extra row holds the plate's vertical balance
  sum(fn_top) = top_force. This is S of the paper's protocol.
* ``top="loads"``: ``forcespace.full_problem`` -- TOP contact forces
  held fixed at their jammed values (a subset of the above).

relative_distance = ||x - P_S(x)|| / (<Fn> sqrt(m)): the rms per-contact
distance in units of the rigid mean normal force.

Verdict (:func:`verdict`): a soft network cannot be closer to S than its own accuracy.
Its geometry differs from the rigid one by its overlaps (contact normals turn by up to
max_overlap / r_min, moving forces between the normal and tangential parts by that
fraction of <Fn>), and its equilibrium holds to its residual. So the accuracy of a soft
network, in the units of the relative distance, is
``accuracy = max(max_overlap / r_min, residual / <Fn>)`` (residual: the soft run's own
largest per-disk force residual when it records one, else the network's equilibrium
residual), and the network counts as **inside S at the soft code's accuracy** when
``relative_distance <= INSIDE_FACTOR * accuracy`` (INSIDE_FACTOR = 10: converged LIGGGHTS
and pymunk networks that keep the rigid contact network sit at 1-4x their accuracy on the
paper packings, while one extra soft contact -- a rigid gap closed by the soft overlaps --
puts the network 1e3-1e4x its accuracy away).
"""
from __future__ import annotations

import numpy as np

import forcespace as fs
from forcespace.errors import InputError
from forcespace import Packing

from .matching import MatchResult, match_contacts

INSIDE_FACTOR = 10.0
IN_S_VIOLATION = 1e-9     # [<Fn>] a sphere network violating S by less is a point of S


def make_problem(rigid: Packing, top: str = "plate"):
    """The statics problem (S) to measure distances in: ``top="plate"`` (default) the
    plate problem (TOP contacts unknown, plate balance a row), ``"loads"`` the full
    problem (TOP forces fixed); see the module docstring. Spheres: the same two as
    second-order-cone problems (``fs.sphere_plate_problem``, ``fs.sphere_full_problem``)."""
    if top not in ("plate", "loads"):
        raise InputError("distance", "top", "must be 'plate' or 'loads'", got=top)
    if getattr(rigid, "dim", 2) == 3:
        return fs.sphere_plate_problem(rigid) if top == "plate" else \
            fs.sphere_full_problem(rigid)
    return fs.plate_problem(rigid) if top == "plate" else fs.full_problem(rigid)


def check_made_from(rigid: Packing, soft: Packing) -> None:
    """InputError (naming the soft network's file) unless ``soft`` was made from ``rigid``:
    the packing fingerprint it records (``meta["packing_fingerprint"]``) must be the rigid
    packing's; a network without one (written before it was recorded) must have the
    rigid disks (same number and radii) within half the smallest radius of their places."""
    src = soft.source or "soft network"
    made_from = soft.meta.get("packing_fingerprint")
    whose = f"the packing {rigid.source}" if rigid.source else "the rigid packing"
    if made_from:
        if made_from != rigid.fingerprint:
            raise InputError(src, "meta/packing_fingerprint", f"names another packing "
                             f"({made_from}, not {rigid.fingerprint} of {whose}): a soft "
                             "network is measured in S of the packing it was made from")
        return
    n = rigid.n_disks
    if soft.n_disks != n or not np.allclose(soft.r, rigid.r, rtol=1e-9, atol=0.0):
        raise InputError(src, "disks", f"are not those of {whose} ({soft.n_disks} disks, "
                         f"it has {n}, or other radii): a soft network is measured in S of "
                         "the packing it was made from")
    if getattr(rigid, "dim", 2) == 3:       # spheres: periodic in x and y
        d = soft.pos - rigid.pos
        size = np.asarray(rigid.lateral, float)
        d[:, :2] -= size * np.round(d[:, :2] / size)
        moved = float(np.linalg.norm(d, axis=1).max(initial=0.0))
    else:
        dx = soft.x - rigid.x
        if rigid.periodic_x:
            dx -= rigid.width * np.round(dx / rigid.width)
        moved = float(np.hypot(dx, soft.y - rigid.y).max(initial=0.0))
    if not moved <= 0.5 * float(rigid.r.min(initial=1.0)):
        raise InputError(src, "disks", f"lie up to {moved:.3g} R from those of {whose} "
                         "(more than half a radius): not a soft network of that packing")


def soft_vector(rigid: Packing, soft: Packing, problem=None):
    """(problem, x, match): the soft forces as a vector of the rigid statics problem
    (InputError if ``soft`` was not made from ``rigid``, :func:`check_made_from`)."""
    check_made_from(rigid, soft)
    prob = problem if problem is not None else make_problem(rigid)
    m = match_contacts(rigid, soft)
    return prob, prob.forces_from_packing(m.fn, m.ft), m


def compare(rigid: Packing, soft: Packing, problem=None,
            match: MatchResult | None = None) -> dict:
    """Distance to S and matching report of ``soft`` against ``rigid`` (JSON-ready dict).

    Keys: relative_distance, absolute_distance [F0], rigid_equilibrium_residual and
    coulomb_violation (the soft forces on the rigid geometry: largest |A x - b| and
    largest excess over the Coulomb cones, / <Fn>), unmatched_contacts,
    lost_contacts, max_unmatched_force(_rel), max_lost_rigid_force(_rel),
    max_overlap [R], soft_equilibrium_residual (soft geometry), n_unknown_contacts,
    force_scale [F0], plus the soft run's parameters. The projection is
    ``forcespace.space.projection.distance_to_S`` (exact, KKT-verified). ``verdict``:
    whether the network is inside S at the soft code's own accuracy (:func:`verdict`).
    """
    prob, x, m = soft_vector(rigid, soft, problem)
    viol = prob.violation(x)
    if getattr(rigid, "dim", 2) == 3:
        rel, ab, method = _sphere_distance(prob, x)
    else:
        from forcespace.extend import distance_to_S
        d = distance_to_S(prob, x)
        rel, ab, method = d.relative, d.absolute, d.method
    eq, cone = prob.residuals(x)
    out = {"relative_distance": rel, "absolute_distance": ab, "max_violation_rel": viol,
           "rigid_equilibrium_residual": float(np.abs(eq).max(initial=0.0) / prob.force_scale),
           "coulomb_violation": float(max(cone.max(initial=0.0), 0.0) / prob.force_scale),
           **m.summary(prob.force_scale),
           "max_overlap": soft.max_overlap(),
           "soft_equilibrium_residual": soft.equilibrium_residual(),
           "n_unknown_contacts": prob.n_contacts, "force_scale": prob.force_scale,
           "projection_method": method}
    out["unmatched"] = m.unmatched
    out["lost"] = m.lost
    out["run"] = {k: v for k, v in soft.meta.items() if isinstance(v, (int, float, str, bool))}
    out["soft_run_converged"], out["soft_run_reason"] = run_status(soft.meta)
    out["verdict"] = verdict(rel, soft, out)
    return out


def _sphere_distance(problem, x):
    """(relative, absolute [F0], method) distance of x from S of a sphere problem: 0 when x
    violates equilibrium and the cones by at most IN_S_VIOLATION <Fn> (an engine network,
    static to 1e-10, is a point of S), else the nearest admissible network by Clarabel's
    second-order-cone program (``fs.nearest_admissible``); relative = rms per contact /
    <Fn>. An interior-point method meets a nearest point on a cone's boundary (a sliding
    contact) only to about the square root of its tolerance: distances below ~1e-6 are at
    the solver's accuracy (an admissible engine network measured 1.7e-6 this way)."""
    if problem.violation(x) <= IN_S_VIOLATION:
        return 0.0, 0.0, "clarabel socp"
    near = fs.nearest_admissible(problem, target=x)
    if not near.feasible:
        raise InputError("distance", "S", f"the rigid packing's S is empty here (Clarabel: "
                         f"{near.status})")
    ab = float(np.linalg.norm(x - near.x))
    return ab / (problem.force_scale * np.sqrt(problem.n_contacts)), ab, "clarabel socp"


def verdict(relative_distance: float, soft: Packing, report: dict | None = None) -> dict:
    """Is the soft network inside S at its own accuracy (module docstring)?

    Returns {"inside_S": bool, "relative_distance", "accuracy", "overlap_scale"
    (max_overlap / r_min), "residual_scale" (residual / <Fn>), "factor", "text"}. A soft
    run that stopped at its step cap gets inside_S False and "no verdict" (its network
    is not an equilibrium of the soft code)."""
    meta = soft.meta or {}
    overlap = soft.max_overlap() / float(soft.r.min())
    scale = meta.get("force_scale") or soft.mean_normal_force() or 1.0
    if meta.get("max_residual_force") is not None:
        residual = float(meta["max_residual_force"]) / scale
    elif meta.get("max_residual_rel") is not None:
        residual = float(meta["max_residual_rel"])
    else:
        residual = soft.equilibrium_residual()
    acc = max(overlap, residual)
    converged, reason = run_status(meta)
    if converged is False:      # a run stopped at its cap is no soft equilibrium at all
        return {"inside_S": False, "relative_distance": relative_distance, "accuracy": acc,
                "overlap_scale": overlap, "residual_scale": residual,
                "factor": INSIDE_FACTOR,
                "text": f"no verdict: the soft run {reason} (relative distance "
                        f"{relative_distance:.2e}, residual {residual:.2e} <Fn>)"}
    inside = bool(relative_distance <= INSIDE_FACTOR * acc)
    why = (f"relative distance {relative_distance:.2e} {'<=' if inside else '>'} "
           f"{INSIDE_FACTOR:g} x accuracy {acc:.2e} (max overlap / r_min {overlap:.2e}, "
           f"residual {residual:.2e} <Fn>)")
    extra = ""
    if not inside and report and report.get("unmatched_contacts"):
        extra = (f"; {report['unmatched_contacts']} soft contact(s) absent from the rigid "
                 f"packing carry up to {report['max_unmatched_force_rel']:.2g} <Fn> (rigid gaps "
                 "closed by the soft overlaps)")
    if not inside:      # the soft code's own error falls as its springs stiffen
        kn = meta.get("kn")
        extra += ("; a stiffer soft run lands closer to S" + (f" (try kn = {10 * kn:g} <Fn>/R"
                  if kn else " (a larger kn") + "; all 6 paper packings of the LIGGGHTS "
                  "ladder land inside S at kn = 1e7 <Fn>/R, 2 of 6 at 1e6)")
    text = ("inside S at the soft code's accuracy: " if inside else
            "outside S beyond the soft code's accuracy: ") + why + extra
    return {"inside_S": inside, "relative_distance": relative_distance, "accuracy": acc,
            "overlap_scale": overlap, "residual_scale": residual,
            "factor": INSIDE_FACTOR, "text": text}


def run_status(meta: dict):
    """(converged, reason) of the soft run that made a network (its file's meta)."""
    if "converged" not in meta:
        return None, "the soft network records no convergence status"
    if bool(meta["converged"]):
        return True, "converged"
    res, tol = meta.get("max_residual_force"), meta.get("tolerance_abs")
    steps = meta.get("steps")
    why = f"stopped at max_steps ({steps} steps)" if steps is not None else "did not converge"
    if res is not None and tol is not None:
        why += f" with largest per-disk force residual {res:.2e} F0 > tolerance {tol:.2e} F0"
    return False, why


def distance_between(rigid: Packing, soft1: Packing, soft2: Packing, problem=None) -> float:
    """rms per-contact difference of two soft networks on the rigid contacts, / <Fn>."""
    prob = problem if problem is not None else make_problem(rigid)
    _, x1, _ = soft_vector(rigid, soft1, prob)
    _, x2, _ = soft_vector(rigid, soft2, prob)
    return float(np.linalg.norm(x1 - x2) / (prob.force_scale * np.sqrt(prob.n_contacts)))
