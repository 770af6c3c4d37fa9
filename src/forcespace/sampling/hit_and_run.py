"""Uniform sampling of S by hit-and-run (Smith 1984) in its affine hull.

Coordinates: x = x_c + T w, with x_c the centre of the MVE of S, T = N L where
N (2m, d) is an orthonormal basis of the affine hull of S (d = dim S, from
:class:`~forcespace.space.force_space.ForceSpace`) and L (d, d) a fixed rounding
matrix. The non-implicit inequalities become ``H w <= s0`` with H = G T, s0 = -G x_c
(>= 0).

A step draws a direction u (isotropic Gaussian normalised, "hypersphere"; or
a random coordinate axis, "coordinate"), intersects the line w + t u with the
polytope (exact chord) and moves to a uniform point of the chord. Both
kernels leave the uniform distribution on {H w <= s0} invariant, and a linear
map keeps uniformity, so the x samples are uniform on S.

Rounding (computed once before any sample, then FROZEN): the maximum-volume
inscribed ellipsoid of S in its affine hull (rounding.py, Zhang-Gao interior
point, iterated until the ellipsoid's axis ratio < 6) maps S to a polytope
between the unit ball and the ball of radius d; w = 0 is the MVE centre.
Above MVE_MAX_ROWS inequality rows the interior point's p x p factorisations
cost more than the sampling, and the Lewis-weight approximation of the same
ellipsoid (rounding.john_ellipsoid, d x d factorisations) replaces it; the
method used is recorded in the parameters ("rounding").
Covariance rounding from short walks was tried first and failed on the paper
slices (dim 60-300, inner radius ~1e-3 <Fn>): the walks never equilibrated
between rounds, so the covariance kept growing into thin spikes and the
sampler over-weighted them (eta 10x too large, R-hat 1.4). Default directions
are coordinate (CHRR, Haraldsdottir et al. 2017): O(p) per step with H in
Fortran order, thinning d^2 steps, burn-in 10 thinning intervals per chain.
Nothing is adapted while samples are kept.

Random numbers: xoshiro256** per chain inside numba (xoshiro.py, state 4 x uint64),
saved in the checkpoint so that a resumed run continues the same streams.

Diagnostics: split R-hat and a bulk effective sample size (Geyer initial
monotone sequence) of the per-sample scalar |x - mean|^2 (the quantity η
averages) and of three fixed random projections; per-chain η.
"""
from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from .. import config
from ..errors import InputError, NumericalError, require_int
from ..kernels import kernel
from ..linalg import onto_affine_hull
from ..model.problem import StaticsProblem
from ..progress import progress as progress_bar
from ..space.force_space import ForceSpace
from ..space.lp import inner_ball
from ..streams import chain_states
from .driver import FrameSampler, Stop, check_target, run_walk
from .rounding import mve_rounding
from .xoshiro import normal, uniform



# ----------------------------------------------------------------------------
# kernels
# ----------------------------------------------------------------------------
@kernel
def slack_refresh(d):
    """Steps between exact slack recomputations: 64 up to d = 64, else the power-of-two
    multiple of 64 at or above d (so the O(p d) product costs O(p) per step; the
    update's round-off grows like sqrt(steps) eps, negligible)."""
    r = 64
    while r < d and r < 64 * 4096:
        r *= 2
    return r


@kernel
def har_steps(H, s0, w, state, n_steps, coordinate):
    """Run ``n_steps`` hit-and-run steps from w (d,) in place; returns #degenerate chords.

    H (p, d), s0 (p,): polytope {H w <= s0}. state (4,) uint64 xoshiro state,
    advanced in place. coordinate: directions along axes instead of isotropic.
    Slack s = s0 - H w is recomputed exactly every :func:`slack_refresh` (d) steps
    (no drift; an O(p d) product amortised to O(p) per step).
    """
    p, d = H.shape
    refresh = slack_refresh(d)
    slack = s0 - H @ w
    u = np.zeros(d)
    Hu = np.zeros(p)
    bad = 0
    for step in range(n_steps):
        if step % refresh == 0 and step > 0:
            slack = s0 - H @ w
        if coordinate:
            c = int(uniform(state) * d)
            if c >= d:
                c = d - 1
            hu = H[:, c]                 # a column: contiguous with H in Fortran order
        else:
            nrm = 0.0
            for i in range(d):
                u[i] = normal(state)
                nrm += u[i] * u[i]
            nrm = np.sqrt(nrm)
            for i in range(d):
                u[i] /= nrm
            for j in range(p):
                acc = 0.0
                for i in range(d):
                    acc += H[j, i] * u[i]
                Hu[j] = acc
            hu = Hu
        tmin = -np.inf
        tmax = np.inf
        for j in range(p):               # chord: divide only where a bound tightens
            sj = slack[j] if slack[j] > 0.0 else 0.0
            h = hu[j]
            if h > 1e-300:
                if sj < tmax * h:
                    tmax = sj / h
            elif h < -1e-300:
                if sj < tmin * h:
                    tmin = sj / h
        r = uniform(state)
        if not (np.isfinite(tmin) and np.isfinite(tmax)) or tmax < tmin:
            bad += 1
            continue
        t = tmin + r * (tmax - tmin)
        if coordinate:
            w[c] += t
        else:
            for i in range(d):
                w[i] += t * u[i]
        for j in range(p):
            slack[j] -= t * hu[j]
    return bad


# ----------------------------------------------------------------------------
# set-up and driver
# ----------------------------------------------------------------------------


class Frame(NamedTuple):
    """S in its affine hull: x = xc + N y for the points y of {H0 y <= s0}.

    xc (2m,) [F0] a point of the hull strictly inside every free row (slacks s0 > 0, of
    the widened rows when ``widening`` > 0);
    N (2m, d) orthonormal basis of the hull; H0 = G_free N (p, d) [1]; s0 (p,) [F0];
    free (p,) the rows of ``problem.inequalities()`` kept; analysis the ForceSpace;
    widening [<Fn>]: 0, or how far every free row was moved out because S, thinner than
    round-off in a direction its dimension keeps, had no point strictly inside in the
    hull (:func:`frame`): every sample then lies within ``widening`` of S."""
    xc: np.ndarray
    N: np.ndarray
    H0: np.ndarray
    s0: np.ndarray
    free: np.ndarray
    analysis: object
    widening: float = 0.0


def frame(problem: StaticsProblem, analysis=None) -> Frame:
    """The affine frame of S (:class:`Frame`).

    The free rows are the inequalities that are neither implicit equalities nor
    constant on the affine hull (|G_i N| <= FLAT_ROW)."""
    an = analysis if analysis is not None else ForceSpace(ranges=False, centre=True).compute(problem)
    if not an.success:
        raise NumericalError(f"analysis of S failed: {an.message}")
    if not an.feasible:
        raise InputError(problem.source or "problem", "S", "is empty (infeasible): nothing to sample")
    if not an.bounded:
        raise InputError(problem.source or "problem", "S",
                         "is unbounded (a recession direction exists, e.g. a wedged contact); "
                         "refusing to sample")
    if an.centre is None:
        raise NumericalError("no Chebyshev centre computed")
    G, _, _ = problem.inequalities()
    free = np.setdiff1d(np.arange(G.shape[0]), an.implicit_rows)
    N = an.affine_basis
    # centre projected exactly onto the affine hull through the affine point
    xc = onto_affine_hull(an.centre, an.affine_point, N)
    H0 = np.asarray(G[free] @ N)
    s0 = -np.asarray(G[free] @ xc)
    # rows orthogonal to the affine hull up to round-off are constant on S: with a slack
    # within round-off of 0 they are implicit equalities the LP test missed (their
    # slack, +-1e-11, would stop the rounding), with a positive one they never bind
    flat = np.linalg.norm(H0, axis=1) <= config.FLAT_ROW
    bad = flat & (s0 < -config.SAMPLE_VIOLATION * problem.force_scale)
    if bad.any():
        raise NumericalError(f"the centre of S violates inequality row {free[bad][0]} by "
                             f"{-s0[bad].min() / problem.force_scale:.3g} <Fn>, and no point "
                             f"of the affine hull satisfies it better")
    H0, s0, free = H0[~flat], s0[~flat], free[~flat]
    widening = 0.0
    if H0.shape[1] and s0.size and s0.min() <= 0:
        # the centre, projected onto the hull, sits on (or a round-off outside) a facet of a
        # thin S: recentre in the frame's own coordinates, where no projection intervenes
        y = _frame_centre(H0, s0, problem)
        xc, s0 = xc + N @ y, s0 - H0 @ y
        if s0.min() <= 0:
            widening = _widening(s0, problem, free)
            s0 = s0 + widening * problem.force_scale
    return Frame(xc, N, H0, s0, free, an, widening)


def _frame_centre(H0, s0, problem) -> np.ndarray:
    """The Chebyshev centre y (d,) of {H0 y <= s0} [F0] (:func:`space.lp.inner_ball`), or
    y = 0 (the analysis' centre) when that LP has no optimum (size study, n = 2000,
    mu = 1, seed 10: every HiGHS attempt ended without one). Either way the slacks at y
    decide (:func:`_widening`): a radius <= 0 means S is thinner than HiGHS' tolerances."""
    ball = inner_ball(H0, s0, problem.force_scale)
    return np.zeros(H0.shape[1]) if ball is None else ball[0]


def _widening(s, problem, rows) -> float:
    """How far [<Fn>] to move every free row out when the frame's Chebyshev centre misses
    S by round-off: its largest violation (-min s / <Fn>) plus config.FRAME_MARGIN, the
    slack the walks start with. Size study, n = 5000, mu = 1, seed 4: S (dim 38) is
    ~1e-8 <Fn> thick in one direction and ~1 <Fn> wide in the others; with the implicit
    rows held exactly, no point of the hull is strictly inside (HiGHS' centre misses a
    row by 1.6e-8 <Fn>, and an LP with iterative refinement does no better than 2e-8).
    Beyond config.FRAME_MAX_WIDENING the frame is refused (NumericalError)."""
    miss = -float(s.min()) / problem.force_scale
    widening = miss + config.FRAME_MARGIN
    if widening > config.FRAME_MAX_WIDENING:
        raise NumericalError(f"S has no point strictly inside its affine hull: its centre "
                             f"misses inequality row {rows[int(np.argmin(s))]} by {miss:.3g} "
                             f"<Fn> (more than {config.FRAME_MAX_WIDENING:g} <Fn> may not be "
                             f"widened: S is numerically thinner than its dimension says)")
    return widening


def tolerance_description(widening: float) -> str:
    """The ensemble file's tolerance line of a walk in the frame (both uniform samplers):
    the checked violation bound, the frame's equilibrium floor and its widening, if any."""
    return (f"every sample has max violation <= {config.SAMPLE_VIOLATION} relative to <Fn> "
            "(checked), plus the equilibrium floor of the frame's directions |A T| |w| / <Fn>"
            + (f", plus the frame's widening {widening:.3g} <Fn> (S had no point strictly "
               "inside in its affine hull)" if widening else ""))


def rounding_method(n_rows: int) -> str:
    """The rounding for a polytope of ``n_rows`` inequalities: "mve" (exact, its p x p
    factorisations cost O(p^3) per iteration) up to MVE_MAX_ROWS rows, "john" (the
    Lewis-weight approximation, O(p d^2)) above: on a random polytope with p = 1200,
    d = 150 the two take 1.4 s and 0.19 s (one BLAS thread), and at the 2000-disk
    slices (p ~ 4900-7400) the MVE took 1000-2700 s."""
    return "mve" if n_rows <= config.MVE_MAX_ROWS else "john"


def rounding(H0, s0, scale, max_rounds=4, progress=False, method=None):
    """Frozen rounding: (y0 (d,), L (d, d), info) with y = y0 + L w in units of <Fn>.

    The frame coordinate is y = N^T (x - x_c) / scale; S is {H0 (scale y) <= s0}.
    ``method``: "mve" or "john" (rounding.py); None picks by :func:`rounding_method`.
    ``progress``: a bar of the iterations on stderr.
    """
    d = H0.shape[1]
    return mve_rounding(H0 * scale, s0, np.zeros(d), max_rounds=max_rounds, progress=progress,
                        method=method or rounding_method(H0.shape[0]))


BURN_IN_CHUNK = 64 * 4096   # steps per har_steps call in the burn-in (a multiple of every
                            # slack_refresh: the exact refresh falls on the same steps as in
                            # one call)


def run_burn_in(H, s0, W, states, steps, coordinate, progress=False):
    """Advance every chain (rows of W, states) by ``steps`` hit-and-run steps in place,
    in chunks of BURN_IN_CHUNK (same walk as one call), with a bar on stderr."""
    with progress_bar(total=W.shape[0] * steps, desc=f"burn-in ({W.shape[0]} chains)",
                      unit="step", disable=not progress) as bar:
        for c in range(W.shape[0]):
            done = 0
            while done < steps:
                k = min(BURN_IN_CHUNK, steps - done)
                har_steps(H, s0, W[c], states[c], k, coordinate)
                done += k
                bar.update(k)


def default_params(problem_dim: int, n_rows: int = 0, **kw) -> dict:
    d = max(problem_dim, 1)
    p = {"seed": 0, "chains": 4, "thin": max(50, d * d), "burn_in": max(500, 10 * d * d),
         "direction": "coordinate", "rounding": rounding_method(n_rows)}
    p.update({k: v for k, v in kw.items() if v is not None})
    return p


def check_options(n, chains=None, thin=None, burn_in=None, direction=None,
                  checkpoint_every=1, source="sample"):
    """Refuse meaningless hit-and-run options before any work (InputError).

    thin >= 1: with 0 steps between samples every sample would repeat the last.
    """
    require_int(source, "n", n, 1, "number of samples")
    require_int(source, "checkpoint_every", checkpoint_every, 1)
    for name, value, lo, meaning in (("chains", chains, 1, "independent chains"),
                                     ("thin", thin, 1, "steps between samples"),
                                     ("burn_in", burn_in, 0, "steps per chain before the first")):
        if value is not None:
            require_int(source, name, value, lo, meaning)
    if direction not in (None, "hypersphere", "coordinate"):
        raise InputError(source, "direction", "must be 'hypersphere' or 'coordinate'",
                         got=direction)


class _Walk:
    """Hit-and-run as a walk of :func:`forcespace.sampling.driver.run_walk`."""

    sampler = "hit-and-run"

    def __init__(self, problem: StaticsProblem, options: dict, analysis, progress: bool):
        t0, c0 = time.perf_counter(), time.process_time()
        self.problem, self.progress = problem, progress
        (self.xc, self.N, self.H0, self.s0, self.free, self.analysis,
         self.widening) = frame(problem, analysis)
        self.d = self.N.shape[1]
        self.params = default_params(self.d, self.H0.shape[0], **options)
        self.times = {"frame_s": time.perf_counter() - t0, "rounding_s": 0.0, "burn_in_s": 0.0}
        self.cpu = {"frame_s": time.process_time() - c0, "rounding_s": 0.0, "burn_in_s": 0.0}
        self.tolerance_description = tolerance_description(self.widening)
        self.floor_max = 0.0

    def set_up(self):
        """Rounding and burn-in: (setup, describe, checkpoint, checkpoint_attrs)."""
        p, d, scale = self.params, self.d, self.problem.force_scale
        xc, s0, H0, N = self.xc, self.s0, self.H0, self.N
        if d:
            t1, c1 = time.perf_counter(), time.process_time()
            y0, L, rinfo = rounding(H0, s0, scale, progress=self.progress, method=p["rounding"])
            xc = xc + scale * (N @ y0)
            s0 = s0 - scale * (H0 @ y0)
            T = scale * (N @ L)
            H = np.asfortranarray(scale * (H0 @ L))
            self.times["rounding_s"] = time.perf_counter() - t1
            self.cpu["rounding_s"] = time.process_time() - c1
        else:
            T, H, rinfo = np.zeros((N.shape[0], 0)), np.zeros((H0.shape[0], 0)), {}
        states = chain_states(p["seed"], p["chains"])
        W = np.zeros((p["chains"], d))
        t1, c1 = time.perf_counter(), time.process_time()
        if d:
            run_burn_in(H, s0, W, states, p["burn_in"], p["direction"] == "coordinate",
                        self.progress)
        self.times["burn_in_s"] = time.perf_counter() - t1
        self.cpu["burn_in_s"] = time.process_time() - c1
        self._start_chains(xc, T, H, s0, W, states)
        setup = {"x_centre": xc, "T": T, "H": np.ascontiguousarray(H), "s0": s0,
                 "free_rows": self.free,
                 "mve_axis_ratio": np.asarray(rinfo.get("axis_ratio", []), float)}
        return setup, SETUP_DESCRIPTION, {"w": W, "rng": states}, \
            {"n_done": 0, "steps_per_sample": p["thin"]}

    def resume(self, stored) -> None:
        """Continue from an ensemble file's set-up and checkpoint."""
        p, d = self.params, self.d
        try:
            W = stored.checkpoint["w"].reshape(p["chains"], d).copy()
            states = stored.checkpoint["rng"].astype(np.uint64).reshape(p["chains"], 4).copy()
        except (KeyError, ValueError) as exc:
            raise InputError(stored.ensemble.path, "checkpoint", f"corrupt ({exc}); delete "
                             "the file to restart") from None
        if not (np.all(np.isfinite(W))):
            raise InputError(stored.ensemble.path, "checkpoint/w", "must be finite (the "
                             "stored chain state was changed); delete the file to restart")
        st = stored.setup
        self._start_chains(st["x_centre"], st["T"], np.asfortranarray(st["H"]), st["s0"], W,
                           states)

    def _start_chains(self, xc, T, H, s0, W, states) -> None:
        self.xc, self.T, self.H, self.s0, self.W, self.states = xc, T, H, s0, W, states
        self.ok = (W.copy(), states.copy())      # chain state after the last accepted sample
        # The analysis keeps directions whose equilibrium residual is below its rank
        # tolerance (singular values ~1e-10 of the largest): along them equilibrium is off by
        # |A T| |w|, a floor of the frame itself (seen at 1.5e-9 <Fn> at mu = 10), allowed
        # on top of config.SAMPLE_VIOLATION.
        self.abs_AT = np.abs(self.problem.A @ T) / self.problem.force_scale if self.d \
            else np.zeros((0, 0))

    def draw(self, i: int):
        p = self.params
        c = i % p["chains"]
        W, states = self.W, self.states
        if self.d:
            bad = har_steps(self.H, self.s0, W[c], states[c], p["thin"],
                            p["direction"] == "coordinate")
            if bad > p["thin"] // 2:
                raise NumericalError("hit-and-run: most chords degenerate; S is "
                                     "(numerically) flat in a direction the analysis kept")
        x = self.xc + self.T @ W[c]
        v = self.problem.violation(x)
        floor = float((self.abs_AT @ np.abs(W[c])).max(initial=0.0)) if self.d else 0.0
        self.floor_max = max(self.floor_max, floor)
        allowed = config.SAMPLE_VIOLATION + floor + self.widening
        if not v <= allowed:
            raise NumericalError(f"hit-and-run sample {i} violates S by {v:.3e} x "
                                 f"<Fn> (> {allowed:.3e})")
        self.ok[0][c], self.ok[1][c] = W[c], states[c]
        return x, c, v

    def state(self, n_total: int):
        return ({"w": self.ok[0], "rng": self.ok[1]},
                {"n_done": n_total, "steps_per_sample": self.params["thin"]})


SETUP_DESCRIPTION = {
    "x_centre": ("F0", "centre of the rounding ellipsoid of S (origin of w)"),
    "T": ("F0", "x = x_centre + T w: affine frame x frozen rounding (params: 'rounding')"),
    "H": ("1", "non-implicit inequalities H w <= s0"),
    "s0": ("F0", "slack of the inequalities at the centre"),
    "free_rows": ("1", "rows of problem.inequalities() kept"),
    "mve_axis_ratio": ("1", "axis ratio of the MVE in each rounding pass (last ~1: rounded)")}


class HitAndRun(FrameSampler):
    """Uniform samples of S by coordinate hit-and-run (compute object).

    ``HitAndRun(n=100, seed=1).compute(problem)`` draws ``n`` samples in memory;
    ``compute(problem, output=PATH)`` writes (and resumes) an ensemble file instead.
    Parameters: ``chains`` (default 4), ``thin`` steps between samples (default
    max(50, d^2)), ``burn_in`` steps per chain (default max(500, 10 d^2)),
    ``direction`` "coordinate" (default) or "hypersphere"; ``max_seconds`` stops early
    (status 1, every sample drawn kept); ``target_ess``: stop as soon as every tracked
    statistic has bulk and tail ESS >= target_ess and split R-hat <= 1.05 (``n`` is then
    the cap; reaching it first is status 1); ``progress`` shows bars on stderr.
    Results: ``ensemble`` (:class:`~forcespace.sampling.ensemble.Ensemble`, with the
    convergence diagnostics), and the run's ``dim``, ``n_rows``, ``times``,
    ``frame_equality_floor``.
    """

    def __init__(self, n: int = 100, seed: int = 0, chains: int | None = None,
                 thin: int | None = None, burn_in: int | None = None,
                 direction: str | None = None, max_seconds: float | None = None,
                 checkpoint_every: int = 10, progress: bool = False,
                 target_ess: float | None = None):
        check_options(n, chains, thin, burn_in, direction, checkpoint_every)
        check_target(target_ess)
        self.n, self.seed, self.progress = n, seed, progress
        self.max_seconds, self.checkpoint_every = max_seconds, checkpoint_every
        self.target_ess = target_ess
        self.options = dict(seed=seed, chains=chains, thin=thin, burn_in=burn_in,
                            direction=direction)

    def compute(self, problem: StaticsProblem, output=None, analysis=None) -> "HitAndRun":
        """Sample S of ``problem``; ``analysis``: its ForceSpace, if already computed."""
        t0, c0 = time.perf_counter(), time.process_time()
        walk = _Walk(problem, self.options, analysis, self.progress)
        stop = Stop(self.n, self.max_seconds, self.target_ess, walk.params["chains"],
                    walk.params["seed"])
        ens = run_walk(walk, problem, stop, output, self.checkpoint_every, self.progress,
                       t_start=t0)
        self._start()
        wall = time.perf_counter() - t0
        times = dict(walk.times, wall_time_s=wall,
                     sampling_s=wall - sum(walk.times.values()))
        cpu_total = time.process_time() - c0
        cpu = dict(walk.cpu, sampling_s=cpu_total - sum(walk.cpu.values()), total_s=cpu_total)
        self._results.update(ensemble=ens, dim=walk.d, n_rows=int(walk.H0.shape[0]),
                             times=times, cpu=cpu, frame_equality_floor=walk.floor_max,
                             frame_widening=walk.widening,
                             params=walk.params)
        self._finish(ens.status, ens.message)
        return self

    def summary(self) -> dict:
        """The run's numbers (what ``forcespace sample --json`` prints)."""
        ens = self.ensemble
        return {"n_samples": ens.n_samples, "dim_S": self.dim, "n_rows": self.n_rows,
                **self.times, "cpu": self.cpu, "frame_equality_floor": self.frame_equality_floor,
                "frame_widening": self.frame_widening,
                "max_violation": float(ens.violations.max(initial=0.0)),
                "params": self.params, "status": self.status, "message": self.message,
                **ens.diagnostics}

