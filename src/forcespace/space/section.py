"""Two-dimensional cross-sections of S (the inset of the paper's Fig. 3).

The plane through a network x0 of S (default the jammed state) spanned by two
orthonormal directions d1, d2 of S's affine hull: x(s, t) = x0 + s d1 + t d2
[F0]. Equilibrium holds on the whole plane; a point is in S when no Coulomb
(or fn >= 0) inequality is violated. :class:`Section` samples the plane on a
grid and returns the violation, in units of <Fn>, at every node.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import linprog

from .. import config
from ..errors import InputError, require_array
from ..linalg import onto_affine_hull
from ..model.problem import StaticsProblem, checked_problem
from ..result import Computed
from ..streams import direction_generator
from .force_space import ForceSpace


def _plane(directions, N):
    """Orthonormal (2m, 2) basis of the plane of ``directions`` (2m, 2) projected onto the
    hull span(N); InputError unless the projections span a plane (two directions that
    are zero, parallel, or normal to S's hull span none)."""
    P = N @ (N.T @ directions)
    sv = np.linalg.svd(P, compute_uv=False)
    if not sv[1] > 1e-8 * max(np.linalg.norm(directions, axis=0).max(), 1e-300):
        raise InputError("Section", "directions", "must span a plane within S's affine hull "
                         "(two independent directions; zero, parallel or off-hull ones span "
                         "none)", got=f"singular values of their projection {sv.tolist()}")
    return np.linalg.qr(P)[0]


class Section(Computed):
    """A cross-section of S through x0 (compute object).

    ``Section(n=201, seed=0, margin=0.3).compute(problem, x0=None, directions=None,
    analysis=None)``: the plane through ``x0`` (2m,) [F0] (default the jammed network,
    moved onto the affine hull) along ``directions`` ((2m, 2), default two random
    orthonormal directions of the hull, from ``seed``), on an n x n grid covering S's
    extent in the plane plus ``margin`` of it on every side. ``analysis``: the
    problem's ForceSpace, if already computed.

    Where x0 sits in the section: ``x0_edge_distance`` [F0], its distance to the
    section's boundary, and ``x0_edge_ratio``, that distance over the section's extent
    (the larger of its widths along d1 and d2): 0 on the edge, at most 1/2; about 0.3 at
    the paper slice's Chebyshev centre.
    """

    def __init__(self, n: int = 201, seed: int = 0, margin: float = 0.3):
        if not (isinstance(n, int) and not isinstance(n, bool) and 3 <= n <= 2001):
            raise InputError("section", "n", "must be an integer in [3, 2001]", got=n)
        self.n, self.seed, self.margin = n, seed, float(margin)

    def compute(self, problem: StaticsProblem, x0=None, directions=None,
                analysis=None) -> "Section":
        problem = checked_problem(problem, "Section")
        S = analysis if analysis is not None else ForceSpace().compute(problem)
        if not S.success:
            raise InputError(problem.source or "problem", "S", f"not analysed: {S.message}")
        if not S.feasible:
            raise InputError(problem.source or "problem", "S", "is empty: no cross-section")
        if not S.bounded:
            raise InputError(problem.source or "problem", "S", "is unbounded: no cross-section")
        N = S.affine_basis
        if N.shape[1] < 2:
            raise InputError(problem.source or "problem", "dim S", "must be >= 2 for a "
                             "cross-section", got=N.shape[1])
        m2 = problem.n_columns
        x0 = problem.x_jammed if x0 is None else \
            require_array("Section", "x0", x0, (m2,), "a force network [F0]")
        if directions is None:
            c = direction_generator(self.seed).normal(size=(N.shape[1], 2))
            D = np.linalg.qr(N @ c)[0]
        else:
            D = _plane(require_array("Section", "directions", directions, (m2, 2),
                                     "two directions of the force space"), N)
        self._start()
        x0 = onto_affine_hull(x0, S.affine_point, N)
        self._results.update(_grid(problem, x0, D[:, 0], D[:, 1], self.n, self.margin))
        self._finish(0, "section computed")
        return self

    @property
    def s(self) -> np.ndarray:
        """(n,) grid coordinate along d1 [F0]."""
        return self._get("s")

    @property
    def t(self) -> np.ndarray:
        """(n,) grid coordinate along d2 [F0]."""
        return self._get("t")

    @property
    def violation(self) -> np.ndarray:
        """(n, n) largest inequality violation at x0 + s[j] d1 + t[i] d2, divided by
        <Fn> (0 inside S)."""
        return self._get("violation")

    @property
    def x0(self) -> np.ndarray:
        """(2m,) the plane's origin [F0]."""
        return self._get("x0")

    @property
    def d1(self) -> np.ndarray:
        """(2m,) first direction of the plane (unit)."""
        return self._get("d1")

    @property
    def d2(self) -> np.ndarray:
        """(2m,) second direction of the plane (unit)."""
        return self._get("d2")

    @property
    def s_range(self) -> tuple:
        """Extent of S along d1 through x0 [F0] (LP)."""
        return self._get("s_range")

    @property
    def t_range(self) -> tuple:
        """Extent of S along d2 through x0 [F0] (LP)."""
        return self._get("t_range")

    @property
    def x0_violation(self) -> float:
        """Largest inequality violation at x0 itself, / <Fn> (0: x0 is in S)."""
        return self._get("x0_violation")

    @property
    def inside_fraction(self) -> float:
        """Fraction of the grid inside S."""
        return float((self.violation <= 0).mean())

    @property
    def x0_edge_distance(self) -> float:
        """Distance [F0] from x0 to the boundary of the section (0 when x0 is on it or
        outside): the smallest slack of an inequality over its gradient in the plane,
        over the inequalities that vary in the plane."""
        return self._get("x0_edge_distance")

    @property
    def x0_edge_ratio(self) -> float:
        """``x0_edge_distance`` over the section's extent (the larger width along d1, d2)."""
        return self._get("x0_edge_ratio")

    def plot(self, ax=None, title: str | None = None):
        """White inside S, grey by Coulomb violation outside (log colour scale, its bar
        beside the plot), x0 marked; axes in F0 with at most five ticks each (an offset
        and power of ten shown once); returns the Axes."""
        from matplotlib import colormaps
        from matplotlib.colors import ListedColormap, LogNorm
        from matplotlib.figure import Figure
        from matplotlib.patches import Rectangle
        from matplotlib.ticker import MaxNLocator

        from ..plot import STYLE

        if ax is None:
            ax = Figure(figsize=(5.6, 4.8)).add_subplot()
        v = np.where(self.violation > 0, self.violation, np.nan)
        pos = v[np.isfinite(v)]
        norm = LogNorm(vmin=pos.min(), vmax=pos.max()) if pos.size else None
        # outside S starts at a visible grey, so white is exactly S (NaN: not drawn)
        greys = ListedColormap(colormaps["Greys"](np.linspace(0.2, 1.0, 256)))
        im = ax.pcolormesh(self.s, self.t, v, cmap=greys, norm=norm, shading="nearest",
                           rasterized=True)
        if pos.size:
            # the bar in an inset right of the Axes: never over the title, and any layout
            # engine (or tight_layout by the caller) sees it as part of the Axes
            bar = ax.figure.colorbar(im, cax=ax.inset_axes([1.04, 0.0, 0.04, 1.0]))
            bar.set_label(r"Coulomb violation / $\langle F_n\rangle$")
        ax.plot([0], [0], marker="*", color=STYLE["increase"], ms=11, ls="none",
                label=r"$x_0$ (jammed network)")
        ax.add_patch(Rectangle((np.nan, np.nan), 0, 0, facecolor="white", edgecolor="0.4",
                               lw=0.6, label=r"$S$ (white: every constraint holds)"))
        ax.set_xlabel(r"$s$ along $d_1$ [$F_0$]")
        ax.set_ylabel(r"$t$ along $d_2$ [$F_0$]")
        ax.set_title(title or r"cross-section of $S$", fontsize=10)
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_locator(MaxNLocator(5))
            fmt = axis.get_major_formatter()
            if hasattr(fmt, "set_powerlimits"):
                fmt.set_powerlimits((-2, 3))        # 1e-4 F0 scales: a x10^k label, once
        ax.set_aspect("equal")
        ax.legend(loc="upper right", fontsize=8, framealpha=0.9)
        return ax

    def __repr__(self) -> str:
        return f"Section(n={self.n}, seed={self.seed}, margin={self.margin:g})"


def _grid(problem, x0, d1, d2, n, margin) -> dict:
    """The violation of the plane x0 + s d1 + t d2 on an n x n grid over S's extent."""
    G, _, _ = problem.inequalities()
    g0 = G @ x0
    H = np.column_stack([G @ d1, G @ d2])
    # extent of S in the plane: G (x0 + s d1 + t d2) <= 0 (2-variable LPs)
    ext = []
    for c in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        r = linprog(-np.array(c, float), A_ub=H, b_ub=-g0, bounds=[(None, None)] * 2,
                    method="highs")
        ext.append(float(np.dot(c, r.x)) if r.status == 0 else 0.0)
    s_range, t_range = (-ext[1], ext[0]), (-ext[3], ext[2])
    span = max(s_range[1] - s_range[0], t_range[1] - t_range[0], 1e-12 * problem.force_scale)
    grad = np.linalg.norm(H, axis=1)
    row_norm = np.sqrt(np.asarray(G.multiply(G).sum(axis=1)).ravel()) if hasattr(G, "multiply") \
        else np.linalg.norm(G, axis=1)
    in_plane = grad > config.FLAT_ROW * row_norm          # the rows the plane moves
    edge = float((np.maximum(-g0[in_plane], 0.0) / grad[in_plane]).min(initial=np.inf))
    pad = margin * span
    s = np.linspace(s_range[0] - pad, s_range[1] + pad, n)
    t = np.linspace(t_range[0] - pad, t_range[1] + pad, n)
    S_, T_ = np.meshgrid(s, t)
    viol = g0[:, None] + H @ np.vstack([S_.ravel(), T_.ravel()])
    worst = np.maximum(viol.max(axis=0), 0.0) / problem.force_scale
    return {"s": s, "t": t, "violation": worst.reshape(n, n), "x0": x0, "d1": d1, "d2": d2,
            "s_range": s_range, "t_range": t_range,
            "x0_violation": float(max(g0.max(initial=0.0), 0.0) / problem.force_scale),
            "x0_edge_distance": edge, "x0_edge_ratio": edge / span}
