"""Two-dimensional cross-sections of S (the inset of the paper's Fig. 3).

The plane through a network x0 of S (default the jammed state) spanned by two
orthonormal directions d1, d2 of S's affine hull: x(s, t) = x0 + s d1 + t d2
[F0]. Equilibrium holds on the whole plane; a point is in S when no Coulomb
(or fn >= 0) inequality is violated. :func:`section` samples the plane on a
grid and returns the violation, in units of <Fn>, at every node.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError
from .polytope import analyze
from .statics import StaticsProblem


@dataclass(frozen=True)
class Section:
    """A cross-section of S.

    s, t: (k,) grid coordinates along d1, d2 [F0]; violation: (k, k) largest
    inequality violation at x0 + s[j] d1 + t[i] d2, divided by <Fn> (0 inside
    S); x0, d1, d2: (2m,) the plane; s_range, t_range: the extent of S along
    s and t through x0 (LP).
    """

    s: np.ndarray
    t: np.ndarray
    violation: np.ndarray
    x0: np.ndarray
    d1: np.ndarray
    d2: np.ndarray
    s_range: tuple
    t_range: tuple

    @property
    def inside_fraction(self) -> float:
        """Fraction of the grid inside S."""
        return float((self.violation <= 0).mean())

    def plot(self, ax=None, title: str | None = None):
        """White inside S, grey by Coulomb violation outside, x0 marked; returns the Axes."""
        from matplotlib import colormaps
        from matplotlib.colors import ListedColormap, LogNorm
        from matplotlib.figure import Figure

        if ax is None:
            ax = Figure(figsize=(5, 4.5)).add_subplot()
        v = np.where(self.violation > 0, self.violation, np.nan)
        pos = v[np.isfinite(v)]
        norm = LogNorm(vmin=pos.min(), vmax=pos.max()) if pos.size else None
        # outside S starts at a visible grey, so white is exactly S (NaN: not drawn)
        greys = ListedColormap(colormaps["Greys"](np.linspace(0.2, 1.0, 256)))
        im = ax.pcolormesh(self.s, self.t, v, cmap=greys, norm=norm, shading="nearest")
        if pos.size:
            ax.figure.colorbar(im, ax=ax, label="Coulomb violation / <Fn>")
        ax.plot([0], [0], "r*", ms=10, label="x0")
        ax.set(xlabel="s [F0]", ylabel="t [F0]", title=title or "cross-section of S")
        ax.set_aspect("equal")
        ax.legend(loc="upper right", fontsize=8)
        return ax


def section(problem: StaticsProblem, x0=None, directions=None, n: int = 201, seed: int = 0,
            margin: float = 0.3) -> Section:
    """The cross-section of S through ``x0`` (default the jammed network, moved onto
    the affine hull) along ``directions`` ((2m, 2), default two random orthonormal
    directions of the hull, seeded), on an n x n grid covering S's extent in the
    plane plus ``margin`` of it on every side."""
    from scipy.optimize import linprog

    if not (isinstance(n, int) and 3 <= n <= 2001):
        raise InputError("section", "n", "must be an integer in [3, 2001]", got=n)
    an = analyze(problem, ranges=False)
    if not an.feasible:
        raise InputError(problem.source or "problem", "S", "is empty: no cross-section")
    if not an.bounded:
        raise InputError(problem.source or "problem", "S", "is unbounded: no cross-section")
    N = an.affine_basis
    if N.shape[1] < 2:
        raise InputError(problem.source or "problem", "dim S", "must be >= 2 for a "
                         "cross-section", got=N.shape[1])
    x0 = problem.x_jammed if x0 is None else np.asarray(x0, float)
    x0 = an.affine_point + N @ (N.T @ (x0 - an.affine_point))     # onto the hull
    if directions is None:
        c = np.random.default_rng(seed).normal(size=(N.shape[1], 2))
        D = np.linalg.qr(N @ c)[0]
    else:
        D = np.linalg.qr(N @ (N.T @ np.asarray(directions, float)))[0]
    d1, d2 = D[:, 0], D[:, 1]
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
    pad = margin * span
    s = np.linspace(s_range[0] - pad, s_range[1] + pad, n)
    t = np.linspace(t_range[0] - pad, t_range[1] + pad, n)
    S_, T_ = np.meshgrid(s, t)
    viol = g0[:, None] + H @ np.vstack([S_.ravel(), T_.ravel()])
    worst = np.maximum(viol.max(axis=0), 0.0) / problem.force_scale
    return Section(s=s, t=t, violation=worst.reshape(n, n), x0=x0, d1=d1, d2=d2,
                   s_range=s_range, t_range=t_range)
