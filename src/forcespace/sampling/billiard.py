"""Uniform sampling of S by the billiard walk (exact specular reflections).

The walk (Polyak & Gryazina 2014, "Billiard walk - a new sampling algorithm for
control and optimization"; Gryazina & Polyak 2014, "Random sampling: Billiard Walk
algorithm"), equivalently reflective Hamiltonian Monte Carlo with a flat potential
(Chalkis, Fisikopoulos, Papachristoudis & Tsigaridas 2023, "Truncated log-concave
sampling for convex bodies with Reflective Hamiltonian Monte Carlo"), one trajectory
on the polytope {H w <= s0}:

1. draw a velocity g ~ N(0, I_d) (isotropic) and a path length L;
2. move from w along v = g / |g|; where the segment leaves the polytope, stop on the
   facet j it crosses first and reflect specularly, v <- v - 2 (h_j . v) h_j / |h_j|^2;
   continue with the rest of the length; stop after a total length L;
3. if the trajectory needed more than ``max_refl`` reflections, discard it: the chain
   stays at its start (Gryazina & Polyak's rule).

Uniform invariance (the literature's conditions, all met here):

* The billiard flow of length L preserves Lebesgue measure on (position, velocity)
  (free flight is a translation, a specular reflection an isometry of the velocity
  whose Jacobian in position is 1) and is reversible: the flow from the end point
  with reversed velocity returns to the start with reversed velocity.
* The velocity law is rotation invariant (isotropic, so unchanged by reflections and
  by v -> -v) and L is drawn independently of the position and of the direction.
  Then the transition kernel is symmetric with respect to Lebesgue measure on the
  polytope, so the uniform distribution is invariant (detailed balance). This is the
  argument of Gryazina & Polyak for the exponential law of L; it uses only these
  two properties, and is the same for reflective HMC (Chalkis et al.).
* Trajectories through a face of dimension <= d - 2 (two facets hit at once) have
  probability zero; the rejection of step 3 keeps the kernel symmetric, since the
  reversed trajectory has the same reflections.
* Exactness is up to round-off: the facet hit is found from the exact slacks and row
  products (no step size, no discretisation), and every sample is checked against S.
* A random L (continuous law) makes the chain aperiodic; the law is ``length``:
  "exponential" (mean tau, Gryazina & Polyak), "uniform" (on [0, 2 tau]) or "rehmc"
  (tau |g| / sqrt(d): Gaussian speed for a fixed time, the reflective HMC of Chalkis
  et al.; |g| / sqrt(d) has a chi law with mean ~1, relative spread 1 / sqrt(2 d)).
  All three are uniform invariant; "rehmc" is the default (measured the cheapest per
  effective sample, 2.1-2.3x cheaper than "exponential": studies/sampler_cost.md).

Nothing is adapted while samples are kept: the rounding, tau, max_refl and the Gram
matrix are fixed in the set-up (tau and max_refl from the burn-in, stored in the file).

Cost. Each reflection needs H v for the reflected velocity. With K = H H^T (p x p,
computed once, BLAS syrk), H v' = H v - c K[j] is O(p): a reflection costs O(p + d)
instead of the O(p d) of recomputing H v. A trajectory starts with one product H v
(O(p d)) for its fresh velocity; the slacks s0 - H w are kept per chain, updated
incrementally and recomputed exactly every ~4 p reflections and after a rejection. K
costs 8 p^2 bytes (0.9 GB at the 5000-disk slice, p = 10676); above
``config.MAX_GRAM_BYTES`` the kernel computes H h_j per reflection instead (O(p d)).

Frame and rounding: x = x_centre + T w with the frame of hit-and-run (hit_and_run.frame:
the affine hull of S, its non-implicit inequalities) and the cheap Lewis-weight rounding
(rounding.lewis_rounding), which puts the unit ball inside the polytope at w = 0: the
walk is exact in any frame, but in a thin one it needs many reflections per unit of
progress. Random numbers: xoshiro.py, one stream per chain.
"""
from __future__ import annotations

import time

import numpy as np

from .. import config
from ..errors import InputError, NumericalError, require_int
from ..kernels import kernel
from ..model.problem import StaticsProblem
from ..progress import progress as progress_bar
from ..streams import chain_states, start_generator
from .driver import FrameSampler, Stop, check_target, run_walk
from .hit_and_run import frame, tolerance_description
from .rounding import lewis_rounding_with_progress
from .xoshiro import normals, uniform

LENGTH_MODES = {"exponential": 0, "uniform": 1, "rehmc": 2}
# counts per chain, (4,) int64: trajectories, reflections, discarded trajectories,
# reflections since the last exact slack recomputation
TRAJ, REFL, DISCARDED, SINCE = range(4)


# ----------------------------------------------------------------------------
# kernels
# ----------------------------------------------------------------------------
@kernel(fastmath={"nsz", "contract"})
def advance(Hv, slack, rate, kj, c, t):
    """One reflection's O(p) work, vectorisable: slacks after a flight of length t
    (slack -= t Hv), the turned velocity's row products (Hv -= c kj), and the hitting
    rates rate_j = Hv_j / slack_j (the next facet hit is the largest rate; rows moving
    away have rate <= 0)."""
    for j in range(Hv.shape[0]):
        sj = slack[j] - t * Hv[j]
        h = Hv[j] - c * kj[j]
        slack[j] = sj
        Hv[j] = h
        rate[j] = h / max(sj, 1e-300)


@kernel
def path_length(state, tau, length_mode, nrm, d):
    """The path length of one trajectory (module docstring; nrm = |g|)."""
    if length_mode == 0:
        u = uniform(state)
        while u <= 0.0:
            u = uniform(state)
        return -tau * np.log(u)
    if length_mode == 1:
        return 2.0 * tau * uniform(state)
    return tau * nrm / np.sqrt(d)


@kernel
def billiard_walk(H, K, s0, w, slack, state, n_traj, tau, length_mode, max_refl, counts, out):
    """Run ``n_traj`` billiard-walk trajectories from w in place (module docstring).

    H (p, d) C-contiguous and s0 (p,): the polytope {H w <= s0}; w (d,) a point of it,
    overwritten with the end point; slack (p,) = s0 - H w on entry, kept up to date.
    K (p, p) = H H^T, or an empty (0, 0) array to compute each needed row H h_j on the
    fly. state (4,) uint64 xoshiro256** state, advanced in place. tau > 0: length scale
    (units of w). length_mode: LENGTH_MODES. max_refl: a trajectory that needs more
    reflections is discarded (the chain stays at its start). counts (4,) int64,
    incremented in place (TRAJ, REFL, DISCARDED, SINCE). out (k, d): w is written to
    out[i] after trajectory (i + 1) n_traj // k (k = 0: nothing recorded).
    """
    p, d = H.shape
    every = max(n_traj // out.shape[0], 1) if out.shape[0] > 0 else n_traj + 1
    use_k = K.shape[0] == p
    v = np.zeros(d)
    w_start = np.zeros(d)
    rate = np.zeros(p)
    zero = np.zeros(p)
    for it in range(n_traj):
        normals(state, v)
        nrm = np.sqrt(np.sum(v * v))
        L = path_length(state, tau, length_mode, nrm, d)
        for i in range(d):
            v[i] /= nrm
            w_start[i] = w[i]
        if counts[3] > 4 * p:                # exact slacks now and then (no drift)
            slack[:] = s0 - np.dot(H, w)
            counts[3] = 0
        Hv = np.dot(H, v)
        advance(Hv, slack, rate, zero, 0.0, 0.0)
        nref = 0
        rejected = False
        while True:
            jmin = np.argmax(rate)
            t = L
            if rate[jmin] > 0.0:             # the facet hit first, at path length t
                tj = max(slack[jmin], 0.0) / Hv[jmin]
                if tj < L:
                    t = tj
                else:
                    jmin = -1
            else:
                jmin = -1
            for i in range(d):
                w[i] += t * v[i]
            L -= t
            if jmin < 0:                     # the trajectory ends before the next facet
                for j in range(p):
                    slack[j] -= t * Hv[j]
                break
            nref += 1
            if nref > max_refl:
                rejected = True
                break
            hj = H[jmin]                     # reflect off facet jmin
            kj = K[jmin] if use_k else np.dot(H, hj)
            c = 2.0 * Hv[jmin] / kj[jmin]
            for i in range(d):
                v[i] -= c * hj[i]
            advance(Hv, slack, rate, kj, c, t)
            slack[jmin] = 0.0                # on the facet (its H v is now < 0)
            rate[jmin] = -np.inf
        counts[3] += nref + 1
        counts[0] += 1
        counts[1] += nref
        if rejected:
            counts[2] += 1
            for i in range(d):
                w[i] = w_start[i]
            slack[:] = s0 - np.dot(H, w)
            counts[3] = 0
        if (it + 1) % every == 0:
            k = (it + 1) // every - 1
            for i in range(d):
                out[k, i] = w[i]


# ----------------------------------------------------------------------------
# the walk on a polytope {H w <= s0}
# ----------------------------------------------------------------------------
def gram_matrix(H, max_bytes: float | None = None) -> np.ndarray:
    """K = H H^T (p, p) for :func:`billiard_walk` (BLAS syrk), or an empty (0, 0) array
    when it would take more than ``max_bytes`` (default ``config.MAX_GRAM_BYTES``; the
    kernel then computes rows on the fly)."""
    from scipy.linalg.blas import dsyrk

    H = np.asarray(H, float)
    p = H.shape[0]
    if 8.0 * p * p > (config.MAX_GRAM_BYTES if max_bytes is None else max_bytes):
        return np.zeros((0, 0))
    K = np.triu(dsyrk(1.0, H, trans=0, lower=0))    # upper triangle of H H^T
    return np.ascontiguousarray(K + np.triu(K, 1).T)


def inscribed_radius(H, s0) -> float:
    """Distance from w = 0 to the nearest facet of {H w <= s0} (1 after rounding)."""
    return float(np.min(np.asarray(s0) / np.linalg.norm(H, axis=1)))


def dispersed_starts(H, s0, chains: int, seed: int = 0) -> np.ndarray:
    """(chains, d) starting points: for each chain a random direction u (isotropic) and
    the point 0.9 t u, t the distance from w = 0 to the boundary along u: chains start
    towards different parts of the boundary (over-dispersed, as R-hat wants)."""
    rng = start_generator(seed)
    d = H.shape[1]
    W = np.zeros((chains, d))
    for c in range(chains):
        u = rng.normal(size=d)
        u /= np.linalg.norm(u)
        hu = H @ u
        pos = hu > 0
        t = float(np.min(s0[pos] / hu[pos])) if pos.any() else 1.0
        W[c] = 0.9 * t * u
    return W


NO_OUT = np.zeros((0, 0))


class Chains:
    """The state of the billiard walk's chains on {H w <= s0}: positions W (chains, d),
    slacks (chains, p), generators (chains, 4) and counts (chains, 4), the fixed K, tau,
    length law and max_refl. :meth:`run` advances one chain."""

    def __init__(self, H, s0, W, states, K=None):
        self.H = np.ascontiguousarray(H, dtype=float)
        self.s0 = np.ascontiguousarray(s0, dtype=float)
        self.W = np.array(W, float)
        self.states = np.array(states, np.uint64)
        self.K = gram_matrix(self.H) if K is None else K
        self.slack = self.s0[None, :] - self.W @ self.H.T
        self.counts = np.zeros((self.W.shape[0], 4), np.int64)
        self.tau, self.mode, self.max_refl = 1.0, LENGTH_MODES["rehmc"], 10 ** 7

    def run(self, c: int, n_traj: int, out=NO_OUT) -> None:
        billiard_walk(self.H, self.K, self.s0, self.W[c], self.slack[c], self.states[c],
                      n_traj, self.tau, self.mode, self.max_refl, self.counts[c], out)

    def burn_in(self, n_traj: int, tau_factor: float, length: str, tau=None, max_refl=None,
                progress: bool = False) -> None:
        """``n_traj`` trajectories per chain, nothing kept. Its first half runs with the
        guess tau = tau_factor sqrt(d) r (r the inscribed radius at w = 0); at the end of
        its third quarter tau is fixed to ``tau_factor`` x the rms distance of the chains'
        states in that quarter from their mean (unless ``tau`` is given) and max_refl to
        50x the mean reflections per trajectory + 1000 (unless given); the last quarter
        runs with the final values."""
        chains, d = self.W.shape
        self.mode = LENGTH_MODES[length]
        self.tau = tau if tau is not None else \
            tau_factor * np.sqrt(d) * inscribed_radius(self.H, self.s0)
        self.max_refl = 10 ** 7 if max_refl is None else int(max_refl)
        q1, q2 = n_traj // 2, n_traj // 4
        with progress_bar(total=chains * n_traj, desc=f"billiard burn-in ({chains} chains)",
                          unit="traj", disable=not progress) as bar:
            for c in range(chains):
                self.run(c, q1)
                bar.update(q1)
            if q2 > 0:
                snaps = np.zeros((chains, q2, d))
                for c in range(chains):
                    self.run(c, q2, snaps[c])
                    bar.update(q2)
                if tau is None:
                    S = snaps.reshape(-1, d)
                    self.tau = tau_factor * float(np.sqrt(((S - S.mean(0)) ** 2).sum(1).mean()))
            if max_refl is None:
                tot = self.counts.sum(0)
                self.max_refl = int(50 * tot[REFL] / max(tot[TRAJ], 1)) + 1000
            for c in range(chains):
                self.run(c, n_traj - q1 - q2)
                bar.update(n_traj - q1 - q2)


def walk_polytope(H, s, y0, n: int, seed: int = 0, chains: int = 4, thin: int = 1,
                  burn_in: int = 50, tau_factor: float = 2.5, length: str = "rehmc",
                  rounding_updates: int = 5, tau=None, max_refl=None):
    """Uniform samples of the polytope {H y <= s} (y0 strictly inside) by the billiard
    walk exactly as :class:`BilliardWalk` runs it on S (rounding, dispersed starts,
    burn-in, ``thin`` trajectories per sample): (Y (chains, n, d), walk :class:`Chains`,
    rounding info). For tests and studies on polytopes with known distributions."""
    c0, Lc, info = lewis_rounding_with_progress(H, s, y0, rounding_updates)
    Hr = np.ascontiguousarray(np.asarray(H, float) @ Lc)
    sr = np.asarray(s, float) - np.asarray(H, float) @ c0
    walk = Chains(Hr, sr, dispersed_starts(Hr, sr, chains, seed), chain_states(seed, chains))
    walk.burn_in(burn_in, tau_factor, length, tau, max_refl)
    Wk = np.zeros((chains, n, Hr.shape[1]))
    for c in range(chains):
        walk.run(c, n * thin, Wk[c])
    return c0 + Wk @ Lc.T, walk, info


# ----------------------------------------------------------------------------
# the walk on S, for the driver
# ----------------------------------------------------------------------------
def default_params(**kw) -> dict:
    """Defaults (measured, studies/sampler_cost.md): 4 chains from dispersed starts, one
    trajectory per sample (one trajectory gives 0.6-0.8 effective samples at dim
    48-1714), 50 burn-in trajectories per chain (|w|^2 reaches its stationary spread
    after 2-3 at dim 1714), reflective-HMC lengths with tau 2.5x the rms distance of the
    burn-in states from their mean (the optimum of the scan at dim 184 and 1714), 5
    Lewis-weight updates of the rounding."""
    p = {"seed": 0, "chains": 4, "thin": 1, "burn_in": 50, "tau_factor": 2.5,
         "length": "rehmc", "rounding_updates": 5}
    p.update({k: v for k, v in kw.items() if v is not None})
    return p


def check_options(n, chains=None, thin=None, burn_in=None, tau_factor=None, length=None,
                  rounding_updates=None, checkpoint_every=1, source="sample") -> None:
    """Refuse meaningless billiard-walk options before any work (InputError)."""
    require_int(source, "n", n, 1, "number of samples")
    require_int(source, "checkpoint_every", checkpoint_every, 1)
    for name, value, lo, meaning in (
            ("chains", chains, 1, "independent chains"),
            ("thin", thin, 1, "trajectories between samples"),
            ("burn_in", burn_in, 0, "trajectories per chain before the first sample"),
            ("rounding_updates", rounding_updates, 0, "Lewis-weight updates")):
        if value is not None:
            require_int(source, name, value, lo, meaning)
    if tau_factor is not None and not (isinstance(tau_factor, (int, float))
                                       and np.isfinite(tau_factor) and tau_factor > 0):
        raise InputError(source, "tau_factor", "must be a positive number", got=tau_factor)
    if length is not None and length not in LENGTH_MODES:
        raise InputError(source, "length", f"must be one of {sorted(LENGTH_MODES)}",
                         got=length)


SETUP_DESCRIPTION = {
    "x_centre": ("F0", "centre of the Lewis-weight rounding ellipsoid of S (origin of w)"),
    "T": ("F0", "x = x_centre + T w: affine frame x frozen rounding"),
    "H": ("1", "non-implicit inequalities H w <= s0"),
    "s0": ("F0", "slack of the inequalities at the centre"),
    "free_rows": ("1", "rows of problem.inequalities() kept"),
    "tau": ("1", "path-length scale in w, fixed at the end of the burn-in"),
    "max_refl": ("1", "reflections above which a trajectory is discarded (chain stays)"),
    "rounding_john_excess": ("1", "max_i a_i^T M^-1 a_i - 1 of the rounding (0: John's)"),
    "rounding_weight_updates": ("1", "Lewis-weight updates the rounding made")}


class _Walk:
    """The billiard walk as a walk of :func:`forcespace.sampling.driver.run_walk`;
    sample i is drawn by chain i % chains, ``thin`` trajectories after its last."""

    sampler = "billiard"

    def __init__(self, problem: StaticsProblem, options: dict, analysis, progress: bool):
        t0, c0 = time.perf_counter(), time.process_time()
        self.problem, self.progress = problem, progress
        (self.xc, self.N, self.H0, self.s0, self.free, self.analysis,
         self.widening) = frame(problem, analysis)
        self.d = self.N.shape[1]
        self.params = default_params(**options)
        self.times = {"frame_s": time.perf_counter() - t0, "rounding_s": 0.0,
                      "burn_in_s": 0.0}
        self.cpu = {"frame_s": time.process_time() - c0, "rounding_s": 0.0, "gram_s": 0.0,
                    "burn_in_s": 0.0, "sampling_s": 0.0}
        self.tolerance_description = tolerance_description(self.widening)
        self.kept = []          # w of every sample drawn (the frame floor, computed at the end)
        self.walk = None

    def set_up(self):
        """Rounding, Gram matrix, burn-in: (setup, describe, checkpoint, checkpoint_attrs)."""
        p, d, scale = self.params, self.d, self.problem.force_scale
        xc, s0, H0, N = self.xc, self.s0, self.H0, self.N
        t1, c1 = time.perf_counter(), time.process_time()
        rinfo = {}
        if d:
            y0, L, rinfo = lewis_rounding_with_progress(H0 * scale, s0, np.zeros(d),
                                                        p["rounding_updates"], self.progress)
            xc, s0 = xc + scale * (N @ y0), s0 - scale * (H0 @ y0)
            T, H = scale * (N @ L), np.ascontiguousarray(scale * (H0 @ L))
        else:
            T, H = np.zeros((N.shape[0], 0)), np.zeros((H0.shape[0], 0))
        self.times["rounding_s"] = time.perf_counter() - t1
        self.cpu["rounding_s"] = time.process_time() - c1
        c1 = time.process_time()
        states = chain_states(p["seed"], p["chains"])
        W = dispersed_starts(H, s0, p["chains"], p["seed"]) if d else np.zeros((p["chains"], 0))
        walk = Chains(H, s0, W, states, None if d else np.zeros((0, 0)))
        self.cpu["gram_s"] = time.process_time() - c1
        t1, c1 = time.perf_counter(), time.process_time()
        if d:
            walk.burn_in(p["burn_in"], p["tau_factor"], p["length"], progress=self.progress)
        self.times["burn_in_s"] = time.perf_counter() - t1
        self.cpu["burn_in_s"] = time.process_time() - c1
        self.burn_in_counts = walk.counts.sum(0).tolist()
        walk.counts[:, :3] = 0
        self._start_chains(xc, T, walk)
        setup = {"x_centre": xc, "T": T, "H": H, "s0": s0, "free_rows": self.free,
                 "tau": self.walk.tau, "max_refl": self.walk.max_refl,
                 "rounding_john_excess": rinfo.get("john_excess", 0.0),
                 "rounding_weight_updates": rinfo.get("weight_updates", 0)}
        self.rounding_info = rinfo
        arrays, attrs = self.state(0)
        return setup, SETUP_DESCRIPTION, arrays, attrs

    def resume(self, stored) -> None:
        """Continue from an ensemble file's set-up and checkpoint (the Gram matrix is
        recomputed: the same BLAS product of the same H)."""
        p, st, ck = self.params, stored.setup, stored.checkpoint
        try:
            W = ck["w"].reshape(p["chains"], self.d).copy()
            states = ck["rng"].astype(np.uint64).reshape(p["chains"], 4).copy()
            walk = Chains(st["H"], st["s0"], W, states)
            walk.slack = ck["slack"].reshape(walk.slack.shape).copy()
            walk.counts = ck["counts"].astype(np.int64).reshape(p["chains"], 4).copy()
        except (KeyError, ValueError) as exc:
            raise InputError(stored.ensemble.path, "checkpoint", f"corrupt ({exc}); delete "
                             "the file to restart") from None
        if not (np.all(np.isfinite(W)) and np.all(np.isfinite(walk.slack))):
            raise InputError(stored.ensemble.path, "checkpoint/w", "must be finite (the "
                             "stored chain state was changed); delete the file to restart")
        walk.tau, walk.max_refl = float(st["tau"]), int(st["max_refl"])
        walk.mode = LENGTH_MODES[p["length"]]
        self.burn_in_counts, self.rounding_info = [0, 0, 0, 0], {}
        self._start_chains(st["x_centre"], st["T"], walk)

    def _start_chains(self, xc, T, walk) -> None:
        self.xc, self.T, self.walk = xc, T, walk
        w = walk
        self.ok = (w.W.copy(), w.states.copy(), w.slack.copy(), w.counts.copy())
        # the frame's equilibrium floor, as for hit-and-run (hit_and_run._Walk)
        self.abs_AT = np.abs(self.problem.A @ T) / self.problem.force_scale if self.d \
            else np.zeros((0, 0))

    def floor(self, W) -> np.ndarray:
        """Equilibrium floor |A T| |w| / <Fn> of the frame at the states W (k, d)."""
        W = np.asarray(W, float).reshape(-1, self.d)
        if not self.d or not len(W):
            return np.zeros(len(W))
        return (np.abs(W) @ self.abs_AT.T).max(1)

    def draw(self, i: int):
        c0 = time.process_time()
        c, w = i % self.params["chains"], self.walk
        if self.d:
            w.run(c, self.params["thin"])
        x = self.xc + self.T @ w.W[c]
        v = self.problem.violation(x)
        if not v <= config.SAMPLE_VIOLATION:     # the floor is computed only when needed
            allowed = config.SAMPLE_VIOLATION + float(self.floor(w.W[c])[0]) + self.widening
            if not v <= allowed:
                raise NumericalError(f"billiard sample {i} violates S by {v:.3e} x <Fn> "
                                     f"(> {allowed:.3e})")
        for saved, now in zip(self.ok, (w.W, w.states, w.slack, w.counts)):
            saved[c] = now[c]
        self.kept.append(w.W[c].copy())
        self.cpu["sampling_s"] += time.process_time() - c0
        return x, c, v

    def postfix(self) -> dict:
        t = self.walk.counts.sum(0)
        return {"refl/traj": f"{t[REFL] / max(t[TRAJ], 1):.0f}", "discarded": int(t[DISCARDED])}

    def state(self, n_total: int):
        W, states, slack, counts = self.ok
        return ({"w": W, "rng": states, "slack": slack, "counts": counts},
                {"n_done": n_total, "trajectories_per_sample": self.params["thin"]})


class _TimedStop(Stop):
    """:class:`Stop` that also counts the CPU seconds of its convergence checks (the
    run's diagnostics, kept apart from the sampling's)."""

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.cpu_s = 0.0

    def __call__(self, k, samples, t0):
        c0 = time.process_time()
        try:
            return super().__call__(k, samples, t0)
        finally:
            self.cpu_s += time.process_time() - c0


class BilliardWalk(FrameSampler):
    """Uniform samples of S by the billiard walk (compute object; module docstring).

    ``BilliardWalk(n=100, seed=1).compute(problem)`` draws ``n`` samples in memory;
    ``compute(problem, output=PATH)`` writes (and resumes) an ensemble file instead.
    Parameters: ``chains`` (default 4, from dispersed starts), ``thin`` trajectories
    between samples (default 1), ``burn_in`` trajectories per chain (default 50),
    ``tau_factor`` (default 2.5: tau = 2.5 x the rms distance of the burn-in states from
    their mean), ``length`` "rehmc" (default), "exponential" or "uniform",
    ``rounding_updates`` Lewis-weight updates of the rounding (default 5);
    ``max_seconds`` stops early (status 1, every sample drawn kept); ``target_ess``:
    stop as soon as every tracked statistic has bulk and tail ESS >= target_ess and
    split R-hat <= 1.05 (``n`` is then the cap; reaching it first is status 1);
    ``progress`` shows bars (rounding, burn-in, sampling) on stderr.
    Results: ``ensemble`` (:class:`~forcespace.sampling.ensemble.Ensemble`, with the
    convergence diagnostics), and the run's ``dim``, ``n_rows``, ``times`` (wall),
    ``cpu`` (CPU seconds per stage), ``counts``, ``walk_info`` (tau, max_refl, rounding),
    ``frame_equality_floor``.
    """

    def __init__(self, n: int = 100, seed: int = 0, chains: int | None = None,
                 thin: int | None = None, burn_in: int | None = None,
                 tau_factor: float | None = None, length: str | None = None,
                 rounding_updates: int | None = None, max_seconds: float | None = None,
                 checkpoint_every: int = 10, progress: bool = False,
                 target_ess: float | None = None):
        check_options(n, chains, thin, burn_in, tau_factor, length, rounding_updates,
                      checkpoint_every)
        check_target(target_ess)
        self.n, self.seed, self.progress = n, seed, progress
        self.max_seconds, self.checkpoint_every = max_seconds, checkpoint_every
        self.target_ess = target_ess
        self.options = dict(seed=seed, chains=chains, thin=thin, burn_in=burn_in,
                            tau_factor=tau_factor, length=length,
                            rounding_updates=rounding_updates)

    def compute(self, problem: StaticsProblem, output=None, analysis=None) -> "BilliardWalk":
        """Sample S of ``problem``; ``analysis``: its ForceSpace, if already computed."""
        t0, c0 = time.perf_counter(), time.process_time()
        walk = _Walk(problem, self.options, analysis, self.progress)
        stop = _TimedStop(self.n, self.max_seconds, self.target_ess, walk.params["chains"],
                          walk.params["seed"])
        ens = run_walk(walk, problem, stop, output, self.checkpoint_every, self.progress,
                       t_start=t0)
        self._start()
        wall = time.perf_counter() - t0
        cpu = dict(walk.cpu, diagnostics_s=stop.cpu_s, total_s=time.process_time() - c0)
        t = walk.walk.counts.sum(0)
        self._results.update(
            ensemble=ens, dim=walk.d, n_rows=int(walk.H0.shape[0]), params=walk.params,
            times=dict(walk.times, wall_time_s=wall, sampling_s=wall - sum(walk.times.values())),
            cpu=cpu, frame_equality_floor=float(walk.floor(walk.kept).max(initial=0.0)),
            frame_widening=walk.widening,
            counts={"trajectories": int(t[TRAJ]), "reflections": int(t[REFL]),
                    "discarded": int(t[DISCARDED]),
                    "burn_in_trajectories": int(walk.burn_in_counts[TRAJ]),
                    "burn_in_reflections": int(walk.burn_in_counts[REFL])},
            walk_info={"tau": float(walk.walk.tau), "max_refl": int(walk.walk.max_refl),
                       "gram": bool(walk.walk.K.shape[0] == walk.walk.H.shape[0] > 0),
                       "rounding": walk.rounding_info})
        self._finish(ens.status, ens.message)
        return self

    @property
    def counts(self) -> dict:
        """Trajectories, reflections and discarded trajectories of this run's draws, and
        the burn-in's trajectories and reflections."""
        return self._get("counts")

    @property
    def walk_info(self) -> dict:
        """tau and max_refl fixed by the burn-in, whether K = H H^T was kept, the
        rounding's info (empty when resumed)."""
        return self._get("walk_info")

    def summary(self) -> dict:
        """The run's numbers (what ``forcespace sample --json`` prints)."""
        ens = self.ensemble
        return {"n_samples": ens.n_samples, "dim_S": self.dim, "n_rows": self.n_rows,
                **self.times, "cpu": self.cpu, "counts": self.counts,
                "walk": self.walk_info, "frame_equality_floor": self.frame_equality_floor,
                "frame_widening": self.frame_widening,
                "max_violation": float(ens.violations.max(initial=0.0)),
                "params": self.params, "status": self.status, "message": self.message,
                **ens.diagnostics}

