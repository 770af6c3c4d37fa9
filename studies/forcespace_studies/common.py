"""What several studies share: packings jammed once per study directory."""
from __future__ import annotations

import inspect
import math
import time
from pathlib import Path

import forcespace as fs
from forcespace import config, jam, read_packing, write_packing
from forcespace.errors import InputError
from forcespace.extend import file_lock, parse_scene_text


def packing_path(out, scene: str, mu: float, seed: int, n_disks: int) -> Path:
    """Where a study directory ``out`` keeps the packing (scene, mu, seed, n_disks)."""
    return Path(out) / "packings" / f"{scene}_n{n_disks}_mu{mu:.6g}_s{seed}.h5"


def jam_lock(path):
    """The lock a process holds while it jams the packing kept at ``path`` (blocking;
    creates the directory): another process that needs it waits, then reads it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return file_lock(path.parent / f".{path.name}.jamlock")


def shared_packing(out, scene: str, mu: float, seed: int, n_disks: int, reuse_from=(),
                   overrides=None):
    """The packing jammed from the bundled scene SCENE at (mu, seed, n_disks), made once per
    study directory and shared by every task that needs it.

    Kept as ``OUT/packings/SCENE_nN_muMU_sSEED.h5``; a worker that needs a packing
    another worker is jamming waits for it (a blocking file lock) instead of jamming it
    a second time. ``reuse_from``: names of sibling study directories (e.g. "fig1")
    whose packings are read instead when they have it. ``overrides``: further scene
    keys (``jam`` style, e.g. ``{"physics__plate_mu": mu}``) that must be a function
    of (scene, mu, seed, n_disks), since the file name does not record them: a kept
    packing jammed under other values of them is refused (InputError naming the file
    and the key), never reused.
    An interrupted compression resumes from ``OUT/packings/NAME.checkpoint.h5``
    (saved every 30 s; bit-identical to an uninterrupted run), so a study stopped
    in the middle of a long jam loses at most half a minute of it.
    Returns (Packing, jam wall time [s] of this call, 0 when it was reused).
    """
    path = packing_path(out, scene, mu, seed, n_disks)
    for other in reuse_from:
        theirs = Path(out).parent / other / "packings" / path.name
        if theirs.is_file():
            return reused(theirs, overrides), 0.0
    with jam_lock(path):
        if path.is_file():
            return reused(path, overrides), 0.0
        t0 = time.perf_counter()
        p = jam(scene, physics__mu=mu, scene__seed=seed,
                disks__n=n_disks, checkpoint=path.with_name(path.name + ".checkpoint.h5"),
                **(overrides or {}))
        write_packing(p, path)
        return read_packing(path), time.perf_counter() - t0


def kept_packing(out, scene: str, mu: float, seed: int, n_disks: int, reuse_from=()):
    """The packing (scene, mu, seed, n_disks) a study directory ``out`` (or a sibling in
    ``reuse_from``) already keeps, or None. Never jams: summaries (and ``--report-only``)
    draw from what the tasks left behind and say so when a packing is not there."""
    path = packing_path(out, scene, mu, seed, n_disks)
    for where in [Path(out).parent / other / "packings" / path.name for other in reuse_from] + [path]:
        if where.is_file():
            return reused(where)
    return None


def no_packing_panel(ax, what: str) -> None:
    """An axes that says the packing it would draw is not kept in the study directory."""
    ax.axis("off")
    ax.text(0.5, 0.5, f"{what}: the packing is not in this directory\n(run the study's task "
            "again to draw it)", ha="center", va="center", fontsize=8)


def reused(path, overrides=None):
    """The kept packing at ``path``, checked against the scene ``overrides`` (``jam``
    style) it must have been jammed with (its stored scene text); InputError names the
    file, the first key that differs and both values."""
    p = read_packing(path)
    if overrides:
        scene = parse_scene_text(p.scene_text, str(path))
        for k, want in overrides.items():
            key = k.replace("__", ".")
            got = scene[key]
            same = (math.isclose(got, want, rel_tol=1e-12, abs_tol=0.0)
                    if isinstance(want, float) and isinstance(got, (int, float)) else got == want)
            if not same:
                raise InputError(path, key, f"the study jams with {want!r}; this kept packing "
                                 "was jammed with another value: move it away to rejam",
                                 got=got)
    return p


# Rule 4 of the report (report.RULES): a sampling run enters a verdict only if it converged
# (the library's convergence thresholds: ESS 100, split R-hat 1.05)
TARGET_ESS = config.MIN_ESS
RHAT_MAX = config.RHAT_MAX
SAMPLERS = ("hit_and_run", "relax")


def sampler(name: str, seed: int, cap: int, max_seconds, **options):
    """The study's sampler ``name`` ("hit_and_run", "billiard" or "relax"): 4 chains run
    to ESS 100 on every tracked statistic, capped at ``cap`` samples and ``max_seconds``."""
    cls = {"hit_and_run": fs.HitAndRun, "billiard": fs.BilliardWalk,
           "relax": fs.RelaxWalk}[name]
    return cls(n=cap, seed=seed, chains=4, target_ess=TARGET_ESS, max_seconds=max_seconds,
               **options)


def run_samplers(row: dict, runs, prob, wd, tag: str = "", analysis=None) -> dict:
    """Run each (name, sampler) of ``runs`` on ``prob`` into ``wd/NAME{tag}.h5`` and add
    to ``row``: eta_NAME (every run's), converged_NAME (rule 4: finished with bulk and
    tail ESS >= 100 and R-hat <= 1.05 on every tracked statistic), n_NAME, ess_NAME,
    rhat_NAME, t_NAME_s, relax_projected (stalls finished by projection) and widening_NAME
    (a uniform sampler's frame widening, <Fn>, where S had no point strictly inside in its
    affine hull: samples within it of S; absent when 0). A run whose method fails
    (NumericalError) keeps the row: error_NAME says why (rule 5: a failed sampling).
    Anything else -- a corrupt or foreign work file, a lock held elsewhere -- is no
    result: it propagates, the task fails and the next run retries it. Returns
    {name: Ensemble, or None if the run failed}."""
    from forcespace.errors import NumericalError

    out = {}
    for name, smp in runs:
        out[name] = None
        t0 = time.perf_counter()
        try:
            given = ({"analysis": analysis} if analysis is not None and "analysis"
                     in inspect.signature(smp.compute).parameters else {})
            ens = smp.compute(prob, output=Path(wd) / f"{name}{tag}.h5", **given).ensemble
        except NumericalError as exc:
            row.update({f"eta_{name}": None, f"converged_{name}": False,
                        f"error_{name}": f"{type(exc).__name__}: {exc}",
                        f"t_{name}_s": time.perf_counter() - t0})
            continue
        d = ens.diagnostics
        ess, rhat = d.get("min_ess"), d.get("max_rhat")
        row.update({f"eta_{name}": ens.eta if ens.n_samples >= 2 else None,
                    f"n_{name}": ens.n_samples, f"ess_{name}": ess, f"rhat_{name}": rhat,
                    f"converged_{name}": bool(smp.success and ess is not None
                                              and ess >= TARGET_ESS and rhat <= RHAT_MAX),
                    f"stop_{name}": smp.message, f"t_{name}_s": time.perf_counter() - t0})
        if name == "relax":
            row["relax_projected"] = int(smp.projected.size)
        elif getattr(smp, "frame_widening", 0.0):
            row[f"widening_{name}"] = smp.frame_widening
        out[name] = ens
    return out


def determinate(row: dict, names=SAMPLERS) -> None:
    """S is one point (dim S = 0, mu > 0): eta is 0 exactly, for every sampler, converged
    by definition (nothing to sample)."""
    for name in names:
        row.update({f"eta_{name}": 0.0, f"converged_{name}": True, f"n_{name}": 0})
