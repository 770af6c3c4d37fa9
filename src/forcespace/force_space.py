"""S as a compute object: exact analysis of the force ensemble of a statics problem.

In the style of freud's compute objects: parameters in the constructor,
``compute()`` returns self, results are read-only properties (shapes and units
below), ``plot(packing, ax)`` draws on the caller's Axes.

>>> S = ForceSpace(problem).compute()
>>> S.dim, S.bounded, S.centre.shape, len(S.domains)
"""
from __future__ import annotations

import numpy as np

from .errors import InputError
from .polytope import PolytopeAnalysis, analyze, distance_to_S
from .statics import StaticsProblem


class ForceSpace:
    """The set S of admissible force networks of ``problem`` (equilibrium + Coulomb).

    ``compute(ranges=True)`` runs the LPs (feasibility, boundedness, implicit
    equalities, dimension, Chebyshev centre and, with ``ranges``, min/max of
    every force). Vectors are in problem column order: x[2j] = fn, x[2j+1] = ft
    of unknown contact j [F0].
    """

    def __init__(self, problem: StaticsProblem):
        self.problem = problem
        self._an: PolytopeAnalysis | None = None
        self._domains = None

    def compute(self, ranges: bool = True) -> "ForceSpace":
        self._an = analyze(self.problem, ranges=ranges, centre=True)
        self._domains = None
        return self

    # ---- results -------------------------------------------------------------
    @property
    def analysis(self) -> PolytopeAnalysis:
        """Everything the LPs found (:class:`forcespace.polytope.PolytopeAnalysis`)."""
        if self._an is None:
            raise InputError("ForceSpace", "compute()", "must be called before reading results")
        return self._an

    @property
    def feasible(self) -> bool:
        """S is non-empty."""
        return self.analysis.feasible

    @property
    def bounded(self) -> bool | None:
        """S is bounded (False: a wedged geometry admits arbitrarily large forces)."""
        return self.analysis.bounded

    @property
    def dim(self) -> int | None:
        """Dimension of S (0: the network is determined by the statics)."""
        return self.analysis.dim_S

    @property
    def degree_of_indeterminacy(self) -> int:
        """Unknowns minus the rank of the equilibrium equations."""
        return self.analysis.degree_of_indeterminacy

    @property
    def centre(self) -> np.ndarray | None:
        """Chebyshev centre of S in its affine hull, (2m,) [F0]."""
        return self.analysis.centre

    @property
    def radius(self) -> float | None:
        """Radius of the largest ball in S (within its affine hull) [F0]."""
        return self.analysis.centre_radius

    @property
    def fn_range(self) -> np.ndarray | None:
        """(m, 2) min and max of fn over S [F0] (compute(ranges=True))."""
        return self.analysis.fn_range

    @property
    def ft_range(self) -> np.ndarray | None:
        """(m, 2) min and max of ft over S [F0] (compute(ranges=True))."""
        return self.analysis.ft_range

    @property
    def affine_point(self) -> np.ndarray | None:
        """A point of S, (2m,) [F0]; S lies in affine_point + affine_basis @ y."""
        return self.analysis.affine_point

    @property
    def affine_basis(self) -> np.ndarray | None:
        """Orthonormal basis (2m, dim) of the directions of S."""
        return self.analysis.affine_basis

    @property
    def varying_contacts(self) -> np.ndarray:
        """Problem contact indices whose force can change within S (> 1e-6 <Fn>)."""
        from .measures import varying_contacts
        return varying_contacts(self.analysis)

    @property
    def domains(self) -> list:
        """Independent domains of indeterminacy (:class:`forcespace.measures.Domain`);
        the elementary clusters are the domains of dimension 1."""
        if self._domains is None:
            from .measures import domains
            an = self.analysis
            self._domains = domains(self.problem, an) if an.feasible and an.dim_S else []
        return self._domains

    # ---- questions -----------------------------------------------------------
    def contains(self, x, tol: float = 1e-9) -> bool:
        """Whether x (2m,) [F0] is in S up to ``tol`` <Fn>."""
        return self.problem.violation(x) <= tol

    def distance(self, x):
        """Exact Euclidean distance from x (2m,) [F0] to S
        (:class:`forcespace.polytope.DistanceResult`)."""
        return distance_to_S(self.problem, x, self.analysis)

    def plot(self, packing, ax=None, **kw):
        """The packing with the disks of each domain of indeterminacy outlined."""
        kw.setdefault("title", f"S: dim {self.dim}, {len(self.domains)} domain(s)")
        return packing.plot(ax, highlight=[g.disks for g in self.domains], **kw)

    def __repr__(self) -> str:
        if self._an is None:
            return f"ForceSpace({self.problem.kind}, {self.problem.n_contacts} contacts, not computed)"
        an = self._an
        return (f"ForceSpace({self.problem.kind}, {self.problem.n_contacts} contacts: "
                f"feasible={an.feasible}, bounded={an.bounded}, dim={an.dim_S})")
