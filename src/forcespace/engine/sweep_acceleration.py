"""Accelerating the time step's Gauss-Seidel sweeps without changing their fixed point
(issue 42): today's solver (projected SOR 1.8, runs of 64 shuffled, omega 1 after sweep
150) against Anderson acceleration and nonsmooth nonlinear conjugate gradients (NNCG) of
the sweep, on the same frozen contact problems taken from real jam states (a diagnostic of
the engine, not part of the protocol; the results: studies/jam_profile.md).

``capture``: jam ``paper_fast_compaction`` (box scaled as ``--n N --scale-box``, seed 1,
at mu = 1 ``solver.tolerance = 1e-8`` as the size study) with the compression's windows
profiled (:func:`forcespace.engine.jam_profile.profile`, the same trajectory) and the state
before every window saved (bodies, the previous step's contacts and forces, the window's
settings) to ``OUT/problems/nN_muMU/wK.npz``; ``--windows K`` stops the jam after K
windows (the 5000-disk jams: their compaction only). Writes ``OUT/profile_N_muMU.json``.

``bench``: for each saved state chosen (a steady-compaction window, the last window with
the plate moving, a settled window), the first time step's contact problem exactly as
:func:`forcespace.engine.step.steps_kernel` builds it (contacts detected, warm start,
loads and warm-start forces applied to the velocities), solved by each method from the
same start to the same stopping rule (the engine's: sum |dR| of the sweep just done <= tol
x sum |R|, tol the step's: 1e-4 while the plate moves, else the scene's), no sweep cap
below ``--cap``. Rows (JSON lines, ``OUT/bench.jsonl``): sweeps, CPU s (process, best of
``--repeats``, methods interleaved), the relative error of the end velocities against a
reference solve (plain Gauss-Seidel to tol 1e-12 or 100 000 sweeps; errors only where it
reached 1e-10). Usage::

    python -m forcespace.engine.sweep_acceleration capture --n 2000 --mu 1 [--windows K]
    python -m forcespace.engine.sweep_acceleration bench [--cap 20000] [--repeats 3]
    python -m forcespace.engine.sweep_acceleration report     # the markdown table
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from ..io.h5 import atomic_path
from ..kernels import kernel
from ..streams import order_state, shuffle
from .nlgs import records_kernel, sweep_kernel
from .records import SweepStats

OUT = Path("studies/results/sweep_acceleration")
SCENE = "paper_fast_compaction"
PROTOCOL_BY_MU = {1.0: {"solver.tolerance": 1e-8}}   # the size study's (forcespace_studies.size)


def append_row(path: Path, row: dict) -> None:
    """One JSON line appended to ``path``."""
    with open(path, "a") as f:
        f.write(json.dumps(row) + "\n")


def problem_dir(out: Path, n: int, mu: float) -> Path:
    """Where the window states of one capture go."""
    return out / "problems" / f"n{n}_mu{mu:g}"


def save_state(path: Path, bodies, run, seed: int, settings) -> None:
    """The state before a window: the body arrays, the previous step's contacts, the
    window's seed and settings (atomic)."""
    from ..streams import window_seed
    from .records import BodyArrays
    box, step, sweep = settings
    arrays = {f"body_{f}": np.array(getattr(bodies, f)) for f in BodyArrays._fields}
    arrays.update(keys=run.contacts.keys, rn=run.contacts.rn, rt=run.contacts.rt)
    meta = {"steps": run.steps, "window_seed": window_seed(seed, run.steps),
            "box": list(box), "step": list(step), "sweep": list(sweep)}
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, meta=json.dumps(meta), **arrays)


class Enough(Exception):
    """Raised to end a capture after the windows asked for."""


def capture(n: int, mu: float, out: Path, windows: int) -> None:
    """Jam the scene (profiled), the state before every window saved; see the module doc."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from . import compress, jam_profile
    from ..model.setup import Setup
    where = problem_dir(out, n, mu)
    where.mkdir(parents=True, exist_ok=True)
    original, count = compress.run_window, [0]

    def saving_window(window, bodies, run, seed, settings, *rest):
        if windows and count[0] >= windows:
            raise Enough
        save_state(where / f"w{count[0]:03d}.npz", bodies, run, seed, settings)
        count[0] += 1
        return original(window, bodies, run, seed, settings, *rest)

    settings = dict(PROTOCOL_BY_MU.get(mu, {}))
    setup = Setup.from_scene(jam_profile.scene_for(SCENE, n, mu, settings))
    compress.run_window = saving_window
    try:
        p = dict(jam_profile.profile(setup), scene=SCENE, settings=settings)
    except Enough:
        print(f"stopped after {windows} windows (states in {where})")
        return
    finally:
        compress.run_window = original
    path = out / f"profile_{n}_mu{mu:g}.json"
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(p, indent=1))
    print("\n".join(jam_profile.compaction_phases(p)))


# ---- Anderson acceleration of the sweep (type II, Walker & Ni 2011) ----


@kernel
def body_free_kernel(pairs, rec, body, rn, rt, dt):
    """Velocities of the body records (nb * 8,) without the contact forces rn, rt: the
    free velocities (3 nb,) (vx, vy, w per body) the forces are added to."""
    nb = body.shape[0] // 8
    free = np.empty(3 * nb)
    for i in range(nb):
        free[3 * i] = body[8 * i]
        free[3 * i + 1] = body[8 * i + 1]
        free[3 * i + 2] = body[8 * i + 2]
    forces_into(pairs, rec, body, rn, rt, dt, free, 3, -1.0)
    return free


@kernel
def forces_into(pairs, rec, body, rn, rt, dt, v, stride, sign):
    """v += sign * dt M^-1 (the contact forces rn, rt), on the solver records; body i's
    (vx, vy, w) at v[stride * i : stride * i + 3] (stride 8: the body records themselves,
    3: a packed (3 nb,) array)."""
    for k in range(rn.shape[0]):
        q = 16 * k
        i = pairs[2 * k]
        j = pairs[2 * k + 1]
        ex = rec[q]
        ey = rec[q + 1]
        fx = sign * dt * (rn[k] * ex - rt[k] * ey)
        fy = sign * dt * (rn[k] * ey + rt[k] * ex)
        v[stride * j] += fx * body[8 * j + 3]
        v[stride * j + 1] += fy * body[8 * j + 4]
        v[stride * i] -= fx * body[8 * i + 3]
        v[stride * i + 1] -= fy * body[8 * i + 4]
        v[stride * j + 2] -= sign * rec[q + 12] * rt[k] * body[8 * j + 5]
        v[stride * i + 2] -= sign * rec[q + 11] * rt[k] * body[8 * i + 5]


@kernel
def velocities_from_forces(pairs, rec, body, rn, rt, dt, free):
    """Body records' velocities := free + dt M^-1 (contact forces) (in place)."""
    nb = body.shape[0] // 8
    v = free.copy()
    forces_into(pairs, rec, body, rn, rt, dt, v, 3, 1.0)
    for i in range(nb):
        body[8 * i] = v[3 * i]
        body[8 * i + 1] = v[3 * i + 1]
        body[8 * i + 2] = v[3 * i + 2]


@kernel
def shuffled_sweep(pairs, rec, body, rn, rt, x, order, runs, block, dt, omega, state):
    """One sweep of :func:`forcespace.engine.nlgs.sweep_kernel` in a fresh shuffled order
    (as the engine's solve), the forces before it kept in x (2 Nc,) = (rn, rt); returns
    (sum |dR| / sum |R| after it, the order's state, normal updates, tangential updates)."""
    nc = rn.shape[0]
    x[:nc] = rn
    x[nc:] = rt
    if block > 0:
        state = shuffle(runs, runs.shape[0], state)
    else:
        state = shuffle(order, rn.shape[0], state)
    dsum, _, _, nn, nt = sweep_kernel(pairs, rec, body, rn, rt, order, runs, block, dt, omega)
    rsum = 0.0
    for k in range(rn.shape[0]):
        rsum += abs(rn[k]) + abs(rt[k])
    rel = dsum / rsum if rsum > 0.0 else (0.0 if dsum == 0.0 else np.inf)
    return rel, state, nn, nt


@kernel
def anderson_mix(DF, DG, gram, count, f, g):
    """g -= DG[:count]^T gamma (in place), gamma the least-squares fit of f (n,) by the
    rows DF[:count] (Gram matrix ``gram``; Tikhonov 1e-12 of its trace)."""
    A = gram[:count, :count].copy()
    rhs = np.zeros(count)
    for a in range(count):
        rhs[a] = np.dot(DF[a], f)
    reg = 1e-12 * np.trace(A) + 1e-300
    for a in range(count):
        A[a, a] += reg
    gamma = np.linalg.solve(A, rhs)
    for a in range(count):
        g -= gamma[a] * DG[a]


@kernel
def anderson_kernel(c, m, rn, rt, s, seed, depth, every, restart):
    """Projected Gauss-Seidel (or SOR, ``s.relaxation``) sweeps accelerated by Anderson
    mixing of depth ``depth`` applied after every ``every``-th sweep (the history dropped
    when |f|^2 grows by more than the factor ``restart``): with the forces
    x_k, g_k = sweep(x_k) and f_k = g_k - x_k, x_{k+1} = g_k - DG gamma with gamma the
    least-squares fit of f_k by the last ``depth`` differences DF of f (DG of g), then
    projected (R_n >= 0, |R_t| <= mu R_n) and the velocities recomputed from the forces.
    At a fixed point of the sweep f = 0 and nothing changes: the sweep's fixed points.
    Same records, orders and stopping rule as :func:`forcespace.engine.nlgs.solve_kernel`
    (a sweep's sum |dR| <= tol sum |R|); no omega fall-back. Returns SweepStats."""
    pairs2, rec2, body2 = records_kernel(c, m, s)
    pairs, rec, body = pairs2.ravel(), rec2.ravel(), body2.ravel()
    nc = rn.shape[0]
    n = 2 * nc
    free = body_free_kernel(pairs, rec, body, rn, rt, s.dt)
    order, runs = np.arange(nc), np.arange((nc + s.block - 1) // max(s.block, 1))
    state = order_state(seed)
    DF, DG, gram = np.zeros((depth, n)), np.zeros((depth, n)), np.zeros((depth, depth))
    x, f, g, f_prev, g_prev = np.empty(n), np.empty(n), np.empty(n), np.zeros(n), np.zeros(n)
    f_norm_prev, count, slot, sweeps, rel, n_norm, n_tang = np.inf, 0, 0, 0, 0.0, 0, 0
    for sweep in range(s.max_sweeps):
        sweeps = sweep + 1
        rel, state, nn, nt = shuffled_sweep(pairs, rec, body, rn, rt, x, order, runs,
                                            s.block, s.dt, s.relaxation, state)
        n_norm += nn
        n_tang += nt
        if rel <= s.tol or depth == 0:
            if rel <= s.tol:
                break
            continue
        g[:nc] = rn
        g[nc:] = rt
        f[:] = g - x
        f_norm = np.dot(f, f)
        if f_norm > restart * f_norm_prev:
            count, slot = 0, 0   # the residual grew: the history no longer describes the map
        elif sweep > 0:
            DF[slot] = f - f_prev
            DG[slot] = g - g_prev
            for a in range(min(count + 1, depth)):
                gram[slot, a] = gram[a, slot] = np.dot(DF[slot], DF[a])
            count, slot = min(count + 1, depth), (slot + 1) % depth
        f_norm_prev = f_norm
        f_prev[:] = f
        g_prev[:] = g
        if count == 0 or sweeps % every != 0:
            continue
        anderson_mix(DF, DG, gram, count, f, g)
        for k in range(nc):
            rn[k] = max(g[k], 0.0)
            lim = rec[16 * k + 6] * rn[k]
            rt[k] = min(max(g[nc + k], -lim), lim)
        velocities_from_forces(pairs, rec, body, rn, rt, s.dt, free)
    copy_velocities(body, m)
    return SweepStats(sweeps, rel, n_norm, n_tang)


@kernel
def copy_velocities(body, m):
    """The body records' velocities into the Motion record ``m`` (in place)."""
    for i in range(m.vx.shape[0]):
        m.vx[i] = body[8 * i]
        m.vy[i] = body[8 * i + 1]
        m.w[i] = body[8 * i + 2]


@kernel
def nncg_kernel(c, m, rn, rt, s, seed):
    """Nonsmooth nonlinear conjugate gradients (Silcowitz, Niebe, Erleben 2010) on the
    projected sweeps: with x_k the forces and r = sweep(x_k) - x_k, beta = |r|^2 /
    |r_prev|^2; beta > 1 restarts (p = r), else x += beta p (velocities updated alike) and
    p = beta p + r. A fixed point of the sweep has r = 0: the sweep's fixed points. Same
    records, orders and stopping rule as :func:`anderson_kernel`. Returns SweepStats."""
    pairs2, rec2, body2 = records_kernel(c, m, s)
    pairs, rec, body = pairs2.ravel(), rec2.ravel(), body2.ravel()
    nc = rn.shape[0]
    order, runs = np.arange(nc), np.arange((nc + s.block - 1) // max(s.block, 1))
    state = order_state(seed)
    x, p, step = np.empty(2 * nc), np.zeros(2 * nc), np.empty(2 * nc)
    r_prev, sweeps, rel, n_norm, n_tang = np.inf, 0, 0.0, 0, 0
    for sweep in range(s.max_sweeps):
        sweeps = sweep + 1
        rel, state, nn, nt = shuffled_sweep(pairs, rec, body, rn, rt, x, order, runs,
                                            s.block, s.dt, s.relaxation, state)
        n_norm += nn
        n_tang += nt
        if rel <= s.tol:
            break
        r2 = 0.0
        for k in range(nc):
            r2 += (rn[k] - x[k]) ** 2 + (rt[k] - x[nc + k]) ** 2
        beta = r2 / r_prev
        r_prev = r2
        if beta > 1.0:
            for k in range(nc):
                p[k] = rn[k] - x[k]
                p[nc + k] = rt[k] - x[nc + k]
            continue
        step[:] = beta * p
        for k in range(nc):
            p[k] = step[k] + rn[k] - x[k]
            p[nc + k] = step[nc + k] + rt[k] - x[nc + k]
            rn[k] += step[k]
            rt[k] += step[nc + k]
        forces_into(pairs, rec, body, step[:nc], step[nc:], s.dt, body, 8, 1.0)
    copy_velocities(body, m)
    return SweepStats(sweeps, rel, n_norm, n_tang)


# ---- the frozen step problems and the bench ----

SOR_FALLBACK = 150      # the shipped solve's omega -> 1 sweep (half of the 300-sweep cap)


def step_problem(path: Path):
    """The first time step's contact problem of a saved window state, as
    :func:`forcespace.engine.step.steps_kernel` builds it: (contacts, motion, rn, rt,
    settings, seed) with the velocities holding the loads and the warm-start forces."""
    from ..streams import step_seed
    from .contacts import detect_kernel
    from .nlgs import velocities_kernel
    from .records import Box, Motion, StepSettings, SweepSettings
    from .step import contacts_kernel, step_sweep_settings, warm_start_kernel
    z = np.load(path)
    meta = json.loads(str(z["meta"]))
    box, step = Box(*meta["box"]), StepSettings(*meta["step"])
    sweep = SweepSettings(*meta["sweep"])
    b = {k[5:]: z[k].copy() for k in z.files if k.startswith("body_")}
    n = b["r"].shape[0]
    ints, floats = detect_kernel(b["x"], b["y"], b["r"], box, step.margin)
    c = contacts_kernel(ints, floats, b["r"], step.mu_disk, step.mu_wall)
    rn, rt = warm_start_kernel(c.keys, z["keys"], z["rn"], z["rt"])
    moving = step.tol_moving > 0.0 and abs(b["vy"][n + 1]) > step.moving_speed
    b["vy"] += sweep.dt * b["fy_ext"] * b["inv_my"]
    motion = Motion(b["vx"], b["vy"], b["w"], b["inv_mx"], b["inv_my"], b["inv_i"])
    velocities_kernel(c, rn, rt, motion, sweep.dt)
    settings = step_sweep_settings(step, sweep, moving)
    return c, motion, rn, rt, settings, int(step_seed(meta["window_seed"], 0)), moving


def run_method(method: dict, problem, cap: int, tol: float):
    """Solve a copy of ``problem`` by ``method``; (SweepStats, velocities (2 nb,), CPU s)."""
    from .nlgs import checked_sweep_settings, solve_kernel
    from .records import Motion
    c, motion, rn, rt, settings, seed, _ = problem
    m = Motion(*(np.array(v) for v in motion))
    rn, rt = rn.copy(), rt.copy()
    s = checked_sweep_settings(settings._replace(
        tol=tol, max_sweeps=cap, relaxation=method.get("omega", settings.relaxation),
        relax_until=method.get("relax_until", SOR_FALLBACK)))
    t0 = time.process_time()
    if method["kind"] == "sor":
        st = solve_kernel(c, m, rn, rt, s, seed)
    elif method["kind"] == "nncg":
        st = nncg_kernel(c, m, rn, rt, s, seed)
    else:
        st = anderson_kernel(c, m, rn, rt, s, seed, method["depth"], method.get("every", 1),
                             method.get("restart", np.inf))
    cpu = time.process_time() - t0
    return st, np.concatenate([m.vx, m.vy]), cpu


METHODS = {
    "sor (today)": {"kind": "sor"},
    "anderson m=5 on GS": {"kind": "anderson", "depth": 5, "omega": 1.0},
    "anderson m=5 on GS, restarts": {"kind": "anderson", "depth": 5, "omega": 1.0, "restart": 1.0},
    "anderson m=5 on SOR 1.8, restarts": {"kind": "anderson", "depth": 5, "restart": 1.0},
    "nncg on GS": {"kind": "nncg", "omega": 1.0},
    "nncg on SOR 1.8": {"kind": "nncg"},
}
REFERENCE = {"kind": "sor", "omega": 1.0}    # plain Gauss-Seidel
REFERENCE_SWEEPS = 100000


def chosen_states(where: Path, profile: dict | None) -> dict:
    """{stage: window state file}: the middle window of the steady compaction, the last
    window with the plate faster than moving_speed, the last window (settled), from the
    capture's profile (without one, the last window saved: its steady compaction)."""
    files = sorted(where.glob("w*.npz"))
    if profile is None:
        return {"steady compaction": files[-1]}
    w = profile["windows"]
    v = np.array([r["plate_speed"] for r in w])
    steady = np.flatnonzero(v > 0.5 * v.max())
    moving = np.flatnonzero(v > profile["moving_speed"])
    return {"steady compaction": files[steady[len(steady) // 2]],
            "deceleration": files[moving[-1]], "settled": files[len(w) - 1]}


def bench(out: Path, cap: int, repeats: int, methods: list, sets: list) -> None:
    """The chosen states of the captured sets (``sets``: names like ``n2000_mu1``, [] for
    all) solved by every method (module doc); rows to OUT/bench.jsonl."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    for where in sorted((out / "problems").iterdir()):
        if sets and where.name not in sets:
            continue
        n, mu = where.name[1:].split("_mu")
        prof = out / f"profile_{n}_mu{mu}.json"
        profile = json.loads(prof.read_text()) if prof.is_file() else None
        for stage, path in chosen_states(where, profile).items():
            problem = step_problem(path)
            ref_stats, v_ref, _ = run_method(REFERENCE, problem, REFERENCE_SWEEPS, 1e-12)
            for name, row in compared(problem, methods, cap, repeats, v_ref, ref_stats).items():
                row = {"n": int(n), "mu": float(mu), "stage": stage, "window": path.stem,
                       "contacts": int(problem[0].a.shape[0]), "moving": bool(problem[6]),
                       "tol": problem[4].tol, "method": name, **row,
                       "reference_sweeps": int(ref_stats.sweeps),
                       "reference_change": float(ref_stats.relative_change),
                       "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
                append_row(out / "bench.jsonl", row)
                print(json.dumps(row), flush=True)


def compared(problem, methods: list, cap: int, repeats: int, v_ref, ref_stats) -> dict:
    """{method: row} for one problem, the methods interleaved ``repeats`` times (best CPU):
    sweeps, CPU s and relative change at the engine's stopping rule (cap ``cap``), the
    relative change after 300 sweeps (the shipped cap); the end velocities' relative error
    against ``v_ref`` where the reference converged (relative change <= 1e-10), else None."""
    tol = problem[4].tol
    ok = ref_stats.relative_change <= 1e-10
    scale = np.linalg.norm(v_ref)
    best = {}
    for _ in range(repeats):
        for name in methods:
            st, v, cpu = run_method(METHODS[name], problem, cap, tol)
            st300, v300, _ = run_method(METHODS[name], problem, 300, 0.0)
            row = best.setdefault(name, {"cpu_s": np.inf})
            row.update(sweeps=int(st.sweeps), converged=bool(st.relative_change <= tol),
                       relative_change=float(st.relative_change),
                       change_at_300=float(st300.relative_change),
                       error=float(np.linalg.norm(v - v_ref) / scale) if ok else None,
                       error_at_300=float(np.linalg.norm(v300 - v_ref) / scale) if ok else None,
                       cpu_s=min(row["cpu_s"], cpu))
    return best


def report(out: Path) -> list[str]:
    """Markdown rows of OUT/bench.jsonl: per problem, each method's sweeps and CPU ms to
    the stopping rule (or the relative change it stalled at within the cap)."""
    rows = [json.loads(line) for line in (out / "bench.jsonl").read_text().splitlines()
            if line.strip()]
    names = [m for m in METHODS if any(r["method"] == m for r in rows)]
    lines = ["| disks, mu, stage (contacts, tol) | " + " | ".join(names) + " |",
             "|---|" + "---|" * len(names)]
    stages = ("steady compaction", "deceleration", "settled")
    keys = sorted({(r["n"], r["mu"], r["stage"]) for r in rows},
                  key=lambda k: (k[1], k[0], stages.index(k[2])))
    for key in keys:
        by = {r["method"]: r for r in rows if (r["n"], r["mu"], r["stage"]) == key}
        any_row = next(iter(by.values()))
        cells = [f"{r['sweeps']} / {1e3 * r['cpu_s']:.1f} ms" if r["converged"] else
                 f"not in {r['sweeps']} ({r['relative_change']:.0e}) / {1e3 * r['cpu_s']:.0f} ms"
                 if r else "" for r in (by.get(m) for m in names)]
        lines.append(f"| {key[0]}, {key[1]:g}, {key[2]} ({any_row['contacts']}, "
                     f"{any_row['tol']:g}) | " + " | ".join(cells) + " |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    c = sub.add_parser("capture")
    c.add_argument("--n", type=int, required=True)
    c.add_argument("--mu", type=float, required=True)
    c.add_argument("--windows", type=int, default=0, help="stop after K windows (0: the whole jam)")
    c.add_argument("--out", type=Path, default=OUT)
    b = sub.add_parser("bench")
    b.add_argument("--cap", type=int, default=20000)
    b.add_argument("--repeats", type=int, default=3)
    b.add_argument("--methods", nargs="*", default=list(METHODS), choices=list(METHODS))
    b.add_argument("--sets", nargs="*", default=[], help="e.g. n2000_mu1 (default: all)")
    b.add_argument("--out", type=Path, default=OUT)
    r = sub.add_parser("report")
    r.add_argument("--out", type=Path, default=OUT)
    a = ap.parse_args(argv)
    if a.command == "report":
        print("\n".join(report(a.out)))
    elif a.command == "capture":
        capture(a.n, a.mu, a.out, a.windows)
    else:
        bench(a.out, a.cap, a.repeats, a.methods, a.sets)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
