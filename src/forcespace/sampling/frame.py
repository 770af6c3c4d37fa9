"""The affine frame of S the uniform walks move in, and what the walks share.

S in its affine hull: x = xc + N y for the points y of {H0 y <= s0} (:func:`frame`);
rounded by an ellipsoid {y0 + L w : |w| <= 1} inscribed in it (each walk its own:
hit-and-run the MVE or John's, the billiard walk Lewis weights), the walks move w in
{H w <= s} with x = x_centre + T w (:meth:`Frame.rounded`). :class:`FrameWalk` is the
template of both uniform walks for :func:`forcespace.sampling.driver.run_walk`: the
frame and its timing, the set-up in three steps (round, start the chains, burn in; the
walk fills each), the check of every sample against S up to the frame's equilibrium
floor and widening, and the chains' state after the last accepted sample.

Units: x, xc, s [F0]; y, w in the frame's own units (y in <Fn>); widening [<Fn>].
"""
from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from .. import config
from ..errors import InputError, NumericalError
from ..linalg import onto_affine_hull
from ..model.problem import StaticsProblem
from ..space.force_space import ForceSpace
from ..space.lp import inner_ball
from ..space.questions import check_bounded


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

    def rounded(self, y0, L, scale: float, HL=None):
        """The frame rounded by the ellipsoid {y0 + L w} (y in units of ``scale`` =
        <Fn>): (x_centre (2m,), T (2m, d), H (p, d), s (p,)) with x = x_centre + T w and
        the free rows H w <= s. ``HL``: scale H0 L when the rounding has it already
        (rounding.lewis_rounding(mapped=True)); L is then upper triangular and T is
        formed by a triangular product (half the flops of a general one)."""
        xc = self.xc + scale * (self.N @ y0)
        s = self.s0 - scale * (self.H0 @ y0)
        if HL is None:
            return xc, scale * (self.N @ L), scale * (self.H0 @ L), s
        from scipy.linalg.blas import dtrmm
        # T^T = scale L^T N^T: N^T is N's Fortran-ordered view, no copy
        T = dtrmm(scale, L, self.N.T, side=0, lower=0, trans_a=1).T
        return xc, np.ascontiguousarray(T), HL, s

    def unrounded(self):
        """The frame of a zero-dimensional S: (x_centre, T (2m, 0), H (p, 0), s0)."""
        return (self.xc, np.zeros((self.N.shape[0], 0)), np.zeros((self.H0.shape[0], 0)),
                self.s0)


def sampled_analysis(problem, analysis=None, centre: bool = True, boundedness: bool = True):
    """The analysis of S a walk starts from (``analysis``, else ForceSpace's, without the
    varying-contacts LPs: no walk reads them, and they were most of the set-up of a dim-200
    slice; with the Chebyshev centre unless ``centre`` is False; without the boundedness
    LP if ``boundedness`` is False: the walk then proves S bounded itself,
    :func:`refuse_unbounded`): NumericalError if it failed, InputError if S is empty or
    unbounded, NumericalError if a centre was asked for and is missing."""
    an = analysis if analysis is not None else \
        ForceSpace(ranges=False, centre=centre, varying=False,
                   boundedness=boundedness).compute(problem)
    if not an.success:
        raise NumericalError(f"analysis of S failed: {an.message}")
    if not an.feasible:
        raise InputError(problem.source or "problem", "S", "is empty (infeasible): nothing to sample")
    if an.bounded is None and boundedness:
        raise InputError("analysis", "bounded", "must be decided for this walk (an analysis "
                         "by ForceSpace(boundedness=True))", got=None)
    if an.bounded is False:
        _refuse(problem)
    if centre and an.centre is None:
        raise NumericalError("no Chebyshev centre computed")
    return an


def _refuse(problem):
    raise InputError(problem.source or "problem", "S",
                     "is unbounded (a recession direction exists, e.g. a wedged contact); "
                     "refusing to sample")


def refuse_unbounded(problem, proven: bool) -> None:
    """For a frame whose analysis left boundedness undecided (:func:`frame` with
    ``boundedness=False``): nothing if the walk's rounding ``proven`` S bounded, else the
    exact recession-cone LP decides (InputError if S is unbounded)."""
    if not proven and not check_bounded(problem)[0]:
        _refuse(problem)


def on_large_path(problem) -> bool:
    """Whether S of ``problem`` is on the analysis' large path (config.SWEEP_MIN_COLUMNS
    columns and up: interior-point LPs): the frame starts at the analysis' interior point
    (:func:`frame_start`), and the billiard walk rounds and burns in more cheaply."""
    return problem.n_columns >= config.SWEEP_MIN_COLUMNS


def frame_start(an, N) -> np.ndarray:
    """The point of S's affine hull (2m,) [F0] the frame is centred at: the analysis'
    Chebyshev centre if it has one, else (the large path, config.SWEEP_MIN_COLUMNS columns
    and up) the interior point of its strict-rows LP (max sum of capped slacks: every row
    strict in S has slack >= config.INTERIOR_STRICT <Fn> there) projected onto the hull.
    The rounding re-centres from it (to its analytic centre), so the Chebyshev centre's LP,
    9 of the 21 CPU s of the dim-1714 slice's analysis, is not needed; a start on a facet
    (slack <= 0 after the projection) is recentred by :func:`frame` as before."""
    if an.centre is not None:
        return onto_affine_hull(an.centre, an.affine_point, N)
    return an.affine_point


def frame(problem: StaticsProblem, analysis=None, boundedness: bool = True) -> Frame:
    """The affine frame of S (:class:`Frame`), centred at :func:`frame_start`.

    The free rows are the inequalities that are neither implicit equalities nor
    constant on the affine hull (|G_i N| <= FLAT_ROW). ``boundedness`` False: the
    analysis skips its boundedness LP (``analysis.bounded`` None) and the caller must
    decide it (:func:`refuse_unbounded`) before walking."""
    an = sampled_analysis(problem, analysis, centre=not on_large_path(problem),
                          boundedness=boundedness)
    G, _, _ = problem.inequalities()
    free = np.setdiff1d(np.arange(G.shape[0]), an.implicit_rows)
    N = an.affine_basis
    xc = frame_start(an, N)
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
    y = 0 (the analysis' centre) when that LP has no optimum (the case:
    studies/field_notes.md). Either way the slacks at y decide (:func:`_widening`): a
    radius <= 0 means S is thinner than HiGHS' tolerances."""
    ball = inner_ball(H0, s0, problem.force_scale)
    return np.zeros(H0.shape[1]) if ball is None else ball[0]


def _widening(s, problem, rows) -> float:
    """How far [<Fn>] to move every free row out when the frame's Chebyshev centre misses
    S by round-off: its largest violation (-min s / <Fn>) plus config.FRAME_MARGIN, the
    slack the walks start with (a thin S whose centre misses a row by round-off:
    studies/field_notes.md). Beyond config.FRAME_MAX_WIDENING the frame is refused
    (NumericalError)."""
    miss = -float(s.min()) / problem.force_scale
    widening = miss + config.FRAME_MARGIN
    if widening > config.FRAME_MAX_WIDENING:
        raise NumericalError(f"S has no point strictly inside its affine hull: its centre "
                             f"misses inequality row {rows[int(np.argmin(s))]} by {miss:.3g} "
                             f"<Fn> (more than {config.FRAME_MAX_WIDENING:g} <Fn> may not be "
                             f"widened: S is numerically thinner than its dimension says)")
    return widening


def _abs_scaled(M, scale: float) -> np.ndarray:
    """|M| / scale in M's own memory (M (k, d) a fresh product: |A T| of the frame, 3n x d,
    124 MB at dim 1714; two temporaries fewer at the set-up's peak, the same numbers)."""
    M = np.asarray(M)
    np.abs(M, out=M)
    M /= scale
    return M


def tolerance_description(widening: float) -> str:
    """The ensemble file's tolerance line of a walk in the frame (both uniform samplers):
    the checked violation bound, the frame's equilibrium floor and its widening, if any."""
    return (f"every sample has max violation <= {config.SAMPLE_VIOLATION} relative to <Fn> "
            "(checked), plus the equilibrium floor of the frame's directions |A T| |w| / <Fn>"
            + (f", plus the frame's widening {widening:.3g} <Fn> (S had no point strictly "
               "inside in its affine hull)" if widening else ""))




class FrameWalk:
    """What the uniform walks (hit-and-run, billiard) share, as a walk of
    :func:`forcespace.sampling.driver.run_walk`: sample i is drawn by chain i % chains.

    A walk sets ``sampler``, ``SETUP_DESCRIPTION`` and ``STATE``: the names of its chain
    state arrays (rows per chain; the first is the position w), and fills
    :meth:`default_params`, :meth:`round` ((y0, L, info) of the frame at <Fn> scale),
    :meth:`start_chains` (the chains on {H w <= s} from the rounded frame, burnt in),
    :meth:`setup_extra` (its own set-up arrays), :meth:`resume_chains` (from a
    checkpoint), :meth:`advance` (move chain c to its next sample) and
    :meth:`state_attrs`. Times: ``times`` (wall) and ``cpu`` (process) seconds per stage.
    """

    sampler = ""
    SETUP_DESCRIPTION: dict = {}
    STATE: tuple = ("w", "rng")

    def __init__(self, problem: StaticsProblem, options: dict, analysis, progress: bool):
        t0, c0 = time.perf_counter(), time.process_time()
        self.problem, self.progress = problem, progress
        self.frame = self.make_frame(problem, analysis)
        self.free, self.widening = self.frame.free, self.frame.widening
        self.H0 = self.frame.H0
        self.d = self.frame.N.shape[1]
        self.params = self.default_params(options)
        self.times = {"frame_s": time.perf_counter() - t0, "rounding_s": 0.0,
                      "burn_in_s": 0.0}
        self.cpu = {"frame_s": time.process_time() - c0, "rounding_s": 0.0,
                    "burn_in_s": 0.0, "sampling_s": 0.0}
        self.tolerance_description = tolerance_description(self.widening)
        self.kept = []          # w of every sample drawn (the frame floor, at the end)
        self.rounding_info = {}

    # ---- the template -----------------------------------------------------------------
    def set_up(self):
        """Round, start and burn in the chains: (setup, describe, checkpoint arrays,
        checkpoint attrs) for the ensemble file."""
        t1, c1 = time.perf_counter(), time.process_time()
        if self.d:
            y0, L, self.rounding_info, *HL = self.round()      # HL: the rows mapped, if
            xc, T, H, s = self.frame.rounded(y0, L, self.problem.force_scale, *HL)
        else:
            xc, T, H, s = self.frame.unrounded()
        self.times["rounding_s"] = time.perf_counter() - t1
        self.cpu["rounding_s"] = time.process_time() - c1
        H, s = self.start_chains(H, s)
        self._start(xc, T)
        setup = {"x_centre": xc, "T": T, "H": np.ascontiguousarray(H), "s0": s,
                 "free_rows": self.free, **self.setup_extra()}
        arrays, attrs = self.state(0)
        return setup, self.SETUP_DESCRIPTION, arrays, attrs

    def resume(self, stored) -> None:
        """Continue from an ensemble file's set-up and checkpoint."""
        chains = self.params["chains"]
        try:
            state = {"w": stored.checkpoint["w"].reshape(chains, self.d).copy(),
                     "rng": stored.checkpoint["rng"].astype(np.uint64).reshape(chains, 4).copy()}
            self.resume_chains(stored.setup, stored.checkpoint, state)
        except (KeyError, ValueError) as exc:
            raise InputError(stored.ensemble.path, "checkpoint", f"corrupt ({exc}); delete "
                             "the file to restart") from None
        if not all(np.all(np.isfinite(state[k])) for k in state if k != "rng"):
            raise InputError(stored.ensemble.path, "checkpoint/w", "must be finite (the "
                             "stored chain state was changed); delete the file to restart")
        self._start(stored.setup["x_centre"], stored.setup["T"])

    def _start(self, xc, T) -> None:
        self.xc, self.T = xc, T
        self.ok = tuple(a.copy() for a in self.chain_arrays())   # after the last sample
        # The analysis keeps directions whose equilibrium residual is below its rank
        # tolerance (singular values ~1e-10 of the largest): along them equilibrium is off
        # by |A T| |w|, a floor of the frame itself (seen at 1.5e-9 <Fn> at mu = 10),
        # allowed on top of config.SAMPLE_VIOLATION.
        self.abs_AT = _abs_scaled(self.problem.A @ T, self.problem.force_scale) if self.d \
            else np.zeros((0, 0))

    def floor(self, W) -> np.ndarray:
        """Equilibrium floor |A T| |w| / <Fn> of the frame at the states W (k, d)."""
        if not self.d:                  # S is a point: no direction, no floor
            return np.zeros(len(W) if np.ndim(W) != 1 else 1)
        W = np.asarray(W, float).reshape(-1, self.d)
        if not len(W):
            return np.zeros(0)
        return (np.abs(W) @ self.abs_AT.T).max(1)

    def draw(self, i: int):
        """Sample i (chain i % chains): (x (2m,) [F0], chain, violation / <Fn>)."""
        c0 = time.process_time()
        c = i % self.params["chains"]
        if self.d:
            self.advance(c)
        w = self.chain_arrays()[0][c]
        x = self.xc + self.T @ w
        v = self.problem.violation(x)
        if not v <= config.SAMPLE_VIOLATION:     # the floor is computed only when needed
            allowed = config.SAMPLE_VIOLATION + float(self.floor(w)[0]) + self.widening
            if not v <= allowed:
                raise NumericalError(f"{self.sampler} sample {i} violates S by {v:.3e} x "
                                     f"<Fn> (> {allowed:.3e})")
        for saved, now in zip(self.ok, self.chain_arrays()):
            saved[c] = now[c]
        self.kept.append(w.copy())
        self.cpu["sampling_s"] += time.process_time() - c0
        return x, c, v

    def state(self, n_total: int):
        """The checkpoint: the chains after their last accepted sample, and attrs."""
        return dict(zip(self.STATE, self.ok)), dict(n_done=n_total, **self.state_attrs())

    @property
    def frame_equality_floor(self) -> float:
        """Largest equilibrium floor of the frame at a sample drawn, / <Fn>."""
        return float(self.floor(self.kept).max(initial=0.0))

    # ---- what each walk fills ---------------------------------------------------------
    def min_draws_per_chain(self) -> int:
        """Draws per chain before a target-ESS run's first check (driver.Stop)."""
        return config.MIN_DRAWS_PER_CHAIN

    def make_frame(self, problem, analysis) -> Frame:
        """The walk's frame of S (polytopes: :func:`frame`)."""
        return frame(problem, analysis)

    def default_params(self, options: dict) -> dict:
        raise NotImplementedError

    def round(self):
        raise NotImplementedError

    def start_chains(self, H, s):
        raise NotImplementedError

    def chain_arrays(self) -> tuple:
        raise NotImplementedError

    def setup_extra(self) -> dict:
        return {}

    def resume_chains(self, setup, checkpoint, state) -> None:
        raise NotImplementedError

    def advance(self, c: int) -> None:
        raise NotImplementedError

    def state_attrs(self) -> dict:
        return {}
