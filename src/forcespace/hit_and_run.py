"""Uniform sampling of S by hit-and-run (Smith 1984) in its affine hull.

Coordinates: x = x_c + T w, with x_c the centre of the MVE of S, T = N L where
N (2m, d) is an orthonormal basis of the affine hull of S (d = dim S, from
polytope.analyze) and L (d, d) a fixed rounding matrix. The non-implicit
inequalities become ``H w <= s0`` with H = G T, s0 = -G x_c (>= 0).

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

Random numbers: xoshiro256** per chain inside numba (state 4 x uint64),
saved in the checkpoint so that a resumed run continues the same streams.

Diagnostics: split R-hat and a bulk effective sample size (Geyer initial
monotone sequence) of the per-sample scalar |x - mean|^2 (the quantity η
averages) and of three fixed random projections; per-chain η.
"""
from __future__ import annotations

import json
import sys
import time

import numpy as np
from numba import njit

from . import ensemble_file as ef
from .errors import InputError, NumericalError, require_int
from .polytope import analyze
from .statics import StaticsProblem

MAX_VIOLATION = 1e-9   # every sample: max violation of S relative to <Fn>


# ----------------------------------------------------------------------------
# kernels
# ----------------------------------------------------------------------------
@njit(cache=True)
def _rotl(x, k):
    return (x << np.uint64(k)) | (x >> np.uint64(64 - k))


@njit(cache=True)
def _next(s):
    """xoshiro256** step on state s (4,) uint64; returns a uint64."""
    result = _rotl(s[1] * np.uint64(5), 7) * np.uint64(9)
    t = s[1] << np.uint64(17)
    s[2] ^= s[0]
    s[3] ^= s[1]
    s[1] ^= s[2]
    s[0] ^= s[3]
    s[2] ^= t
    s[3] = _rotl(s[3], 45)
    return result


@njit(cache=True)
def _uniform(s):
    """Uniform double in [0, 1)."""
    return float(_next(s) >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(cache=True)
def _normal(s):
    """Standard normal (Box-Muller, one of the pair)."""
    u1 = _uniform(s)
    while u1 <= 0.0:
        u1 = _uniform(s)
    u2 = _uniform(s)
    return np.sqrt(-2.0 * np.log(u1)) * np.cos(2.0 * np.pi * u2)


@njit(cache=True)
def slack_refresh(d):
    """Steps between exact slack recomputations: 64 up to d = 64, else the power-of-two
    multiple of 64 at or above d (so the O(p d) product costs O(p) per step; the
    update's round-off grows like sqrt(steps) eps, negligible)."""
    r = 64
    while r < d and r < 64 * 4096:
        r *= 2
    return r


@njit(cache=True)
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
            c = int(_uniform(state) * d)
            if c >= d:
                c = d - 1
            hu = H[:, c]                 # a column: contiguous with H in Fortran order
        else:
            nrm = 0.0
            for i in range(d):
                u[i] = _normal(state)
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
        r = _uniform(state)
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


def seed_states(seed: int, n_chains: int) -> np.ndarray:
    """Independent xoshiro states (n_chains, 4) uint64 from numpy's SeedSequence."""
    ss = np.random.SeedSequence(seed)
    return np.array([c.generate_state(4, dtype=np.uint64) for c in ss.spawn(n_chains)],
                    dtype=np.uint64)


# ----------------------------------------------------------------------------
# diagnostics
# ----------------------------------------------------------------------------
def split_rhat(chains: list[np.ndarray]) -> float:
    """Split-R-hat (Gelman et al.) of a scalar over chains of equal length (>= 4)."""
    k = min(len(c) for c in chains)
    if k < 4:
        return float("nan")
    half = k // 2
    parts = []
    for c in chains:
        parts += [np.asarray(c[:half]), np.asarray(c[half:2 * half])]
    parts = np.array(parts)
    n = parts.shape[1]
    B = n * parts.mean(1).var(ddof=1)
    W = parts.var(1, ddof=1).mean()
    if W == 0:
        return 1.0 if B == 0 else float("inf")
    var = (n - 1) / n * W + B / n
    return float(np.sqrt(var / W))


def ess(chains: list[np.ndarray]) -> float:
    """Effective sample size over chains (Geyer initial monotone sequence)."""
    k = min(len(c) for c in chains)
    if k < 4:
        return float("nan")
    X = np.array([np.asarray(c[:k], float) for c in chains])
    M = X.shape[0]
    mean = X.mean()
    var = X.var()
    if var == 0:
        return float(M * k)
    rho = []
    for lag in range(k):
        ac = np.mean([np.mean((x[:k - lag] - mean) * (x[lag:] - mean)) for x in X]) / var
        rho.append(ac)
    rho = np.array(rho)
    tau = -1.0
    prev = np.inf
    for t in range(0, k - 1, 2):
        pair = rho[t] + rho[t + 1]
        if pair < 0:
            break
        pair = min(pair, prev)
        prev = pair
        tau += 2 * pair
    tau = max(tau, 1.0)
    return float(M * k / tau)


def diagnostics(samples: np.ndarray, chains: np.ndarray, seed: int = 0) -> dict:
    """R-hat / ESS of |x - mean|^2 and of 3 random projections; per-chain eta."""
    from .measures import eta as eta_fn

    X = np.asarray(samples, float)
    ids = np.unique(chains)
    out = {"n_chains": int(ids.size)}
    if X.shape[0] < 8:
        return out
    mean = X.mean(0)
    q = ((X - mean) ** 2).sum(1)
    per = [q[chains == c] for c in ids]
    out["rhat_sqdev"] = split_rhat(per)
    out["ess_sqdev"] = ess(per)
    rng = np.random.default_rng(seed)
    rh = []
    es = []
    for _ in range(3):
        v = rng.normal(size=X.shape[1])
        pr = X @ v
        per = [pr[chains == c] for c in ids]
        rh.append(split_rhat(per))
        es.append(ess(per))
    # chains too short for split R-hat / ESS give NaN: reported as None, not a warning
    rh, es = np.asarray(rh, float), np.asarray(es, float)
    out["rhat_projections_max"] = float(rh[np.isfinite(rh)].max()) if np.isfinite(rh).any() \
        else None
    out["ess_projections_min"] = float(es[np.isfinite(es)].min()) if np.isfinite(es).any() \
        else None
    out["eta_per_chain"] = [float(eta_fn(X[chains == c])) if (chains == c).sum() > 1
                            else float("nan") for c in ids]
    return out


# ----------------------------------------------------------------------------
# set-up and driver
# ----------------------------------------------------------------------------
FLAT_ROW = 1e-9   # |G_i N| below this: row i is constant on S (G rows and N columns O(1))


def frame(problem: StaticsProblem, analysis=None):
    """Affine frame of S: (x_c (2m,), N (2m, d), H0 = G_free N (p, d), s0 (p,), free rows).

    The free rows are the inequalities that are neither implicit equalities nor
    constant on the affine hull (|G_i N| <= FLAT_ROW)."""
    an = analysis if analysis is not None else analyze(problem, ranges=False, centre=True)
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
    xc = an.affine_point + N @ (N.T @ (an.centre - an.affine_point))
    H0 = np.asarray(G[free] @ N)
    s0 = -np.asarray(G[free] @ xc)
    # rows orthogonal to the affine hull up to round-off are constant on S: with a slack
    # within round-off of 0 they are implicit equalities the LP test missed (their
    # slack, +-1e-11, would stop the rounding), with a positive one they never bind
    flat = np.linalg.norm(H0, axis=1) <= FLAT_ROW
    bad = flat & (s0 < -MAX_VIOLATION * problem.force_scale)
    if bad.any():
        raise NumericalError(f"the centre of S violates inequality row {free[bad][0]} by "
                             f"{-s0[bad].min() / problem.force_scale:.3g} <Fn>, and no point "
                             f"of the affine hull satisfies it better")
    return xc, N, H0[~flat], s0[~flat], free[~flat], an


MVE_MAX_ROWS = 1500   # more inequality rows: John (Lewis-weight) rounding, not the exact MVE


def rounding_method(n_rows: int) -> str:
    """The rounding for a polytope of ``n_rows`` inequalities: "mve" (exact, its p x p
    factorisations cost O(p^3) per iteration) up to MVE_MAX_ROWS rows, "john" (the
    Lewis-weight approximation, O(p d^2)) above: on a random polytope with p = 1200,
    d = 150 the two take 1.4 s and 0.19 s (one BLAS thread), and at the 2000-disk
    slices (p ~ 4900-7400) the MVE took 1000-2700 s."""
    return "mve" if n_rows <= MVE_MAX_ROWS else "john"


def rounding(H0, s0, scale, max_rounds=4, progress=False, method=None):
    """Frozen rounding: (y0 (d,), L (d, d), info) with y = y0 + L w in units of <Fn>.

    The frame coordinate is y = N^T (x - x_c) / scale; S is {H0 (scale y) <= s0}.
    ``method``: "mve" or "john" (rounding.py); None picks by :func:`rounding_method`.
    ``progress``: a bar of the iterations on stderr.
    """
    from .rounding import mve_rounding

    d = H0.shape[1]
    return mve_rounding(H0 * scale, s0, np.zeros(d), max_rounds=max_rounds, progress=progress,
                        method=method or rounding_method(H0.shape[0]))


BURN_IN_CHUNK = 64 * 4096   # steps per har_steps call in the burn-in (a multiple of every
                            # slack_refresh: the exact refresh falls on the same steps as in
                            # one call)


def run_burn_in(H, s0, W, states, steps, coordinate, progress=False):
    """Advance every chain (rows of W, states) by ``steps`` hit-and-run steps in place,
    in chunks of BURN_IN_CHUNK (same walk as one call), with a bar on stderr."""
    from .progress import progress as progress_bar

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


def sample(problem: StaticsProblem, n: int, out, packing_file: str = "", scene_name: str = "",
           scene_text: str = "", seed: int = 0, chains: int | None = None, thin: int | None = None,
           burn_in: int | None = None, direction: str | None = None,
           checkpoint_every: int = 10, progress: bool = False, analysis=None,
           max_seconds: float | None = None) -> dict:
    """Write ``n`` uniform samples of S to ``out`` (resumes if ``out`` continues this run).

    Returns a summary dict (n_samples, dim_S, n_rows of the rounded polytope, wall
    time and its parts frame_s (analysis and frame), rounding_s, burn_in_s (0 when
    resumed) and sampling_s (the rest), max violation, diagnostics).
    """
    check_options(n, chains, thin, burn_in, direction, checkpoint_every)
    t0 = time.perf_counter()
    xc, N, H0, s0, free, an = frame(problem, analysis)
    d = N.shape[1]
    params = default_params(d, H0.shape[0], seed=seed, chains=chains, thin=thin,
                            burn_in=burn_in, direction=direction)
    ens = ef.existing(out, problem, "hit-and-run", params)
    times = {"frame_s": time.perf_counter() - t0, "rounding_s": 0.0, "burn_in_s": 0.0}
    if ens is None:
        scale = problem.force_scale
        if d:
            t1 = time.perf_counter()
            y0, L, rinfo = rounding(H0, s0, scale, progress=progress,
                                    method=params["rounding"])
            xc = xc + scale * (N @ y0)
            s0 = s0 - scale * (H0 @ y0)
            T = scale * (N @ L)
            H = np.asfortranarray(scale * (H0 @ L))
            times["rounding_s"] = time.perf_counter() - t1
        else:
            T, H, rinfo = np.zeros((N.shape[0], 0)), np.zeros((H0.shape[0], 0)), {}
        ratios = np.asarray(rinfo.get("axis_ratio", []), float)
        states = seed_states(params["seed"], params["chains"])
        W = np.zeros((params["chains"], d))
        t1 = time.perf_counter()
        if d:
            run_burn_in(H, s0, W, states, params["burn_in"], params["direction"] == "coordinate",
                        progress)
        times["burn_in_s"] = time.perf_counter() - t1
        ef.create(out, problem, "hit-and-run", params, packing_file, scene_name, scene_text,
                  setup={"x_centre": xc, "T": T, "H": np.ascontiguousarray(H), "s0": s0,
                         "free_rows": free, "mve_axis_ratio": ratios},
                  setup_describe={"x_centre": ("F0", "centre of the rounding ellipsoid "
                                               "of S (origin of w)"),
                                  "T": ("F0", "x = x_centre + T w: affine frame x frozen "
                                         "rounding (params: 'rounding')"),
                                  "H": ("1", "non-implicit inequalities H w <= s0"),
                                  "s0": ("F0", "slack of the inequalities at the centre"),
                                  "free_rows": ("1", "rows of problem.inequalities() kept"),
                                  "mve_axis_ratio": ("1", "axis ratio of the MVE in each "
                                                     "rounding pass (last ~1: rounded)")},
                  checkpoint={"w": W, "rng": states},
                  checkpoint_attrs={"n_done": 0, "steps_per_sample": params["thin"]},
                  tolerance_description=f"every sample has max violation <= {MAX_VIOLATION} "
                                        f"relative to <Fn> (checked), plus the equilibrium "
                                        f"floor of the frame's directions |A T| |w| / <Fn>")
        ens = ef.read(out)
    T, s0 = ens.setup["T"], ens.setup["s0"]
    H = np.asfortranarray(ens.setup["H"])
    xc = ens.setup["x_centre"]
    try:
        W = ens.checkpoint["w"].reshape(params["chains"], d).copy()
        states = ens.checkpoint["rng"].astype(np.uint64).reshape(params["chains"], 4).copy()
    except (KeyError, ValueError) as exc:
        raise InputError(out, "checkpoint", f"corrupt ({exc}); delete the file to restart") \
            from None
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=n, initial=min(ens.n_samples, n), desc="hit-and-run", unit="sample",
                   file=sys.stderr)
    coord = params["direction"] == "coordinate"
    state_ok = (W.copy(), states.copy())     # chain state after the last accepted sample
    # The analysis keeps directions whose equilibrium residual is below its rank tolerance
    # (singular values ~1e-10 of the largest): along them equilibrium is off by
    # |A T| |w|, a floor of the frame itself (seen at 1.5e-9 <Fn> at mu = 10), allowed on
    # top of MAX_VIOLATION.
    abs_AT = np.abs(problem.A @ T) / problem.force_scale if d else np.zeros((0, 0))
    floor_max = [0.0]

    def frame_floor(w):
        f = float((abs_AT @ np.abs(w)).max(initial=0.0)) if d else 0.0
        floor_max[0] = max(floor_max[0], f)
        return f

    def state(n_total):
        return ({"w": state_ok[0], "rng": state_ok[1]},
                {"n_done": n_total, "steps_per_sample": params["thin"]})

    try:
        with ef.SampleWriter(out, ens.n_samples, checkpoint_every, state, max_seconds,
                             t0) as writer:
            while writer.n_total < n:
                i = writer.n_total
                c = i % params["chains"]
                if d:
                    bad = har_steps(H, s0, W[c], states[c], params["thin"], coord)
                    if bad > params["thin"] // 2:
                        raise NumericalError("hit-and-run: most chords degenerate; S is "
                                             "(numerically) flat in a direction the analysis "
                                             "kept")
                x = xc + T @ W[c]
                v = problem.violation(x)
                allowed = MAX_VIOLATION + frame_floor(W[c])
                if not v <= allowed:
                    raise NumericalError(f"hit-and-run sample {i} violates S by {v:.3e} x "
                                         f"<Fn> (> {allowed:.3e})")
                state_ok[0][c], state_ok[1][c] = W[c], states[c]
                if bar is not None:
                    bar.update(1)
                if writer.add(x, c, v):
                    break
    finally:
        if bar is not None:
            bar.close()
    ens = ef.read(out)
    diag = diagnostics(ens.samples, ens.chains, params["seed"])
    wall = time.perf_counter() - t0
    return {"n_samples": ens.n_samples, "dim_S": d, "n_rows": int(H.shape[0]),
            "wall_time_s": wall, **times, "sampling_s": wall - sum(times.values()),
            "frame_equality_floor": floor_max[0],
            "max_violation": float(ens.violations.max(initial=0.0)), "params": params,
            **diag}


def load_params(path) -> dict:
    return json.loads(ef.read(path, samples=False).attrs["params"])


class HitAndRun:
    """Uniform samples of S by hit-and-run (compute object; see :func:`sample`).

    ``HitAndRun(n=100, seed=1).run(problem)`` returns the samples as an
    :class:`~forcespace.ensemble_file.Ensemble` in memory; ``output=PATH``
    writes (and resumes) an ensemble file instead.
    """

    def __init__(self, n: int = 100, seed: int = 0, chains: int | None = None,
                 thin: int | None = None, burn_in: int | None = None,
                 direction: str | None = None, progress: bool = False):
        check_options(n, chains, thin, burn_in, direction)
        self.n, self.seed, self.progress = n, seed, progress
        self.options = dict(chains=chains, thin=thin, burn_in=burn_in, direction=direction)
        self.summary: dict = {}

    def run(self, problem: StaticsProblem, output=None,
            max_seconds: float | None = None) -> "ef.Ensemble":
        """Sample ``problem``'s S; stops early (fewer than n samples, all kept) after
        ``max_seconds``. The run's numbers are in ``self.summary``."""
        from .h5io import MemoryFile
        out = MemoryFile("<hit-and-run>") if output is None else output
        self.summary = sample(problem, self.n, out, seed=self.seed, progress=self.progress,
                              max_seconds=max_seconds, **self.options)
        return ef.read(out)

    def __repr__(self) -> str:
        return f"HitAndRun(n={self.n}, seed={self.seed})"
