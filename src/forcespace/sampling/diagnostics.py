"""Convergence diagnostics of Markov chains of samples of S.

Split R-hat (Gelman et al.) and a bulk effective sample size (Geyer's initial
monotone sequence) of scalar statistics of the samples, one chain per walker:
the per-sample |x - mean|^2 (the quantity eta averages) and three fixed random
projections; and eta per chain.
"""
from __future__ import annotations

import numpy as np

from ..measures import eta as eta_fn


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
