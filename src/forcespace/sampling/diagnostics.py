"""Convergence diagnostics of Markov chains of samples of S (ArviZ): split R-hat, bulk and
tail effective sample sizes.

Tracked statistics, per sample (computed from samples arranged (chains, draws, 2m)):

* ``sqdev``: |x - xbar|^2, xbar the mean over all chains and draws. Its mean is the
  total variance of S, the quantity eta is built from (eta = <dF> / <|F|>, dF the
  per-contact rms deviation), and it is the statistic a walk that has not explored the
  whole polytope gets wrong first (under-dispersed hit-and-run chains showed R-hat
  1.09 here at dim S 1714);
* ``proj0``, ``proj1``, ...: x . r_k for fixed random unit directions r_k
  (reproducible from ``seed``): generic linear functionals of the forces.

Each is judged as ArviZ judges it (Vehtari, Gelman, Simpson, Carpenter & Buerkner 2021,
"Rank-normalization, folding, and localization: an improved R-hat"):
``arviz.rhat(method="rank")`` (the larger of the rank-normalised split R-hat and its
folded version) and ``arviz.ess(method="bulk" | "tail")`` (FFT autocorrelations, Geyer's
initial monotone sequence; the tail ESS is the smaller ESS of the 5 % and 95 %
quantiles). The three are a line-by-line port of ArviZ 0.23's ``stats.diagnostics``
(Apache-2.0; :func:`ess_bulk`, :func:`ess_tail`, :func:`rhat_rank`; tests check them
against ArviZ itself to 1e-12): importing ArviZ costs ~1.8 CPU s (xarray, pandas), most
of the budget of a 2-second run at dim 200. Samples are converged for a target ESS when
every tracked statistic has bulk and tail ESS >= target and R-hat <=
``config.RHAT_MAX``. No I/O.
"""
from __future__ import annotations

import warnings

import numpy as np

from .. import config
from ..measures import eta as eta_fn
from ..streams import projection_generator


# ---- the ArviZ 0.23 estimators (v: (chains, draws) float) ------------------------------
def _split_chains(v) -> np.ndarray:
    """(2 chains, draws // 2): each chain's first and last halves as chains of their own."""
    half = v.shape[1] // 2
    return np.vstack((v[:, :half], v[:, -half:]))


def _average_ranks(v) -> np.ndarray:
    """Ranks 1..n of the flattened v, ties sharing their average rank (scipy.stats.rankdata
    's "average": the same values, exact half-integers); all NaN if v has a NaN (every
    estimator here is then NaN: :func:`_ess`, :func:`_rhat`). Not scipy.stats itself: its
    import cost ~0.3 CPU s, a quarter of a dim-228 run."""
    x = np.asarray(v, float).ravel()
    if np.isnan(x).any():
        return np.full(x.size, np.nan)
    order = np.argsort(x, kind="mergesort")
    xs = x[order]
    start = np.flatnonzero(np.r_[True, xs[1:] != xs[:-1]])
    count = np.diff(np.r_[start, x.size])
    rank = np.empty(x.size)
    rank[order] = np.repeat(start + 1 + 0.5 * (count - 1), count)
    return rank


def _z_scale(v) -> np.ndarray:
    """Rank-normalised values: Phi^-1 of the average ranks, Blom's offset 3/8
    (scipy.stats.norm.ppf is scipy.special.ndtri)."""
    from scipy.special import ndtri

    rank = _average_ranks(v)
    return ndtri((rank - 0.375) / (rank.size + 0.25)).reshape(v.shape)


def _quantile7(v, q: float) -> float:
    """The q-quantile of the flattened v, R's type 7, as
    scipy.stats.mstats.mquantiles(v, q, alphap=1, betap=1) computes it (same operations)."""
    x = np.sort(np.asarray(v, float).ravel())
    n = x.size
    p = np.atleast_1d(np.asarray(q, float))
    aleph = n * p + (1.0 - p)       # mquantiles' n p + alphap + p (1 - alphap - betap)
    k = np.floor(aleph.clip(1, n - 1)).astype(int)
    gamma = (aleph - k).clip(0, 1)
    return float(((1.0 - gamma) * x[(k - 1).tolist()] + gamma * x[k.tolist()])[0])


def _autocov(v) -> np.ndarray:
    """Autocovariance of every chain at every lag (FFT, biased: / draws)."""
    from scipy.fftpack import next_fast_len

    n = v.shape[1]
    f = np.fft.rfft(v - v.mean(1, keepdims=True), n=next_fast_len(2 * n), axis=1)
    f *= np.conjugate(f)
    return np.fft.irfft(f, n=next_fast_len(2 * n), axis=1)[:, :n] / n


def _ess(v) -> float:
    """Effective sample size of (chains, draws) by Geyer's initial monotone sequence."""
    v = np.asarray(v, float)
    if np.isnan(v).any():
        return np.nan
    if np.max(v) - np.min(v) < np.finfo(float).resolution:
        return v.size
    n_chain, n_draw = v.shape
    acov = _autocov(v)
    mean_var = np.mean(acov[:, 0]) * n_draw / (n_draw - 1.0)
    var_plus = mean_var * (n_draw - 1.0) / n_draw
    if n_chain > 1:
        var_plus += np.var(v.mean(1), ddof=1)
    rho = np.zeros(n_draw)
    even, odd = 1.0, 1.0 - (mean_var - np.mean(acov[:, 1])) / var_plus
    rho[0], rho[1] = even, odd
    t = 1
    while t < n_draw - 3 and even + odd > 0.0:        # initial positive sequence
        even = 1.0 - (mean_var - np.mean(acov[:, t + 1])) / var_plus
        odd = 1.0 - (mean_var - np.mean(acov[:, t + 2])) / var_plus
        if even + odd >= 0:
            rho[t + 1], rho[t + 2] = even, odd
        t += 2
    max_t = t - 2
    if even > 0:
        rho[max_t + 1] = even
    t = 1
    while t <= max_t - 2:                             # initial monotone sequence
        if rho[t + 1] + rho[t + 2] > rho[t - 1] + rho[t]:
            rho[t + 1] = rho[t + 2] = (rho[t - 1] + rho[t]) / 2.0
        t += 2
    tau = -1.0 + 2.0 * np.sum(rho[:max_t + 1]) + np.sum(rho[max_t + 1:max_t + 2])
    tau = max(tau, 1 / np.log10(n_chain * n_draw))
    return np.nan if np.isnan(rho).any() else n_chain * n_draw / tau


def ess_bulk(v) -> float:
    """Bulk ESS of (chains, draws): of the rank-normalised split chains."""
    return _ess(_z_scale(_split_chains(np.asarray(v, float))))


def ess_tail(v) -> float:
    """Tail ESS of (chains, draws): the smaller ESS of the indicators of the 5 % and
    95 % quantiles (R's type 7), split chains."""
    v = np.asarray(v, float)
    return min(_ess(_split_chains(v <= _quantile7(v, q))) for q in (0.05, 0.95))


def _rhat(v) -> float:
    n = v.shape[1]
    between = n * np.var(v.mean(1), ddof=1)
    within = np.mean(np.var(v, axis=1, ddof=1))
    return float(np.sqrt((between / within + n - 1) / n))


def rhat_rank(v) -> float:
    """Rank-normalised split R-hat of (chains >= 2, draws; NaN for one chain): the
    larger of the bulk one and the folded one (|v - median|)."""
    v = np.asarray(v, float)
    if v.shape[0] < 2:
        return np.nan
    split = _split_chains(v)
    return max(_rhat(_z_scale(split)), _rhat(_z_scale(np.abs(split - np.median(split)))))


def projection_directions(dim: int, n_proj: int | None = None, seed: int = 0) -> np.ndarray:
    """(n_proj, dim) fixed random unit directions for the ``proj*`` statistics
    (default ``config.N_PROJECTIONS`` of them)."""
    n_proj = config.N_PROJECTIONS if n_proj is None else n_proj
    R = projection_generator(seed).normal(size=(n_proj, dim))
    return R / np.linalg.norm(R, axis=1, keepdims=True)


def by_chain(samples, chains) -> np.ndarray:
    """Samples (k, D) with their chain ids (k,) as (n_chains, draws, D), each chain cut to
    the shortest one's length (in drawing order)."""
    X = np.asarray(samples, float)
    ids = np.unique(chains)
    per = [X[np.asarray(chains) == c] for c in ids]
    k = min((len(p) for p in per), default=0)
    return np.stack([p[:k] for p in per]) if per else np.zeros((0, 0, X.shape[1]))


def tracked_statistics(X, n_proj: int | None = None, seed: int = 0) -> dict:
    """{name: (chains, draws)}: ``sqdev`` and ``proj0..`` of X (chains, draws, D)."""
    X = np.asarray(X, float)
    mean = X.reshape(-1, X.shape[2]).mean(0)
    out = {"sqdev": ((X - mean) ** 2).sum(2)}
    for k, r in enumerate(projection_directions(X.shape[2], n_proj, seed)):
        out[f"proj{k}"] = X @ r
    return out


def summarize(stats: dict) -> dict:
    """Per statistic bulk ESS, tail ESS and R-hat, and over all of them ``min_ess``
    (the smallest bulk or tail ESS), ``max_rhat`` and ``worst`` (the statistic with the
    smallest ESS). NaN where chains are too short (< 4 draws)."""
    per = {}
    for name, v in stats.items():
        v = np.asarray(v, float)
        if v.ndim == 2 and v.shape[0] == 1 and v.shape[1] >= 8:   # one chain: its halves
            v = v[:, :2 * (v.shape[1] // 2)].reshape(2, -1)
        if v.ndim != 2 or v.shape[1] < 4 or not np.all(np.isfinite(v)):
            per[name] = {"ess_bulk": float("nan"), "ess_tail": float("nan"),
                         "rhat": float("nan")}
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if np.ptp(v) == 0:                   # a constant statistic (S is a point)
                per[name] = {"ess_bulk": float(v.size), "ess_tail": float(v.size),
                             "rhat": 1.0}
                continue
            per[name] = {"ess_bulk": float(ess_bulk(v)), "ess_tail": float(ess_tail(v)),
                         "rhat": float(rhat_rank(v))}
    ess = {k: min(d["ess_bulk"], d["ess_tail"]) for k, d in per.items()}
    finite = {k: e for k, e in ess.items() if np.isfinite(e)}
    rh = [d["rhat"] for d in per.values() if np.isfinite(d["rhat"])]
    return {"statistics": per,
            "min_ess": min(finite.values()) if finite and len(finite) == len(ess)
            else float("nan"),
            "max_rhat": max(rh) if rh and len(rh) == len(per) else float("nan"),
            "worst": min(finite, key=finite.get) if finite else None}


def converged(summary: dict, target_ess: float | None = None,
              rhat_max: float | None = None) -> bool:
    """Every tracked statistic has bulk and tail ESS >= target_ess (default
    ``config.MIN_ESS``) and R-hat <= rhat_max (default ``config.RHAT_MAX``)."""
    target_ess = config.MIN_ESS if target_ess is None else target_ess
    rhat_max = config.RHAT_MAX if rhat_max is None else rhat_max
    return bool(np.isfinite(summary["min_ess"]) and summary["min_ess"] >= target_ess
                and summary["max_rhat"] <= rhat_max)


def diagnostics(samples: np.ndarray, chains: np.ndarray, seed: int = 0,
                per_contact: int = 2) -> dict:
    """The convergence record of an ensemble: n_chains, min_ess, max_rhat, worst, the
    per-statistic table, the R-hat/ESS of |x - mean|^2 and the extremes over the
    projections (``rhat_sqdev``, ``ess_sqdev``, ``rhat_projections_max``,
    ``ess_projections_min``) and eta per chain (``per_contact`` columns per contact: 2
    disks, 3 spheres). Fewer than 8 samples: n_chains only."""
    X = np.asarray(samples, float)
    ids = np.unique(chains)
    out = {"n_chains": int(ids.size)}
    if X.shape[0] < 8:
        return out
    s = summarize(tracked_statistics(by_chain(X, chains), seed=seed))
    table = s["statistics"]
    proj = [v for k, v in table.items() if k.startswith("proj")]
    finite = lambda vals: [v for v in vals if np.isfinite(v)]     # noqa: E731
    rp = finite([d["rhat"] for d in proj])
    ep = finite([min(d["ess_bulk"], d["ess_tail"]) for d in proj])
    out.update(min_ess=s["min_ess"], max_rhat=s["max_rhat"], worst=s["worst"],
               statistics=table, rhat_sqdev=table["sqdev"]["rhat"],
               ess_sqdev=min(table["sqdev"]["ess_bulk"], table["sqdev"]["ess_tail"]),
               rhat_projections_max=max(rp) if rp else None,
               ess_projections_min=min(ep) if ep else None,
               eta_per_chain=[float(eta_fn(X[chains == c], per_contact)) if (chains == c).sum() > 1
                              else float("nan") for c in ids])
    return out


def read_ensemble(path):
    """The ensemble of an ensemble file (:func:`forcespace.io.ensemble_file.read_file`)
    with its convergence diagnostics, computed as the sampler computed them in memory
    (:func:`diagnostics`, the walk's seed): the same R-hat and ESS for every sampler."""
    from ..io.ensemble_file import read_file

    ens = read_file(path).ensemble
    ens.diagnostics = diagnostics(ens.samples, ens.chains, ens.params.get("seed", 0),
                                  ens.per_contact)
    return ens
