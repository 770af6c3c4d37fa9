"""S as a compute object: the exact analysis of the force ensemble of a statics problem.

S = {x : A x = b, x_fixed = 0, G x <= 0} (columns and rows: :mod:`forcespace.model.problem`).
The questions (:mod:`forcespace.space.questions`, LPs on the problem scaled to <Fn> = 1)
are asked in order by :func:`_analyze`, and reported in F0. Tolerances are relative to <Fn>
(``problem.force_scale``, the mean jammed normal force over the unknown contacts):
an inequality is "tight everywhere" (an implicit equality) when no point of S has
slack larger than ``tol`` <Fn> (``config.IMPLICIT_TOL``).

>>> S = ForceSpace().compute(problem)
>>> S.dim, S.bounded, S.centre.shape, len(S.domains)
"""
from __future__ import annotations

import time

import numpy as np

from .. import config
from ..errors import InputError, NumericalError, require_array
from ..linalg import affine_hull, rank
from ..model.problem import StaticsProblem, checked_problem
from ..model.sphere_problem import SphereStaticsProblem
from ..progress import progress as progress_bar
from ..result import Computed
from .conic import CONE_FACE_TOL, analyze_conic, nearest_admissible
from .lp import eq_system, unit_problem
from .questions import (RangeCertificate, centre_and_radius, column_ranges,
                        feasibility, implicit_kinds, interior_max_sum_fn, interior_strict_rows,
                        tight_rows, scaled_diagnosis, varying_contacts)
from .questions import boundedness as check_recession

_SCALED = ("fn_range", "ft_range", "centre", "affine_point", "radius", "max_sum_fn")
RANGE_CERTIFICATE_CONVENTION = (
    "lps: range LPs; an answer its multipliers do not prove to within config.RANGE_GAP_TOL "
    "<Fn> on S is asked again (retried) in the 2m forces: simplex, interior point, dual "
    "simplex without presolve; confirmed: not proven, but two methods agree within "
    "RANGE_GAP_TOL; uncertified: neither, the most extreme point of S found is reported; "
    "max_gap [<Fn>]: largest gap of a proven answer; exact / polished / not_polished: "
    "warm-started hull LPs whose basis was optimal to round-off / was pivoted to the exact "
    "optimum / stayed as HiGHS left it (within its 1e-10 tolerances); null: S unbounded, "
    "nothing checked")


class ForceSpace(Computed):
    """The set S of admissible force networks of a statics problem, analysed exactly.

    ``ForceSpace(ranges=False, centre=True, tol=config.IMPLICIT_TOL).compute(problem)``
    runs the LPs: feasibility, boundedness, implicit equalities (contacts forced to
    slide or to carry nothing), the affine hull and dimension, the Chebyshev centre
    (``centre``) and, with ``ranges``, the min and max of every force (4 LPs per
    contact). Vectors are in problem column order: x[2j] = fn, x[2j+1] = ft of
    unknown contact j [F0]. Arrays indexed by problem contact j unless stated.
    An LP that fails ends ``compute`` with ``success = False`` (``message`` says
    which); results it did not reach then raise AttributeError.

    A sphere problem (:class:`~forcespace.model.sphere_problem.SphereStaticsProblem`;
    x[3j:3j+3] = fn, f1, f2) is answered by SOCPs (:func:`forcespace.space.conic.analyze_conic`):
    the same results, the implicit equalities being the cones' faces (:attr:`faces`; a
    contact on one ray of its cone or at its apex), ``ft_range`` the range of |f_t|,
    ``centre``/``radius`` a certified inscribed ball; ``domains``, ``varying`` and
    ``implicit_rows`` are for disks only (a one-line InputError, or None).

    ``boundedness=False`` (disks; only with ``ranges``, ``centre`` and ``varying`` off)
    skips the boundedness LP: ``bounded`` and ``max_sum_fn`` are then None (not decided).
    The billiard walk's frame asks for it on the large path, where its rounding proves S
    bounded (:func:`forcespace.sampling.rounding.lewis_rounding`) and the LP was 4.5 of
    the 13 CPU s of the dim-1714 slice's analysis.
    """

    def __init__(self, ranges: bool = False, centre: bool = True,
                 tol: float = config.IMPLICIT_TOL, progress: bool = False,
                 varying: bool = True, boundedness: bool = True):
        self.ranges, self.centre_ball, self.tol = bool(ranges), bool(centre), float(tol)
        self.varying_test = bool(varying)
        self.boundedness = bool(boundedness)
        if not self.boundedness and (self.ranges or self.centre_ball or self.varying_test):
            raise InputError("ForceSpace", "boundedness", "may be False only with ranges, "
                             "centre and varying False (they need S bounded)", got=False)
        self.progress = bool(progress)
        self.problem: StaticsProblem | None = None
        self._domains = None

    def compute(self, problem: StaticsProblem) -> "ForceSpace":
        """Analyse S of ``problem`` (:class:`~forcespace.model.problem.StaticsProblem`)."""
        conic = isinstance(problem, SphereStaticsProblem)
        problem = problem.check("ForceSpace") if conic else checked_problem(problem,
                                                                             "ForceSpace")
        if problem.n_contacts == 0:
            raise InputError(problem.source or "problem", "contacts",
                             "no unknown contact in the problem")
        self._start()
        self.problem, self._domains = problem, None
        if conic:       # spheres: S has curved faces, its questions are SOCPs
            P, s = problem.scaled(1.0 / problem.force_scale), problem.force_scale
            analyze = analyze_conic
        else:
            (P, s), analyze = unit_problem(problem), _analyze
        r = self._results
        r["force_scale"] = s
        with progress_bar(total=100, desc="analysis of S", unit="%",
                          disable=not self.progress) as bar:
            done, cpu = [], r.setdefault("stage_cpu_s", {})
            clock = [time.process_time(), "set-up"]

            def stage(name=None):
                now = time.process_time()
                cpu[clock[1]] = cpu.get(clock[1], 0.0) + now - clock[0]
                clock[:] = [now, name]
                if name is None:
                    return
                bar.update(round(100 * sum(STAGES[n] for n in done)) - bar.n)
                bar.set_postfix_str(name)
                done.append(name)
            try:
                analyze(P, r, ranges=self.ranges, centre=self.centre_ball,
                        tol=max(self.tol, CONE_FACE_TOL) if conic else self.tol, stage=stage,
                        **({} if conic else {"varying": self.varying_test,
                                             "boundedness": self.boundedness}))
            except NumericalError as exc:
                stage()
                self._finish(2, str(exc))
            else:
                stage()
                self._finish(0, "analysis complete")
                bar.update(100 - bar.n)
        for name in _SCALED:
            if r.get(name) is not None:
                r[name] = r[name] * s
        r["infeasibility"] = scaled_diagnosis(r.get("infeasibility"), s)
        return self

    # ---- results ---------------------------------------------------------------
    @property
    def feasible(self) -> bool:
        """S is non-empty."""
        return self._get("feasible")

    @property
    def bounded(self) -> bool | None:
        """S is bounded (False: a wedged geometry admits arbitrarily large forces; None
        when S is empty)."""
        return self._get("bounded")

    @property
    def dim(self) -> int | None:
        """Dimension of S (0: the network is determined by the statics; None when S is
        empty)."""
        return self._get("dim")

    @property
    def n_interior(self) -> int:
        """Interior (non-rattler) disks of the problem."""
        return self.problem.n_interior

    @property
    def n_contacts(self) -> int:
        """Unknown contacts m."""
        return self.problem.n_contacts

    @property
    def n_unknowns(self) -> int:
        """Free columns: 2m minus the ft of frictionless contacts (fixed at 0)."""
        return self._get("n_unknowns")

    @property
    def rank_A(self) -> int:
        """Rank of the equilibrium matrix A over the unknown columns."""
        return self._get("rank_A")

    @property
    def full_row_rank(self) -> bool:
        """A has full row rank (every disk's three balance rows independent)."""
        return self._get("full_row_rank")

    @property
    def degree_of_indeterminacy(self) -> int:
        """Unknowns minus the rank of the equilibrium equations (an upper bound of dim)."""
        return self._get("degree_of_indeterminacy")

    @property
    def implicit_rows(self) -> np.ndarray:
        """Rows of ``problem.inequalities()`` tight on all of S (int, (k,))."""
        return self._get("implicit_rows")

    @property
    def implicit(self) -> list:
        """(contact j, kind) of every implicit equality: "slides+" (ft = +mu fn),
        "slides-" (ft = -mu fn) or "zero" (fn = ft = 0); spheres: "ray" (f_t = mu fn
        times one fixed unit vector) or "apex" (fn = f_t = 0)."""
        return self._get("implicit")

    @property
    def sliding_contacts(self) -> np.ndarray:
        """Contacts at the Coulomb limit on all of S (int, sorted)."""
        return self._get("sliding_contacts")

    @property
    def zero_contacts(self) -> np.ndarray:
        """Contacts carrying no force on all of S (int, sorted)."""
        return self._get("zero_contacts")

    @property
    def n_sliding(self) -> int | None:
        """Number of contacts at the Coulomb limit on all of S (None when S is empty)."""
        c = self.sliding_contacts
        return None if c is None else int(c.size)

    @property
    def n_zero(self) -> int | None:
        """Number of contacts carrying no force on all of S (None when S is empty)."""
        c = self.zero_contacts
        return None if c is None else int(c.size)

    @property
    def stage_cpu_s(self) -> dict:
        """CPU seconds (this process) of each stage of the analysis, in order ("set-up":
        before the first, e.g. the rank of A)."""
        return self._get("stage_cpu_s")

    @property
    def fn_range(self) -> np.ndarray | None:
        """(m, 2) min and max of fn over S [F0] (``ranges=True``; else None); an unbounded
        side is +-inf."""
        return self._get("fn_range")

    @property
    def ft_range(self) -> np.ndarray | None:
        """(m, 2) min and max of ft over S [F0] (``ranges=True``; else None); spheres: of
        |f_t| (the max certified by support polygons, :func:`forcespace.space.conic.ft_range`)."""
        return self._get("ft_range")

    @property
    def centre(self) -> np.ndarray | None:
        """Chebyshev centre of S in its affine hull, (2m,) [F0] (None: not asked, or S
        unbounded)."""
        return self._get("centre")

    @property
    def radius(self) -> float | None:
        """Radius of the largest ball in S within its affine hull [F0] (spheres: of the
        largest ball the per-cone bounds certify, :func:`forcespace.space.conic.conic_centre`;
        at most the largest inscribed one)."""
        return self._get("radius")

    @property
    def faces(self):
        """Spheres: the face of every contact's cone that S spans
        (:class:`forcespace.space.conic.Faces`; None for disks or an empty S)."""
        return self._results.get("faces") if self._results is not None else self._get("faces")

    @property
    def max_sum_fn(self) -> float:
        """Largest total normal force over S [F0] (inf when S is unbounded)."""
        return self._get("max_sum_fn")

    @property
    def recession_direction(self) -> np.ndarray | None:
        """(2m,) a direction along which S is unbounded (max |entry| = 1), else None."""
        return self._get("recession_direction")

    @property
    def infeasibility(self) -> dict | None:
        """Why S is empty: the disks that need the smallest extra loads [F0], else None."""
        return self._get("infeasibility")

    @property
    def affine_point(self) -> np.ndarray:
        """A point of S, (2m,) [F0]; S lies in affine_point + affine_basis @ y."""
        return self._get("affine_point")

    @property
    def affine_basis(self) -> np.ndarray:
        """Orthonormal basis (2m, dim) of the directions of S."""
        return self._get("affine_basis")

    @property
    def varying(self) -> np.ndarray:
        """(m,) bool: the contact's force can change by more than ``config.VARY_TOL``
        <Fn> within S (decided on forces: bounds from the ball and the diameter of S,
        LPs where they do not decide). Not computed by ``ForceSpace(varying=False)``
        (the samplers' frame: it needs no per-contact LP)."""
        if not self.varying_test and self.computed:
            raise AttributeError("ForceSpace.varying: not computed (ForceSpace(varying=False))")
        return self._get("varying")

    @property
    def varying_contacts(self) -> np.ndarray:
        """Problem contact indices whose force can change within S (none if S is empty)."""
        v = self.varying
        return np.zeros(0, np.int64) if v is None else np.flatnonzero(v)

    @property
    def force_scale(self) -> float:
        """<Fn> of the problem [F0]: the unit of every tolerance."""
        return self._get("force_scale")

    @property
    def domains(self) -> list:
        """Independent domains of indeterminacy (:class:`forcespace.space.structure.Domain`);
        the elementary clusters are the domains of dimension 1."""
        if self.problem.dim == 3:
            raise InputError("ForceSpace.domains", "problem", "domains of indeterminacy are "
                             "found for disks only so far (S of spheres has curved faces)",
                             got="SphereStaticsProblem")
        if self._domains is None:
            from .structure import domains
            self._domains = domains(self.problem, self) if self.feasible and self.dim else []
        return self._domains

    # ---- questions -------------------------------------------------------------
    def contains(self, x, tol: float = config.SAMPLE_VIOLATION) -> bool:
        """Whether x (2m,) [F0] is in S up to ``tol`` <Fn>."""
        x = require_array("ForceSpace.contains", "x", x, (self.problem.n_columns,),
                          "a network of the problem [F0]")
        return self.problem.violation(x) <= tol

    def distance(self, x):
        """Exact Euclidean distance from x (2m,) [F0] to S
        (:class:`forcespace.space.projection.DistanceResult`)."""
        from .projection import distance_to_S
        if not self.feasible:
            raise InputError("distance", "S", "is empty (infeasible); no distance")
        if self.problem.dim == 3:
            return conic_distance(self.problem, x)
        return distance_to_S(self.problem, x)

    def summary(self) -> dict:
        """The analysis as a JSON-able dict (what ``forcespace analyze`` prints)."""
        r = self._results or {}
        d = {"feasible": r.get("feasible"), "bounded": r.get("bounded"),
             "n_interior": self.problem.n_interior, "n_contacts": self.problem.n_contacts,
             "n_unknowns": r.get("n_unknowns"), "rank_A": r.get("rank_A"),
             "full_row_rank": r.get("full_row_rank"),
             "degree_of_indeterminacy": r.get("degree_of_indeterminacy"),
             "dim_S": r.get("dim"),
             "n_sliding": None if r.get("sliding_contacts") is None else self.n_sliding,
             "n_zero_force": None if r.get("zero_contacts") is None else self.n_zero,
             "max_sum_fn": r.get("max_sum_fn"), "force_scale": r.get("force_scale"),
             "centre_radius": r.get("radius")}
        if r.get("fn_range") is not None and self.problem.dim != 3:     # LP ranges: disks
            d["range_certificate"] = None if r.get("range_certificate") is None else dict(
                r["range_certificate"], convention=RANGE_CERTIFICATE_CONVENTION)
        if r.get("infeasibility") is not None:
            d["infeasibility"] = {k: v for k, v in r["infeasibility"].items()
                                  if k not in ("least_violating", "relaxation")}
        rd = r.get("recession_direction")
        if rd is not None:
            d["recession_direction_support"] = int((np.abs(rd) > config.RECESSION_SUPPORT_TOL * np.abs(rd).max()).sum())
        if self.problem.dim == 3 and r.get("feasible"):
            pk = self.problem.contacts
            d.update({"dimension": 3, "n_on_a_ray": int(r["sliding_contacts"].size),
                      "n_at_the_apex": int(r["zero_contacts"].size),
                      "contacts_on_a_ray": pk[r["sliding_contacts"]].tolist(),
                      "contacts_at_the_apex": pk[r["zero_contacts"]].tolist(),
                      "faces_convention": FACES_CONVENTION})
        elif r.get("feasible") and r.get("dim") is not None and not self._status \
                and self.varying_test:      # domains need the varying contacts
            doms = self.domains
            d.update({"n_domains": len(doms), "domain_dims": [g.dim for g in doms],
                      # a domain of dimension 1 is one elementary cluster that shares no
                      # contact with another; elementary clusters inside larger domains
                      # are counted by the cluster decomposition (analyze --clusters)
                      "n_domains_of_dim_1": int(sum(g.elementary for g in doms)),
                      "n_varying_contacts": int(self.varying_contacts.size),
                      # directions of S along which no contact force changes by more
                      # than config.VARY_TOL <Fn>
                      "n_thin_directions": int(r["dim"]) - sum(g.dim for g in doms)})
        if self._status:
            d["analysis_failed"] = self._message
        d["units"] = {"max_sum_fn": "F0", "centre_radius": "F0 (radius of the largest ball "
                      "in S within its affine hull)", "force_scale": "F0 (<Fn>: the jammed "
                      "mean normal force of the problem's contacts)",
                      "range_certificate.max_gap": "<Fn>"}
        return d

    def plot(self, packing, ax=None, **kw):
        """The packing with the disks of each domain of indeterminacy outlined; returns
        the Axes."""
        from ..plot import plot_packing
        kw.setdefault("title", f"S: dim {self.dim}, {len(self.domains)} domain(s)")
        return plot_packing(packing, ax, highlight=[g.disks for g in self.domains], **kw)

    def __repr__(self) -> str:
        args = f"ranges={self.ranges}, centre={self.centre_ball}"
        if not self.computed:
            return f"ForceSpace({args})"
        r = self._results
        return (f"ForceSpace({args}): {self.problem.kind}, {self.problem.n_contacts} contacts, "
                f"feasible={r.get('feasible')}, bounded={r.get('bounded')}, dim={r.get('dim')}")


FACES_CONVENTION = (
    "spheres: a contact whose Coulomb cone S enters only on one ray (it slides in one fixed "
    "direction on all of S: n_on_a_ray, counted in n_sliding) or only at its apex (it "
    "carries nothing on all of S: n_at_the_apex, counted in n_zero_force); each gives linear "
    "equalities of S's affine hull, 2 and 3; contacts_on_a_ray, contacts_at_the_apex: their "
    "packing contact indices")


def conic_distance(problem: SphereStaticsProblem, x):
    """Euclidean distance from x (3m,) [F0] to S of spheres and the nearest point, by
    Clarabel's SOCP (:func:`forcespace.space.conic.nearest_admissible`): a
    :class:`~forcespace.space.projection.DistanceResult` (kkt_residual NaN: the
    interior-point solver's own optimality, to ``SOLVER_TOLERANCE``, stands for it; its
    nearest point is accurate to ~1e-5 <Fn> where it lies on a cone's boundary). A point
    in S to ``config.SAMPLE_VIOLATION`` is its own nearest point."""
    from .projection import DistanceResult
    x = require_array("distance", "x", x, (problem.n_columns,), "a network of the problem "
                      "(fn, f1, f2 per contact) [F0]")
    if problem.violation(x) <= config.SAMPLE_VIOLATION:       # in S already: itself
        return DistanceResult(0.0, 0.0, x.copy(), problem.violation(x), 0.0, "in S")
    res = nearest_admissible(problem, target=x)
    if not res.feasible:
        raise NumericalError(f"nearest point of S: Clarabel status {res.status}")
    dist = float(np.linalg.norm(res.x - x))
    return DistanceResult(dist, dist / (problem.force_scale * np.sqrt(problem.n_contacts)),
                          res.x, res.violation, float("nan"), "clarabel socp")


# the stages of an analysis and their share of its time (5000-disk slice, CPU), for the
# progress bar's estimate
STAGES = {"feasibility and implicit equalities": 0.45, "boundedness": 0.15,
          "affine hull": 0.1, "centre": 0.25, "ranges": 0.0, "varying contacts": 0.05}


def _analyze(problem: StaticsProblem, out: dict, ranges: bool, centre: bool, tol: float,
             stage=lambda name: None, varying: bool = True, boundedness: bool = True):
    """Fill ``out`` with the analysis of S of ``problem`` (at <Fn> = 1), in order:
    feasibility, boundedness (unless ``boundedness`` is False: ``bounded`` stays None),
    implicit equalities, affine hull, ranges, centre,
    varying contacts (unless ``varying`` is False: the samplers' frame needs none of its
    LPs, most of a small slice's analysis); ``stage(name)`` is called as each begins.
    Large problems (``config.SWEEP_MIN_COLUMNS`` columns and up) decide the strict rows,
    the largest total force and the centre by interior-point LPs without crossover (one each),
    then confirm the undecided rows by the exact test. An LP failure raises
    NumericalError with ``out`` holding what was reached."""
    m2 = problem.n_columns
    fixed = problem.fixed_columns()
    free_cols = np.setdiff1d(np.arange(m2), fixed)
    out["n_unknowns"] = m2 - fixed.size
    large = m2 >= config.SWEEP_MIN_COLUMNS

    def set_rank(rank_A):
        # rank over the unknowns (not ft of mu=0 contacts). [A; fixed] is block
        # triangular in (free, fixed) columns with an identity on the fixed ones:
        # its rank is n_fixed + rank_A (no SVD of its own)
        out["rank_A"], out["full_row_rank"] = rank_A, rank_A == problem.A.shape[0]
        out["degree_of_indeterminacy"] = m2 - (fixed.size + rank_A)

    out.update(bounded=None, dim=None, infeasibility=None, recession_direction=None,
               fn_range=None, ft_range=None, centre=None, radius=None, max_sum_fn=None,
               implicit_rows=None, implicit=[], sliding_contacts=None, zero_contacts=None,
               affine_point=None, affine_basis=None, varying=None, range_certificate=None)
    stage("feasibility and implicit equalities")
    interior = interior_strict_rows(problem) if large else None
    if interior is not None:
        (x0, strict), feas = interior, True
    else:
        feas, x0, diag = feasibility(problem)
        strict = None
    out["feasible"] = feas
    if not feas:
        set_rank(rank(problem.A[:, free_cols]))
        out["infeasibility"] = diag
        return
    G, owner, kind = problem.inequalities()
    imp = tight_rows(problem, tol, None if strict is None else ~strict)
    out["implicit_rows"] = imp
    bounded = msum = None
    if boundedness:
        stage("boundedness")
        msum = interior_max_sum_fn(problem) if large else None
        bounded, msum, rdir = (True, msum, None) if msum is not None else \
            check_recession(problem)
        out.update(bounded=bounded, max_sum_fn=msum, recession_direction=rdir)
    stage("affine hull")
    Eq, rhs = eq_system(problem, G[imp])
    # one point of S and the affine hull: x0 projected onto the hull (removes LP
    # round-off along the equalities), from the same SVD as the hull's basis
    N, xa, rank_eq = affine_hull(Eq, rhs, x0)
    out["dim"] = int(N.shape[1])
    # without fixed columns and implicit rows Eq is A itself: same SVD, same rank
    set_rank(rank_eq if imp.size == 0 and fixed.size == 0 else rank(problem.A[:, free_cols]))
    out["affine_point"], out["affine_basis"] = xa, N
    out["implicit"], out["sliding_contacts"], out["zero_contacts"] = \
        implicit_kinds(imp, owner, kind)
    # every range LP's answer is checked by its multipliers (needs S's diameter bound:
    # the ranges of an unbounded S are not checked)
    cert = RangeCertificate(problem, N, xa, msum) if bounded and msum is not None else None
    if ranges:                  # an unbounded side of a range is +-inf
        stage("ranges")
        out["fn_range"], out["ft_range"] = column_ranges(problem, N, xa, cert=cert)
    if bounded and centre:
        stage("centre")
        out["centre"], out["radius"] = centre_and_radius(problem, N, imp, interior=large)
    if not varying:
        return
    stage("varying contacts")
    rngs = (out["fn_range"], out["ft_range"]) if out["fn_range"] is not None else None
    out["varying"] = varying_contacts(problem, N, msum, out["radius"] or 0.0, rngs,
                                      points=(xa, out["centre"]), cert=cert)
    out["range_certificate"] = None if cert is None else dict(cert.stats)


