"""Hit-and-run on S of spheres: a convex set with curved faces (the Coulomb cones).

S in its affine hull: x = xc + N y (:func:`forcespace.space.conic.analyze_conic`'s hull and
certified centre). A chain at x draws a direction u uniform on the unit sphere of the
hull's coordinates, v = N u, and moves to a point uniform on the chord {x + t v} in S.
The chord is exact: per frictional contact whose cone S enters fully, with p = x_j and
q = v_j (fn, f1, f2), ``mu (p_n + t q_n) >= |p_t + t q_t|`` is the quadratic
``Q(t) = a t^2 + b t + c >= 0`` (a = mu^2 q_n^2 - |q_t|^2, b = 2 (mu^2 p_n q_n - p_t.q_t),
c = mu^2 p_n^2 - |p_t|^2 >= 0) on the nappe ``p_n + t q_n >= 0``: the interval of t
about 0 where both hold (:func:`cone_chords`). Frictionless contacts and contacts on a ray
of their cone (their equalities hold in the hull) need fn >= 0 only; contacts at the
apex do not move. Hit-and-run with uniform directions and uniform points on the chord
has the uniform distribution on S as its stationary law (Smith 1984).

Units: x [F0]; t in F0 per unit of the direction (|u| = 1 in the hull's coordinates,
which are those of x: N is orthonormal).
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..model.sphere_problem import SphereStaticsProblem
from ..space import conic
from ..streams import chain_generators


def cone_chords(P, Q, mu):
    """(lo, hi) (k,): the interval of t about 0 where p + t q stays in the cone
    |f_t| <= mu fn, for k cones at once; P, Q (k, 3) rows (fn, f1, f2) of the points
    (inside their cones) and of the direction; mu (k,) > 0. Unbounded sides are +-inf."""
    P, Q, mu = np.asarray(P, float), np.asarray(Q, float), np.asarray(mu, float)
    m2 = mu * mu
    a = m2 * Q[:, 0] ** 2 - (Q[:, 1:] ** 2).sum(1)
    b = 2.0 * (m2 * P[:, 0] * Q[:, 0] - (P[:, 1:] * Q[:, 1:]).sum(1))
    c = np.maximum(m2 * P[:, 0] ** 2 - (P[:, 1:] ** 2).sum(1), 0.0)   # inside: c >= 0
    lo, hi = half_line(P[:, 0], Q[:, 0])                                # the nappe fn >= 0
    disc = b * b - 4 * a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.sqrt(np.maximum(disc, 0.0))
        # roots by the stable pair: q = -(b + sign(b) root) / 2, r1 = q / a, r2 = c / q
        qq = -0.5 * (b + np.where(b >= 0, 1.0, -1.0) * root)
        r1, r2 = qq / a, c / qq
    r_lo, r_hi = np.minimum(r1, r2), np.maximum(r1, r2)
    concave = a < 0                  # Q >= 0 between its roots
    lo = np.where(concave, np.maximum(lo, r_lo), lo)
    hi = np.where(concave, np.minimum(hi, r_hi), hi)
    convex = a > 0                   # Q >= 0 outside its roots: the side 0 is on
    above = convex & (disc >= 0) & (r_lo >= 0)
    below = convex & (disc >= 0) & (r_hi <= 0)
    hi = np.where(above, np.minimum(hi, r_lo), hi)
    lo = np.where(below, np.maximum(lo, r_hi), lo)
    # round-off only (x a hair outside, or 0 between a convex Q's roots): stay put
    stuck = (concave & (disc < 0)) | (convex & (disc >= 0) & ~above & ~below)
    lo, hi = np.where(stuck, 0.0, lo), np.where(stuck, 0.0, hi)
    flat = a == 0                    # Q linear: b t + c >= 0
    lo = np.where(flat & (b > 0), np.maximum(lo, -c / np.where(b > 0, b, 1.0)), lo)
    hi = np.where(flat & (b < 0), np.minimum(hi, -c / np.where(b < 0, b, 1.0)), hi)
    return np.minimum(lo, 0.0), np.maximum(hi, 0.0)


def half_line(p, q):
    """(lo, hi) (k,): the t with p + t q >= 0, for p >= 0 (clipped at 0)."""
    p, q = np.maximum(np.asarray(p, float), 0.0), np.asarray(q, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        lo = np.where(q > 0, -p / q, -np.inf)
        hi = np.where(q < 0, -p / q, np.inf)
    return lo, hi


class ConicHitAndRun:
    """Uniform samples of S of a sphere problem by hit-and-run with exact chords.

    ``ConicHitAndRun(n, seed=0, chains=4, thin=None, burn_in=None).compute(problem)``:
    ``samples`` (n, 3m) [F0] (sample i drawn by chain i % chains), ``chain`` (n,), the
    analysis (``analysis``: a ForceSpace of the problem). Every chain starts at the
    certified centre; ``thin`` steps per sample (default d, the dimension of S) and
    ``burn_in`` steps before the first (default 10 d). In memory only: the sampling
    driver's files, rounding and diagnostics are the disks' so far."""

    def __init__(self, n: int, seed: int = 0, chains: int = 4, thin: int | None = None,
                 burn_in: int | None = None):
        if not (isinstance(n, (int, np.integer)) and 1 <= n <= 10 ** 7):
            raise InputError("ConicHitAndRun", "n", "must be an integer in [1, 1e7]", got=n)
        self.n, self.seed, self.chains = int(n), int(seed), int(chains)
        self.thin, self.burn_in = thin, burn_in

    def compute(self, problem: SphereStaticsProblem, analysis=None) -> "ConicHitAndRun":
        from ..space.force_space import ForceSpace
        if not isinstance(problem, SphereStaticsProblem):
            raise InputError("ConicHitAndRun", "problem", "must be a SphereStaticsProblem "
                             "(disks: HitAndRun)", got=type(problem).__name__)
        S = analysis if analysis is not None else ForceSpace().compute(problem)
        if not (S.success and S.feasible and S.bounded):
            raise InputError(problem.source or "problem", "S", "must be non-empty and "
                             "bounded to be sampled", got=f"feasible={S.feasible}, "
                             f"bounded={S.bounded}")
        self.analysis = S
        N, d = S.affine_basis, S.dim
        thin = max(d, 1) if self.thin is None else int(self.thin)
        burn = 10 * max(d, 1) if self.burn_in is None else int(self.burn_in)
        walk = ChordWalk(problem, S.faces, S.centre, N)
        rngs = chain_generators(self.seed, self.chains)
        xs = [S.centre.copy() for _ in range(self.chains)]
        out, chain = np.empty((self.n, problem.n_columns)), np.arange(self.n) % self.chains
        for c in range(self.chains):
            for _ in range(burn if d else 0):
                xs[c] = walk.step(xs[c], rngs[c])
        for i in range(self.n):
            c = chain[i]
            for _ in range(thin if d else 0):
                xs[c] = walk.step(xs[c], rngs[c])
            out[i] = xs[c]
        self.samples, self.chain = out, chain
        return self


class ChordWalk:
    """One hit-and-run step on S: ``step(x, rng)`` -> the next point (3m,) [F0]."""

    def __init__(self, problem: SphereStaticsProblem, faces, x0, N):
        self.N = N
        cone = (faces.kind == conic.FULL) & (problem.mu > 0)
        self.cone = np.flatnonzero(cone)
        self.line = np.flatnonzero(~cone & (faces.kind != conic.APEX))
        self.mu = problem.mu[self.cone]

    def step(self, x, rng):
        u = rng.normal(size=self.N.shape[1])
        v = self.N @ (u / np.linalg.norm(u))
        X, V = x.reshape(-1, 3), v.reshape(-1, 3)
        lo, hi = cone_chords(X[self.cone], V[self.cone], self.mu)
        l2, h2 = half_line(X[self.line, 0], V[self.line, 0])
        t_lo = max(lo.max(initial=-np.inf), l2.max(initial=-np.inf))
        t_hi = min(hi.min(initial=np.inf), h2.min(initial=np.inf))
        return x + rng.uniform(t_lo, t_hi) * v
