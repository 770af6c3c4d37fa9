"""Second-order-cone programs over S of a sphere packing, with Clarabel (interior point).

S = {x : A x = b, f1 = f2 = 0 and fn >= 0 where mu = 0, ||(f1, f2)|| <= mu fn elsewhere}
(columns and rows: :mod:`forcespace.model.sphere_problem`). The Coulomb cone of a sphere
contact is a second-order (Lorentz) cone, which no LP takes; Clarabel (sparse LDL^T,
homogeneous embedding) decides feasibility exactly to its tolerances and certifies
infeasibility. As with the LPs of :mod:`forcespace.space.lp`, every question is asked of
the problem scaled to <Fn> = 1 and answered back in F0.

The conic room of S (the disks' LP questions are :mod:`forcespace.space.questions`):
:func:`nearest_admissible` (a point of S, the nearest to a target); :func:`socp`, the one
SOCP builder every question goes through; :func:`facial_reduction` (the face of each cone
that S spans, :class:`Faces`: its linear equalities make S's affine hull);
:func:`conic_boundedness`, :func:`conic_centre` (a certified inscribed ball),
:func:`fn_range`, :func:`ft_range`, :func:`conic_infeasibility`; :func:`analyze_conic`
asks them in order for :class:`~forcespace.space.force_space.ForceSpace`. The cross-check
by inscribed pyramids (:func:`pyramid_fn_ranges`) answers by LPs.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .. import config
from ..errors import NumericalError
from ..linalg import affine_hull, rank
from ..model.sphere_problem import SphereStaticsProblem

SOLVER_TOLERANCE = 1e-10     # [1] Clarabel's feasibility and gap tolerances (<Fn> = 1)


@dataclass(frozen=True)
class ConicResult:
    """The answer of :func:`nearest_admissible`: ``feasible`` (S is not empty), ``x``
    (3m,) [F0] the point found (None if infeasible), ``status`` (Clarabel's),
    ``iterations``, ``seconds`` (CPU), ``violation`` (:meth:`SphereStaticsProblem.violation`
    of x, in <Fn>; inf if none)."""

    feasible: bool
    x: np.ndarray | None
    status: str
    iterations: int
    seconds: float
    violation: float


def cone_constraints(problem: SphereStaticsProblem):
    """Clarabel's data ``(A, b, cones)`` for S: rows ``A x + s = b`` with s in the zero
    cone (equilibrium, fixed columns), the non-negative cone (fn of frictionless
    contacts) and one 3-D second-order cone (mu fn, f1, f2) per frictional contact."""
    import clarabel

    m = problem.n_columns
    fixed = problem.fixed_columns()
    eye = sp.identity(m, format="csr")
    free = np.flatnonzero(problem.mu == 0.0)
    cone = np.flatnonzero(problem.mu > 0.0)
    soc_rows = []
    for j in cone:
        soc_rows.append(sp.csr_matrix(([-problem.mu[j], -1.0, -1.0],
                                       ([0, 1, 2], [3 * j, 3 * j + 1, 3 * j + 2])),
                                      shape=(3, m)))
    blocks = [problem.A, eye[fixed], -eye[3 * free]] + soc_rows
    A = sp.vstack(blocks).tocsc()
    b = np.concatenate([problem.b, np.zeros(fixed.size + free.size + 3 * cone.size)])
    cones = [clarabel.ZeroConeT(problem.A.shape[0] + fixed.size)]
    if free.size:
        cones.append(clarabel.NonnegativeConeT(int(free.size)))
    cones += [clarabel.SecondOrderConeT(3) for _ in cone]
    return A, b, cones


def nearest_admissible(problem: SphereStaticsProblem, target=None,
                       tol: float = SOLVER_TOLERANCE) -> ConicResult:
    """A point of S: the one nearest (Euclidean, in F0) to ``target`` (3m,) when given,
    e.g. the dynamics' last forces, else a central point of S (zero objective: the
    interior point method ends in the relative interior). Solved on the problem scaled
    to <Fn> = 1; ``tol`` Clarabel's feasibility and gap tolerances there."""
    import clarabel

    scale = problem.force_scale if problem.force_scale > 0 else 1.0
    unit = problem.scaled(1.0 / scale)
    m = unit.n_columns
    A, b, cones = cone_constraints(unit)
    if target is None:
        P, q = sp.csc_matrix((m, m)), np.zeros(m)
    else:
        P, q = sp.identity(m, format="csc"), -np.asarray(target, float) / scale
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    for name in ("tol_feas", "tol_gap_abs", "tol_gap_rel", "tol_infeas_abs",
                 "tol_infeas_rel"):
        setattr(settings, name, tol)
    t0 = time.process_time()
    sol = clarabel.DefaultSolver(P, q, A, b, cones, settings).solve()
    seconds = time.process_time() - t0
    status = str(sol.status).split(".")[-1]
    if status not in ("Solved", "AlmostSolved"):
        return ConicResult(False, None, status, int(sol.iterations), seconds, float("inf"))
    x = np.asarray(sol.x, float) * scale
    x[problem.fixed_columns()] = 0.0
    return ConicResult(True, x, status, int(sol.iterations), seconds, problem.violation(x))


# ----------------------------------------------------------------------------
# the exact questions about S of spheres, each one SOCP on the problem at <Fn> = 1
# ----------------------------------------------------------------------------
CONE_FACE_TOL = 1e-7     # [<Fn>] a cone whose slack mu fn - |f_t| (fn at mu = 0) never
                         # exceeds this on S is touched only on its boundary (a ray or the
                         # apex); interior-point optima are accurate to ~sqrt(solver tol)
                         # along a tangency, so the LPs' 1e-9 would be noise here
FN_CAP = 1e6             # [<Fn>] the largest fn asked for where S may be unbounded
FULL, RAY, APEX = 0, 1, 2   # the face of a contact's cone that S spans: all of it, one ray, 0


@dataclass(frozen=True)
class Faces:
    """The smallest face of every contact's cone that holds S: ``kind`` (m,) FULL, RAY
    or APEX; ``angle`` (m,) the ray's direction in the tangent frame [rad] (f_t =
    mu fn (cos, sin) on it; NaN where kind is not RAY)."""

    kind: np.ndarray
    angle: np.ndarray

    @classmethod
    def whole(cls, m: int) -> "Faces":
        return cls(np.full(m, FULL), np.full(m, np.nan))

    def equalities(self, mu) -> sp.csr_matrix:
        """The face's linear equalities E x = 0, (k, 3m): fn = f1 = f2 = 0 at an apex;
        on a ray, mu fn = cos f1 + sin f2 and sin f1 = cos f2."""
        rows, cols, vals, k = [], [], [], 0
        for j in np.flatnonzero(self.kind == APEX):
            rows += [k, k + 1, k + 2]
            cols += [3 * j, 3 * j + 1, 3 * j + 2]
            vals += [1.0, 1.0, 1.0]
            k += 3
        for j in np.flatnonzero(self.kind == RAY):
            c, s = np.cos(self.angle[j]), np.sin(self.angle[j])
            rows += [k, k, k, k + 1, k + 1]
            cols += [3 * j, 3 * j + 1, 3 * j + 2, 3 * j + 1, 3 * j + 2]
            vals += [float(mu[j]), -c, -s, s, -c]
            k += 2
        return sp.csr_matrix((vals, (rows, cols)), shape=(k, 3 * self.kind.size))


class Infeasible(Exception):
    """The SOCP asked has no feasible point (S, or S with the question's extra rows, is
    empty)."""


def socp(unit: SphereStaticsProblem, faces: Faces, q, shift=None, rows=(), rhs: bool = True,
         coupling=None, tol: float = SOLVER_TOLERANCE):
    """Minimise q.z over z = (x (3m), e (k)), x in S on ``faces`` (A x = b, or A x = 0 with
    ``rhs=False``: the recession cone; the fixed columns; the faces' equalities), each
    contact's cone entry mu fn (fn where mu = 0 or on a ray) reduced by ``shift`` (m, k)
    @ e; ``rows``: more constraints, each (M (r, 3m + k), c (r,), "zero" | "nonneg" |
    "soc"), M z = c, c - M z >= 0 or c - M z in one second-order cone; ``coupling``
    (rows of A, k): A x + coupling @ e = b instead (a relaxation). Returns z, or None
    when the objective is unbounded below; raises :class:`Infeasible`, NumericalError."""
    import clarabel

    m, q = unit.n_contacts, np.asarray(q, float)
    k = q.size - 3 * m
    shift = sp.csr_matrix((m, k)) if shift is None else sp.csr_matrix(shift)

    def wide(M):
        return sp.hstack([M, sp.csr_matrix((M.shape[0], k))]).tocsr()
    E = sp.vstack([unit.A, sp.identity(3 * m, format="csr")[unit.fixed_columns()],
                   faces.equalities(unit.mu)]).tocsr()
    E = wide(E)
    if coupling is not None:
        E = E + sp.vstack([sp.hstack([sp.csr_matrix(unit.A.shape), coupling]),
                           sp.csr_matrix((E.shape[0] - unit.A.shape[0], E.shape[1]))])
    zero = [(E.tocsr(), np.concatenate([unit.b if rhs else np.zeros(unit.A.shape[0]),
                                      np.zeros(E.shape[0] - unit.A.shape[0])]))]
    zero += [(M, c) for M, c, kind in rows if kind == "zero"]
    line = np.flatnonzero((faces.kind != APEX) & ((unit.mu == 0) | (faces.kind == RAY)))
    cone = np.flatnonzero((faces.kind == FULL) & (unit.mu > 0))
    eye = sp.identity(3 * m, format="csr")
    nonneg = [(sp.hstack([-eye[3 * line], shift[line]]).tocsr(), np.zeros(line.size))]
    nonneg += [(M, c) for M, c, kind in rows if kind == "nonneg"]
    # one 3-row block per cone: rows (mu fn - shift e, f1, f2) of each in turn
    r3 = np.arange(3 * cone.size)
    coulomb = sp.csr_matrix((np.column_stack([-unit.mu[cone], -np.ones((cone.size, 2))]).ravel(),
                             (r3, (3 * cone[:, None] + np.arange(3)).ravel())),
                            shape=(3 * cone.size, 3 * m))
    lift = sp.csr_matrix((np.ones(cone.size), (3 * np.arange(cone.size), cone)),
                         shape=(3 * cone.size, m))
    socs = [(sp.hstack([coulomb, lift @ shift]).tocsr(), np.zeros(3 * cone.size))]
    socs += [(M, c) for M, c, kind in rows if kind == "soc"]
    blocks = zero + nonneg + socs
    A = sp.vstack([M for M, _ in blocks]).tocsc()
    b = np.concatenate([c for _, c in blocks])
    cones = [clarabel.ZeroConeT(sum(M.shape[0] for M, _ in zero)),
             clarabel.NonnegativeConeT(sum(M.shape[0] for M, _ in nonneg))]
    cones += [clarabel.SecondOrderConeT(3) for _ in cone]
    cones += [clarabel.SecondOrderConeT(M.shape[0]) for M, _, kind in rows if kind == "soc"]
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    for name in ("tol_feas", "tol_gap_abs", "tol_gap_rel", "tol_infeas_abs",
                 "tol_infeas_rel"):
        setattr(settings, name, tol)
    n = q.size
    sol = clarabel.DefaultSolver(sp.csc_matrix((n, n)), q, A, b, cones, settings).solve()
    status = str(sol.status).split(".")[-1]
    if status in ("Solved", "AlmostSolved"):
        return np.asarray(sol.x, float)
    if status in ("PrimalInfeasible", "AlmostPrimalInfeasible"):
        raise Infeasible(status)
    if status in ("DualInfeasible", "AlmostDualInfeasible"):
        return None
    raise NumericalError(f"conic program failed: Clarabel status {status}")


def unit_vector(n: int, i, value=1.0) -> np.ndarray:
    v = np.zeros(n)
    v[i] = value
    return v


def facial_reduction(unit: SphereStaticsProblem, tol: float = CONE_FACE_TOL):
    """(faces, x): the smallest face of every cone holding S, and a point x (3m,) of S
    (the mean of the points found: strict in every cone that S enters). S must be
    non-empty.

    As the disks' iterative slack LP: maximise the sum of the cones' slacks s_j in
    [0, 1] (mu fn - |f_t| >= s_j, or fn >= s_j at mu = 0) over the contacts not yet
    shown strict; those with s_j > ``tol`` are; when none is, the rest touch S only on
    their boundary. A convex set on a cone's boundary lies on one ray of it (the boundary
    holds no other segment): the apex when max fn <= ``tol``, else the ray through the
    point of largest fn (where its direction is best resolved)."""
    m = unit.n_contacts
    open_ = np.ones(m, dtype=bool)
    points = []
    while open_.any():
        idx = np.flatnonzero(open_)
        q = np.concatenate([np.zeros(3 * m), -np.ones(idx.size)])
        shift = sp.csr_matrix((np.ones(idx.size), (idx, np.arange(idx.size))),
                              shape=(m, idx.size))
        cap = sp.hstack([sp.csr_matrix((idx.size, 3 * m)), sp.identity(idx.size)]).tocsr()
        z = socp(unit, Faces.whole(m), q, shift,
                 rows=[(cap, np.ones(idx.size), "nonneg"), (-cap, np.zeros(idx.size), "nonneg")])
        points.append(z[:3 * m])
        strict = idx[z[3 * m:] > tol]
        if strict.size == 0:
            break
        open_[strict] = False
    kind, angle = np.where(open_, APEX, FULL), np.full(m, np.nan)
    for j in np.flatnonzero(open_ & (unit.mu > 0)):
        cap = (sp.csr_matrix(unit_vector(3 * m, 3 * j))[:, :], np.array([FN_CAP]), "nonneg")
        z = socp(unit, Faces.whole(m), unit_vector(3 * m, 3 * j, -1.0), rows=[cap])
        if z[3 * j] > tol:
            kind[j], angle[j] = RAY, np.arctan2(z[3 * j + 2], z[3 * j + 1])
    return Faces(kind, angle), np.mean(points, axis=0)


def conic_boundedness(unit: SphereStaticsProblem, faces: Faces):
    """(bounded, max sum fn, recession direction (3m,) or None), as the disks'
    ``boundedness``: the cones are pointed, so S is bounded iff max sum d_fn over its
    recession cone {A d = 0, d in the faces} with sum d_fn <= 1 is 0."""
    m = unit.n_contacts
    q = np.zeros(3 * m)
    q[0::3] = -1.0
    total = (sp.csr_matrix(-q), np.ones(1), "nonneg")
    d = socp(unit, faces, q, rows=[total], rhs=False)
    if -q @ d > config.UNBOUNDED_TOL:
        return False, np.inf, d / max(np.abs(d).max(), 1e-300)
    x = socp(unit, faces, q)
    return True, float(-q @ x), None


def cone_ball_coefficients(unit: SphereStaticsProblem, N) -> np.ndarray:
    """c (m,): a ball of radius r in S's affine hull (basis N (3m, d)) around x lies in
    contact j's cone when mu fn - |f_t| >= c_j r (fn >= c_j r at mu = 0 or on a ray).
    With a = N's fn row and B its two tangential rows: |f_t + B y| <= |f_t| + r |B| and
    mu (fn + a.y) >= mu fn - r mu |a| give c = |B| + mu |a|; the 3-D ball of radius
    r |N_j| around (fn, f_t) gives c = sqrt(1 + mu^2) |N_j|; the smaller of the two.
    Both are sufficient, so the ball found is inside S; its radius is exact where the
    hull moves a contact only along fn, or only tangentially about f_t = 0."""
    m, d = unit.n_contacts, N.shape[1]
    blocks = N.reshape(m, 3, d)
    a = np.linalg.norm(blocks[:, 0], axis=1)
    B = np.linalg.norm(blocks[:, 1:], ord=2, axis=(1, 2))
    whole = np.linalg.norm(blocks, ord=2, axis=(1, 2))
    return np.where(unit.mu > 0, np.minimum(B + unit.mu * a,
                                            np.sqrt(1 + unit.mu ** 2) * whole), a)


def conic_centre(unit: SphereStaticsProblem, faces: Faces, N, xa):
    """(x (3m,), radius): the centre and radius of the largest ball in S within its
    affine hull that :func:`cone_ball_coefficients` certifies (a ball inside S; see there
    when its radius is that of the largest inscribed ball). Radius 0 at dim 0."""
    m = unit.n_contacts
    if N.shape[1] == 0:
        return np.asarray(xa, float), 0.0
    c = cone_ball_coefficients(unit, N)
    shift = sp.csr_matrix(c[:, None])
    cap = (sp.csr_matrix(unit_vector(3 * m + 1, 3 * m)), np.array([FN_CAP]), "nonneg")
    z = socp(unit, faces, unit_vector(3 * m + 1, 3 * m, -1.0), shift, rows=[cap])
    return z[:3 * m], float(z[3 * m])


def fn_range(unit: SphereStaticsProblem, faces: Faces, j: int, points: list | None = None):
    """(min, max) of fn of contact j over S (max inf where S is unbounded along it);
    ``points``, a list: the tangential force (2,) of j at both optima is appended."""
    m = unit.n_contacts
    lo = socp(unit, faces, unit_vector(3 * m, 3 * j))
    hi = socp(unit, faces, unit_vector(3 * m, 3 * j, -1.0))
    if points is not None:
        points += [z[3 * j + 1:3 * j + 3] for z in (lo, hi) if z is not None]
    return lo[3 * j], (np.inf if hi is None else hi[3 * j])


FT_MAX_TOL = 1e-7       # [<Fn>] max |f_t| is certified when its upper and lower bounds
                        # differ by at most this (SOCP points are good to ~1e-10 <Fn>, ~1e-5
                        # along a cone's tangency)
FT_MAX_SOCPS = 60       # support SOCPs at most per contact (then the best point found)


def ft_min(unit: SphereStaticsProblem, faces: Faces, j: int) -> float:
    """min |f_t| of contact j over S: one SOCP (|f_t| <= t, minimise t)."""
    m = unit.n_contacts
    soc = (sp.csr_matrix(([-1.0, -1.0, -1.0], ([0, 1, 2], [3 * m, 3 * j + 1, 3 * j + 2])),
                         shape=(3, 3 * m + 1)), np.zeros(3), "soc")
    return float(socp(unit, faces, unit_vector(3 * m + 1, 3 * m), rows=[soc])[3 * m])


def support_point(unit: SphereStaticsProblem, faces: Faces, j: int, angle: float):
    """The point p (2,) of the projection C of S onto contact j's tangent plane that is
    farthest along (cos angle, sin angle) (one SOCP), or None where C is unbounded."""
    m = unit.n_contacts
    q = np.zeros(3 * m)
    q[3 * j + 1], q[3 * j + 2] = -np.cos(angle), -np.sin(angle)
    z = socp(unit, faces, q)
    return None if z is None else z[3 * j + 1:3 * j + 3]


def outer_vertices(angles, support) -> np.ndarray:
    """(k, 2): the vertices of the polygon {u : e_i . u <= support_i} (e_i = (cos, sin) of
    ``angles`` (k,), sorted, consecutive gaps below pi): vertex i where lines i and i + 1
    meet."""
    a1, a2 = angles, np.roll(angles, -1)
    h1, h2 = support, np.roll(support, -1)
    det = np.sin(a2 - a1)
    return np.column_stack([(h1 * np.sin(a2) - h2 * np.sin(a1)) / det,
                            (np.cos(a1) * h2 - np.cos(a2) * h1) / det])


def ft_range(unit: SphereStaticsProblem, faces: Faces, j: int, fn_max: float | None = None,
             points=(), tol: float = FT_MAX_TOL, max_socps: int = FT_MAX_SOCPS):
    """(min, max) of |f_t| of contact j over S [<Fn>, the unit problem's forces].

    min: :func:`ft_min`. max: the largest norm over the projection C of S onto the tangent
    plane of j (convex, 2-D), bracketed: the support points p_i of C in directions e_i
    lie in C (max |f_t| >= max |p_i|), C lies in the polygon {e_i . u <= e_i . p_i} and in
    the disc |u| <= mu fn_max (max |f_t| <= the smaller of its largest vertex norm and
    mu fn_max). Starting from 4 directions, each new one points at the polygon's farthest
    vertex, until the bounds meet to ``tol`` (a global maximum, unlike a local ascent);
    ``points`` (k, 2): tangential forces at points of S already known (e.g. where fn is
    largest: when one has |f_t| = mu fn_max, no support SOCP runs). inf where S is
    unbounded along f_t; after ``max_socps`` support SOCPs, the lower bound."""
    lo = ft_min(unit, faces, j)
    if faces.kind[j] == APEX or unit.mu[j] == 0:
        return lo, lo
    cap = np.inf if fn_max is None else unit.mu[j] * fn_max
    best = max([lo] + [float(np.hypot(*p)) for p in points])
    if cap - best <= tol:
        return lo, min(best, cap)
    angles, support = np.arange(4) * np.pi / 2, np.zeros(4)
    for i, a in enumerate(angles):
        p = support_point(unit, faces, j, a)
        if p is None:
            return lo, np.inf
        support[i], best = np.cos(a) * p[0] + np.sin(a) * p[1], max(best, np.hypot(*p))
    for _ in range(max_socps - 4):
        v = outer_vertices(angles, support)
        norms = np.hypot(v[:, 0], v[:, 1])
        k = int(np.argmax(norms))
        if min(norms[k], cap) - best <= tol:
            break
        a = np.arctan2(v[k, 1], v[k, 0]) % (2 * np.pi)
        if np.min(np.abs(np.angle(np.exp(1j * (angles - a))))) < 1e-9:  # its own line
            a = angles[k] + 0.5 * ((angles[(k + 1) % angles.size] - angles[k]) % (2 * np.pi))
        p = support_point(unit, faces, j, a)
        if p is None:
            return lo, np.inf
        best = max(best, float(np.hypot(*p)))
        i = np.searchsorted(angles, a % (2 * np.pi))
        angles = np.insert(angles, i, a % (2 * np.pi))
        support = np.insert(support, i, np.cos(a) * p[0] + np.sin(a) * p[1])
    return lo, best


def ft_range_ascent(unit: SphereStaticsProblem, faces: Faces, j: int, starts: int = 4,
                    steps: int = 40):
    """(min, max) of |f_t| of contact j over S by support ascent (the first method, kept as
    the reference :func:`ft_range` is checked against): the support point p of C in the
    direction u is at least as far out as any point of C along u, so |p(angle of p)| >=
    |p|; from ``starts`` directions, each to a fixed point (|p| stalls to 1e-12 <Fn>). A
    local maximum of |f_t|: exact where C has no second local maximum."""
    lo = ft_min(unit, faces, j)
    if faces.kind[j] == APEX or unit.mu[j] == 0:
        return lo, lo
    best = lo
    for angle in np.arange(starts) * 2 * np.pi / starts:
        last = -1.0
        for _ in range(steps):
            p = support_point(unit, faces, j, angle)
            if p is None:
                return lo, np.inf
            norm = float(np.hypot(*p))
            best = max(best, norm)
            if norm <= last + 1e-12 or norm == 0.0:
                break
            last, angle = norm, np.arctan2(p[1], p[0])
    return lo, best


def conic_infeasibility(unit: SphereStaticsProblem, tol: float = config.IMPLICIT_TOL) -> dict:
    """Why S is empty (the disks' diagnosis for spheres): the L1 relaxation
    A x + s+ - s- = b, x in the cones, minimise sum s; the spheres whose rows need an
    extra load above ``tol`` <Fn>, the worst rows first."""
    m, nr = unit.n_contacts, unit.A.shape[0]
    k = 2 * nr
    ident = sp.identity(nr, format="csr")
    nonneg = (sp.hstack([sp.csr_matrix((k, 3 * m)), -sp.identity(k)]).tocsr(), np.zeros(k),
              "nonneg")
    z = socp(unit, Faces.whole(m), np.concatenate([np.zeros(3 * m), np.ones(k)]),
             rows=[nonneg], coupling=sp.hstack([ident, -ident]).tocsr())
    s = z[3 * m:3 * m + nr] - z[3 * m + nr:]
    bad = np.flatnonzero(np.abs(s) > tol)
    comp = ("fx", "fy", "fz", "torque_x/r", "torque_y/r", "torque_z/r")
    name = [unit.spheres[i // 6] if i < 6 * unit.n_interior else -1 for i in range(nr)]
    worst = [{"sphere": int(name[i]), "row": comp[i % 6] if name[i] >= 0 else "plate",
              "imbalance": float(s[i])} for i in bad[np.argsort(-np.abs(s[bad]))][:10]]
    return {"min_total_imbalance": float(np.abs(s).sum()),
            "relative_to_mean_force": float(np.abs(s).sum()),
            "unbalanced_spheres": sorted({int(name[i]) for i in bad if name[i] >= 0}),
            "worst_rows": worst,
            "reason": "no force network satisfies equilibrium and the Coulomb cones; the "
                      "listed spheres need the smallest extra loads",
            "least_violating": z[:3 * m], "relaxation": s}


def analyze_conic(unit: SphereStaticsProblem, out: dict, ranges: bool, centre: bool,
                  tol: float = CONE_FACE_TOL, stage=lambda name: None):
    """Fill ``out`` with the analysis of S of a sphere problem at <Fn> = 1, under the
    keys of the disks' analysis (:class:`~forcespace.space.force_space.ForceSpace`):
    feasibility, the cones' faces (:func:`facial_reduction`; ``implicit``: (contact,
    "ray" | "apex"), ``sliding_contacts`` on a ray, ``zero_contacts`` at the apex),
    boundedness, the affine hull {A x = b, fixed columns, the faces' equalities} and
    dim S, the ranges of fn and |f_t| (``ranges``), the certified ball (``centre``)."""
    m = unit.n_contacts
    fixed = unit.fixed_columns()
    free = np.setdiff1d(np.arange(3 * m), fixed)
    rank_A = rank(unit.A[:, free])
    out.update(bounded=None, dim=None, infeasibility=None, recession_direction=None,
               fn_range=None, ft_range=None, centre=None, radius=None, max_sum_fn=None,
               implicit_rows=None, implicit=[], sliding_contacts=None, zero_contacts=None,
               affine_point=None, affine_basis=None, varying=None, faces=None,
               n_unknowns=3 * m - fixed.size, rank_A=rank_A,
               full_row_rank=rank_A == unit.A.shape[0],
               degree_of_indeterminacy=3 * m - fixed.size - rank_A)
    stage("feasibility and implicit equalities")
    try:
        faces, x0 = facial_reduction(unit, tol)
    except Infeasible:
        out["feasible"] = False
        out["infeasibility"] = conic_infeasibility(unit)
        return
    out["feasible"], out["faces"] = True, faces
    ray, apex = np.flatnonzero(faces.kind == RAY), np.flatnonzero(faces.kind == APEX)
    out["implicit"] = sorted([(int(j), "ray") for j in ray] + [(int(j), "apex") for j in apex])
    out["sliding_contacts"], out["zero_contacts"] = ray, apex
    stage("boundedness")
    out["bounded"], out["max_sum_fn"], out["recession_direction"] = \
        conic_boundedness(unit, faces)
    stage("affine hull")
    E = sp.vstack([unit.A, sp.identity(3 * m, format="csr")[fixed],
                   faces.equalities(unit.mu)]).tocsr()
    rhs = np.concatenate([unit.b, np.zeros(E.shape[0] - unit.A.shape[0])])
    N, xa, _ = affine_hull(E, rhs, x0)
    out["dim"], out["affine_point"], out["affine_basis"] = int(N.shape[1]), xa, N
    if ranges:
        stage("ranges")
        moving = np.linalg.norm(N.reshape(m, 3, -1), axis=(1, 2)) > config.MOVING_ROW_TOL
        fn_rng = np.repeat(xa[0::3, None], 2, axis=1)
        ft_rng = np.repeat(np.hypot(xa[1::3], xa[2::3])[:, None], 2, axis=1)
        for j in np.flatnonzero(moving):
            points = []
            fn_rng[j] = fn_range(unit, faces, j, points)
            ft_rng[j] = ft_range(unit, faces, j, fn_rng[j, 1], points)
        out["fn_range"], out["ft_range"] = fn_rng, ft_rng
    if out["bounded"] and centre:
        stage("centre")
        out["centre"], out["radius"] = conic_centre(unit, faces, N, xa)


# ----------------------------------------------------------------------------
# the cross-check by pyramids: each cone replaced by an inscribed k-sided pyramid
# ----------------------------------------------------------------------------
def pyramid_rows(problem: SphereStaticsProblem, k: int) -> sp.csr_matrix:
    """G (k m', 3m) with G x <= 0 the k-sided pyramids inscribed in the cones of the m'
    frictional contacts: cos(a_i) f1 + sin(a_i) f2 <= mu cos(pi / k) fn, a_i = 2 pi i / k
    (the regular k-gon with its vertices on the circle |f_t| = mu fn); -fn <= 0 at mu = 0.
    An inscribed pyramid lies in its cone and reaches 1 - cos(pi / k) short of it."""
    m = problem.n_contacts
    a = 2 * np.pi * np.arange(k) / k
    rows, cols, vals, r = [], [], [], 0
    for j in range(m):
        mu = problem.mu[j]
        if mu == 0:
            rows.append(r)
            cols.append(3 * j)
            vals.append(-1.0)
            r += 1
            continue
        for ai in a:
            rows += [r, r, r]
            cols += [3 * j, 3 * j + 1, 3 * j + 2]
            vals += [-mu * np.cos(np.pi / k), np.cos(ai), np.sin(ai)]
            r += 1
    return sp.csr_matrix((vals, (rows, cols)), shape=(r, 3 * m))


def pyramid_fn_ranges(problem: SphereStaticsProblem, k: int, contacts=None) -> np.ndarray:
    """(len(contacts), 2) [F0]: min and max of fn of each of ``contacts`` (default all) over
    S with every cone replaced by its inscribed k-sided pyramid, by LPs (HiGHS,
    :func:`forcespace.space.lp.solve_lp`); inf where unbounded, NaN where that polytope is
    empty. Each range lies inside the conic one."""
    from .lp import solve_lp

    contacts = np.arange(problem.n_contacts) if contacts is None else np.asarray(contacts)
    scale = problem.force_scale
    unit = problem.scaled(1.0 / scale)
    G = pyramid_rows(unit, k)
    fixed = unit.fixed_columns()
    E = sp.vstack([unit.A, sp.identity(unit.n_columns, format="csr")[fixed]]).tocsr()
    rhs = np.concatenate([unit.b, np.zeros(fixed.size)])
    out = np.full((contacts.size, 2), np.nan)
    for i, j in enumerate(contacts):
        for side, sgn in ((0, 1.0), (1, -1.0)):
            res = solve_lp(unit_vector(unit.n_columns, 3 * j, sgn), G, np.zeros(G.shape[0]),
                           E, rhs, (None, None))
            if res.status == 0:
                out[i, side] = res.x[3 * j] * scale
            elif res.status == 3:
                out[i, side] = -sgn * np.inf
    return out
