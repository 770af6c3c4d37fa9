"""Distance of a soft force network from the rigid packing's force ensemble S.

Uses only forcespace's public statics API: ``forcespace.statics.full_problem``
builds S for the full packing (TOP contacts are fixed loads, BOTTOM contacts
unknowns, rattlers excluded) and ``forcespace.polytope.distance_to_S`` gives the
exact Euclidean projection. relative_distance = ||x - P_S(x)|| / (<Fn> sqrt(m)):
the rms per-contact distance in units of the rigid mean normal force.
"""
from __future__ import annotations

import numpy as np

from forcespace.packing import Packing

from .matching import MatchResult, match_contacts


def soft_vector(rigid: Packing, soft: Packing, problem=None):
    """(problem, x, match): the soft forces as a vector of the rigid statics problem."""
    from forcespace.statics import full_problem
    prob = problem if problem is not None else full_problem(rigid)
    m = match_contacts(rigid, soft)
    return prob, prob.forces_from_packing(m.fn, m.ft), m


def compare(rigid: Packing, soft: Packing, problem=None, match: MatchResult | None = None) -> dict:
    """Distance to S and matching report of ``soft`` against ``rigid`` (JSON-ready dict).

    Keys: relative_distance, absolute_distance [F0], unmatched_contacts,
    lost_contacts, max_unmatched_force(_rel), max_lost_rigid_force(_rel),
    max_overlap [R], soft_equilibrium_residual (soft geometry), n_unknown_contacts,
    force_scale [F0], plus the soft run's parameters.
    """
    from forcespace.polytope import distance_to_S
    prob, x, m = soft_vector(rigid, soft, problem)
    d = distance_to_S(prob, x)
    out = {"relative_distance": d.relative, "absolute_distance": d.absolute,
           **m.summary(prob.force_scale),
           "max_overlap": soft.max_overlap(),
           "soft_equilibrium_residual": soft.equilibrium_residual(),
           "n_unknown_contacts": prob.n_contacts, "force_scale": prob.force_scale,
           "projection_method": d.method}
    out["unmatched"] = m.unmatched
    out["lost"] = m.lost
    out["run"] = {k: v for k, v in soft.meta.items() if isinstance(v, (int, float, str, bool))}
    return out


def distance_between(rigid: Packing, soft1: Packing, soft2: Packing, problem=None) -> float:
    """rms per-contact difference of two soft networks on the rigid contacts, / <Fn>."""
    from forcespace.statics import full_problem
    prob = problem if problem is not None else full_problem(rigid)
    _, x1, _ = soft_vector(rigid, soft1, prob)
    _, x2, _ = soft_vector(rigid, soft2, prob)
    return float(np.linalg.norm(x1 - x2) / (prob.force_scale * np.sqrt(prob.n_contacts)))
