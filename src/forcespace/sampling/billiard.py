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
``config.MAX_GRAM_BYTES`` it is kept in float32 (4 p^2 bytes; the hit facet's slack and
rate recomputed exactly, slacks exact at every trajectory's end: the same reflections as
float64, end points within 1e-12 at dim 1714, studies/sampler_cost.md), beyond that the
kernel computes H h_j per reflection (O(p d)). A reflection's cost is its passes over
the p slacks, rates and row products, so float32 saves memory, not time. K = C (T T^T)
C^T with C the cone rows per contact is no smaller: two rows per contact, 2m >= p.

Frame and rounding: x = x_centre + T w in the frame both uniform walks share (frame.frame:
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
from ..progress import progress as progress_bar
from ..streams import chain_states, start_generator
from .conic_walk import ConicBilliardWalk
from .driver import FrameSampler
from .frame import FrameWalk, frame, on_large_path, refuse_unbounded
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
def hit_row(H, s0, w, v, j):
    """Row j's exact slack s0_j - h_j . w and rate h_j . v (O(d), float64): the float32
    Gram walk's hit facet, taken from the exact values, not from the propagated ones."""
    hw = 0.0
    hv = 0.0
    for i in range(w.shape[0]):
        hw += H[j, i] * w[i]
        hv += H[j, i] * v[i]
    return s0[j] - hw, hv


@kernel
def reflect(v, hj, c):
    """v -= c h_j in place (the specular turn off facet j, c = 2 h_j.v / |h_j|^2)."""
    for i in range(v.shape[0]):
        v[i] -= c * hj[i]


@kernel
def exact_slacks(H, s0, w, slack) -> float:
    """slack = s0 - H w in place (O(p d)); returns its minimum."""
    slack[:] = s0 - np.dot(H, w)
    return np.min(slack) if slack.shape[0] else 0.0


@kernel
def billiard_walk(H, gram, s0, w, slack, state, n_traj, tau, length_mode, max_refl, counts,
                  out):
    """Run ``n_traj`` billiard-walk trajectories from w in place (module docstring).

    H (p, d) C-contiguous and s0 (p,): the polytope {H w <= s0}; w (d,) a point of it,
    overwritten with the end point; slack (p,) = s0 - H w on entry, kept up to date.
    gram = (K, kdiag): K (p, p) = H H^T (float64, or float32: then kdiag (p,) holds
    |h_j|^2 in float64, else it is empty), or an empty (0, 0) K to compute each needed row
    H h_j on the fly. With float32 K the hit row's slack and rate are recomputed exactly
    (O(d)), the slacks exactly at every trajectory's end, and a trajectory ending outside
    the polytope (an exact slack < 0, missed through the float32 rows) is discarded.
    state (4,) uint64 xoshiro256** state, advanced in place. tau > 0: length scale
    (units of w). length_mode: LENGTH_MODES. max_refl: a trajectory that needs more
    reflections is discarded (the chain stays at its start). counts (4,) int64,
    incremented in place (TRAJ, REFL, DISCARDED, SINCE). out (k, d): w is written to
    out[i] after trajectory (i + 1) n_traj // k (k = 0: nothing recorded).
    """
    p, d = H.shape
    every = max(n_traj // out.shape[0], 1) if out.shape[0] > 0 else n_traj + 1
    exact = gram[1].shape[0] == p
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
            exact_slacks(H, s0, w, slack)
            counts[3] = 0
        Hv = np.dot(H, v)
        advance(Hv, slack, rate, zero, 0.0, 0.0)
        nref = flight(H, gram, s0, w, v, Hv, slack, rate, L, max_refl)
        rejected = nref > max_refl
        counts[3] += nref + 1
        counts[0] += 1
        counts[1] += nref
        if exact and not rejected:
            rejected = exact_slacks(H, s0, w, slack) < 0.0
            counts[3] = 0
        if rejected:
            counts[2] += 1
            for i in range(d):
                w[i] = w_start[i]
            exact_slacks(H, s0, w, slack)
            counts[3] = 0
        if (it + 1) % every == 0:
            k = (it + 1) // every - 1
            for i in range(d):
                out[k, i] = w[i]


@kernel
def flight(H, gram, s0, w, v, Hv, slack, rate, L, max_refl):
    """One trajectory of path length L from w along the unit v (both moved in place; Hv,
    slack, rate (p,) kept up to date; gram as for :func:`billiard_walk`): the number of
    reflections, max_refl + 1 when it stopped there (to be discarded)."""
    p, d = H.shape
    K, kdiag = gram
    use_k = K.shape[0] == p
    exact = kdiag.shape[0] == p
    nref = 0
    while True:
        jmin = np.argmax(rate)
        t = L
        if rate[jmin] > 0.0:                 # the facet hit first, at path length t
            if exact:
                slack[jmin], Hv[jmin] = hit_row(H, s0, w, v, jmin)
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
        if jmin < 0:                         # the trajectory ends before the next facet
            for j in range(p):
                slack[j] -= t * Hv[j]
            return nref
        nref += 1
        if nref > max_refl:
            return nref
        hj = H[jmin]                         # reflect off facet jmin
        if use_k:
            c = 2.0 * Hv[jmin] / (kdiag[jmin] if exact else K[jmin, jmin])
            reflect(v, hj, c)
            advance(Hv, slack, rate, K[jmin], c, t)
        else:
            kj = np.dot(H, hj)
            c = 2.0 * Hv[jmin] / kj[jmin]
            reflect(v, hj, c)
            advance(Hv, slack, rate, kj, c, t)
        slack[jmin] = 0.0                    # on the facet (its H v is now < 0)
        rate[jmin] = -np.inf


# ----------------------------------------------------------------------------
# the walk on a polytope {H w <= s0}
# ----------------------------------------------------------------------------
GRAM_FORMS = ("auto", "float64", "float32", "rows")


def gram_matrix(H, max_bytes: float | None = None, form: str = "auto") -> np.ndarray:
    """K = H H^T (p, p) for :func:`billiard_walk`, or an empty (0, 0) array (the kernel
    then computes the rows it needs on the fly, O(p d) each). ``form``: "float64" (BLAS
    syrk), "float32" (half the memory: the float64 products rounded to float32, computed
    in row blocks), "rows" (none), "auto": float64 if its 8 p^2 bytes fit ``max_bytes``
    (default ``config.MAX_GRAM_BYTES``), else float32 if its 4 p^2 bytes fit, else rows."""
    from scipy.linalg.blas import dsyrk

    H = np.asarray(H, float)
    p = H.shape[0]
    cap = config.MAX_GRAM_BYTES if max_bytes is None else max_bytes
    if form == "auto":
        form = "float64" if 8.0 * p * p <= cap else "float32" if 4.0 * p * p <= cap else "rows"
    if form == "rows" or p == 0:
        return np.zeros((0, 0))
    if form == "float32":
        return _gram_float32(H)
    # upper triangle of H H^T (Fortran order): its transpose is C-ordered with the lower
    # triangle set, mirrored in place (one (p, p) array held, not four)
    return _mirror_lower(dsyrk(1.0, H, trans=0, lower=0).T)


def _mirror_lower(M, block: int = 1024) -> np.ndarray:
    """M (p, p) C-ordered with its lower triangle set: made symmetric in place, by blocks."""
    p = M.shape[0]
    for a in range(0, p, block):
        b = min(a + block, p)
        M[a:b, a:b] = np.tril(M[a:b, a:b]) + np.tril(M[a:b, a:b], -1).T
        M[a:b, b:] = M[b:, a:b].T
    return M


def _gram_float32(H, block: int = 1024) -> np.ndarray:
    """H H^T (p, p) rounded to float32, upper block rows by float64 products (the flops
    of one syrk), mirrored: no float64 (p, p) array is ever held."""
    p = H.shape[0]
    K = np.empty((p, p), np.float32)
    for a in range(0, p, block):
        b = min(a + block, p)
        K[a:b, a:] = H[a:b] @ H[a:].T
        K[b:, a:b] = K[a:b, b:].T
    return K


def gram_form(K) -> str:
    """"float64", "float32" or "rows": how :func:`gram_matrix` kept K."""
    return "rows" if K.shape[0] == 0 else str(K.dtype)


def gram_diagonal(H, K) -> np.ndarray:
    """|h_j|^2 (p,) in float64 for a float32 K (the reflection's exact denominator), an
    empty array for a float64 K or none (the kernel reads K's own diagonal)."""
    if K.dtype == np.float32 and K.shape[0]:
        return np.einsum("ij,ij->i", H, H)
    return np.zeros(0)


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

    def __init__(self, H, s0, W, states, K=None, gram: str = "auto"):
        self.H = np.ascontiguousarray(H, dtype=float)
        self.s0 = np.ascontiguousarray(s0, dtype=float)
        self.W = np.array(W, float)
        self.states = np.array(states, np.uint64)
        self.K = gram_matrix(self.H, form=gram) if K is None else K
        self.kdiag = gram_diagonal(self.H, self.K)
        self.slack = self.s0[None, :] - self.W @ self.H.T
        self.counts = np.zeros((self.W.shape[0], 4), np.int64)
        self.tau, self.mode, self.max_refl = 1.0, LENGTH_MODES["rehmc"], 10 ** 7

    def run(self, c: int, n_traj: int, out=NO_OUT) -> None:
        billiard_walk(self.H, (self.K, self.kdiag), self.s0, self.W[c], self.slack[c],
                      self.states[c], n_traj, self.tau, self.mode, self.max_refl,
                      self.counts[c], out)

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
    Lewis-weight updates of the rounding (the walk on S takes config.LEWIS_UPDATES_LARGE
    on the large path)."""
    p = {"seed": 0, "chains": 4, "thin": 1, "burn_in": 50, "tau_factor": 2.5,
         "length": "rehmc", "rounding_updates": 5}
    p.update({k: v for k, v in kw.items() if v is not None})
    return p


def check_options(n, chains=None, thin=None, burn_in=None, tau_factor=None, length=None,
                  rounding_updates=None, checkpoint_every=1, source="sample",
                  gram=None) -> None:
    """Refuse meaningless billiard-walk options before any work (InputError)."""
    require_int(source, "n", n, 1, "number of samples", config.MAX_SAMPLES)
    require_int(source, "checkpoint_every", checkpoint_every, 1)
    for name, value, lo, meaning, hi in (
            ("chains", chains, 1, "independent chains", config.MAX_CHAINS),
            ("thin", thin, 1, "trajectories between samples", config.MAX_BILLIARD_THIN),
            ("burn_in", burn_in, 0, "trajectories per chain before the first sample",
             config.MAX_BILLIARD_BURN_IN),
            ("rounding_updates", rounding_updates, 0, "Lewis-weight updates", 1000)):
        if value is not None:
            require_int(source, name, value, lo, meaning, hi)
    if tau_factor is not None and not (isinstance(tau_factor, (int, float))
                                       and np.isfinite(tau_factor) and tau_factor > 0):
        raise InputError(source, "tau_factor", "must be a positive number", got=tau_factor)
    if length is not None and length not in LENGTH_MODES:
        raise InputError(source, "length", f"must be one of {sorted(LENGTH_MODES)}",
                         got=length)
    if gram is not None and gram not in GRAM_FORMS:
        raise InputError(source, "gram", f"must be one of {list(GRAM_FORMS)}", got=gram)


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


class BilliardFrameWalk(FrameWalk):
    """The billiard walk in the rounded frame (:class:`~forcespace.sampling.frame.
    FrameWalk`): ``thin`` trajectories of chain i % chains between its samples."""

    sampler = "billiard"
    SETUP_DESCRIPTION = SETUP_DESCRIPTION
    STATE = ("w", "rng", "slack", "counts")

    def default_params(self, options: dict) -> dict:
        """default_params, with config.LEWIS_UPDATES_LARGE Lewis-weight updates and
        config.BILLIARD_BURN_IN_LARGE burn-in trajectories on the large path (unless
        given)."""
        large = {"rounding_updates": config.LEWIS_UPDATES_LARGE,
                 "burn_in": config.BILLIARD_BURN_IN_LARGE} if self.large else {}
        return default_params(**{**large, **{k: v for k, v in options.items()
                                             if v is not None}})

    def min_draws_per_chain(self) -> int:
        """config.BILLIARD_MIN_DRAWS_PER_CHAIN (measured for this walk)."""
        return config.BILLIARD_MIN_DRAWS_PER_CHAIN

    @property
    def large(self) -> bool:
        """frame.on_large_path: the rounding centres to config.LEWIS_CENTRED_LARGE."""
        return on_large_path(self.problem)

    def make_frame(self, problem, analysis):
        """frame.frame; on the large path without the analysis' boundedness LP (4.5 of the
        13 CPU s of the dim-1714 slice's analysis): the rounding proves S bounded
        (:meth:`round`)."""
        return frame(problem, analysis, boundedness=not on_large_path(problem))

    def round(self):
        """The Lewis rounding of the frame (y0, L, info; on the large path also the mapped
        rows, frame.Frame.rounded's HL); where the analysis left boundedness undecided,
        its certificate (rounding.lewis_rounding's info["bounded"]) decides, else the exact
        recession-cone LP (frame.refuse_unbounded: InputError if S is unbounded)."""
        scale = self.problem.force_scale
        undecided = self.frame.analysis.bounded is None
        try:
            rounded = lewis_rounding_with_progress(
                self.H0 * scale, self.frame.s0, np.zeros(self.d),
                self.params["rounding_updates"], self.progress,
                config.LEWIS_CENTRED_LARGE if self.large else config.LEWIS_CENTRED,
                mapped=self.large)
        except NumericalError:
            if undecided:
                refuse_unbounded(self.problem, False)
            raise
        if undecided:
            refuse_unbounded(self.problem, rounded[2]["bounded"] is True)
        return rounded

    def start_chains(self, H, s):
        """Dispersed starts, the Gram matrix and the burn-in (its counts kept apart)."""
        p, d = self.params, self.d
        c1 = time.process_time()
        H = np.ascontiguousarray(H)
        states = chain_states(p["seed"], p["chains"])
        W = dispersed_starts(H, s, p["chains"], p["seed"]) if d else np.zeros((p["chains"], 0))
        self.walk = Chains(H, s, W, states, None if d else np.zeros((0, 0)),
                           gram=p.get("gram") or "auto")
        self.cpu["gram_s"] = time.process_time() - c1
        t1, c1 = time.perf_counter(), time.process_time()
        if d:
            self.walk.burn_in(p["burn_in"], p["tau_factor"], p["length"],
                              progress=self.progress)
        self.times["burn_in_s"] = time.perf_counter() - t1
        self.cpu["burn_in_s"] = time.process_time() - c1
        self.burn_in_counts = self.walk.counts.sum(0).tolist()
        self.walk.counts[:, :3] = 0
        return H, s

    def setup_extra(self) -> dict:
        info = self.rounding_info
        return {"tau": self.walk.tau, "max_refl": self.walk.max_refl,
                "rounding_john_excess": info.get("john_excess", 0.0),
                "rounding_weight_updates": info.get("weight_updates", 0)}

    def resume_chains(self, setup, checkpoint, state) -> None:
        """The chains of a checkpoint (the Gram matrix is recomputed: the same BLAS
        product of the same H)."""
        chains = self.params["chains"]
        walk = Chains(setup["H"], setup["s0"], state["w"], state["rng"],
                      gram=self.params.get("gram") or "auto")
        walk.slack = checkpoint["slack"].reshape(walk.slack.shape).copy()
        walk.counts = checkpoint["counts"].astype(np.int64).reshape(chains, 4).copy()
        state["slack"] = walk.slack
        walk.tau, walk.max_refl = float(setup["tau"]), int(setup["max_refl"])
        walk.mode = LENGTH_MODES[self.params["length"]]
        self.walk, self.burn_in_counts, self.rounding_info = walk, [0, 0, 0, 0], {}

    def chain_arrays(self) -> tuple:
        w = self.walk
        return w.W, w.states, w.slack, w.counts

    def advance(self, c: int) -> None:
        self.walk.run(c, self.params["thin"])

    def postfix(self) -> dict:
        t = self.walk.counts.sum(0)
        return {"refl/traj": f"{t[REFL] / max(t[TRAJ], 1):.0f}", "discarded": int(t[DISCARDED])}

    def state_attrs(self) -> dict:
        return {"trajectories_per_sample": self.params["thin"]}


class BilliardWalk(FrameSampler):
    """Uniform samples of S by the billiard walk (compute object; module docstring).

    ``BilliardWalk(n=100, seed=1).compute(problem)`` draws ``n`` samples in memory;
    ``compute(problem, output=PATH)`` writes (and resumes) an ensemble file instead.
    Parameters: ``chains`` (default 4, from dispersed starts), ``thin`` trajectories
    between samples (default 1), ``burn_in`` trajectories per chain (default 50; on the
    large path config.BILLIARD_BURN_IN_LARGE = 20),
    ``tau_factor`` (default 2.5: tau = 2.5 x the rms distance of the burn-in states from
    their mean), ``length`` "rehmc" (default), "exponential" or "uniform",
    ``rounding_updates`` Lewis-weight updates of the rounding (default 5; on the large
    path, ``config.SWEEP_MIN_COLUMNS`` columns and up, config.LEWIS_UPDATES_LARGE = 0);
    ``max_seconds`` stops early (status 1, every sample drawn kept); ``target_ess``:
    stop as soon as every tracked statistic has bulk and tail ESS >= target_ess and
    split R-hat <= 1.05 (``n`` is then the cap; reaching it first is status 1);
    ``progress`` shows bars (rounding, burn-in, sampling) on stderr; ``gram``: how K =
    H H^T is kept (:func:`gram_matrix`; default "auto": float64 where it fits
    ``config.MAX_GRAM_BYTES``, then float32, then rows on the fly).
    Results: ``ensemble`` (:class:`~forcespace.model.ensemble.Ensemble`, with the
    convergence diagnostics), and the run's ``dim``, ``n_rows``, ``times`` (wall),
    ``cpu`` (CPU seconds per stage), ``counts``, ``walk_info`` (tau, max_refl, rounding),
    ``frame_equality_floor``.
    """

    Walk = BilliardFrameWalk
    ConicWalk = ConicBilliardWalk

    def __init__(self, n: int = 100, seed: int = 0, chains: int | None = None,
                 thin: int | None = None, burn_in: int | None = None,
                 tau_factor: float | None = None, length: str | None = None,
                 rounding_updates: int | None = None, max_seconds: float | None = None,
                 checkpoint_every: int = 10, progress: bool = False,
                 target_ess: float | None = None, gram: str | None = None):
        check_options(n, chains, thin, burn_in, tau_factor, length, rounding_updates,
                      checkpoint_every, gram=gram)
        super().__init__(n, seed, max_seconds, checkpoint_every, progress, target_ess,
                         chains=chains, thin=thin, burn_in=burn_in, tau_factor=tau_factor,
                         length=length, rounding_updates=rounding_updates, gram=gram)

    def _walk_results(self, walk: BilliardFrameWalk) -> dict:
        if isinstance(walk, ConicBilliardWalk):
            return walk.results()
        t, w = walk.walk.counts.sum(0), walk.walk
        return {"counts": {"trajectories": int(t[TRAJ]), "reflections": int(t[REFL]),
                           "discarded": int(t[DISCARDED]),
                           "burn_in_trajectories": int(walk.burn_in_counts[TRAJ]),
                           "burn_in_reflections": int(walk.burn_in_counts[REFL])},
                "walk_info": {"tau": float(w.tau), "max_refl": int(w.max_refl),
                              "gram": bool(w.K.shape[0] == w.H.shape[0] > 0),
                              "gram_form": gram_form(w.K),
                              "rounding": walk.rounding_info}}

    def _summary_extra(self) -> dict:
        return {"counts": self.counts, "walk": self.walk_info}

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
