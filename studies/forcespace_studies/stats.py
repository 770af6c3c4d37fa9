"""Statistics the studies' verdicts rest on: fits, bootstrap intervals over packings,
and the operational readings of the paper's words. Pure functions of arrays."""
from __future__ import annotations

import numpy as np

N_BOOT = 2000
HALF_DECADE = np.sqrt(10.0)   # "near x" = within a factor sqrt(10) (half a decade) of x


def slope_fit(x, y) -> tuple[float, float]:
    """Least-squares slope of log y against log x, and its standard error (nan below 3
    points or without spread in x)."""
    lx, ly = np.log(np.asarray(x, float)), np.log(np.asarray(y, float))
    if lx.size < 3 or np.ptp(lx) == 0:
        return float("nan"), float("nan")
    X = np.column_stack([np.ones_like(lx), lx])
    coef, *_ = np.linalg.lstsq(X, ly, rcond=None)
    resid = ly - X @ coef
    cov = resid @ resid / (lx.size - 2) * np.linalg.inv(X.T @ X)
    return float(coef[1]), float(np.sqrt(cov[1, 1]))


def slope_interval(x, y, level: float = 0.95) -> dict:
    """slope_fit with its t-interval: {slope, se, lo, hi, points}."""
    from scipy.stats import t as student

    slope, se = slope_fit(x, y)
    k = len(x)
    q = student.ppf(0.5 + level / 2, max(k - 2, 1)) if k >= 3 else float("nan")
    return {"slope": slope, "se": se, "lo": slope - q * se, "hi": slope + q * se,
            "points": k}


def interval_verdict(lo: float, hi: float, accept: tuple[float, float]) -> str:
    """A claim that a quantity lies in ``accept``: reproduced when its 95 % interval
    [lo, hi] lies inside, refuted when they do not overlap, else not decidable."""
    a, b = accept
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return "not decidable"
    if a <= lo and hi <= b:
        return "reproduced"
    if hi < a or lo > b:
        return "refuted"
    return "not decidable"


def near(value: float) -> tuple[float, float]:
    """The reading of "near ``value``": within half a decade either side."""
    return value / HALF_DECADE * (1 - 1e-9), value * HALF_DECADE * (1 + 1e-9)


def bootstrap_mean(groups: dict, n_boot: int = N_BOOT, seed: int = 0) -> dict:
    """{key: (mean, lo, hi)}: the mean of each group (array over packings) and its 95 %
    bootstrap interval (resampling packings)."""
    return bootstrap_stat(groups, np.mean, n_boot, seed)


def bootstrap_stat(groups: dict, stat=np.median, n_boot: int = N_BOOT, seed: int = 0) -> dict:
    """{key: (stat, lo, hi)}: a statistic (``stat(array, axis=...)``: np.median, np.mean)
    of each group (array over packings) and its 95 % bootstrap interval (resampling
    packings); empty groups are left out."""
    rng = np.random.default_rng(seed)
    out = {}
    for key, v in groups.items():
        v = np.asarray(v, float)
        if v.size == 0:
            continue
        boots = stat(rng.choice(v, (n_boot, v.size)), axis=1)
        out[key] = (float(stat(v)), *np.quantile(boots, [0.025, 0.975]).tolist())
    return out


def difference_interval(a, b, stat=np.mean, n_boot: int = N_BOOT, seed: int = 0):
    """(stat(a) - stat(b), lo, hi): a difference of two independent groups' statistics
    with its 95 % bootstrap interval (both groups resampled)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.size == 0 or b.size == 0:
        return float("nan"), float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    d = stat(rng.choice(a, (n_boot, a.size)), axis=1) - stat(rng.choice(b, (n_boot, b.size)),
                                                           axis=1)
    return float(stat(a) - stat(b)), *np.quantile(d, [0.025, 0.975]).tolist()


def peak_of_log_parabola(x, y):
    """(x*, curvature) of the least-squares parabola of log y against log x: the
    location of its maximum (None if it curves up)."""
    lx, ly = np.log10(np.asarray(x, float)), np.log(np.asarray(y, float))
    if np.unique(lx).size < 3:
        return None, float("nan")
    c2, c1, _ = np.polyfit(lx, ly, 2)
    return (10 ** (-c1 / (2 * c2)) if c2 < 0 else None), float(c2)


def peak_bootstrap(groups: dict, window: tuple[float, float], n_boot: int = N_BOOT,
                   seed: int = 0) -> dict:
    """Where a positive quantity (eta) peaks against x (mu): a parabola in (log x, log y)
    fitted to every packing's value with x in ``window``, and its 95 % bootstrap interval
    (packings resampled within each x). {peak, lo, hi, curvature, fits (fraction of
    resamples with a maximum inside the window), points}."""
    keys = sorted(k for k in groups if window[0] <= k <= window[1] and len(groups[k]))
    xs = np.concatenate([np.full(len(groups[k]), k) for k in keys]) if keys else np.zeros(0)
    ys = np.concatenate([np.asarray(groups[k], float) for k in keys]) if keys else np.zeros(0)
    keep = ys > 0
    peak, curv = peak_of_log_parabola(xs[keep], ys[keep]) if keep.sum() >= 3 else (None, np.nan)
    rng = np.random.default_rng(seed)
    picks = []
    for _ in range(n_boot):
        bx, by = [], []
        for k in keys:
            v = np.asarray(groups[k], float)
            bx.append(np.full(v.size, k))
            by.append(rng.choice(v, v.size))
        bx, by = np.concatenate(bx), np.concatenate(by)
        ok = by > 0
        p, _ = peak_of_log_parabola(bx[ok], by[ok]) if ok.sum() >= 3 else (None, None)
        picks.append(p if p is not None and window[0] <= p <= window[1] else np.nan)
    picks = np.asarray(picks, float)
    inside = np.isfinite(picks)
    lo, hi = (np.quantile(picks[inside], [0.025, 0.975]).tolist() if inside.mean() >= 0.95
              else (float("nan"), float("nan")))
    return {"peak": peak, "lo": lo, "hi": hi, "curvature": curv,
            "fits": float(inside.mean()), "points": int(keep.sum())}


def ratio_interval(a, b, n_boot: int = N_BOOT, seed: int = 0):
    """(mean a / mean b, lo, hi): a ratio of group means with its 95 % bootstrap interval
    (both groups resampled)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.size == 0 or b.size == 0 or b.mean() == 0:
        return float("nan"), float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    r = rng.choice(a, (n_boot, a.size)).mean(1) / np.maximum(
        rng.choice(b, (n_boot, b.size)).mean(1), 1e-300)
    return float(a.mean() / b.mean()), *np.quantile(r, [0.025, 0.975]).tolist()


def argmax_bootstrap(groups: dict, n_boot: int = N_BOOT, seed: int = 0, stat=np.mean):
    """x of the largest group statistic (``stat``: the mean, or e.g. np.median), and its
    2.5-97.5 % bootstrap interval over packings (grid values; packings resampled within
    each group)."""
    xs = np.array(list(groups))
    means = np.array([stat(v) for v in groups.values()])
    rng = np.random.default_rng(seed)
    picks = [xs[int(np.argmax([stat(rng.choice(v, len(v))) for v in groups.values()]))]
             for _ in range(n_boot)]
    lo, hi = np.quantile(picks, [0.025, 0.975], method="inverted_cdf")
    return float(xs[int(np.argmax(means))]), float(lo), float(hi)


def binomial_interval(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) ``level`` interval of a proportion, k successes of n
    independent trials (packings); (nan, nan) for n = 0."""
    from scipy.stats import binomtest

    if n <= 0:
        return float("nan"), float("nan")
    ci = binomtest(int(k), int(n)).proportion_ci(confidence_level=level, method="exact")
    return float(ci.low), float(ci.high)


def majority_call(k: int, n: int, level: float = 0.95) -> str:
    """Does a statement hold on most packings? "most" when the exact ``level`` interval
    of the fraction k / n lies above 1/2, "few" when it lies below, else "undecided"."""
    lo, hi = binomial_interval(k, n, level)
    if np.isfinite(lo) and lo > 0.5:
        return "most"
    if np.isfinite(hi) and hi < 0.5:
        return "few"
    return "undecided"


def packings_to_decide(k: int, n: int, level: float = 0.95, limit: int = 1000):
    """The smallest number of packings at which the observed fraction k / n, if it
    stayed, would decide :func:`majority_call`; None at k / n = 1/2, for n = 0, or
    beyond ``limit``."""
    if n <= 0 or 2 * k == n:
        return None
    p = k / n
    for m in range(max(n, 1), limit + 1):
        if majority_call(int(round(p * m)), m, level) != "undecided":
            return m
    return None


def pooled_fraction(hits, totals, n_boot: int = N_BOOT, seed: int = 0):
    """(sum hits / sum totals, lo, hi): a fraction of items pooled over packings (e.g.
    domains found again; ``hits[i]`` of ``totals[i]`` items on packing i) with its 95 %
    bootstrap interval, packings resampled with their items (items of one packing are not
    independent). nan for no item."""
    h, t = np.asarray(hits, float), np.asarray(totals, float)
    keep = t > 0
    h, t = h[keep], t[keep]
    if t.size == 0:
        return float("nan"), float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, t.size, (n_boot, t.size))
    boots = h[pick].sum(1) / t[pick].sum(1)
    return float(h.sum() / t.sum()), *np.quantile(boots, [0.025, 0.975]).tolist()


def trend_test(x, y, level: float = 0.01) -> dict:
    """Is y monotonic in x, over every point (packing)? Kendall's tau-b between x and y
    (ties, e.g. a grid of x and y = 0, handled by tau-b) and its one-sided p-values:
    {tau, p_decreasing, p_increasing, points, call}, call "decreases" / "increases" when
    the one-sided p is below ``level``, else "no trend"; nan below 3 points."""
    from scipy.stats import kendalltau

    x, y = np.asarray(x, float), np.asarray(y, float)
    if x.size < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return {"tau": float("nan"), "p_decreasing": float("nan"),
                "p_increasing": float("nan"), "points": int(x.size), "call": "no trend"}
    tau = float(kendalltau(x, y).statistic)
    p_dec = float(kendalltau(x, y, alternative="less").pvalue)
    p_inc = float(kendalltau(x, y, alternative="greater").pvalue)
    call = "decreases" if p_dec < level else "increases" if p_inc < level else "no trend"
    return {"tau": tau, "p_decreasing": p_dec, "p_increasing": p_inc, "points": int(x.size),
            "call": call}


def all_of(*verdicts: str) -> str:
    """A claim made of several conditions (each an :func:`interval_verdict`): refuted if
    one is refuted, reproduced if every one is, else not decidable."""
    if "refuted" in verdicts:
        return "refuted"
    return "reproduced" if all(v == "reproduced" for v in verdicts) else "not decidable"
