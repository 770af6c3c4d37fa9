"""Uniform walks on S of spheres, a convex set with curved faces (the Coulomb cones):
hit-and-run with exact chords, the billiard walk with reflections off the cones, and the
polytope walk on inscribed pyramids (the cross-check).

S in its affine hull: x = xc + N y (:func:`forcespace.space.conic.analyze_conic`'s hull and
certified centre), rounded (:func:`pyramid_rounding`) to x = x_centre + T w; a chain moves
w along a direction (a random axis of w, "coordinate", or uniform on its unit sphere,
"hypersphere") to a point uniform on the chord through w in S. The chord is exact: per
frictional contact whose cone S enters fully, with p = x_j and q = (T u)_j (fn, f1, f2),
``mu (p_n + t q_n) >= |p_t + t q_t|`` is the quadratic ``Q(t) = a t^2 + b t + c >= 0``
(a = mu^2 q_n^2 - |q_t|^2, b = 2 (mu^2 p_n q_n - p_t.q_t), c = mu^2 p_n^2 - |p_t|^2 >= 0)
on the nappe ``p_n + t q_n >= 0``: the interval of t about 0 where both hold
(:func:`cone_interval`). Frictionless contacts and contacts on a ray of their cone (their
equalities hold in the hull) need fn >= 0 only; contacts at the apex, and contacts whose
forces do not vary in S, do not move. Hit-and-run with these directions and uniform points
on the chord leaves the uniform distribution on S invariant (Smith 1984), and a linear map
keeps uniformity.

Rounding fit to the conic set: each cone replaced by its circumscribed k-sided pyramid
(k = ``PYRAMID_SIDES``, the regular k-gon around the circle |f_t| = mu fn, one side
touching it where the centre's f_t points: tight where S presses against its cone) gives a
polytope that holds S and lies within the cones of mu / cos(pi / k); an ellipsoid inscribed
in it is the rounding (any affine map keeps uniformity; the fit only sets the speed): the
exact MVE (:func:`forcespace.sampling.rounding.mve_rounding`) up to ``config.MVE_MAX_ROWS``
rows, above them the Dikin ellipsoid at the analytic centre (the polytopes' billiard's
rounding on its large path, :func:`forcespace.sampling.rounding.lewis_rounding` without
weight updates; John's by Lewis weights took 80 iterations, 35 CPU s at dim 233 and did
not converge in 300 at dim 1244). Both are computed in the frame of the Dikin ellipsoid
at the centre (:func:`dikin_factor`), where S's thin directions are not ill-conditioned.
The hit-and-run chains start at the analysis' certified centre (inside S; the
ellipsoid's centre may lie just outside it), the billiard's dispersed about it.

The walk runs through the one sampling driver (:func:`forcespace.sampling.driver.run_walk`,
via :class:`~forcespace.sampling.hit_and_run.HitAndRun`): files, resume, diagnostics,
progress as for disks. The chain state is w and the xoshiro256** state, as for disks; x is
recomputed from w at the start of every call of the kernel (and every
``CONE_REFRESH`` steps), so a resumed run continues bit for bit.

The billiard walk (:class:`ConicBilliardWalk`, :func:`conic_billiard_steps`) moves in the
same rounded frame: a velocity uniform on the unit sphere of w, a path of length
tau |g| / sqrt(d) (reflective HMC), the first hit of each straight segment exact (the same
quadratic per cone; fn >= 0 of the line contacts), and a specular reflection off the
surface hit, by its normal at the hit point (cone: (-mu, f_t / |f_t|) in (fn, f1, f2),
mapped to w by T^T); a trajectory with more than ``max_refl`` reflections is discarded.
Its invariance is the polytopes' argument (:mod:`forcespace.sampling.billiard`): the flow
between reflections is a translation and a reflection an isometry of the velocity off a
C^1 surface, both volume preserving and reversible.

:func:`pyramid_frame` is the cross-check: S with every cone replaced by its inscribed
k-sided pyramid, a polytope for the disks' hit-and-run
(:class:`~forcespace.sampling.hit_and_run.PyramidHitAndRunWalk`).

Units: x [F0]; t in F0 per unit of the direction; y, w as in :mod:`forcespace.sampling.frame`.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.linalg as sla

from .. import config
from ..errors import InputError, NumericalError
from ..kernels import kernel
from ..linalg import onto_affine_hull
from ..progress import progress as progress_bar
from ..space import conic
from ..space.lp import inner_ball
from ..streams import chain_states, start_generator
from .frame import Frame, FrameWalk, sampled_analysis
from .rounding import lewis_rounding_with_progress, mve_rounding
from .xoshiro import uniform, unit_direction

PYRAMID_SIDES = 16     # sides of the circumscribed pyramids the rounding is fit to
CONE_REFRESH = 4096    # [steps] x = xc + T w recomputed exactly (incremental x drifts ~eps sqrt n)


# ----------------------------------------------------------------------------
# kernels
# ----------------------------------------------------------------------------
@kernel
def cone_interval(pn, p1, p2, qn, q1, q2, mu):
    """(lo, hi): the interval of t about 0 where p + t q stays in the cone
    ``|(f1, f2)| <= mu fn`` (p inside it, mu > 0); unbounded sides are +-inf. Round-off
    (p a hair outside, or 0 between a convex Q's roots) gives (0, 0): stay put."""
    m2 = mu * mu
    a = m2 * qn * qn - q1 * q1 - q2 * q2
    b = 2.0 * (m2 * pn * qn - p1 * q1 - p2 * q2)
    c = max(m2 * pn * pn - p1 * p1 - p2 * p2, 0.0)
    lo, hi = -np.inf, np.inf
    pp = max(pn, 0.0)                       # the nappe fn >= 0
    if qn > 0.0:
        lo = -pp / qn
    elif qn < 0.0:
        hi = -pp / qn
    if a == 0.0:                            # Q linear: b t + c >= 0
        if b > 0.0:
            lo = max(lo, -c / b)
        elif b < 0.0:
            hi = min(hi, -c / b)
        return min(lo, 0.0), max(hi, 0.0)
    disc = b * b - 4.0 * a * c
    if disc < 0.0:
        if a < 0.0:
            return 0.0, 0.0
        return min(lo, 0.0), max(hi, 0.0)  # convex Q without roots: Q > 0 everywhere
    root = np.sqrt(disc)
    qq = -0.5 * (b + root) if b >= 0.0 else -0.5 * (b - root)   # the stable pair
    r1 = qq / a
    r2 = c / qq if qq != 0.0 else 0.0
    r_lo, r_hi = min(r1, r2), max(r1, r2)
    if a < 0.0:                             # Q >= 0 between its roots
        lo, hi = max(lo, r_lo), min(hi, r_hi)
    elif r_lo >= 0.0:                       # convex: the side 0 is on
        hi = min(hi, r_lo)
    elif r_hi <= 0.0:
        lo = max(lo, r_hi)
    else:
        return 0.0, 0.0
    return min(lo, 0.0), max(hi, 0.0)


@kernel
def chord(x, q, cone, mu, line):
    """(lo, hi): the chord {x + t q} in S: every cone ``cone`` (k,) (contact j: columns
    3j..3j+2 of x, q) with its mu (k,), every fn >= 0 of ``line`` (l,)."""
    lo, hi = -np.inf, np.inf
    for k in range(cone.size):
        j = 3 * cone[k]
        a, b = cone_interval(x[j], x[j + 1], x[j + 2], q[j], q[j + 1], q[j + 2], mu[k])
        lo, hi = max(lo, a), min(hi, b)
    for k in range(line.size):
        j = 3 * line[k]
        pn, qn = max(x[j], 0.0), q[j]
        if qn > 1e-300:
            lo = max(lo, -pn / qn)
        elif qn < -1e-300:
            hi = min(hi, -pn / qn)
    return lo, hi


@kernel
def conic_har_steps(T, xc, cone, mu, line, w, state, n_steps, coordinate):
    """Run ``n_steps`` hit-and-run steps on S from w (d,) in place; returns the number of
    degenerate chords (skipped). T (3m, d) Fortran order, xc (3m,) [F0]: x = xc + T w;
    cone (k,), mu (k,), line (l,): :func:`chord`. state (4,) uint64, advanced in place."""
    n3, d = T.shape
    x = xc + T @ w
    u = np.zeros(d)
    Tu = np.zeros(n3)
    bad = 0
    for step in range(n_steps):
        if step % CONE_REFRESH == 0 and step > 0:
            x = xc + T @ w
        c = 0
        if coordinate:
            c = min(int(uniform(state) * d), d - 1)
            q = T[:, c]                     # a column: contiguous in Fortran order
        else:
            unit_direction(state, u)
            for r in range(n3):
                acc = 0.0
                for i in range(d):
                    acc += T[r, i] * u[i]
                Tu[r] = acc
            q = Tu
        lo, hi = chord(x, q, cone, mu, line)
        r = uniform(state)
        if not (np.isfinite(lo) and np.isfinite(hi)) or hi < lo:
            bad += 1
            continue
        t = lo + r * (hi - lo)
        if coordinate:
            w[c] += t
        else:
            for i in range(d):
                w[i] += t * u[i]
        for i in range(n3):
            x[i] += t * q[i]
    return bad


@kernel
def first_hit(x, q, cone, mu, line):
    """(t, kind, k): where the ray {x + t q, t >= 0} leaves S first: t [F0 per unit q],
    kind 0 for cone k (of ``cone``), 1 for the fn >= 0 of line contact k, -1 never."""
    t, kind, at = np.inf, -1, -1
    for k in range(cone.size):
        j = 3 * cone[k]
        hi = cone_interval(x[j], x[j + 1], x[j + 2], q[j], q[j + 1], q[j + 2], mu[k])[1]
        if hi < t:
            t, kind, at = hi, 0, k
    for k in range(line.size):
        j = 3 * line[k]
        if q[j] < -1e-300:
            hi = max(x[j], 0.0) / -q[j]
            if hi < t:
                t, kind, at = hi, 1, k
    return t, kind, at


@kernel
def reflect(T, G, x, v, q, j, kind, mu):
    """Reflect the velocity v (d,) in place off the surface of contact j's constraint at x
    (kind 0: the cone |f_t| <= mu fn, normal g = (-mu, f_t / |f_t|); 1: fn >= 0, normal
    (-1, 0, 0)), mapped to w by T^T: v -= 2 (g.T_j v) / (g.T_j T_j^T g) T_j^T g; q = T v
    (3m,) kept: q -= the same factor x G_j g, G = T T^T (3m, 3m) (O(m + d), not the
    O(m d) of T v), or recomputed as T v where G is empty (too large to keep)."""
    n3, d = T.shape
    g = np.zeros(3)
    g[0] = -mu if kind == 0 else -1.0
    if kind == 0:
        ft = np.hypot(x[3 * j + 1], x[3 * j + 2])
        if ft > 0.0:
            g[1], g[2] = x[3 * j + 1] / ft, x[3 * j + 2] / ft
    nw = np.zeros(d)
    for i in range(d):
        nw[i] = g[0] * T[3 * j, i] + g[1] * T[3 * j + 1, i] + g[2] * T[3 * j + 2, i]
    nn, vn = 0.0, 0.0
    for i in range(d):
        nn += nw[i] * nw[i]
        vn += nw[i] * v[i]
    if nn <= 0.0:
        return
    a = 2.0 * vn / nn
    for i in range(d):
        v[i] -= a * nw[i]
    if G.shape[0] == n3:
        for r in range(n3):
            q[r] -= a * (g[0] * G[3 * j, r] + g[1] * G[3 * j + 1, r] + g[2] * G[3 * j + 2, r])
        return
    for r in range(n3):
        acc = 0.0
        for i in range(d):
            acc += T[r, i] * v[i]
        q[r] = acc


@kernel
def conic_billiard_steps(T, G, xc, cone, mu, line, w, state, n_traj, tau, max_refl, counts):
    """Run ``n_traj`` billiard trajectories on S from w (d,) in place: velocity g ~ N(0, I)
    in w, length tau |g| / sqrt(d) (reflective HMC), specular reflections off the cones
    and the fn >= 0 faces (:func:`reflect`); a trajectory with more than ``max_refl``
    reflections is discarded (the chain stays). counts (3,) int64 += trajectories,
    reflections, discarded. T (3m, d) C order, xc (3m,) [F0]: x = xc + T w; G = T T^T
    (3m, 3m) C order, or (0, 0) (:func:`reflect`)."""
    n3, d = T.shape
    v, w0, q = np.zeros(d), np.zeros(d), np.zeros(n3)
    for _ in range(n_traj):
        w0[:] = w
        left = tau * unit_direction(state, v) / np.sqrt(d)
        x = xc + T @ w
        q[:] = T @ v
        refl = 0
        while True:
            t, kind, k = first_hit(x, q, cone, mu, line)
            if t >= left:
                t = left
            for i in range(d):
                w[i] += t * v[i]
            for r in range(n3):
                x[r] += t * q[r]
            left -= t
            if left <= 0.0 or kind < 0:
                break
            refl += 1
            if refl > max_refl:
                w[:] = w0
                counts[2] += 1
                break
            j = cone[k] if kind == 0 else line[k]
            reflect(T, G, x, v, q, j, kind, mu[k] if kind == 0 else 0.0)
        counts[0] += 1
        counts[1] += refl
    return counts[2]


def cone_chords(P, Q, mu):
    """(lo, hi) (k,): :func:`cone_interval` of k cones at once; P, Q (k, 3) rows (fn, f1,
    f2) of the points (inside their cones) and of the direction; mu (k,) > 0."""
    P, Q = np.asarray(P, float).reshape(-1, 3), np.asarray(Q, float).reshape(-1, 3)
    out = np.array([cone_interval(*p, *q, float(m)) for p, q, m in zip(P, Q, np.ravel(mu))])
    return out[:, 0], out[:, 1]


def conic_dispersed_starts(T, x0, w0, cone, mu, line, chains: int, seed: int):
    """(W (chains, d), t (chains,)): the billiard's over-dispersed starts, as the
    polytopes' (:func:`forcespace.sampling.billiard.dispersed_starts`): per chain a random
    direction u (isotropic in w) and the point w0 + 0.9 t u, t the exact distance from w0
    (x0 = xc + T w0, inside S) to S's boundary along u (:func:`first_hit`; 1 where S is
    unbounded): t is S's size about w0 in w."""
    rng = start_generator(seed)
    W, ts = np.tile(w0, (chains, 1)), np.ones(chains)
    for c in range(chains):
        u = rng.normal(size=w0.size)
        u /= np.linalg.norm(u)
        t = first_hit(x0, T @ u, cone, mu, line)[0]
        ts[c] = t if np.isfinite(t) else 1.0
        W[c] += 0.9 * ts[c] * u
    return W, ts


# ----------------------------------------------------------------------------
# the frame and its rounding
# ----------------------------------------------------------------------------
def conic_frame(problem, analysis=None):
    """(Frame, cone (k,), mu (k,), line (l,)): S of a sphere problem in its affine hull
    (:class:`~forcespace.sampling.frame.Frame`; its rows H0 y <= s0 are the fn >= 0 of the
    ``line`` contacts: frictionless, or on a ray of their cone), the contacts whose cone S
    enters fully (``cone``, with their mu) and which vary on the hull."""
    an = sampled_analysis(problem, analysis)
    N = an.affine_basis
    xc = onto_affine_hull(an.centre, an.affine_point, N)
    m = problem.n_contacts
    moving = np.linalg.norm(N.reshape(m, 3, -1), axis=(1, 2)) > config.FLAT_ROW
    full = an.faces.kind == conic.FULL
    cone = np.flatnonzero(full & (problem.mu > 0) & moving)
    line = np.flatnonzero(~(full & (problem.mu > 0)) & (an.faces.kind != conic.APEX) & moving)
    H0, s0 = -N[3 * line], xc[3 * line].copy()
    keep = np.linalg.norm(H0, axis=1) > config.FLAT_ROW
    line, H0, s0 = line[keep], H0[keep], s0[keep]
    return Frame(xc, N, H0, s0, line, an, 0.0), cone, problem.mu[cone].astype(float), line


def pyramid_frame(problem, k: int, analysis=None) -> Frame:
    """The polytope of the cross-check by pyramids as a frame of the polytope walks: S with
    every fully entered cone replaced by its inscribed k-sided pyramid
    (:func:`forcespace.space.conic.pyramid_rows`' rows, cos(a_i) f1 + sin(a_i) f2 <=
    mu cos(pi / k) fn, turned so that a vertex lies along the centre's f_t: a contact
    whose centre is near its cone's surface stays inside its pyramid), in the conic S's
    affine hull, recentred at the Chebyshev centre of the pyramids (NumericalError without
    a point strictly inside them). free: the rows, pyramids' first, then the fn >= 0 of
    the line contacts."""
    fr, cone, mu, line = conic_frame(problem, analysis)
    xc = fr.xc.reshape(-1, 3)[cone]
    a = (np.arctan2(xc[:, 2], xc[:, 1])[:, None] + np.pi / k
         + 2 * np.pi * np.arange(k) / k).ravel()
    rows = np.column_stack([-np.repeat(mu, k) * np.cos(np.pi / k), np.cos(a), np.sin(a)])
    cols = 3 * np.repeat(cone, k)[:, None] + np.arange(3)
    H = np.vstack([np.einsum("rc,rcd->rd", rows, fr.N[cols]), fr.H0])
    s = np.concatenate([-(rows * fr.xc[cols]).sum(1), fr.s0])
    ball = inner_ball(H, s, problem.force_scale)
    if ball is None or not ball[1] > config.SAMPLE_VIOLATION * problem.force_scale:
        raise NumericalError(f"the inscribed {k}-sided pyramids leave no point strictly "
                             "inside S's affine hull")
    y = ball[0]
    return Frame(fr.xc + fr.N @ y, fr.N, H, s - H @ y, np.arange(H.shape[0]), fr.analysis,
                 0.0)


def pyramid_rounding(fr: Frame, cone, problem, progress: bool = False, method=None):
    """(y0 (d,), L (d, d), info) in units of <Fn>: the inscribed ellipsoid of the polytope
    {y : the k-sided pyramids circumscribed about the ``cone`` contacts' cones, fn >= 0 of
    the frame's rows} (it holds S; module docstring), started from the frame's centre
    y = 0. If that polytope is unbounded or the rounding fails, the frame is not rounded
    (L = identity; info["method"] = "none", with the reason)."""
    k, scale, d = PYRAMID_SIDES, problem.force_scale, fr.N.shape[1]
    xc = fr.xc.reshape(-1, 3)[cone]
    a = (np.arctan2(xc[:, 2], xc[:, 1])[:, None] + 2 * np.pi * np.arange(k) / k).ravel()
    rows = np.column_stack([-np.repeat(problem.mu[cone], k), np.cos(a), np.sin(a)])
    cols = 3 * np.repeat(cone, k)[:, None] + np.arange(3)
    H = np.vstack([np.einsum("rc,rcd->rd", rows, fr.N[cols]), fr.H0])
    s = np.concatenate([-(rows * fr.xc[cols]).sum(1), fr.s0])
    live = np.linalg.norm(H, axis=1) > config.FLAT_ROW
    H, s = H[live], s[live]
    method = method or ("mve" if H.shape[0] <= config.MVE_MAX_ROWS else "lewis")
    try:
        if not np.all(s > 0):
            raise InputError("rounding", "y0", "the centre is on a pyramid's face")
        R = dikin_factor(H * scale, s)
        Hu = sla.solve_triangular(R, (H * scale).T, trans="T").T
        if method == "lewis":
            u0, L, info = lewis_rounding_with_progress(Hu, s, np.zeros(d), 0, progress,
                                                       config.LEWIS_CENTRED_LARGE)
        else:
            u0, L, info = mve_rounding(Hu, s, np.zeros(d), progress=progress, method=method)
        y0, L = sla.solve_triangular(R, u0), sla.solve_triangular(R, L)
        L = L @ np.linalg.svd(L)[2].T          # columns along the ellipsoid's axes, as
                                                # before the preconditioning (coordinate
                                                # hit-and-run's directions)
    except (InputError, NumericalError, np.linalg.LinAlgError) as exc:
        return np.zeros(d), np.eye(d), {"method": "none", "pyramid_sides": k,
                                        "reason": str(exc)}
    return y0, L, dict(info, pyramid_sides=k, n_rows=int(H.shape[0]))


def dikin_factor(H, s) -> np.ndarray:
    """R (d, d) upper triangular, R^T R = M = sum_i a_i a_i^T (a_i = H_i / s_i: the Dikin
    ellipsoid {y : y^T M y <= 1} of {H y <= s} at y = 0, inside it). In u = R y it is the
    unit ball: the John / MVE iteration then starts from a well-conditioned frame (S's
    thin directions, e.g. a contact whose forces S fixes to ~1e-7 <Fn> in the
    2000-sphere slice, made M's condition ~1e14 in y and its Newton steps stall)."""
    At = H / s[:, None]
    return sla.cholesky(At.T @ At, lower=False)


SETUP_DESCRIPTION = {
    "x_centre": ("F0", "centre of the rounding ellipsoid (origin of w; may lie just "
                 "outside S: the chains start at w_start)"),
    "w_start": ("1", "the chains' start in w: the analysis' certified centre of S"),
    "T": ("F0", "x = x_centre + T w: affine frame x frozen rounding (params: 'rounding')"),
    "H": ("1", "fn >= 0 of the line contacts in w: H w <= s0"),
    "s0": ("F0", "slack of those rows at the centre"),
    "free_rows": ("1", "line contacts (frictionless or on a ray of their cone): fn >= 0"),
    "cone_contacts": ("1", "unknown contacts whose cone S enters fully (the walk's cones)"),
    "cone_mu": ("1", "their Coulomb coefficients"),
    "mve_axis_ratio": ("1", "axis ratio of the pyramids' inscribed ellipsoid per pass"),
    "tau": ("1", "billiard: path-length scale in w, fixed at the end of the burn-in"),
    "max_refl": ("1", "billiard: reflections above which a trajectory is discarded")}


def conic_default_params(d: int, **kw) -> dict:
    """hit-and-run's defaults (4 chains, thin max(50, d^2), burn-in max(500, 10 d^2),
    coordinate directions) with the pyramids' rounding."""
    d = max(d, 1)
    p = {"seed": 0, "chains": 4, "thin": max(50, d * d), "burn_in": max(500, 10 * d * d),
         "direction": "coordinate", "rounding": f"pyramids{PYRAMID_SIDES}"}
    p.update({k: v for k, v in kw.items() if v is not None})
    return p


class ConicHitAndRunWalk(FrameWalk):
    """Hit-and-run on S of spheres in the rounded frame (the template
    :class:`~forcespace.sampling.frame.FrameWalk`): ``thin`` steps of chain i % chains
    between its samples."""

    sampler = "hit-and-run"
    SETUP_DESCRIPTION = SETUP_DESCRIPTION
    pending_burn_in = False
    rounding_L = (np.zeros((0, 0)), np.zeros(0))    # (L, y0) of the frame's rounding

    def make_frame(self, problem, analysis) -> Frame:
        fr, self.cone, self.cone_mu, self.line = conic_frame(problem, analysis)
        return fr

    def default_params(self, options: dict) -> dict:
        return conic_default_params(self.d, **options)

    def round(self):
        y0, L, info = pyramid_rounding(self.frame, self.cone, self.problem, self.progress)
        self.rounding_L = (L, y0)
        return y0, L, info

    def start_chains(self, H, s):
        p = self.params
        self.states = chain_states(p["seed"], p["chains"])
        L, y0 = self.rounding_L
        self.w_start = -np.linalg.solve(L, y0) if self.d else np.zeros(0)
        self.W = np.tile(self.w_start, (p["chains"], 1))
        self.H, self.s0 = H, s
        self.pending_burn_in = bool(self.d and p["burn_in"])    # once T is set (_start)
        return H, s

    def _start(self, xc, T) -> None:
        super()._start(xc, T)
        self.Tf = np.asfortranarray(T)
        if self.pending_burn_in:
            self.pending_burn_in = False
            self._burn_in()

    def _burn_in(self) -> None:
        t1, c1 = time.perf_counter(), time.process_time()
        steps, W = self.params["burn_in"], self.W
        with progress_bar(total=W.shape[0] * steps, desc=f"burn-in ({W.shape[0]} chains)",
                          unit="step", disable=not self.progress) as bar:
            for c in range(W.shape[0]):
                self._steps_shown(c, steps, bar)
        self.ok = tuple(a.copy() for a in self.chain_arrays())
        self.times["burn_in_s"] = time.perf_counter() - t1
        self.cpu["burn_in_s"] = time.process_time() - c1

    def _steps_shown(self, c: int, n: int, bar) -> None:
        """``n`` hit-and-run steps of chain c in calls of CONE_REFRESH * 64 steps, ``bar``
        advanced after each: the same steps as one call (the kernel recomputes x at the
        start of a call and every CONE_REFRESH steps of it)."""
        done = 0
        while done < n:
            k = min(CONE_REFRESH * 64, n - done)
            self._steps(c, k)
            done += k
            bar.update(k)

    def _steps(self, c: int, n: int) -> int:
        return conic_har_steps(self.Tf, self.xc, self.cone, self.cone_mu, self.line,
                               self.W[c], self.states[c], n,
                               self.params["direction"] == "coordinate")

    def setup_extra(self) -> dict:
        return {"cone_contacts": self.cone, "cone_mu": self.cone_mu, "w_start": self.w_start,
                "mve_axis_ratio": np.asarray(self.rounding_info.get("axis_ratio", []), float)}

    def resume_chains(self, setup, checkpoint, state) -> None:
        self.cone = np.asarray(setup["cone_contacts"], np.int64)
        self.cone_mu = np.asarray(setup["cone_mu"], float)
        self.line = np.asarray(setup["free_rows"], np.int64)
        self.H, self.s0 = setup["H"], setup["s0"]
        self.W, self.states = state["w"], state["rng"]

    def chain_arrays(self) -> tuple:
        return self.W, self.states

    def advance(self, c: int) -> None:
        thin = self.params["thin"]
        if self._steps(c, thin) > thin // 2:
            raise NumericalError("hit-and-run: most chords degenerate; S is "
                                 "(numerically) flat in a direction the analysis kept")

    def state_attrs(self) -> dict:
        return {"steps_per_sample": self.params["thin"]}


class ConicBilliardWalk(ConicHitAndRunWalk):
    """The billiard walk on S of spheres (reflective HMC lengths, specular reflections off
    the cones by their surface normal at the hit point; :func:`conic_billiard_steps`) in
    the same rounded frame as :class:`ConicHitAndRunWalk`. Its chains start dispersed
    (:func:`conic_dispersed_starts`) and tau is set as the 2-D polytope billiard sets it
    (:meth:`forcespace.sampling.billiard.Chains.burn_in`): ``burn_in`` trajectories per
    chain, the first half with a guess, tau fixed at the end of the third quarter to
    ``tau_factor`` x the rms distance of that quarter's states from their mean, the last
    quarter with it. The guess is ``tau_factor`` x the mean distance from the centre to
    S's boundary along the starts' random directions (exact chords; the polytopes' guess,
    tau_factor sqrt(d) x a certified inscribed radius, was 0.66 where 2.5 x S's rms
    spread in w is 46 on a 100-sphere packing (mu = 0.03, seed 5, dim 154): tau ended at
    7.3 and the chains had not mixed after 4000 samples, ESS 51, R-hat 1.07). ``thin``
    trajectories of chain i % chains between its samples."""

    sampler = "billiard"
    STATE = ("w", "rng", "counts")
    fresh = False          # set by start_chains (not on resume): disperse, guess tau

    def default_params(self, options: dict) -> dict:
        if options.get("length") not in (None, "rehmc"):
            raise InputError("sample", "length", "must be 'rehmc' on S of spheres (the only "
                             "trajectory law of the conic billiard so far)",
                             got=options["length"])
        if options.get("rounding_updates") is not None:
            raise InputError("sample", "rounding_updates", "is not used on S of spheres "
                             "(rounded by the circumscribed pyramids)",
                             got=options["rounding_updates"])
        p = {"seed": 0, "chains": 4, "thin": 1, "burn_in": 50, "tau_factor": 2.5,
             "length": "rehmc", "rounding": f"pyramids{PYRAMID_SIDES}"}
        p.update({k: v for k, v in options.items() if v is not None
                  and k not in ("rounding_updates",)})
        return p

    def start_chains(self, H, s):
        self.counts = np.zeros((self.params["chains"], 3), np.int64)
        self.tau, self.max_refl = 1.0, 100 * max(self.d, 10)
        self.fresh = True
        return super().start_chains(H, s)

    def _burn_in(self) -> None:
        t1, c1 = time.perf_counter(), time.process_time()
        p, W = self.params, self.W
        chains, n = W.shape[0], p["burn_in"]
        q1, q2 = n // 2, n // 4
        seen = []
        with progress_bar(total=chains * n, unit="trajectory",
                          desc=f"billiard burn-in ({chains} chains)",
                          disable=not self.progress) as bar:
            for part, keep in ((q1, False), (q2, True), (n - q1 - q2, False)):
                for c in range(chains):
                    for _ in range(part):
                        self._trajectories(c, 1)
                        if keep:
                            seen.append(W[c].copy())
                        bar.update(1)
                if keep and seen:
                    S = np.array(seen)
                    self.tau = p["tau_factor"] * float(np.sqrt(((S - S.mean(0)) ** 2)
                                                               .sum(1).mean()))
        self.counts[:] = 0
        self.ok = tuple(a.copy() for a in self.chain_arrays())
        self.times["burn_in_s"] = time.perf_counter() - t1
        self.cpu["burn_in_s"] = time.process_time() - c1

    def _start(self, xc, T) -> None:
        self.Tc = np.ascontiguousarray(T)
        n3 = T.shape[0]
        self.G = self.Tc @ self.Tc.T if 8.0 * n3 * n3 <= config.MAX_GRAM_BYTES else \
            np.zeros((0, 0))
        if self.fresh and self.d:
            self.fresh = False
            self.W[:], t = conic_dispersed_starts(self.Tc, xc + T @ self.w_start,
                                                  self.w_start, self.cone, self.cone_mu,
                                                  self.line, self.W.shape[0],
                                                  self.params["seed"])
            self.tau = self.params["tau_factor"] * float(np.mean(t))
        super()._start(xc, T)

    def _trajectories(self, c: int, n: int) -> None:
        conic_billiard_steps(self.Tc, self.G, self.xc, self.cone, self.cone_mu, self.line,
                             self.W[c], self.states[c], n, self.tau, self.max_refl,
                             self.counts[c])

    def setup_extra(self) -> dict:
        return dict(super().setup_extra(), tau=self.tau, max_refl=self.max_refl)

    def resume_chains(self, setup, checkpoint, state) -> None:
        super().resume_chains(setup, checkpoint, state)
        self.tau, self.max_refl = float(setup["tau"]), int(setup["max_refl"])
        self.counts = checkpoint["counts"].astype(np.int64).reshape(-1, 3).copy()

    def chain_arrays(self) -> tuple:
        return self.W, self.states, self.counts

    def advance(self, c: int) -> None:
        self._trajectories(c, self.params["thin"])

    def results(self) -> dict:
        """The run's counts and walk parameters (:class:`~forcespace.sampling.billiard.
        BilliardWalk`'s ``counts`` and ``walk_info``)."""
        t = self.counts.sum(0)
        return {"counts": {"trajectories": int(t[0]), "reflections": int(t[1]),
                           "discarded": int(t[2])},
                "walk_info": {"tau": float(self.tau), "max_refl": int(self.max_refl),
                              "rounding": self.rounding_info}}

    def postfix(self) -> dict:
        t = self.counts.sum(0)
        return {"refl/traj": f"{t[1] / max(t[0], 1):.0f}", "discarded": int(t[2])}

    def state_attrs(self) -> dict:
        return {"trajectories_per_sample": self.params["thin"]}
