"""A measured force network checked against S: how far it is from equilibrium and Coulomb,
the nearest admissible network, and what the geometry and the loads alone leave open.

``Measured(...).compute(problem, x)``: ``problem`` is the statics problem of a frame's
region (:func:`forcespace.model.frame.frame_problem`), whose loads are the measured
forces at the contacts that cross the region's boundary (and at the walls); ``x`` (2m,)
[F0] is the measured network on the unknown contacts (default: the packing's forces,
``problem.x_jammed``), in problem column order (x[2j] = fn, x[2j+1] = ft).

Answers, in units of <Fn> (``problem.force_scale``: the mean measured normal force over
the region's contacts) unless stated:

* ``imbalance`` (n, 3): the measured network's net force (x, y) and torque / r on every
  region disk, loads included; ``coulomb_violation`` (m,): by how much each contact
  leaves its cone (|ft| - mu fn, or -fn, if positive);
* ``nearest`` (2m,) [F0]: the admissible network closest to x (a sparse interior-point
  QP, :func:`~forcespace.space.projection.qp_project`; Euclidean, or with
  ``weighted=True`` in the metric sum ((fn - fn_m)^2 / sigma_fn^2 + (ft - ft_m)^2 /
  sigma_ft^2) of the measurement's uncertainty); contacts whose force was not measured
  enter with an uncertainty of ``config.UNKNOWN_SIGMA`` <Fn> (practically free);
  ``distance`` (rms per measured contact), ``contact_distance`` (m,): |F_m - F_nearest|
  per contact;
* ``fn_range``, ``ft_range`` (m, 2) [F0]: min and max of each contact's force over S:
  the error bars the geometry and the loads alone leave; ``inside`` (m,): the measured
  value lies in its range;
* ``dim``, ``bounded``, ``domains`` (of :class:`~forcespace.space.force_space.ForceSpace`);
  with ``samples``: a uniform sample of S (billiard walk to ESS ``target_ess``) and its
  ``eta`` (the paper's force ambiguity);
* when S is empty (noisy loads that no network balances, or Coulomb cones that cannot
  hold them): ``feasible = False``, ``least_violating`` (2m,) [F0] the network with the
  smallest total imbalance that respects every cone, ``relaxation`` the extra loads
  (disk, row, amount) that make S non-empty (their L1 total is the smallest). The
  check then goes on at the *least adjusted loads* (``loads = "adjusted"``): the network
  and the boundary forces nearest to the measured ones, jointly (the boundary contacts
  as unknowns too, :func:`extended_problem`), such that the region balances; its
  boundary forces are the loads of the S analysed (``load_adjustment``: rms change per
  load contact, ``distance_joint``: rms over all contacts). ``Measured(adjust_loads=
  True)`` does so always.

Loads that no network can balance by more than ``config.LOAD_ROUND_OFF`` <Fn> (A x = b
inconsistent) are taken as measured (S then empty), not projected away as the
engine's round-off is.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp

from .. import config
from ..errors import InputError, NumericalError
from ..model.problem import StaticsProblem
from ..result import Computed
from .force_space import ForceSpace
from .questions import check_feasible
from .projection import qp_project, weighted_problem
from .lp import unit_problem

RATTLERS = ("a disk with no force-bearing contact carries no load (a rattler) and is left "
            "out with all its contacts; where the data leave forces unknown, a disk without "
            "measured load is a rattler when it has fewer than 2 contacts that may carry force "
            "(repeatedly); contacts measured at zero force are unknowns like any other")
UNITS = ("fn, ft, nearest, ranges in the packing's force unit; imbalance (force and torque / "
         "r), coulomb_violation, distance, contact distance in <Fn> (force_scale)")
OPTIONAL = ("nearest", "contact_distance", "distance", "distance_abs", "distance_joint",
            "fn_range", "ft_range", "inside", "least_violating", "relaxation",
            "relaxation_total", "eta", "n_samples", "dim", "bounded")


def measured_problem(problem: StaticsProblem) -> StaticsProblem:
    """``problem`` with its loads as measured: the projection of b onto range(A) that the
    problem builder applies (round-off of jammed packings) is undone where it moved the
    loads by more than ``config.LOAD_ROUND_OFF`` <Fn>."""
    if problem.meta.get("load_inconsistency", 0.0) <= config.LOAD_ROUND_OFF:
        return problem
    return dataclasses.replace(problem, b=np.asarray(problem.meta["b_raw"], float).copy())


class Measured(Computed):
    """A measured network against S (module docstring).

    ``Measured(ranges=True, weighted=False, adjust_loads=False, samples=0, seed=1,
    target_ess=100, progress=False).compute(problem, x=None, sigma=None, known=None,
    load_sigma=None)``: ``sigma`` (m, 2) [F0] the uncertainty of each unknown contact's
    fn, ft (needed by ``weighted``), ``load_sigma`` (L, 2) that of the load contacts
    (default: the median of sigma); ``known`` (m,) bool: the contacts whose force was
    measured (default all).
    """

    def __init__(self, ranges: bool = True, weighted: bool = False, adjust_loads: bool = False,
                 samples: int = 0, seed: int = 1, target_ess: float = 100.0,
                 progress: bool = False):
        self.adjust_loads = bool(adjust_loads)
        if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 0:
            raise InputError("Measured", "samples", "must be an integer >= 0 (0: no sampling)",
                             got=samples)
        self.ranges, self.weighted, self.samples = bool(ranges), bool(weighted), int(samples)
        self.seed, self.target_ess, self.progress = seed, target_ess, bool(progress)
        self.problem: StaticsProblem | None = None
        self.analysed: StaticsProblem | None = None     # the problem whose S was analysed
        self.space: ForceSpace | None = None
        self.ensemble = None

    def compute(self, problem: StaticsProblem, x=None, sigma=None, known=None,
                load_sigma=None) -> "Measured":
        """Check the measured network ``x`` (2m,) [F0] against S of ``problem``."""
        x, known = self._checked(problem, x, known)
        sigma = self._sigma(problem, sigma, known)
        load_sigma = self._load_sigma(problem, load_sigma, sigma[known])
        self._start()
        self.problem, self.x, self.space = problem, x, None
        r = self._results
        prob = measured_problem(problem)
        s = problem.force_scale
        r.update({k: None for k in OPTIONAL})
        r.update(force_scale=s, known=known, load_inconsistency=problem.meta.get(
            "load_inconsistency", 0.0), loads="measured", load_adjustment=0.0,
            **_statics(problem, x, s))
        feasible, _, diag = check_feasible(prob)
        r["feasible"] = feasible
        if not feasible:
            r.update(_empty(prob, diag))
        if feasible and not self.adjust_loads:
            r.update(_nearest(prob, x, sigma, known, self.weighted))
        else:
            try:
                prob, adjusted = _adjusted(prob, x, sigma, known, load_sigma, self.weighted)
            except NumericalError as exc:      # no loads make S non-empty (or unverified)
                r.update(dim=None, bounded=None)
                self._finish(0, f"S is empty and no adjustment of the loads helps ({exc})")
                return self
            r.update(adjusted, loads="adjusted")
        self.analysed = prob
        S = ForceSpace(ranges=self.ranges, progress=self.progress).compute(prob)
        self.space = S
        if not S.success:
            self._finish(2, S.message)
            return self
        r.update(dim=S.dim, bounded=S.bounded)
        if self.ranges and S.fn_range is not None:
            r.update(_ranges(S, x, known, s))
        if self.samples:
            self._sample(prob, S)
        self._finish(0, "checked" if r["loads"] == "measured" else
                     "S at the measured loads is empty: checked against S at the least "
                     "adjusted loads (see relaxation, load_adjustment)")
        return self

    def _checked(self, problem, x, known):
        m = problem.n_contacts
        if m == 0:
            raise InputError(problem.source or "problem", "contacts", "no unknown contact in "
                             "the region: nothing to check (choose a larger region)")
        x = np.asarray(problem.x_jammed if x is None else x, float)
        if x.shape != (2 * m,) or not np.all(np.isfinite(x)):
            raise InputError("Measured", "x", f"must be a finite vector of shape ({2 * m},) [F0]",
                             got=x.shape)
        known = np.ones(m, bool) if known is None else np.asarray(known, bool)
        if known.shape != (m,):
            raise InputError("Measured", "known", f"must have shape ({m},)", got=known.shape)
        return x, known

    def _load_sigma(self, problem, load_sigma, given):
        k = problem.load_contacts.size
        if load_sigma is None:
            med = float(np.median(given)) if given.size else problem.force_scale
            return np.full((k, 2), med)
        load_sigma = np.array(load_sigma, float)
        if load_sigma.shape != (k, 2) or not np.all(np.isfinite(load_sigma)) or np.any(
                load_sigma <= 0):
            raise InputError("Measured", "load_sigma", f"must be finite, > 0, shape ({k}, 2) "
                             "[F0]", got=load_sigma.shape)
        return load_sigma

    def _sigma(self, problem, sigma, known):
        m = problem.n_contacts
        if sigma is None:
            if self.weighted:
                raise InputError("Measured", "sigma", "weighted=True needs the measurement's "
                                 "uncertainty (m, 2) [F0]")
            sigma = np.ones((m, 2)) * problem.force_scale
        sigma = np.array(sigma, float)
        if sigma.shape != (m, 2) or not np.all(np.isfinite(sigma)) or np.any(sigma < 0):
            raise InputError("Measured", "sigma", f"must be finite, >= 0, shape ({m}, 2) [F0]",
                             got=sigma.shape)
        med = float(np.median(sigma[known])) if known.any() else problem.force_scale
        sigma = np.maximum(sigma, config.SIGMA_FLOOR * max(med, 1e-300))
        sigma[~known] = config.UNKNOWN_SIGMA * problem.force_scale
        return sigma

    def _sample(self, prob, S):
        from ..sampling.billiard import BilliardWalk
        if not S.bounded or not S.dim:
            self._results.update(eta=0.0 if S.dim == 0 else None, n_samples=0)
            return
        walk = BilliardWalk(n=self.samples, seed=self.seed, target_ess=self.target_ess,
                            progress=self.progress).compute(prob, analysis=S)
        self.ensemble = walk.ensemble
        d = walk.ensemble.diagnostics
        self._results.update(eta=walk.ensemble.eta, n_samples=walk.ensemble.n_samples,
                             min_ess=d.get("min_ess"), max_rhat=d.get("max_rhat"),
                             sampling_message=walk.message)

    # ---- results -------------------------------------------------------------------
    def _res(name, doc):      # noqa: N805 (a property factory, used in the class body)
        return property(lambda self: self._get(name), doc=doc)

    force_scale = _res("force_scale", "<Fn> [F0]: the unit of every relative answer.")
    imbalance = _res("imbalance", "(n, 3) net x, y force and torque / r of the measured "
                     "network on each region disk (loads included) [<Fn>].")
    imbalance_disks = _res("imbalance_disks", "(n,) packing indices of the region disks.")
    coulomb_violation = _res("coulomb_violation", "(m,) max(0, |ft| - mu fn, -fn) [<Fn>].")
    load_inconsistency = _res("load_inconsistency", "largest load no network can balance "
                              "(A x = b inconsistent) [<Fn>].")
    feasible = _res("feasible", "S is non-empty.")
    dim = _res("dim", "dim S (None when empty).")
    bounded = _res("bounded", "S is bounded (None when empty).")
    nearest = _res("nearest", "(2m,) the admissible network closest to x [F0].")
    distance = _res("distance", "rms distance per measured contact from x to S [<Fn>].")
    distance_abs = _res("distance_abs", "Euclidean distance over the measured contacts [F0].")
    contact_distance = _res("contact_distance", "(m,) |F_measured - F_nearest| per contact "
                            "[<Fn>] (NaN where not measured).")
    fn_range = _res("fn_range", "(m, 2) min, max of fn over S [F0].")
    ft_range = _res("ft_range", "(m, 2) min, max of ft over S [F0].")
    inside = _res("inside", "(m,) the measured fn and ft lie in their ranges over S (to "
                  "config.VARY_TOL <Fn>); False where not measured.")
    loads = _res("loads", '"measured": S at the measured loads was analysed; "adjusted": at '
                 'the least adjusted loads (S at the measured ones empty, or asked for).')
    load_adjustment = _res("load_adjustment", "rms change per load contact of the adjusted "
                           "loads [<Fn>] (0: measured loads).")
    distance_joint = _res("distance_joint", "with adjusted loads: rms distance per contact "
                          "(region and load contacts) of the joint nearest network [<Fn>].")
    least_violating = _res("least_violating", "(2m,) when S is empty: the network with the "
                           "least total imbalance inside every cone [F0].")
    relaxation = _res("relaxation", "when S is empty: the extra loads that make it non-empty "
                      "(list of disk, row, amount [F0]), least in total.")
    relaxation_total = _res("relaxation_total", "when S is empty: the L1 total of the smallest "
                            "relaxation (extra loads) [F0].")
    eta = _res("eta", "the force ambiguity of a uniform sample of S (samples > 0).")
    del _res

    @property
    def domains(self) -> list:
        """Independent domains of indeterminacy of S (ForceSpace.domains)."""
        ok = self.space is not None and self.space.success and self.space.feasible
        return self.space.domains if ok else []

    def summary(self, packing=None) -> dict:
        """A JSON-able report (what ``forcespace check --json`` prints); with ``packing``
        the per-contact rows name its contact indices and bodies."""
        r = self._results or {}
        if not r:
            raise AttributeError("Measured.summary: call compute() first")
        p, s = self.problem, r["force_scale"]
        out = {"region": p.meta.get("region", p.kind), "walls": p.meta.get("walls"),
               "n_region_disks": p.n_interior, "n_unknown_contacts": p.n_contacts,
               "n_measured_contacts": int(r["known"].sum()),
               "n_load_contacts": int(p.load_contacts.size),
               "n_rattlers_excluded": int(p.rattlers.size), "rattler_convention": RATTLERS,
               "force_scale": s, "units": UNITS, "load_inconsistency": r["load_inconsistency"],
               "imbalance_max": float(np.abs(r["imbalance"]).max(initial=0.0)),
               "imbalance_rms": float(np.sqrt(np.mean(r["imbalance"] ** 2)))
               if r["imbalance"].size else 0.0,
               "n_coulomb_violations": int((r["coulomb_violation"] > 0).sum()),
               "coulomb_violation_max": float(r["coulomb_violation"].max(initial=0.0)),
               **{k: r.get(k) for k in ("feasible", "relaxation_total", "loads",
                                         "load_adjustment",
                                         "distance_joint", "dim", "bounded", "distance",
                                         "distance_abs", "eta", "n_samples", "min_ess",
                                         "max_rhat")}}
        if r["inside"] is not None:
            out["fraction_inside_ranges"] = float(r["inside"][r["known"]].mean()) \
                if r["known"].any() else None
        if self.space is not None and self.space.success and r.get("dim") is not None:
            doms = self.domains
            out.update(n_domains=len(doms), domain_dims=[g.dim for g in doms])
        if r["feasible"] is False:
            out.update(relaxation=r["relaxation"], infeasibility=r["infeasibility"])
        out["disks"] = [{"disk": int(d), "fx": v[0], "fy": v[1], "torque_over_r": v[2]}
                        for d, v in zip(r["imbalance_disks"], r["imbalance"].tolist())]
        out["contacts"] = self._contact_rows(packing)
        return out

    def _contact_rows(self, packing) -> list:
        r, p = self._results, self.problem
        x = self.x
        key = "nearest" if r["nearest"] is not None else "least_violating"
        net = r[key]
        rows = []
        for j in range(p.n_contacts):
            k = int(p.contacts[j])
            row = {"contact": k, "measured": bool(r["known"][j]),
                   "fn": float(x[2 * j]), "ft": float(x[2 * j + 1]),
                   "coulomb_violation": float(r["coulomb_violation"][j])}
            if packing is not None:
                row.update(a=int(packing.a[k]), b=int(packing.b[k]))
            if net is not None:
                row.update({f"fn_{key}": float(net[2 * j]), f"ft_{key}": float(net[2 * j + 1])})
            if r["contact_distance"] is not None:
                row["distance"] = float(r["contact_distance"][j])
            if r["fn_range"] is not None:
                row.update(fn_min=float(r["fn_range"][j, 0]), fn_max=float(r["fn_range"][j, 1]),
                           ft_min=float(r["ft_range"][j, 0]), ft_max=float(r["ft_range"][j, 1]),
                           inside=bool(r["inside"][j]))
            rows.append(row)
        return rows

    def __repr__(self) -> str:
        if not self.computed:
            return f"Measured(ranges={self.ranges}, weighted={self.weighted})"
        r = self._results
        return (f"Measured: {self.problem.n_contacts} contacts, feasible={r.get('feasible')}, "
                f"dim={r.get('dim')}, distance={r.get('distance')}")


def _statics(problem: StaticsProblem, x, s) -> dict:
    """Imbalance per region disk and Coulomb violation per contact of x, in <Fn>."""
    b_raw = np.asarray(problem.meta.get("b_raw", problem.b), float)
    n = problem.n_interior
    res = (problem.A @ x - b_raw)[:3 * n].reshape(n, 3) / s
    fn, ft = x[0::2], x[1::2]
    viol = np.maximum.reduce([np.abs(ft) - problem.mu * fn, -fn, np.zeros_like(fn)]) / s
    viol[viol <= config.MEASURED_VIOLATION] = 0.0
    return {"imbalance": res, "imbalance_disks": problem.disks.copy(),
            "coulomb_violation": viol}


def _nearest(prob: StaticsProblem, x, sigma, known, weighted) -> dict:
    """The nearest admissible network and the distances (module docstring)."""
    s = prob.force_scale
    P, scale = unit_problem(prob)
    if weighted or not known.all():
        kn, kt = (sigma[:, 0] / s) ** 2, (sigma[:, 1] / s) ** 2
        Pw, d = weighted_problem(P, kn, kt)
        near = d * qp_project(Pw, x / scale / d).nearest * scale
    else:
        near = qp_project(P, x / scale).nearest * scale
    return _nearest_parts(x, near, known, s)


def _nearest_parts(x, near, known, s) -> dict:
    """nearest, contact_distance (m,) [<Fn>], distance_abs [F0], distance (rms per
    measured contact) [<Fn>]."""
    diff = (x - near).reshape(-1, 2)
    per = np.hypot(diff[:, 0], diff[:, 1]) / s
    per[~known] = np.nan
    k = int(known.sum())
    absolute = float(np.sqrt(np.nansum(per ** 2)) * s)
    return {"nearest": near, "contact_distance": per, "distance_abs": absolute,
            "distance": absolute / (s * np.sqrt(max(k, 1)))}


def extended_problem(problem: StaticsProblem) -> StaticsProblem:
    """``problem`` with its load contacts as unknowns too (their friction ``load_mu``; the
    disks beyond them are not balanced): S of the region's networks under free boundary
    forces. Columns: the problem's 2m, then 2L of the load contacts (problem order of
    ``load_contacts``)."""
    meta = problem.meta
    x_l = np.asarray(meta["load_x"], float)
    return dataclasses.replace(
        problem, kind=problem.kind + "+loads", A=sp.hstack([problem.A, meta["load_A"]]).tocsr(),
        b=np.asarray(meta["b_body"], float).copy(),
        mu=np.concatenate([problem.mu, meta["load_mu"]]),
        contacts=np.concatenate([problem.contacts, problem.load_contacts]),
        load_contacts=np.zeros(0, np.int64), x_jammed=np.concatenate([problem.x_jammed, x_l]),
        meta=dict(meta, b_raw=np.asarray(meta["b_body"], float), load_inconsistency=0.0))


def _adjusted(prob: StaticsProblem, x, sigma, known, load_sigma, weighted):
    """(the problem at the least adjusted loads, results): the network and the boundary
    forces nearest to the measured ones (jointly, in the measurement's metric when
    ``weighted``) such that the region balances; its loads fix S."""
    ext = extended_problem(prob)
    m2 = prob.n_columns
    x_ext = np.concatenate([x, ext.x_jammed[m2:]])
    res = _nearest(ext, x_ext, np.vstack([sigma, load_sigma]),
                   np.concatenate([known, np.ones(prob.load_contacts.size, bool)]), weighted)
    near = res["nearest"]
    loads = near[m2:]
    b = np.asarray(prob.meta["b_body"], float) - prob.meta["load_A"] @ loads
    adj = dataclasses.replace(prob, b=b, meta=dict(prob.meta, b_raw=b, load_x=loads,
                                                   load_inconsistency=0.0))
    s = prob.force_scale
    d_load = (ext.x_jammed[m2:] - loads).reshape(-1, 2)
    dist = _nearest_parts(x, near[:m2], known, s)
    return adj, {**dist, "distance_joint": res["distance"],
                 "load_adjustment": float(np.sqrt(np.mean(np.sum(d_load ** 2, axis=1))) / s)
                 if d_load.size else 0.0, "adjusted_load_x": loads}


def _ranges(S: ForceSpace, x, known, s) -> dict:
    tol = config.VARY_TOL * s
    fn, ft = x[0::2], x[1::2]
    inside = ((fn >= S.fn_range[:, 0] - tol) & (fn <= S.fn_range[:, 1] + tol)
              & (ft >= S.ft_range[:, 0] - tol) & (ft <= S.ft_range[:, 1] + tol) & known)
    return {"fn_range": S.fn_range, "ft_range": S.ft_range, "inside": inside}


def _empty(prob: StaticsProblem, diag) -> dict:
    """The least-violating network and the smallest relaxation of an empty S."""
    rows = ("fx", "fy", "torque/r")
    extra = np.asarray(diag["relaxation"], float)
    relax = [{"disk": int(prob.disks[i // 3]), "row": rows[i % 3], "extra_load": float(extra[i])}
             for i in np.flatnonzero(np.abs(extra) > config.IMPLICIT_TOL * prob.force_scale)]
    relax.sort(key=lambda v: -abs(v["extra_load"]))
    return {"least_violating": np.asarray(diag["least_violating"], float),
            "relaxation": relax, "relaxation_total": float(diag["min_total_imbalance"]),
            "infeasibility": {k: v for k, v in diag.items()
                              if k not in ("least_violating", "relaxation")}}


__all__ = ["Measured", "measured_problem", "extended_problem"]
