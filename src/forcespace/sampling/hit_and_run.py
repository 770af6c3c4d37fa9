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

import numpy as np

from .. import config
from ..errors import InputError, NumericalError, require_int
from ..kernels import kernel
from ..progress import progress as progress_bar
from ..streams import chain_states
from .conic_walk import ConicHitAndRunWalk, pyramid_frame
from .driver import FrameSampler
from .frame import FrameWalk
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
    require_int(source, "n", n, 1, "number of samples", config.MAX_SAMPLES)
    require_int(source, "checkpoint_every", checkpoint_every, 1)
    for name, value, lo, meaning, hi in (
            ("chains", chains, 1, "independent chains", config.MAX_CHAINS),
            ("thin", thin, 1, "steps between samples", config.MAX_HAR_THIN),
            ("burn_in", burn_in, 0, "steps per chain before the first",
             config.MAX_HAR_BURN_IN)):
        if value is not None:
            require_int(source, name, value, lo, meaning, hi)
    if direction not in (None, "hypersphere", "coordinate"):
        raise InputError(source, "direction", "must be 'hypersphere' or 'coordinate'",
                         got=direction)


SETUP_DESCRIPTION = {
    "x_centre": ("F0", "centre of the rounding ellipsoid of S (origin of w)"),
    "T": ("F0", "x = x_centre + T w: affine frame x frozen rounding (params: 'rounding')"),
    "H": ("1", "non-implicit inequalities H w <= s0"),
    "s0": ("F0", "slack of the inequalities at the centre"),
    "free_rows": ("1", "rows of problem.inequalities() kept"),
    "mve_axis_ratio": ("1", "axis ratio of the MVE in each rounding pass (last ~1: rounded)")}


class HitAndRunFrameWalk(FrameWalk):
    """Hit-and-run in the rounded frame (:class:`~forcespace.sampling.frame.FrameWalk`):
    ``thin`` steps of chain i % chains between its samples."""

    sampler = "hit-and-run"
    SETUP_DESCRIPTION = SETUP_DESCRIPTION

    def default_params(self, options: dict) -> dict:
        return default_params(self.d, self.H0.shape[0], **options)

    def round(self):
        return rounding(self.H0, self.frame.s0, self.problem.force_scale,
                        progress=self.progress, method=self.params["rounding"])

    def start_chains(self, H, s):
        p = self.params
        self.H, self.s0 = np.asfortranarray(H), s
        self.states = chain_states(p["seed"], p["chains"])
        self.W = np.zeros((p["chains"], self.d))
        t1, c1 = time.perf_counter(), time.process_time()
        if self.d:
            run_burn_in(self.H, s, self.W, self.states, p["burn_in"],
                        p["direction"] == "coordinate", self.progress)
        self.times["burn_in_s"] = time.perf_counter() - t1
        self.cpu["burn_in_s"] = time.process_time() - c1
        return self.H, s

    def setup_extra(self) -> dict:
        return {"mve_axis_ratio": np.asarray(self.rounding_info.get("axis_ratio", []), float)}

    def resume_chains(self, setup, checkpoint, state) -> None:
        self.H, self.s0 = np.asfortranarray(setup["H"]), setup["s0"]
        self.W, self.states = state["w"], state["rng"]

    def chain_arrays(self) -> tuple:
        return self.W, self.states

    def advance(self, c: int) -> None:
        thin = self.params["thin"]
        bad = har_steps(self.H, self.s0, self.W[c], self.states[c], thin,
                        self.params["direction"] == "coordinate")
        if bad > thin // 2:
            raise NumericalError("hit-and-run: most chords degenerate; S is "
                                 "(numerically) flat in a direction the analysis kept")

    def state_attrs(self) -> dict:
        return {"steps_per_sample": self.params["thin"]}


class PyramidHitAndRunWalk(HitAndRunFrameWalk):
    """Hit-and-run (the polytopes' walk, rounding and kernel) on S of spheres with every
    cone replaced by its inscribed k-sided pyramid
    (:func:`~forcespace.sampling.conic_walk.pyramid_frame`): the cross-check by pyramids.
    Its samples lie in S (the pyramids are inside the cones)."""

    def __init__(self, problem, options: dict, analysis, progress: bool):
        options = dict(options)
        self.sides = int(options.pop("pyramids"))
        super().__init__(problem, options, analysis, progress)
        self.params["pyramids"] = self.sides

    def make_frame(self, problem, analysis):
        return pyramid_frame(problem, self.sides, analysis)


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
    Results: ``ensemble`` (:class:`~forcespace.model.ensemble.Ensemble`, with the
    convergence diagnostics), and the run's ``dim``, ``n_rows``, ``times``,
    ``frame_equality_floor``. A sphere problem (:mod:`forcespace.model.sphere_problem`)
    is sampled with exact chords through its cones
    (:class:`~forcespace.sampling.conic_walk.ConicHitAndRunWalk`; rounding fit to
    circumscribed pyramids); with ``pyramids`` k, the cones replaced by inscribed k-sided
    pyramids instead (:class:`PyramidHitAndRunWalk`, the cross-check).
    """

    Walk = HitAndRunFrameWalk
    ConicWalk = ConicHitAndRunWalk

    def walk_for(self, problem):
        """With ``pyramids`` k: the pyramids' polytope walk on S of spheres."""
        walk = super().walk_for(problem)
        if self.options.get("pyramids") is None:
            self.options.pop("pyramids", None)
            return walk
        if walk is not self.ConicWalk:
            raise InputError("HitAndRun", "pyramids", "applies to S of spheres only",
                             got=self.options["pyramids"])
        return PyramidHitAndRunWalk

    def __init__(self, n: int = 100, seed: int = 0, chains: int | None = None,
                 thin: int | None = None, burn_in: int | None = None,
                 direction: str | None = None, max_seconds: float | None = None,
                 checkpoint_every: int = 10, progress: bool = False,
                 target_ess: float | None = None, pyramids: int | None = None):
        check_options(n, chains, thin, burn_in, direction, checkpoint_every)
        if pyramids is not None:
            require_int("HitAndRun", "pyramids", pyramids, 3, "sides of the inscribed "
                        "pyramids", 4096)
        super().__init__(n, seed, max_seconds, checkpoint_every, progress, target_ess,
                         chains=chains, thin=thin, burn_in=burn_in, direction=direction,
                         pyramids=pyramids)
