"""Size dependence of the force ambiguity: uniform eta, dim S / Nc and the domains against n.

The paper (end of its cluster section): where the elementary clusters are sparse
(large mu) the domains fluctuate independently and eta should be intensive; where
the indeterminacy percolates (small mu) overlapping clusters feed each other
fluctuating boundary forces and eta grows with the system -- seen up to 500
disks, "not clear what happens in the thermodynamic limit". This study asks it of
the uniform measure on S, judged by the report's rules (report.RULES): the paper's claim
that eta grows with n where indeterminacy percolates (mu = 0.01 and 0.1) in its range
(n <= 500); the open questions, whether eta grows without bound there (three laws
compared, :func:`compare_models`, and checked at the largest sizes, :func:`local_slope`)
and whether it is size-independent at mu = 1.

Tasks: one per (n, mu, seed), seed-major (every size and mu of seed 1, then of seed 2,
...), so an interrupted run holds complete seed rounds. The box keeps the paper's
shape: width and slice height scale by sqrt(n / n0) from the scene's own n0
(:meth:`Scene.scaled_to`; paper: n0 = 200, width 42 R, slice 28 R), so the slice holds
the same fraction of the disks at every n. Per packing: jam (resumable through a
compression checkpoint), the slice's S (:class:`forcespace.ForceSpace`), its
domains (contacts whose force varies in S) and percolation, elementary clusters (rho)
where dim S is small enough, and uniform eta from the billiard walk at every size and
from coordinate hit-and-run (the reference) up to ``har_max_n`` disks; each sampler runs
4 chains to ESS 100 (rule 4), capped in samples and time. The relax walk is not run: it
does not sample S uniformly (fig3), and the size question is asked of uniform eta.

Bulk and boundary: besides the whole scaled slice, eta and the fraction of varying
contacts are measured on a FIXED interior window: the unknown contacts whose contact
point lies in a box of the scene's n0 slice size (paper_fast: 42 R wide, 28 R high),
centred in the slice (horizontally in the periodic box, vertically on the slice
centre), from the same samples restricted to those contacts' columns. The window is
defined only where it lies inside the slice (n >= n0); at n = n0 it is the slice.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import forcespace as fs
from forcespace import config as fs_config, eta as eta_of
from forcespace.extend import ClusterDecomposition, decompose, domains, percolates
from .runner import Task

from .common import run_samplers, sampler, shared_packing
from .report import Verdict
from .stats import slope_fit

# seeds: packings per size (seeds 1..k); caps: samples per sampler (4 chains, the run
# stops at ESS 100 on every tracked statistic, or at the cap / max_seconds: then it is
# excluded from verdicts); har_max_n: largest n sampled by hit-and-run too (its cost per
# effective sample is 300-900x the billiard walk's: studies/sampler_cost.md);
# clusters_max_dim: largest dim S decomposed into elementary clusters (one LP per degree
# of freedom, ~40 s at dim 110-130; above it domains and percolation only, rho empty).
QUICK = dict(scene="quick", sizes=(40, 50, 60), mus=(0.1,), seeds=2,
             caps={"billiard": 4000, "hit_and_run": 1500}, max_seconds=None, har_max_n=60,
             clusters_max_dim=400)
# FULL: the paper's protocol with the fast sweep (inputs/paper_fast.toml: same physics,
# runs of contacts + over-relaxation) at every size; seeds_by_size: fewer packings where
# a jam costs most (n = 5000: ~750 CPU s per jam at mu = 0.1, 53-133 CPU-min at mu = 1
# with its tighter contact solve, 4 jams; the issue's >= 4 packings).
FULL = dict(scene="paper_fast", sizes=(100, 200, 400, 800, 2000, 5000), mus=(0.01, 0.1, 1.0),
            seeds=10, seeds_by_size={5000: 4}, caps={"billiard": 20000, "hit_and_run": 3000},
            max_seconds=900.0, har_max_n=400, clusters_max_dim=60,
            last=((2000, 1.0), (5000, 1.0)),
            protocol_by_mu={1.0: {"solver.tolerance": 1e-8}})
# last: (n, mu) run after every seed round of the others (the costliest jams).
# protocol_by_mu: scene keys set at one mu, for the reason PROTOCOL_WHY gives (the report
# quotes it).
PROTOCOL_WHY = {1.0: (
    "at the scene's 1e-6 the truncated contact solve keeps the mu = 1 jams at n >= 2000 "
    "creeping (n = 2000, seed 1: 83 600 steps, window speeds up to 4e3 x the rest "
    "tolerance; resumed from its checkpoint at 1e-8 it comes to rest in 2-3 windows). The "
    "change is validated against the scene as shipped at n = 200, 400 and 800 over 10 "
    "seeds: no difference in z, packing fraction, rattler fraction or dim S / Nc "
    "(studies/protocol_validation_tolerance_mu1.md)")}
UNIFORM = ("billiard", "hit_and_run")   # the uniform samplers, in the order they are judged
GROWS_MUS = (0.01, 0.1)   # the hypothesis: eta grows with n where indeterminacy percolates
INTENSIVE_MU = 1.0        # ... and is size-independent at mu = INTENSIVE_MU
FLAT = 0.1                # |slope| of log eta vs log n below which eta counts as intensive
MIN_SIZES = 3             # a sampler is judged only with converged eta at >= 3 sizes
AIC_MARGIN = 2.0          # stated before the run: |AIC difference| > 2 favours a model
PAPER_MAX_N = 500         # the paper's range: "simulations up to 500 particles"
SCOPES = ("slice", "window")
# eta at or below this is zero within the samples' accuracy (config.SPREAD_FLOOR: a spread
# per contact below 1e-8 <Fn> is round-off; a window at mu = 1 without a varying contact
# gave eta = 6e-11): such a packing counts as determinate, not as a point of the log fit
ETA_ZERO = fs_config.SPREAD_FLOOR


def config(quick: bool) -> dict:
    return QUICK if quick else FULL


def scaled_geometry(scene: str, n: int) -> tuple[float, int, dict]:
    """(slice height, n0, scene overrides) of the bundled scene SCENE scaled to
    n disks (:meth:`Scene.scaled_to`: box, slice, plate load and mass, dt, rest
    criterion; the overrides use the study's ``section__key`` spelling)."""
    base = fs.load_scene(scene)
    sc, _ = base.scaled_to(n)
    over = {k.replace(".", "__"): sc[k] for k in sc.values
            if k != "disks.n" and sc[k] != base[k]}
    return float(sc["analysis.slice_height"]), int(base["disks.n"]), over


def window_size(scene: str) -> tuple[float, float]:
    """(width, height) [R] of the fixed window: the scene's own (n0) box width and slice
    height."""
    base = fs.load_scene(scene)
    return float(base["box.width"]), float(base["analysis.slice_height"])


def tasks(quick: bool = False) -> list[Task]:
    """Seed-major: for each seed, every size (largest first, so the longest tasks start
    first on a pool) and every mu; an interrupted study has complete seed rounds. The
    (n, mu) of the config's ``last`` come after all rounds, in the order listed (every
    seed of the first, then of the next: a run stopped early has whole sizes done)."""
    cfg = config(quick)
    win = window_size(cfg["scene"])
    out = []
    for seed in range(1, cfg["seeds"] + 1):
        for n in sorted(cfg["sizes"], reverse=True):
            if seed > cfg.get("seeds_by_size", {}).get(n, cfg["seeds"]):
                continue
            for mu in cfg["mus"]:
                out.append(Task(f"n{n}_mu{mu:.3g}_s{seed}", "forcespace_studies.size:packing_task",
                                dict(scene=cfg["scene"], n_disks=n, mu=mu, seed=seed,
                                     caps=dict(cfg["caps"]), max_seconds=cfg["max_seconds"],
                                     hit_and_run=n <= cfg["har_max_n"],
                                     clusters_max_dim=cfg["clusters_max_dim"],
                                     window=list(win),
                                     **protocol_param(cfg, mu))))
    last = [(n, float(mu)) for n, mu in cfg.get("last", ())]
    late = [t for t in out if (t.params["n_disks"], t.params["mu"]) in last]
    late.sort(key=lambda t: last.index((t.params["n_disks"], t.params["mu"])))  # stable
    return [t for t in out if t not in late] + late


def window_contacts(p, prob, window) -> np.ndarray | None:
    """Indices (into the problem's unknown contacts) of those whose contact point lies
    in the fixed window (width, height) centred in the slice; None when the window does
    not fit inside the slice (it would not be fixed)."""
    w, h = window
    if w > p.width * (1 + 1e-9) or h > prob.height * (1 + 1e-9):
        return None
    yc = 0.5 * (p.y_bottom + p.y_top) if np.isfinite(p.y_bottom) and np.isfinite(p.y_top) \
        else 0.5 * (np.min(p.y) + np.max(p.y))
    pt = np.asarray(p.point, float)[prob.contacts]
    dx = np.mod(pt[:, 0], p.width) - 0.5 * p.width     # x in [0, width), periodic
    return np.flatnonzero((np.abs(dx) <= 0.5 * w) & (np.abs(pt[:, 1] - yc) <= 0.5 * h))


def _structure(row, prob, an, p, clusters_max_dim, win):
    """Domains (varying contacts), percolation, rho where dim S is small, and the
    window's varying fraction, into ``row``."""
    t0 = time.perf_counter()
    nc = prob.n_contacts
    if an.dim and an.dim <= clusters_max_dim:
        dec = decompose(prob, an, p)
        rho = dec.density
    else:
        doms = domains(prob, an) if an.dim else []
        dec = ClusterDecomposition(clusters=[], domains=doms,
                                   percolates=[percolates(prob, p, g) for g in doms],
                                   n_interior=prob.n_interior)
        rho = 0.0 if not an.dim else None
    varying = np.zeros(nc, bool)
    for g in dec.domains:
        varying[np.asarray(g.contacts, int)] = True
    row.update(n_domains=len(dec.domains), n_elementary=dec.n_elementary if rho is not None
               else None, density_rho=rho,
               largest_domain_fraction=max((g.contacts.size for g in dec.domains),
                                           default=0) / max(nc, 1),
               varying_fraction=float(varying.sum() / max(nc, 1)),
               percolates=bool(any(dec.percolates)), t_clusters_s=time.perf_counter() - t0)
    if win is not None:
        row.update(window_contacts=int(win.size),
                   window_varying_fraction=float(varying[win].mean()) if win.size else None)


def protocol_param(cfg: dict, mu: float) -> dict:
    """``{"protocol": {key: value}}``, the scene keys the config's ``protocol_by_mu`` sets
    at this mu (dotted keys), or {} where the scene is jammed as shipped (the task's
    parameters then stay those of the runs made before protocol_by_mu existed)."""
    over = cfg.get("protocol_by_mu", {}).get(float(mu))
    return {"protocol": dict(over)} if over else {}


def packing_task(scene: str, n_disks: int, mu: float, seed: int, workdir, caps: dict,
                 max_seconds=None, hit_and_run: bool = True, clusters_max_dim: int = 400,
                 window=(42.0, 28.0), protocol: dict | None = None) -> dict:
    """Jam (or reuse) the packing (n, mu, seed) in the scaled box, analyse its scaled
    slice and its domains, and sample S uniformly (module docstring). ``protocol``:
    scene keys (dotted) jammed with instead of the scene's own (config protocol_by_mu)."""
    wd = Path(workdir)
    height, n0, over = scaled_geometry(scene, n_disks)
    over.update({k.replace(".", "__"): v for k, v in (protocol or {}).items()})
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks, overrides=over)
    prob = fs.slice_problem(p, height)
    t0 = time.perf_counter()
    an = fs.ForceSpace().compute(prob)
    nc = prob.n_contacts
    win = window_contacts(p, prob, window)
    row = {"n": n_disks, "mu": mu, "seed": seed, "width": p.width, "slice_height": height,
           "window_width": window[0], "window_height": window[1],
           "z": p.coordination(), "n_rattlers": int(p.rattlers().sum()),
           "slice_disks": prob.n_interior, "slice_contacts": nc, "feasible": an.feasible,
           "bounded": an.bounded, "full_row_rank": an.full_row_rank, "dim_S": an.dim,
           "dim_S_over_Nc": an.dim / nc if an.dim is not None and nc else None,
           "degree_of_indeterminacy": an.degree_of_indeterminacy,
           "n_sliding": an.n_sliding, "n_zero_force": an.n_zero, "analysis_ok": an.success,
           "jam_steps": p.meta.get("steps"), "static_retries": p.meta.get("static_retries"),
           "static_restart": p.meta.get("static_restart"),
           "t_jam_s": t_jam, "t_analyze_s": time.perf_counter() - t0}
    if not (an.success and an.feasible and an.bounded):
        row["error_analysis"] = an.message if not an.success else "S empty or unbounded"
        return row
    _structure(row, prob, an, p, clusters_max_dim, win)
    names = ["billiard"] + (["hit_and_run"] if hit_and_run else [])
    if not an.dim:                          # S is one point: no ambiguity (mu > 0)
        for k in names:
            row.update({f"eta_{k}": 0.0, f"converged_{k}": True, f"n_{k}": 0})
            if win is not None:
                row[f"eta_window_{k}"] = 0.0
        return row
    runs = [(k, sampler(k, seed, caps[k], max_seconds)) for k in names]
    ens = run_samplers(row, runs, prob, wd, analysis=an)
    for k, e in ens.items():
        if e is not None and win is not None and win.size and e.n_samples >= 2:
            cols = np.stack([2 * win, 2 * win + 1], 1).ravel()
            row[f"eta_window_{k}"] = eta_of(e.samples[:, cols])
    return row


ROW_KEYS = ["task", "n", "mu", "seed", "width", "slice_height", "window_width",
            "window_height", "z", "n_rattlers", "slice_disks", "slice_contacts",
            "window_contacts", "full_row_rank", "analysis_ok", "dim_S", "dim_S_over_Nc",
            "degree_of_indeterminacy", "n_sliding", "n_zero_force", "n_domains",
            "n_elementary", "density_rho", "largest_domain_fraction", "varying_fraction",
            "window_varying_fraction", "percolates",
            "eta_billiard", "eta_window_billiard", "converged_billiard", "n_billiard",
            "ess_billiard", "rhat_billiard", "stop_billiard", "error_billiard",
            "eta_hit_and_run", "eta_window_hit_and_run", "converged_hit_and_run",
            "n_hit_and_run", "ess_hit_and_run", "rhat_hit_and_run", "stop_hit_and_run",
            "error_hit_and_run", "widening_billiard", "widening_hit_and_run",
            "error_analysis", "jam_steps", "static_retries",
            "static_restart", "t_jam_s", "t_analyze_s", "t_clusters_s",
            "t_billiard_s", "t_hit_and_run_s"]


# ----------------------------------------------------------------------------
# the fits and the decision
# ----------------------------------------------------------------------------
def slope_interval(n, eta, level: float = 0.95) -> dict:
    """Least-squares slope of log eta against log n (:func:`stats.slope_fit`), its
    standard error and its ``level`` t-interval (df = points - 2); the residual sd
    on log eta; nan where fewer than 3 points or a single size."""
    from scipy.stats import t as student

    n, eta = np.asarray(n, float), np.asarray(eta, float)
    slope, se = slope_fit(n, eta)
    k = int(n.size)
    if not np.isfinite(slope):
        return {"slope": slope, "se": se, "ci95": [float("nan")] * 2, "points": k,
                "resid_sd": float("nan")}
    q = float(student.ppf(0.5 + level / 2, k - 2))
    x, y = np.log(n), np.log(eta)
    resid = y - np.polyval(np.polyfit(x, y, 1), x)
    return {"slope": slope, "se": se, "ci95": [slope - q * se, slope + q * se], "points": k,
            "resid_sd": float(np.sqrt(resid @ resid / (k - 2)))}


def bootstrap_slope(n, eta, n_boot: int = 2000, seed: int = 0):
    """2.5-97.5 % interval of the slope, packings resampled within each size."""
    n, eta = np.asarray(n, float), np.asarray(eta, float)
    groups = [np.flatnonzero(n == v) for v in np.unique(n)]
    if len(groups) < 2 or n.size < 3:
        return [float("nan")] * 2
    rng = np.random.default_rng(seed)
    s = []
    for _ in range(n_boot):
        idx = np.concatenate([rng.choice(g, g.size) for g in groups])
        s.append(slope_fit(n[idx], eta[idx])[0])
    s = np.array(s)
    s = s[np.isfinite(s)]
    return np.quantile(s, [0.025, 0.975]).tolist() if s.size else [float("nan")] * 2


def classify(lo: float, hi: float, flat: float = FLAT) -> str:
    """The size dependence a 95 % slope interval [lo, hi] decides: "grows" (lo > 0),
    "decreases" (hi < 0), "intensive" (inside [-flat, flat], 0 included), else
    "undecided"."""
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return "undecided"
    if lo > 0:
        return "grows"
    if hi < 0:
        return "decreases"
    if -flat <= lo and hi <= flat:
        return "intensive"
    return "undecided"


def needed(fit: dict, n, flat: float = FLAT, add: int = 4, level: float = 0.95) -> dict:
    """What would decide an undecided fit, if the slope and the scatter stay as fitted:
    the half-width h* the interval must shrink to (below |slope| to exclude 0, or below
    flat - |slope| to fall inside +-flat, whichever is easier), the factor more packings
    at the present sizes (~ (h / h*)^2), and the smallest size N at which ``add`` more
    packings would do it (None beyond 1e7 disks)."""
    from scipy.stats import t as student

    s, (lo, hi) = fit["slope"], fit["ci95"]
    h = (hi - lo) / 2
    target = max(abs(s), flat - abs(s))
    x = np.log(np.asarray(n, float))
    out = {"half_width": h, "half_width_needed": target,
           "packings_factor_same_sizes": (h / target) ** 2, "add_packings": add,
           "size_with_added_packings": None}
    for big in np.unique(np.round(np.logspace(np.log10(max(np.exp(x.max()), 2)), 7, 200))):
        xx = np.concatenate([x, np.full(add, np.log(big))])
        q = float(student.ppf(0.5 + level / 2, xx.size - 2))
        if q * fit["resid_sd"] / np.sqrt(((xx - xx.mean()) ** 2).sum()) <= target:
            out["size_with_added_packings"] = int(big)
            break
    return out


def _profiled_fit(y, shape, grid) -> tuple[float, float, float]:
    """Least squares of log eta = alpha + shape(p) over one shape parameter p, alpha
    profiled out (the mean residual): the best of the increasing values ``grid``, then a
    bounded search between its neighbours (the profile need not be unimodal over the
    whole range). (p, alpha, RSS)."""
    from scipy.optimize import minimize_scalar

    def rss(p):
        r = y - shape(p)
        return float(((r - r.mean()) ** 2).sum())
    pts = np.asarray(grid, float)
    i = int(np.argmin([rss(p) for p in pts]))
    a, b = pts[max(i - 1, 0)], pts[min(i + 1, pts.size - 1)]
    best = minimize_scalar(rss, bounds=(a, b), method="bounded", options={"xatol": 1e-12})
    p = float(best.x) if best.fun <= rss(pts[i]) else float(pts[i])
    return p, float((y - shape(p)).mean()), rss(p)


def _log_law(x, y) -> dict:
    """eta = a + b ln n by least squares on log eta: log eta = alpha + log(1 + s (ln n -
    ln n_min)), s from just above -1 / (ln n_max - ln n_min) (decreasing) to 1e4 times
    its scale (growing from ~0 at n_min); b = e^alpha s, a = e^alpha (1 - s ln n_min)."""
    x0, span = x.min(), np.ptp(x)
    lo = -(1 - 1e-9) / span
    grid = np.concatenate([np.linspace(lo, 0, 200, endpoint=False),
                           np.logspace(-4, 4, 300) / span])
    s, alpha, rss = _profiled_fit(y, lambda s: np.log1p(s * (x - x0)), grid)
    e = float(np.exp(alpha))
    return {"a": e * (1 - s * x0), "b": e * s, "rss": rss,
            "at_bound": bool(s <= lo * 0.999 or s >= 0.999e4 / span)}


def law_log_eta(models: dict, law: str, n) -> np.ndarray:
    """log eta of a fitted law (:func:`compare_models`) at sizes n."""
    x = np.log(np.asarray(n, float))
    if law == "power":
        m = models["power"]
        return m["a"] + m["b"] * x
    if law == "logarithmic":
        m = models["logarithmic"]
        return np.log(m["a"] + m["b"] * x)
    m = models["saturating"]
    return np.log(m["eta_inf"]) + np.log1p(-m["c"] * np.exp(-0.5 * x))


UNBOUNDED = ("power", "logarithmic")   # the laws under which eta grows without bound
LAWS = UNBOUNDED + ("saturating",)


def compare_models(n, eta) -> dict:
    """Three two-parameter laws of eta against n, each fitted by least squares on log eta
    over the packings: the power law log eta = a + b log n, the logarithmic law eta = a +
    b ln n (both unbounded) and the saturating law eta = eta_inf (1 - c n^(-1/2)) (c < 0
    approaches eta_inf from above). AIC = N ln(RSS / N) + 2 k. ``preferred``: the
    saturating law when it is below both unbounded laws by more than AIC_MARGIN; the
    lower unbounded law when it is below the saturating law by more than AIC_MARGIN;
    else "no law favoured"."""
    n, y = np.asarray(n, float), np.log(np.asarray(eta, float))
    k = int(n.size)
    if k < 4 or np.unique(n).size < 3:
        return {"points": k, "preferred": "no fit (needs 4 packings at 3 sizes)"}
    x = np.log(n)
    b, a = np.polyfit(x, y, 1)
    rss_pow = float(((y - a - b * x) ** 2).sum())
    u = n ** -0.5
    cmax = (1 - 1e-9) / u.max()
    c, log_inf, rss_sat = _saturating(y, u, cmax)
    log = _log_law(x, y)

    def aic(rss):
        return float(k * np.log(max(rss, 1e-300) / k) + 2 * 2)
    out = {"points": k, "power": {"a": float(a), "b": float(b), "aic": aic(rss_pow)},
           "logarithmic": {"a": log["a"], "b": log["b"], "aic": aic(log["rss"]),
                           "at_bound": log["at_bound"]},
           "saturating": {"eta_inf": float(np.exp(log_inf)), "c": c, "aic": aic(rss_sat),
                          "at_bound": bool(abs(c - cmax) < 1e-6 * cmax
                                           or c <= -50 * cmax * 0.999)}}
    sat = out["saturating"]["aic"]
    out["aic_power_minus_saturating"] = out["power"]["aic"] - sat
    out["aic_log_minus_saturating"] = out["logarithmic"]["aic"] - sat
    best = min(UNBOUNDED, key=lambda m: out[m]["aic"])
    out["preferred"] = ("saturating" if min(out[m]["aic"] for m in UNBOUNDED) - sat > AIC_MARGIN
                        else best if sat - out[best]["aic"] > AIC_MARGIN
                        else "no law favoured")
    return out


def _saturating(y, u, cmax) -> tuple[float, float, float]:
    """(c, log eta_inf, RSS) of log eta = log eta_inf + log(1 - c u), u = n^(-1/2)."""
    from scipy.optimize import minimize_scalar

    def rss_sat(c):
        r = y - np.log1p(-c * u)
        return float(((r - r.mean()) ** 2).sum())
    best = minimize_scalar(rss_sat, bounds=(-50 * cmax, cmax), method="bounded",
                           options={"xatol": 1e-10})
    c = float(best.x)
    return c, float((y - np.log1p(-c * u)).mean()), rss_sat(c)


def local_slope(n, eta, models: dict, n_boot: int = 2000, seed: int = 0) -> dict | None:
    """The data's d log eta / d log n between the two largest sizes with >= 2 packings
    each (the difference of the mean log eta over that of log n), its 95 % Welch
    t-interval (``ci95``; it decides) and percentile bootstrap interval (packings
    resampled within each size; with 4 packings at a size it covers only ~86 %, measured
    on normal scatter: reported beside), and each fitted law's slope between the same
    sizes (``predicted``), with ``agrees``: inside ``ci95``. None when two such sizes or
    the model fits are missing."""
    from scipy.stats import t as student

    n, y = np.asarray(n, float), np.log(np.asarray(eta, float))
    sizes = [v for v in np.unique(n) if (n == v).sum() >= 2]
    if len(sizes) < 2 or "power" not in models:
        return None
    n1, n2 = sizes[-2], sizes[-1]
    y1, y2 = y[n == n1], y[n == n2]
    dx = np.log(n2 / n1)
    v1, v2 = y1.var(ddof=1) / y1.size, y2.var(ddof=1) / y2.size
    df = (v1 + v2) ** 2 / (v1 ** 2 / (y1.size - 1) + v2 ** 2 / (y2.size - 1)) if v1 + v2 else 1
    slope = float((y2.mean() - y1.mean()) / dx)
    half = float(student.ppf(0.975, df) * np.sqrt(v1 + v2) / dx)
    rng = np.random.default_rng(seed)
    boots = (rng.choice(y2, (n_boot, y2.size)).mean(1)
             - rng.choice(y1, (n_boot, y1.size)).mean(1)) / dx
    lo, hi = slope - half, slope + half
    pred = {m: float(np.diff(law_log_eta(models, m, [n1, n2]))[0] / dx) for m in LAWS}
    return {"sizes": [int(n1), int(n2)], "packings": [int(y1.size), int(y2.size)],
            "slope": slope, "ci95": [lo, hi],
            "bootstrap_ci95": np.quantile(boots, [0.025, 0.975]).tolist(),
            "predicted": pred, "agrees": {m: bool(lo <= v <= hi) for m, v in pred.items()}}


LIMIT_VERDICT = {"unbounded": "supported", "saturating": "not supported",
                 "undecided": "not decidable"}


def limit_call(models: dict, local: dict | None) -> str:
    """Rule 7: "unbounded" when an unbounded law is favoured (:func:`compare_models`) and
    its slope between the two largest sizes agrees with the data's (:func:`local_slope`),
    "saturating" when the saturating law is favoured and agrees so, else "undecided"."""
    pref = models.get("preferred")
    if pref not in LAWS or local is None or not local["agrees"][pref]:
        return "undecided"
    return "saturating" if pref == "saturating" else "unbounded"


# ----------------------------------------------------------------------------
# the summary
# ----------------------------------------------------------------------------
def _rows(results):
    return [dict(r, task=r["task"]) for r in results if r.get("ok")]


def _eta_key(scope: str, k: str) -> str:
    return f"eta_{k}" if scope == "slice" else f"eta_window_{k}"


def eta_points(rows, mu, k, scope="slice", max_n=None):
    """(n, eta) arrays of the converged runs of sampler k at mu (rule 4) with eta >
    ETA_ZERO (at n <= ``max_n`` if given), and the count of converged determinate ones
    (eta = 0 within accuracy, left out of the log fits)."""
    key = _eta_key(scope, k)
    ok = [r for r in rows if r["mu"] == mu and r.get(f"converged_{k}")
          and r.get(key) is not None and (max_n is None or r["n"] <= max_n)]
    pos = [(r["n"], r[key]) for r in ok if r[key] > ETA_ZERO]
    n = np.array([q[0] for q in pos], float)
    e = np.array([q[1] for q in pos], float)
    return n, e, len(ok) - len(pos)


def counts(rows, mu, n, k) -> dict:
    """Packings at (n, mu) and what sampler k made of them: converged (entering the
    verdicts), excluded (sampled, not converged or capped: rule 4), failed (the run
    raised, or the analysis it starts from failed), not run (hit-and-run above its
    largest n)."""
    here = [r for r in rows if r["mu"] == mu and r["n"] == n]

    def failed(r):
        return bool(r.get(f"error_{k}") or r.get("error_analysis"))
    conv = sum(1 for r in here if r.get(f"converged_{k}"))
    fail = sum(1 for r in here if failed(r))
    exc = sum(1 for r in here if r.get(f"eta_{k}") is not None and not r.get(f"converged_{k}")
              and not failed(r))
    return {"packings": len(here), "converged": conv, "excluded": exc, "failed": fail,
            "not_run": len(here) - conv - exc - fail}


def _fit(rows, mu, k, scope, max_n=None) -> dict:
    """The slope of log eta against log n over the converged packings of sampler k at mu
    (sizes up to ``max_n``), its call, and (over all sizes) the three laws compared and
    the slope between the two largest sizes."""
    n, e, zeros = eta_points(rows, mu, k, scope, max_n)
    fit = slope_interval(n, e)
    fit["sizes"] = int(np.unique(n).size)
    fit["bootstrap_ci95"] = bootstrap_slope(n, e)
    fit["call"] = classify(*fit["ci95"])
    fit["zeros_left_out"] = zeros
    if fit["call"] == "undecided" and np.isfinite(fit["slope"]):
        fit["needed"] = needed(fit, n)
    if max_n is None:
        fit["models"] = compare_models(n, e)
        fit["local_slope"] = local_slope(n, e, fit["models"])
        if n.size:      # how much the comparison rests on the largest size
            rest = n < n.max()
            fit["preferred_without_largest"] = {
                "n": int(n.max()), "preferred": compare_models(n[rest], e[rest])["preferred"]}
    return fit


def fit_all(rows, mus) -> dict:
    """{(sampler, scope, mu): fit} over every size (scopes slice and window) and, for the
    paper's claim, the slice up to PAPER_MAX_N (scope "paper_range")."""
    fits = {(k, scope, mu): _fit(rows, mu, k, scope)
            for k in UNIFORM for scope in SCOPES for mu in mus}
    fits.update({(k, "paper_range", mu): _fit(rows, mu, k, "slice", PAPER_MAX_N)
                 for k in UNIFORM for mu in mus if mu in GROWS_MUS})
    return fits


def judge(rows) -> tuple[dict, list]:
    """(numbers, verdicts) of the size study from its rows (one per packing, as the tasks
    return them with their ``task``): a pure function of them."""
    mus = sorted({r["mu"] for r in rows})
    return _verdicts(rows, fit_all(rows, mus), mus)


def _fraction_zero(rows):
    d = [r["dim_S"] for r in rows if r.get("dim_S") is not None]
    return float(np.mean([x == 0 for x in d])) if d else None


def _by_n_table(rows, mus) -> list[dict]:
    from .stats import bootstrap_mean

    out = []
    for mu in mus:
        for n in sorted({r["n"] for r in rows if r["mu"] == mu}):
            here = [r for r in rows if r["mu"] == mu and r["n"] == n]

            def mean(key, rs=here):
                v = [float(r[key]) for r in rs if r.get(key) is not None]
                return float(np.mean(v)) if v else None
            row = {"mu": mu, "n": n, "packings": len(here),
                   "slice_disks_mean": mean("slice_disks"), "z_mean": mean("z"),
                   "dim_S_over_Nc_mean": mean("dim_S_over_Nc"),
                   "fraction_dim_S_0": _fraction_zero(here),
                   "varying_fraction_mean": mean("varying_fraction"),
                   "window_varying_fraction_mean": mean("window_varying_fraction"),
                   "window_contacts_mean": mean("window_contacts"),
                   "density_rho_mean": mean("density_rho") if all(
                       r.get("density_rho") is not None for r in here) else None,
                   "percolating_fraction": mean("percolates"),
                   "largest_domain_fraction_mean": mean("largest_domain_fraction")}
            for k in UNIFORM:
                c = counts(rows, mu, n, k)
                row.update({f"{k}_{q}": v for q, v in c.items() if q != "packings"})
                for scope in SCOPES:
                    key = _eta_key(scope, k)
                    v = [r[key] for r in here if r.get(f"converged_{k}")
                         and r.get(key) is not None]
                    pos = [x for x in v if x > ETA_ZERO]   # the population of the log fits
                    b = bootstrap_mean({0: pos}).get(0) if pos else None
                    row.update({f"{key}_mean": b[0] if b else None,
                                f"{key}_lo": b[1] if b else None,
                                f"{key}_hi": b[2] if b else None,
                                f"{key}_packings": len(pos), f"{key}_zeros": len(v) - len(pos)})
            out.append(row)
    return out


def summarize(results: list[dict], out) -> dict:
    """size.csv (one row per packing), size_by_n.csv, size.png/.pdf, verdicts, REPORT.md."""
    from .report import RULES_VERSION, failed_tasks_note, study_info, write_csv, write_section

    out = Path(out)
    rows = _rows(results)
    failed = [r for r in results if not r.get("ok")]
    write_csv(out / "size.csv", rows, ROW_KEYS)
    mus = sorted({r["mu"] for r in rows})
    by_n = _by_n_table(rows, mus)
    if by_n:
        write_csv(out / "size_by_n.csv", by_n, list(by_n[0]))
    fits = fit_all(rows, mus)
    figures = []
    if rows:
        _figure(out, rows, by_n, fits, mus)
        figures = ["size.png"]
    numbers, verdicts = _verdicts(rows, fits, mus)
    numbers.update({"tasks": len(results), "tasks_failed": len(failed),
                    "failed": [f"{r['task']}: {r.get('error')}" for r in failed],
                    "by_n": by_n})
    text = _text(rows, fits, mus)
    info = study_info(out)
    total = info.get("tasks")
    last = (info.get("config") or {}).get("last") or ()
    if last:
        text += ("\n\nRun last, after every seed round of the others: " + ", ".join(
            f"n = {n}, mu = {mu:g}" for n, mu in last) + " (the costliest jams).")
    for mu, keys in sorted(((info.get("config") or {}).get("protocol_by_mu") or {}).items()):
        text += (f"\n\nAt mu = {float(mu):g} every size is jammed with "
                 + ", ".join(f"{k} = {v:g}" for k, v in keys.items()) + " instead of the "
                 "scene's own value" + (f": {PROTOCOL_WHY[float(mu)]}"
                                        if float(mu) in PROTOCOL_WHY else "") + ".")
    text += restarts_note(rows) + widening_note(rows)
    if rows:
        text += ("\n\nPackings per (mu, n) and what entered the fits (converged runs with eta "
                 "> 0; determinate ones counted after the +; mean eta over the former with "
                 "its 95 % bootstrap interval):\n\n" + packings_table(by_n))
    if total and len(results) < total:
        text += (f"\n\n{len(results)} of the {total} tasks of the study were done when this "
                 f"summary was written (a run stopped at its deadline; the runner resumes "
                 f"the rest): the packings counted above are those done.")
    text += failed_tasks_note(failed, results)
    write_section(out, "size", "Size dependence: uniform eta, dim S and the domains against n",
                  text, verdicts, numbers, figures=figures, rules_version=RULES_VERSION)
    return {"tasks": len(results), "failed": len(failed), "rows": len(rows),
            "table": str(out / "size.csv"), "figure": str(out / "size.png"),
            "slopes": {f"{k}/{scope}/{mu:g}": {"slope": f["slope"], "ci95": f["ci95"],
                                              "call": f["call"]}
                       for (k, scope, mu), f in fits.items()},
            "verdicts": [v.verdict for v in verdicts]}


def restarts_note(rows) -> str:
    """The packings whose static solve stalled and restarted from an exact point of S
    (build_packing's last step; rows made before it was recorded say nothing)."""
    hit = [r for r in rows if r.get("static_restart") == "exact point"]
    if not hit:
        return ""
    return ("\n\nStatic solve restarted from an exact point of S (Gauss-Seidel from the "
            "dynamics' forces stalled above the static tolerance, also after the further "
            "compressions; the LP found a static network and Gauss-Seidel finished from "
            f"it): {len(hit)} of {len(rows)} packings (" + ", ".join(
                f"n = {r['n']}, mu = {r['mu']:g}, seed {r['seed']}" for r in hit) + ").")


def widening_note(rows) -> str:
    """The packings whose S had no point strictly inside in its affine hull, so that the
    uniform samplers moved every free row out by round-off (sampling.hit_and_run.frame)."""
    hit = [(r, k) for r in rows for k in ("billiard", "hit_and_run") if r.get(f"widening_{k}")]
    if not hit:
        return ""
    return ("\n\nFrame widened (S, thin as round-off in a direction its dimension keeps, had "
            "no point strictly inside in its affine hull; every free inequality moved out by "
            f"the start's miss plus {fs_config.FRAME_MARGIN:g} <Fn>, every sample within "
            "that of S): " + "; ".join(
                f"n = {r['n']}, mu = {r['mu']:g}, seed {r['seed']} ({k.replace('_', '-')}, "
                f"{r[f'widening_{k}']:.2g} <Fn>)" for r, k in hit) + ".")


def _eta_panel(ax, rows, by_n, fits, mus, scope, win):
    from matplotlib.ticker import NullFormatter

    from .report import SAMPLERS as LABELS

    for i, mu in enumerate(mus):
        c = f"C{i}"
        for k, mk in (("billiard", "o"), ("hit_and_run", "s")):
            n, e, _ = eta_points(rows, mu, k, scope)
            jit = np.exp(0.04 * (1 if k == "hit_and_run" else -1))    # side by side
            ax.plot(n * jit, e, mk, color=c, ms=3 if k == "billiard" else 4, alpha=0.45,
                    mfc=c if k == "billiard" else "none", lw=0)
            key = _eta_key(scope, k)
            b = [r for r in by_n if r["mu"] == mu and r.get(f"{key}_mean")]
            if not b:
                continue
            x = np.array([r["n"] for r in b], float)
            m = np.array([r[f"{key}_mean"] for r in b])
            if k == "billiard":
                ax.fill_between(x, [r[f"{key}_lo"] for r in b], [r[f"{key}_hi"] for r in b],
                                color=c, alpha=0.18, lw=0)
                f = fits[(k, scope, mu)]
                lab = rf"$\mu$ = {mu:g}, {LABELS[k].split(' (')[0]}: mean, 95 % band"
                if np.isfinite(f["slope"]):
                    lab += f"; slope {f['slope']:.2f} [{f['ci95'][0]:.2f}, {f['ci95'][1]:.2f}]"
                ax.plot(x, m, "-", color=c, lw=1.2, label=lab)
            else:
                ax.plot(x, m, "--", color=c, lw=0.9, marker="s", mfc="none", ms=5,
                        label=rf"$\mu$ = {mu:g}, hit-and-run: mean")
    where = ("whole scaled slice" if scope == "slice" else
             f"fixed window {win[0]:g} R x {win[1]:g} R")
    ax.set(xscale="log", yscale="log", xlabel="n (disks in the box)",
           ylabel=r"$\eta = \langle \delta F\rangle / \langle |F| \rangle$ (dimensionless)",
           title=f"uniform eta > 0, {where}\n(converged runs; markers: packings; "
                 "band: 95 % CI of the mean)")
    ax.xaxis.set_minor_formatter(NullFormatter())   # decades only: minor labels collide
    ax.legend(fontsize=6, loc="best")


LAW_STYLE = {"saturating": "-", "logarithmic": "--", "power": ":"}
LAWS_DRAWN_TO = 20000       # the laws are drawn beyond the largest size measured, to here


def _laws_panel(ax, by_n, fits, mus, scope, win):
    """The billiard walk's mean eta per size (95 % interval) and the three laws of
    :func:`compare_models` fitted to its packings, extrapolated to LAWS_DRAWN_TO disks (the
    shaded range has no data: it shows where the laws part, not a prediction)."""
    n_max = max(r["n"] for r in by_n)
    key = _eta_key(scope, "billiard")
    lows = [r[f"{key}_lo"] for r in by_n if r.get(f"{key}_mean") and r[f"{key}_lo"] > 0]
    for i, mu in enumerate(mus):
        c = f"C{i}"
        b = [r for r in by_n if r["mu"] == mu and r.get(f"{key}_mean")]
        if not b:
            continue
        x = np.array([r["n"] for r in b], float)
        m = np.array([r[f"{key}_mean"] for r in b])
        err = [m - [r[f"{key}_lo"] for r in b], [r[f"{key}_hi"] for r in b] - m]
        ax.errorbar(x, m, yerr=err, fmt="o", color=c, ms=4, capsize=2, lw=1,
                    label=rf"$\mu$ = {mu:g}: billiard mean, 95 % CI")
        models = fits[("billiard", scope, mu)].get("models") or {}
        if "saturating" not in models:
            continue
        grid = np.geomspace(x.min(), LAWS_DRAWN_TO, 200)
        daic = {"saturating": 0.0, "power": models["aic_power_minus_saturating"],
                "logarithmic": models["aic_log_minus_saturating"]}
        for law, ls in LAW_STYLE.items():
            with np.errstate(invalid="ignore"):     # a logarithmic law below 0: not drawn
                curve = np.exp(law_log_eta(models, law, grid))
            ax.plot(grid, curve, ls, color=c, lw=1,
                    label=rf"$\mu$ = {mu:g}: {law} law, $\Delta$AIC {daic[law]:+.1f}")
    ax.axvspan(n_max, LAWS_DRAWN_TO, color="0.92", lw=0, zorder=0)
    ax.text(np.sqrt(n_max * LAWS_DRAWN_TO), 0.98, "no data:\nlaws extrapolated",
            transform=ax.get_xaxis_transform(), ha="center", va="top", fontsize=7)
    where = ("whole scaled slice" if scope == "slice" else
             f"fixed window {win[0]:g} R x {win[1]:g} R")
    ax.set(xscale="log", yscale="log", xlabel="n (disks in the box)",
           ylabel=r"$\eta$ (dimensionless)",
           title=f"three laws fitted to the billiard packings, {where}\n"
                 r"(least squares on log eta; $\Delta$AIC against the saturating law)")
    if lows:                    # room below the data for the legend
        ax.set_ylim(bottom=min(lows) / 8)
    ax.legend(fontsize=5.5, loc="lower right", ncol=2)


def _figure(out, rows, by_n, fits, mus) -> None:
    from matplotlib.figure import Figure

    from forcespace.extend import save_figure

    win = (rows[0]["window_width"], rows[0]["window_height"])
    fig = Figure(figsize=(13, 14))
    (a1, a2), (a5, a6), (a3, a4) = fig.subplots(3, 2)
    _eta_panel(a1, rows, by_n, fits, mus, "slice", win)
    _eta_panel(a2, rows, by_n, fits, mus, "window", win)
    _laws_panel(a5, by_n, fits, mus, "slice", win)
    _laws_panel(a6, by_n, fits, mus, "window", win)
    for i, mu in enumerate(mus):
        c = f"C{i}"
        mine = [b for b in by_n if b["mu"] == mu]
        for key, st, lab in (("dim_S_over_Nc_mean", "o-", "dim S / Nc (slice)"),
                             ("varying_fraction_mean", "^--", "varying fraction (slice)"),
                             ("window_varying_fraction_mean", "v:", "varying fraction (window)")):
            ok = [b for b in mine if b[key] is not None]
            a3.plot([b["n"] for b in ok], [b[key] for b in ok], st, color=c, mfc="none",
                    ms=5, label=rf"$\mu$ = {mu:g}: {lab}")
        ok = [b for b in mine if b["percolating_fraction"] is not None]
        a4.plot([b["n"] for b in ok], [b["percolating_fraction"] for b in ok], "o-", color=c,
                label=rf"$\mu$ = {mu:g}: fraction of packings percolating")
        a4.plot([b["n"] for b in ok], [b["largest_domain_fraction_mean"] for b in ok], "^--",
                color=c, mfc="none", label=rf"$\mu$ = {mu:g}: largest domain / Nc")
    a3.set(xscale="log", xlabel="n (disks in the box)", ylabel="fraction of contacts",
           ylim=(-0.03, 1.45), title="dim S per slice contact; contacts whose force varies in S")
    a4.set(xscale="log", xlabel="n (disks in the box)", ylabel="fraction",
           ylim=(-0.03, 1.35), title="percolation (a domain spans the slice) and the "
                                     "largest domain")
    for ax in (a3, a4):
        ax.set_yticks(np.linspace(0, 1, 6))     # the room above 1 is the legend's
    a3.legend(fontsize=6, loc="upper center", ncol=3)
    a4.legend(fontsize=6, loc="upper center", ncol=3)
    save_figure(fig, out / "size.png", tight=True)


def _fit_text(f) -> str:
    if not np.isfinite(f["slope"]):
        return (f"no fit ({f['points']} converged packings with eta > 0 at {f['sizes']} "
                f"sizes; needs 3 and two sizes)")
    s = (f"d log eta / d log n = {f['slope']:.3f} ± {f['se']:.3f} (95 %: "
         f"{f['ci95'][0]:.3f} to {f['ci95'][1]:.3f}; bootstrap over packings "
         f"{f['bootstrap_ci95'][0]:.3f} to {f['bootstrap_ci95'][1]:.3f}), "
         f"{f['points']} converged packings at {f['sizes']} sizes")
    if f["zeros_left_out"]:
        s += f", {f['zeros_left_out']} determinate (eta = 0) left out of the log fit"
    nd = f.get("needed")
    if nd:
        big = nd["size_with_added_packings"]
        s += (f"; to decide, the half-width {nd['half_width']:.3f} must shrink to "
              f"{nd['half_width_needed']:.3f}: ~{nd['packings_factor_same_sizes']:.1f}x the "
              f"packings at these sizes, or {nd['add_packings']} more at n ≈ "
              + (f"{big}" if big else "> 1e7") + " (same scatter)")
    return s


def _models_text(m) -> str:
    if "power" not in m:
        return f"model comparison: {m['preferred']}"
    p, lg, s = m["power"], m["logarithmic"], m["saturating"]
    return (f"three laws (AIC, least squares on log eta): power exponent {p['b']:.3f}; "
            f"logarithmic eta = {lg['a']:.3g} + {lg['b']:.3g} ln n"
            + (" (at its bound)" if lg["at_bound"] else "")
            + f"; saturating eta_inf = {s['eta_inf']:.4g}, c = {s['c']:.3g}"
            + (" (at its bound)" if s["at_bound"] else "")
            + f"; AIC - AIC(saturating): power {m['aic_power_minus_saturating']:.2f}, "
              f"logarithmic {m['aic_log_minus_saturating']:.2f}: "
            + (f"no law favoured (within ±{AIC_MARGIN:g})" if m["preferred"] not in LAWS
               else f"the {m['preferred']} law is favoured"))


def _local_text(local, without=None) -> str:
    """The slope at the two largest sizes against the laws' (:func:`local_slope`), and
    the comparison without the largest size."""
    rest = (f"; without the n = {without['n']} packings: {without['preferred']}"
            if without else "")
    if local is None:
        return "slope at the largest sizes: no two sizes with 2 packings each" + rest
        return "slope at the largest sizes: no two sizes with 2 packings each"
    n1, n2 = local["sizes"]
    pred = ", ".join(f"{law} {v:.3f}" + ("" if local["agrees"][law] else " (outside)")
                     for law, v in local["predicted"].items())
    b = local["bootstrap_ci95"]
    return (f"slope between n = {n1} and {n2} ({local['packings'][0]} and "
            f"{local['packings'][1]} packings): {local['slope']:.3f} (95 % Welch t-interval "
            f"{local['ci95'][0]:.3f} to {local['ci95'][1]:.3f}; bootstrap over packings "
            f"{b[0]:.3f} to {b[1]:.3f}); the laws predict {pred}{rest}")


def _claim(mu, scope):
    where = "" if scope == "slice" else " (fixed interior window: bulk)"
    if scope == "paper_range":
        return (f"eta grows with n where indeterminacy percolates (mu = {mu:g}), in the "
                f"paper's range (n <= {PAPER_MAX_N}, whole slice)")
    if mu in GROWS_MUS:
        return (f"hypothesis: eta grows without bound as n -> infinity where indeterminacy "
                f"percolates (mu = {mu:g}){where}")
    return f"hypothesis: eta is size-independent (intensive) at mu = {mu:g}{where}"


# the call of a slope interval (:func:`classify`) as a verdict: of the paper's claim that
# eta grows (in its range), and of the hypothesis that eta is intensive
VERDICT_OF = {"grows": {"grows": "reproduced", "intensive": "refuted", "decreases": "refuted"},
              "intensive": {"intensive": "supported", "grows": "not supported",
                            "decreases": "not supported"}}


def _percolating_text(rows, mu, k, max_n=None) -> str:
    """The fraction of packings with a percolating domain at each size with converged
    runs of sampler k (up to max_n)."""
    here = [r for r in rows if r["mu"] == mu and (max_n is None or r["n"] <= max_n)]
    sizes = sorted({r["n"] for r in here if r.get(f"converged_{k}")})
    return ", ".join(f"{np.mean([r['percolates'] for r in here if r['n'] == n and r.get('percolates') is not None]):.2f}"
                     for n in sizes)


def _runs_text(numbers, rows, k, scope, mu, max_n=None) -> str:
    """'N disks: c of p; ...' over the sizes judged (window: where it is defined)."""
    return "; ".join(
        f"{n[1:]} disks: {c['converged']} of {c['packings']}"
        + (f" ({c['excluded']} excluded, {c['failed']} failed)"
           if c["excluded"] or c["failed"] else "")
        for n, c in numbers["runs_per_mu_and_n"][k][f"mu{mu:g}"].items()
        if (c["converged"] or c["excluded"] or c["failed"])
        and (max_n is None or int(n[1:]) <= max_n) and (
            scope != "window" or any(r.get("window_contacts") is not None
                                     for r in rows if f"n{r['n']}" == n)))


def _verdicts(rows, fits, mus):
    numbers: dict = {"eta_slopes": {f"{k}/{scope}/mu{mu:g}": f
                                    for (k, scope, mu), f in fits.items()},
                     "runs_per_mu_and_n": {
                         k: {f"mu{mu:g}": {f"n{n}": counts(rows, mu, n, k)
                                           for n in sorted({r['n'] for r in rows
                                                            if r['mu'] == mu})}
                             for mu in mus} for k in UNIFORM},
                     "window": {"width_R": rows[0]["window_width"],
                                "height_R": rows[0]["window_height"]} if rows else None,
                     "aic_margin": AIC_MARGIN, "flat": FLAT, "paper_max_n": PAPER_MAX_N}
    verdicts = []
    for k in UNIFORM:
        for scope in ("paper_range",) + SCOPES:
            for mu in mus:
                f = fits.get((k, scope, mu))
                if f is None or (mu not in GROWS_MUS and mu != INTENSIVE_MU) \
                        or f["sizes"] < MIN_SIZES:
                    continue
                perc = _percolating_text(rows, mu, k, PAPER_MAX_N if scope == "paper_range"
                                         else None)
                conv = _runs_text(numbers, rows, k, scope, mu,
                                  PAPER_MAX_N if scope == "paper_range" else None)
                facts = (f"converged runs per size: {conv}; percolating fraction at the judged "
                         f"sizes: {perc}")
                if mu in GROWS_MUS and scope != "paper_range":
                    verdicts.append(_limit_verdict(mu, scope, k, f, facts))
                    continue
                want = "grows" if mu in GROWS_MUS else "intensive"
                verdicts.append(Verdict(
                    "size", _claim(mu, scope),
                    f"{_fit_text(f)}; size dependence: {f['call']}; {facts}",
                    VERDICT_OF[want].get(f["call"], "not decidable"), sampler=k,
                    kind="paper" if want == "grows" else "hypothesis",
                    rule=(f"the 95 % t-interval of the slope of log eta against log n "
                          f"(converged packings with eta > 0, n <= {PAPER_MAX_N}) above 0; "
                          f"refuted if it lies below 0 or inside ±{FLAT:g} (issue 45, after "
                          f"the data were seen: it was a hypothesis over every size)"
                          if want == "grows"
                          else f"the 95 % t-interval of the slope inside ±{FLAT:g}")
                    + "; not decidable otherwise (what would decide it is stated)"))
    return numbers, verdicts


def _limit_verdict(mu, scope, k, fit, facts):
    """The paper's "not clear what happens in the thermodynamic limit" (rule 7): the
    three laws compared (:func:`compare_models`) and the slope at the largest sizes
    (:func:`local_slope`), decided by :func:`limit_call`."""
    models, local = fit["models"], fit.get("local_slope")
    call = limit_call(models, local) if "power" in models else "undecided"
    s = models.get("saturating") or {}
    tail = {"saturating": f"; eta levels off at eta_inf = {s.get('eta_inf', 0):.3g}",
            "unbounded": f"; eta keeps growing as the {models.get('preferred')} law says"
            }.get(call, "")
    return Verdict(
        "size", _claim(mu, scope),
        f"{_fit_text(fit)}; {_models_text(models)}; "
        f"{_local_text(local, fit.get('preferred_without_largest'))}{tail}; {facts}",
        LIMIT_VERDICT[call], sampler=k, kind="hypothesis",
        rule=f"rule 7: a law decides if it beats each law of the other kind (unbounded: "
             f"power, logarithmic; bounded: saturating eta_inf (1 - c n^-1/2)) by AIC > "
             f"{AIC_MARGIN:g} and its slope between the two largest sizes lies inside the "
             f"data's 95 % Welch t-interval there: unbounded supported, saturating not "
             f"supported (levels off); else not decidable (issue 45: the logarithmic law "
             f"and the check at the largest sizes added after the data were seen)")


def _caps(params) -> str:
    caps = params.get("caps") or {}
    cap = " / ".join(f"{v} ({k.replace('_', '-')})" for k, v in caps.items())
    sec = params.get("max_seconds")
    return f"{cap} samples" + (f" and {sec:g} s per run" if sec else "")


def packings_table(by_n) -> str:
    """Markdown: per (mu, n) the packings, the converged runs that enter the fits
    (eta > 0 / determinate) and excluded, and the means with their 95 % intervals."""
    def eta(b, key):
        if b.get(f"{key}_mean") is None:
            return "-"
        return f"{b[f'{key}_mean']:.4f} [{b[f'{key}_lo']:.4f}, {b[f'{key}_hi']:.4f}]"
    lines = ["| mu | n | packings | billiard: converged (eta > 0 + eta = 0), excluded, "
             "failed | hit-and-run: same | dim S / Nc | eta, slice (billiard) | "
             "eta, window (billiard) | varying fraction, window |", "|" + "---|" * 9]
    for b in by_n:
        cell = {k: f"{b[f'eta_{k}_packings']} + {b[f'eta_{k}_zeros']}, "
                   f"{b[f'{k}_excluded']}, {b[f'{k}_failed']}"
                if b[f"{k}_converged"] + b[f"{k}_excluded"] + b[f"{k}_failed"] else "not run"
                for k in UNIFORM}
        vw = b["window_varying_fraction_mean"]
        lines.append(f"| {b['mu']:g} | {b['n']} | {b['packings']} | {cell['billiard']} | "
                     f"{cell['hit_and_run']} | {b['dim_S_over_Nc_mean']:.3f} | "
                     f"{eta(b, 'eta_billiard')} | {eta(b, 'eta_window_billiard')} | "
                     + (f"{vw:.3f} |" if vw is not None else "- |"))
    return "\n".join(lines)


def params_seeds(rows) -> str:
    """'k at n = N, ...': packings done per size (all mu together)."""
    sizes = sorted({r["n"] for r in rows})
    return ", ".join(f"{len({(r['mu'], r['seed']) for r in rows if r['n'] == n})} at n = {n}"
                     for n in sizes)


def _text(rows, fits, mus) -> str:
    if not rows:
        return "No finished task."
    sizes = sorted({r["n"] for r in rows})
    small = min(rows, key=lambda r: r["n"])
    params = rows[0].get("params") or {}
    har = sorted({r["n"] for r in rows if r.get("n_hit_and_run") is not None
                  or r.get("eta_hit_and_run") is not None})
    per = "; ".join(f"mu = {mu:g}: " + ", ".join(
        f"{sum(1 for r in rows if r['mu'] == mu and r['n'] == n)} at n = {n}"
        for n in sizes if any(r['mu'] == mu and r['n'] == n for r in rows)) for mu in mus)
    ex = {k: sum(c["excluded"] for mu in mus for n in sizes
                 for c in [counts(rows, mu, n, k)]) for k in UNIFORM}
    fl = {k: sum(c["failed"] for mu in mus for n in sizes
                 for c in [counts(rows, mu, n, k)]) for k in UNIFORM}
    models = "\n".join(
        f"- {k}, {scope}, mu = {mu:g}: {_models_text(f['models'])}"
        for (k, scope, mu), f in fits.items() if "power" in f.get("models", {}))
    return (
        f"{len(rows)} packings ({per}), one new packing per (n, mu, seed), run seed-major. "
        f"The box keeps the paper's shape: width and slice height scale with sqrt(n / n0) "
        f"from the scene's n0 (paper: 42 R and 28 R at n0 = 200; here {small['width']:.3g} "
        f"R and {small['slice_height']:.3g} R at n = {small['n']}), so the slice holds the "
        f"same share of the disks. Packings per size: {params_seeds(rows)} (fewer at the "
        f"largest n, where one jam costs ~750 CPU s at mu = 0.1 and 1-2 CPU-h at mu = 1 "
        f"with its tighter contact solve).\n\n"
        f"eta is the uniform measure's: the billiard walk at every size and coordinate "
        f"hit-and-run (the reference) at n = {', '.join(map(str, har)) or '-'}; each runs 4 "
        f"chains to ESS 100 on every tracked statistic with split R-hat <= 1.05 (rule 4), "
        f"capped at {_caps(params)}. "
        f"Runs that did not converge keep their rows and are excluded from the fits and "
        f"verdicts (counted per (n, mu) in the verdicts and under `runs_per_mu_and_n`): "
        f"billiard {ex['billiard']} excluded and {fl['billiard']} failed, hit-and-run "
        f"{ex['hit_and_run']} excluded and {fl['hit_and_run']} failed. The paper's relax "
        f"walk is not run here: it does not sample S uniformly (fig3), and the size "
        f"question is asked of uniform eta.\n\n"
        f"Bulk and boundary: besides the whole scaled slice, eta and the fraction of "
        f"contacts whose force varies in S are measured on a fixed interior window of "
        f"{small['window_width']:g} R x {small['window_height']:g} R (the n0 slice), centred "
        f"in the slice: the unknown contacts whose contact point lies inside it, the same "
        f"samples restricted to their columns. The window is defined for n >= n0 only (at "
        f"n0 it is the slice). dim S / Nc is of the whole slice.\n\n"
        f"Decision: per mu, sampler and scope, the least-squares slope of log eta against "
        f"log n over the converged packings with eta > 0 (determinate packings, eta = 0, "
        f"are counted and left out), with its 95 % t-interval: 'grows' if it lies above "
        f"0, 'intensive' if inside ±{FLAT:g}; a verdict needs converged eta at >= "
        f"{MIN_SIZES} sizes. The paper's claim (\"simulations up to 500 particles show this "
        f"size dependence\", where indeterminacy percolates) is judged in its range, n <= "
        f"{PAPER_MAX_N}, on the whole slice (the paper's measure), at mu = "
        f"{', '.join(f'{m:g}' for m in GROWS_MUS)}. What the paper leaves open: whether "
        f"eta grows without bound there (the thermodynamic limit), asked of all sizes, on "
        f"the slice and on the window, and whether eta is intensive at mu = "
        f"{INTENSIVE_MU:g} (its conjecture for sparse clusters). Thermodynamic limit (rule "
        f"7): three two-parameter laws, each least squares on log eta: the power law log "
        f"eta = a + b log n and the logarithmic law eta = a + b ln n (unbounded), the "
        f"saturating law eta = eta_inf (1 - c n^(-1/2)), compared by AIC = N ln(RSS / N) + "
        f"2k; a law is favoured when it beats each law of the other kind by more than "
        f"{AIC_MARGIN:g}, and it decides only if its slope between the two largest sizes "
        f"(with >= 2 packings each) lies inside the 95 % Welch t-interval of the data's "
        f"slope there (over packings; the percentile bootstrap, reported beside, covers "
        f"only ~86 % with 4 packings at a size): an unbounded law so supports growth without "
        f"bound, the saturating law says eta levels off at eta_inf. The AIC margin and the "
        f"slope reading were fixed before the runs; the logarithmic law, the check at the "
        f"largest sizes and the paper's range were added after them (issue 45), with the "
        f"numbers in view.\n\n"
        f"{models or '- no model comparison yet (it needs 4 packings at 3 sizes)'}\n\n"
        f"rho (elementary clusters per slice disk, a greedy circuit basis: a lower bound) is "
        f"computed where dim S <= {params.get('clusters_max_dim', '?')} only; percolating: "
        f"a domain touches both the top and the bottom load of the slice.")
