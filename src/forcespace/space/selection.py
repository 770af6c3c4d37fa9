"""Which point of S an elastic packing selects: the compatible force network.

Linear contact springs (normal stiffness kn, tangential kt at the contact
point) loaded from a stress-free touching state, without sliding, end in the
force network that minimises the complementary energy

    E(x) = 1/2 sum_j (fn_j^2 / kn_j + ft_j^2 / kt_j)      [F0 R]

over the statically admissible networks: equilibrium A x = b plus elastic
compatibility, which is what the minimum expresses (Castigliano / Menabrea;
cf. Olsen & Kamrin on compatibility conditions in contact dynamics). The KKT
conditions of the minimum over S are

    fn_j / kn_j = n.(u_a - u_b) + mu_j nu_j       (overlap from displacements)
    ft_j / kt_j = -(t.(u_b - u_a) - r_b th_b - r_a th_a) - nu_j s_j

with the disk displacements u and rotations th the multipliers of the
balance rows (:attr:`Selection.displacement`), nu_j >= 0 the multiplier of an
active Coulomb row (ft = s_j mu fn, s_j = +-1) and a contact in tension
opening (fn = ft = 0). So:

* frictionless, or frictional with no Coulomb row active: the selected
  network *is* the linear-elastic (small-displacement) solution, including
  unilateral contacts that open (Signorini) -- exact, not a model;
* a Coulomb row active: the minimum over S is the convex-program stand-in
  for sliding. It is the associated (normality) flow rule, which lets a
  sliding contact also dilate by mu nu; real Coulomb friction is
  non-associated and path dependent (the order of loading decides which
  contacts slide and how far), so with sliding the selection is a prediction
  of the stiff-spring, proportional-loading limit only. ``sliding_contacts``
  names the contacts where that is the case.

Initial misfit (``overlap``): springs that start overlapping by delta0_j
(negative: a gap) -- e.g. a soft code started from the rigid packing, whose
contacts overlap by ~1e-7 R -- add -sum delta0_j fn_j to the energy; the KKT
conditions then read fn_j / kn_j = delta0_j + n.(u_a - u_b) + ..., the linear
solution from that prestressed start (a contact with a gap carries force
only once it closes: Signorini with the gap). Then kn matters in absolute
terms (kn delta0 against the loads).

Without ``overlap`` only the ratios of the stiffnesses matter: multiplying
every kn and kt by c leaves the network unchanged and divides ``energy`` by c. With one kn for
all contacts the network depends on kt/kn alone; per-contact ``kn`` (m,) is
accepted as well.

Method (no dependency beyond scipy): with D = diag(sqrt(kn_j), sqrt(kt_j))
and z = D^-1 x the energy is |z|^2 / 2 and S maps to a polytope of the same
form (columns of A scaled by D, friction mu_j sqrt(kn_j / kt_j)); the
selected network is the Euclidean projection of 0 onto it, computed by
:func:`forcespace.space.projection.distance_to_S`'s verified method (null-space
least-distance programming, then an exact active-set polish whose KKT
conditions are checked). The problem is solved at <Fn> = 1 and scaled back.
Measured against Clarabel (interior point) on the 200-disk paper slice:
see ``studies/bench_select.py`` and ``studies/selection.md``.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp

from .. import config
from ..errors import InputError, NumericalError
from ..model.problem import NO_TENSION, StaticsProblem, checked_problem
from ..result import Computed
from .questions import check_feasible
from .lp import unit_problem
from .projection import project, weighted_problem



def _stiffness(problem: StaticsProblem, kn, kt_ratio, source="select"):
    """(kn (m,), kt (m,)) validated [F0/R]."""
    m = problem.n_contacts
    try:
        r = float(kt_ratio)
    except (TypeError, ValueError):
        raise InputError(source, "kt_ratio", "must be a finite number > 0 (kt/kn)",
                         got=kt_ratio) from None
    if not (np.isfinite(r) and r > 0):
        raise InputError(source, "kt_ratio", "must be a finite number > 0 (kt/kn)", got=kt_ratio)
    k = np.asarray(kn, float)
    if k.ndim == 0:
        k = np.full(m, float(k))
    if k.shape != (m,):
        raise InputError(source, "kn", f"must be a number or an array of shape ({m},)",
                         got=k.shape)
    if not (np.all(np.isfinite(k)) and np.all(k > 0)):
        raise InputError(source, "kn", "must be finite and > 0 [F0/R]")
    return k, r * k


class Selection(Computed):
    """The compatible (minimum complementary energy) network in S of a problem.

    ``Selection(kt_ratio=2/7, kn=1.0, overlap=None).compute(problem)``; kn
    [F0/R] a number or one per unknown contact (m,), kt = kt_ratio * kn;
    overlap (m,) [R] the springs' initial overlaps (module docstring; e.g.
    :func:`packing_overlaps`). Results (problem
    column order, x[2j] = fn, x[2j+1] = ft [F0]):

    x (2m,), fn, ft (m,); energy [F0 R]; sliding_contacts (Coulomb row active,
    fn > 0: where the convex program stands in for path-dependent friction);
    open_contacts (fn = 0: a spring would be in tension); displacement (n, 2)
    [R] and rotation (n,) of the interior disks (the balance-row multipliers,
    minimum norm where the packing has mechanisms); violation (of S, / <Fn>);
    kkt_residual (of the weighted projection, relative); compatibility_residual
    (max |W x - A^T lambda - G_act^T nu| over the contacts, relative to
    max |W x|); method.
    """

    def __init__(self, kt_ratio: float = 2.0 / 7.0, kn=1.0, overlap=None):
        self.kt_ratio = kt_ratio
        self.kn = kn
        self.overlap = overlap
        self.problem: StaticsProblem | None = None

    def compute(self, problem: StaticsProblem) -> "Selection":
        """Select the network in S of ``problem``."""
        problem = checked_problem(problem, "Selection")
        kn, kt = _stiffness(problem, self.kn, self.kt_ratio)
        if problem.n_contacts == 0:
            raise InputError(problem.source or "problem", "contacts", "no unknown contact")
        P, s = unit_problem(problem)
        feas, _, diag = check_feasible(problem)
        if not feas:
            raise InputError(problem.source or "problem", "S",
                             "is empty (no admissible network): nothing to select; "
                             f"smallest total imbalance {diag['relative_to_mean_force']:.3g} <Fn>")
        c = np.zeros(problem.n_columns)           # linear term of the energy: -c.x
        if self.overlap is not None:
            d0 = np.asarray(self.overlap, float)
            if d0.shape != (problem.n_contacts,) or not np.all(np.isfinite(d0)):
                raise InputError("select", "overlap", "must be finite, shape "
                                 f"({problem.n_contacts},) [R] (one per unknown contact)",
                                 got=d0.shape)
            c[0::2] = d0
        Pw, d = weighted_problem(P, kn, kt)
        k0 = float(np.mean(kn))
        r = project(Pw, k0 * d * c / s)
        x = d * r.nearest * s
        x[0::2] = np.maximum(x[0::2], 0.0)      # an open contact's fn is 0, not -1e-31
        viol = problem.violation(x)
        if viol > config.SAMPLE_VIOLATION:
            raise NumericalError(f"selected network violates S by {viol:.2e} <Fn>")
        self._start()
        self.problem = problem
        self._kn, self._kt, self._c = kn, kt, c
        self._results.update(x=x, kkt=r.kkt_residual, violation=viol,
                             method="weighted projection: " + r.method)
        self._results.update(_multipliers(problem, x, kn, kt, c))
        self._finish(0, "selected")
        return self

    # ---- results ---------------------------------------------------------------
    @property
    def x(self) -> np.ndarray:
        """The selected network (2m,) [F0]."""
        return self._get("x")

    @property
    def fn(self) -> np.ndarray:
        return self.x[0::2]

    @property
    def ft(self) -> np.ndarray:
        return self.x[1::2]

    @property
    def energy(self) -> float:
        """Complementary energy 1/2 sum (fn^2/kn + ft^2/kt) - sum overlap fn [F0 R]
        (kn in F0/R, overlap in R)."""
        x = self.x
        return float(0.5 * np.sum(x[0::2] ** 2 / self._kn + x[1::2] ** 2 / self._kt)
                     - self._c @ x)

    @property
    def sliding_contacts(self) -> np.ndarray:
        """Problem contacts at the Coulomb limit with fn > 0 (|ft| = mu fn)."""
        return self._get("sliding")

    @property
    def open_contacts(self) -> np.ndarray:
        """Problem contacts carrying no force (a spring there would be in tension)."""
        return self._get("open")

    @property
    def displacement(self) -> np.ndarray:
        """(n, 2) displacement of each interior disk [R] (minimum norm)."""
        return self._get("displacement")

    @property
    def rotation(self) -> np.ndarray:
        """(n,) rotation of each interior disk [rad], counter-clockwise."""
        return self._get("rotation")

    @property
    def violation(self) -> float:
        return self._get("violation")

    @property
    def kkt_residual(self) -> float:
        return self._get("kkt")

    @property
    def compatibility_residual(self) -> float:
        return self._get("compatibility")

    @property
    def method(self) -> str:
        return self._get("method")

    def to_packing(self, packing):
        """``packing`` (the one the problem was built from) carrying the selected
        forces on the unknown contacts (others keep theirs), with the selection's
        parameters in ``meta`` -- a soft network in the sense of the adapters."""
        fn, ft = self.problem.to_packing_forces(self.x)
        out = packing.with_forces(fn, ft)
        sm = self.summary()
        out.meta = {"code": "forcespace select", "converged": True,
                    "packing_fingerprint": packing.fingerprint,
                    "problem_kind": sm["kind"],
                    "slice_height": float("nan") if sm["slice_height"] is None
                    else float(sm["slice_height"]),
                    "kt_ratio": sm["kt_ratio"],
                    "kn": float(np.mean(self._kn)), "energy": sm["energy"],
                    "initial_overlaps": sm["initial_overlaps"],
                    "n_sliding": sm["n_sliding"], "n_open": sm["n_open"],
                    "violation": sm["violation"], "kkt_residual": sm["kkt_residual"],
                    "compatibility_residual": sm["compatibility_residual"],
                    "mu_override": float("nan") if self.problem.meta.get("mu_override") is None
                    else float(self.problem.meta["mu_override"])}
        return out

    def summary(self) -> dict:
        p = self.problem
        rel = np.linalg.norm(self.x - p.x_jammed) / (p.force_scale * np.sqrt(p.n_contacts))
        return {"kind": p.kind, "slice_height": p.height, "n_contacts": p.n_contacts,
                "kt_ratio": float(self.kt_ratio), "initial_overlaps": self.overlap is not None,
                "energy": self.energy,
                "n_sliding": int(self.sliding_contacts.size),
                "n_open": int(self.open_contacts.size),
                "violation": self.violation, "kkt_residual": self.kkt_residual,
                "compatibility_residual": self.compatibility_residual,
                "distance_from_jammed": float(rel), "force_scale": p.force_scale,
                "method": self.method}

    def __repr__(self) -> str:
        if not self.computed:
            return f"Selection(kt_ratio={self.kt_ratio:g}, not computed)"
        return (f"Selection(kt_ratio={self.kt_ratio:g}: energy={self.energy:.4g}, "
                f"{self.sliding_contacts.size} sliding, {self.open_contacts.size} open)")


def _multipliers(problem: StaticsProblem, x, kn, kt, c) -> dict:
    """Contact classes and the displacement field behind a selected network x."""
    G, owner, kind = problem.inequalities()
    s = problem.force_scale
    gx = G @ x
    fn = x[0::2]
    act = np.flatnonzero(gx > -config.SLIDE_TOL * s)
    open_ = np.flatnonzero(fn <= config.SLIDE_TOL * s)
    sliding = np.setdiff1d(np.unique(owner[act[kind[act] != NO_TENSION]]), open_)
    # stationarity W x = A^T lam - G_act^T nu (+ fixed columns): least squares
    w = np.empty_like(x)
    w[0::2] = fn / kn
    w[1::2] = x[1::2] / kt
    w -= c
    fixed = problem.fixed_columns()
    w[fixed] = 0.0
    m2 = problem.n_columns
    E = sp.csr_matrix((np.ones(fixed.size), (np.arange(fixed.size), fixed)),
                      shape=(fixed.size, m2))
    B = sp.vstack([problem.A, -G[act], E]).T.toarray()
    y = np.linalg.lstsq(B, w, rcond=None)[0]
    comp = float(np.abs(B @ y - w).max(initial=0.0) / max(np.abs(w).max(initial=0.0), 1e-300))
    n = problem.n_interior
    lam = y[:3 * n]
    disp = -np.column_stack([lam[0::3], lam[1::3]])
    rot = -lam[2::3] / problem.radius
    return {"sliding": sliding.astype(np.int64), "open": open_.astype(np.int64),
            "displacement": disp, "rotation": rot, "compatibility": comp}


def packing_overlaps(packing, problem: StaticsProblem) -> np.ndarray:
    """Initial overlap (m,) [R] of every unknown contact in ``packing`` (-gap)."""
    return -np.asarray(packing.gap, float)[problem.contacts]


__all__ = ["Selection", "weighted_problem", "packing_overlaps"]
