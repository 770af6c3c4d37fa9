"""The paper's packing protocol: loose start, compression until jammed, static solve.

Orchestration only (numpy, progress, stopping rules); the physics is in the
numba kernels of :mod:`forcespace.dynamics` and :mod:`forcespace.nlgs`.

1. Radii uniform in [radius_min, radius_max]; random sequential placement of
   non-overlapping disks at ``box.initial_packing_fraction``.
2. Contact dynamics under the scene's loads (top-plate force, gravity) until
   no load-bearing disk and not the top plate moved, over ``jamming.window``
   steps, by more than ``jamming.velocity_tol`` * sqrt(F0 rbar / mbar) times
   the window's duration (a mean speed, so that overlap-correction jitter
   averages out while steady sliding does not).
3. Static solve: positions fixed, velocities zeroed, pairs with gap below
   ``jamming.contact_gap_tol`` taken as closed contacts (gap set to 0), NLGS
   until the relative equilibrium residual of every disk and the top plate
   is at most ``jamming.static_tolerance``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..model.walls import N_WALL_SLOTS, SLOT_BOTTOM, SLOT_TOP, packing_body_code
from .contacts import detect_contacts
from .step import ContactState, StepParams, contact_arrays, run_steps, warm_start
from ..errors import InputError, NumericalError
from ..io.h5 import atomic_path
from .frozen import FrozenContacts, relax
from ..model.packing import Packing
from ..model.radii import draw_radii
from ..progress import progress
from ..model.scene import Scene


@dataclass
class Bodies:
    """Body arrays of the kernels, shape (n+4,) each (disks, then wall slots)."""

    x: np.ndarray
    y: np.ndarray
    th: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    w: np.ndarray
    r: np.ndarray          # (n,)
    inv_mx: np.ndarray
    inv_my: np.ndarray
    inv_i: np.ndarray
    fy_ext: np.ndarray
    contacts: tuple | None = None  # last step's (sorted keys, rn, rt), for warm starts

    @property
    def n(self) -> int:
        return self.r.shape[0]


def random_radii(scene: Scene, rng) -> np.ndarray:
    """Radii (n,) [R] by the scene's ``disks.distribution`` (:mod:`forcespace.model.radii`;
    the default "uniform" is ``rng.uniform(radius_min, radius_max, n)``, as always)."""
    return draw_radii(scene, rng)


def loose_start(scene: Scene, rng) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Random sequential placement of non-overlapping disks.

    Returns x, y, r (n,) and the box height [R] at the scene's initial packing
    fraction. Disks are placed largest first; x is periodic if the scene says so.
    With ``solver.sweep_block`` > 0 the disks are then numbered row by row (rows
    one largest diameter high, x increasing), so that contacts sorted by disk
    index are near each other in space.
    """
    r = np.sort(random_radii(scene, rng))[::-1].copy()
    width = scene["box.width"]
    periodic = scene["box.periodic_x"]
    height = np.pi * (r**2).sum() / (width * scene["box.initial_packing_fraction"])
    height = max(height, 2.0 * r.max() + 1e-9)
    x = np.empty_like(r)
    y = np.empty_like(r)
    for i, ri in enumerate(r):
        for _ in range(100000):
            xi = rng.uniform(0, width) if periodic else rng.uniform(ri, width - ri)
            yi = rng.uniform(ri, height - ri)
            dx = x[:i] - xi
            if periodic:
                dx -= width * np.round(dx / width)
            if i == 0 or (np.hypot(dx, y[:i] - yi) - r[:i] - ri).min() > 0:
                x[i], y[i] = xi, yi
                break
        else:
            raise NumericalError(
                f"could not place disk {i} without overlap at initial packing fraction "
                f"{scene['box.initial_packing_fraction']}: lower box.initial_packing_fraction")
    if scene["solver.sweep_block"] > 0:   # number the disks row by row (local sweeps)
        order = row_order(x, y, r)
        x, y, r = x[order], y[order], r[order]
    return x, y, r, height


def row_order(x, y, r) -> np.ndarray:
    """Disk indices (n,) row by row: rows one largest diameter high (y = 0 at a row
    boundary), x increasing within a row (the numbering of ``solver.sweep_block`` > 0)."""
    return np.lexsort((x, np.floor(y / (2.0 * r.max()))))


def force_unit(scene: Scene) -> float:
    """The engine's internal force unit sigma [F0]: the top-plate load, else rho g R^2.

    The kernels run with every force divided by sigma, so a scene whose loads
    are all multiplied by k gives the same trajectory (positions bit for bit)
    and forces exactly k times larger. Time is therefore measured in
    sqrt(rho R^3 / sigma): ``solver.dt`` is in that unit (for the default
    top_force = 1 F0 the two agree).
    """
    if scene["plates.top"] == "load":
        return float(scene["plates.top_force"])
    return float(scene["disks.density"] * scene["physics.gravity"])


def make_bodies(scene: Scene, x, y, r, height, density=None) -> Bodies:
    """Kernel body arrays for disks and walls; only the scene's physics is switched on.

    Forces are in the internal unit :func:`force_unit`. ``density``: per-disk
    densities (n,) (default the scene's uniform density).
    """
    n = r.shape[0]
    nb = n + N_WALL_SLOTS
    sigma = force_unit(scene)
    rho = scene["disks.density"] if density is None else np.asarray(density, float)
    m = rho * np.pi * r**2
    inv_mx = np.zeros(nb)
    inv_my = np.zeros(nb)
    inv_i = np.zeros(nb)
    fy = np.zeros(nb)
    inv_mx[:n] = inv_my[:n] = 1.0 / m
    if scene.rotation:
        inv_i[:n] = 1.0 / (0.5 * m * r**2)
    if scene["physics.gravity"] > 0:
        fy[:n] = -m * (scene["physics.gravity"] / sigma)
    X = np.zeros(nb)
    Y = np.zeros(nb)
    X[:n], Y[:n] = x, y
    Y[n + SLOT_BOTTOM] = 0.0
    if scene["plates.top"] == "load":
        Y[n + SLOT_TOP] = height
        inv_my[n + SLOT_TOP] = 1.0 / scene["plates.top_mass"]
        fy[n + SLOT_TOP] = -scene["plates.top_force"] / sigma
    return Bodies(X, Y, np.zeros(nb), np.zeros(nb), np.zeros(nb), np.zeros(nb), r.copy(),
                  inv_mx, inv_my, inv_i, fy)


def _flags(scene: Scene):
    return (bool(scene["box.periodic_x"]), scene["plates.bottom"] == "fixed",
            scene["plates.top"] == "load", not scene["box.periodic_x"])


def step_params(scene: Scene) -> StepParams:
    """The time stepper's parameters for a scene."""
    periodic, has_bottom, has_top, has_sides = _flags(scene)
    return StepParams(
        width=scene["box.width"], periodic=periodic, has_bottom=has_bottom, has_top=has_top,
        has_sides=has_sides, margin=scene["solver.contact_margin"], dt=scene["solver.dt"],
        tol=scene["solver.tolerance"], max_sweeps=scene["solver.max_sweeps"],
        mu_disk=scene["physics.mu"], mu_wall=scene["physics.plate_mu"], rotation=scene.rotation,
        overlap_correction=scene["solver.overlap_correction"],
        overlap_slop=scene["solver.overlap_slop"], relaxation=scene["solver.relaxation"],
        sweep_block=scene["solver.sweep_block"])


CHECKPOINT_SECONDS = 30.0
_STATE_ARRAYS = ("x", "y", "th", "vx", "vy", "w")


def _scene_identity(scene: Scene) -> str:
    """What a checkpoint must match: the scene without its step budget."""
    return scene.with_overrides(**{"jamming.max_steps": 1}).to_toml().split("\n", 1)[1]


def save_checkpoint(path, scene: Scene, bodies: Bodies, run: dict) -> None:
    """Write the compression state atomically (temp file, then rename)."""
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, scene=_scene_identity(scene),
                 log=np.array(run["log"], float).reshape(-1, 5), totals=run["totals"],
                 keys=run["keys"], rn=run["rn"], rt=run["rt"], steps=run["steps"],
                 **{k: getattr(bodies, k) for k in _STATE_ARRAYS})


def load_checkpoint(path, scene: Scene, bodies: Bodies) -> dict | None:
    """Restore a compression state saved for the same scene (in place), else None."""
    path = Path(path)
    if not path.is_file():
        return None
    with np.load(path) as d:
        if str(d["scene"]) != _scene_identity(scene):
            raise InputError(path, "scene", "checkpoint belongs to another scene; delete it to "
                             "start afresh")
        for k in _STATE_ARRAYS:
            getattr(bodies, k)[:] = d[k]
        return {"log": [tuple(row) for row in d["log"]], "totals": d["totals"].copy(),
                "keys": d["keys"].copy(), "rn": d["rn"].copy(), "rt": d["rt"].copy(),
                "steps": int(d["steps"])}


def compress(scene: Scene, bodies: Bodies, seed: int, show_progress=True, log=None,
             checkpoint=None) -> dict:
    """Run contact dynamics until jammed (in place). Returns solver statistics.

    Overlaps left by truncated sweeps beyond ``solver.overlap_slop`` are
    removed at the rate ``solver.overlap_correction``; below the slop Unger's
    rule holds exactly, so the jammed state is a true rest state of the rigid
    dynamics.

    ``checkpoint``: a file the state is saved to every ``CHECKPOINT_SECONDS``
    and resumed from if it exists (bit-identical to an uninterrupted run); it
    is removed once jammed. ``log`` (a list) receives one row per window.

    Raises NumericalError if the state becomes non-finite or max_steps is reached.
    """
    window = scene["jamming.window"]
    v_tol = scene["jamming.velocity_tol"] * _velocity_scale(scene, bodies)
    run = load_checkpoint(checkpoint, scene, bodies) if checkpoint else None
    if run is None:
        run = {"log": [], "totals": np.zeros(8), "keys": np.zeros(0, dtype=np.int64),
               "rn": np.zeros(0), "rt": np.zeros(0), "steps": 0}
    totals = run["totals"]
    t0 = time.perf_counter()
    last_save = t0
    bar = progress(total=scene["jamming.max_steps"], desc="compressing", unit="step",
                   disable=not show_progress)
    bar.update(run["steps"])
    window_time = window * scene["solver.dt"]
    params = step_params(scene)
    v_mean = float("nan")
    try:
        while run["steps"] < scene["jamming.max_steps"]:
            start = (bodies.x.copy(), bodies.y.copy(), bodies.th.copy())
            state, st = run_steps(bodies, params, ContactState(run["keys"], run["rn"], run["rt"]),
                                  window, seed + run["steps"])
            run["keys"], run["rn"], run["rt"] = state
            run["steps"] += window
            totals[0] += st.sweeps_total
            totals[1] = max(totals[1], st.sweeps_max_step)
            totals[3] += st.normal_updates
            totals[4] += st.tangential_updates
            totals[7] += st.steps_at_sweep_cap
            _check_state(scene, bodies, run["steps"])
            v_mean = _window_displacement(scene, bodies, start, run["keys"], run["rn"]) \
                / window_time
            bar.update(window)
            bar.set_postfix(v_mean=f"{v_mean:.1e}", v_max=f"{st.max_speed:.1e}",
                            sweeps=f"{st.sweeps_total / window:.0f}", refresh=False)
            run["log"].append((run["steps"], v_mean, st.max_speed, st.sweeps_total / window,
                               st.max_rel_change))
            if v_mean <= v_tol and _load_carried(scene, bodies, run["keys"], run["rn"]):
                break
            if checkpoint and time.perf_counter() - last_save > CHECKPOINT_SECONDS:
                save_checkpoint(checkpoint, scene, bodies, run)
                last_save = time.perf_counter()
        else:
            if checkpoint:
                save_checkpoint(checkpoint, scene, bodies, run)
            capped = int(totals[7])
            raise NumericalError(f"not jammed after jamming.max_steps = {run['steps']} steps "
                                 f"(last mean speed over a window {v_mean:.3g}, "
                                 f"tolerance {v_tol:.3g}; {capped} steps hit "
                                 f"solver.max_sweeps = {scene['solver.max_sweeps']}); raise "
                                 f"jamming.max_steps"
                                 + (", solver.max_sweeps" if capped else "")
                                 + " or the tolerances"
                                 + (f"; the run resumes from {checkpoint}" if checkpoint else ""))
    finally:
        bar.close()
    if checkpoint:
        Path(checkpoint).unlink(missing_ok=True)
    if log is not None:
        log.extend(run["log"])
    bodies.contacts = (run["keys"], run["rn"], run["rt"])
    return {"steps": run["steps"], "sweeps_total": int(totals[0]),
            "sweeps_max_step": int(totals[1]),
            "normal_updates": int(totals[3]), "tangential_updates": int(totals[4]),
            "steps_at_sweep_cap": int(totals[7]),
            "compress_seconds": time.perf_counter() - t0}


def _window_displacement(scene: Scene, bodies: Bodies, start, keys, rn) -> float:
    """Largest displacement [R] over the last window of a disk that bears load or feels
    gravity (centre displacement + r*|rotation|), or of the top plate.

    Jitter from overlap correction averages out over a window; steady sliding does
    not. Free-flying disks (zero gravity) and, with periodic x and frictionless
    walls, the uniform horizontal drift (a zero mode) are left out.
    """
    n = bodies.n
    nb = n + N_WALL_SLOTS
    x0, y0, th0 = start
    a, b = keys // nb, keys % nb
    on = rn > 0
    loaded = bodies.fy_ext[:n] != 0
    loaded[a[on & (a < n)]] = True
    loaded[b[on & (b < n)]] = True
    dx = bodies.x[:n] - x0[:n]
    periodic = scene["box.periodic_x"]
    if periodic:
        dx -= scene["box.width"] * np.round(dx / scene["box.width"])
    plate = abs(bodies.y[n + SLOT_TOP] - y0[n + SLOT_TOP])
    if not loaded.any():
        return float(plate)
    if periodic and scene["physics.plate_mu"] == 0.0:
        m = 1.0 / bodies.inv_mx[:n][loaded]      # the kernel's masses (per-disk densities)
        dx = dx - (m * dx[loaded]).sum() / m.sum()
    disp = np.hypot(dx, bodies.y[:n] - y0[:n]) + bodies.r * np.abs(bodies.th[:n] - th0[:n])
    return float(max(disp[loaded].max(), plate))


def _check_state(scene: Scene, bodies: Bodies, steps: int) -> None:
    """NumericalError if the state is non-finite or disks left the box through a
    plate (a time step far too large for the loads: the implicit scheme stays
    stable, but contacts are then missed between steps)."""
    n = bodies.n
    if not (np.isfinite(bodies.x[:n]).all() and np.isfinite(bodies.y).all()):
        raise NumericalError(f"non-finite positions after {steps} steps; reduce solver.dt "
                             f"(now {scene['solver.dt']:g})")
    y, r = bodies.y[:n], bodies.r
    below = scene["plates.bottom"] == "fixed" and (y + r < bodies.y[n + SLOT_BOTTOM]).any()
    above = scene["plates.top"] == "load" and (y - r > bodies.y[n + SLOT_TOP]).any()
    if below or above:
        raise NumericalError(f"disks passed through the {'bottom' if below else 'top'} plate "
                             f"after {steps} steps: solver.dt = {scene['solver.dt']:g} is too "
                             f"large for these loads; reduce it")


def _load_carried(scene: Scene, bodies: Bodies, keys, rn) -> bool:
    """Whether the packing carries the top plate: its contacts push up with at least
    half the plate load (a plate that has not reached the disks is not at rest,
    even if it moves slowly). True without a top plate."""
    if scene["plates.top"] != "load":
        return True
    nb = bodies.n + N_WALL_SLOTS
    on_plate = (keys % nb) == bodies.n + SLOT_TOP
    return float(rn[on_plate].sum()) >= -0.5 * bodies.fy_ext[bodies.n + SLOT_TOP]


def _velocity_scale(scene: Scene, bodies: Bodies) -> float:
    """v0 = sqrt(F rbar / mbar) in internal units: F the top-plate load, or the mean
    disk weight."""
    n = bodies.n
    m = 1.0 / bodies.inv_mx[:n]
    f0 = -bodies.fy_ext[n + SLOT_TOP] if scene["plates.top"] == "load" \
        else float(-bodies.fy_ext[:n].mean())
    return float(np.sqrt(f0 * bodies.r.mean() / m.mean()))


def static_solve(scene: Scene, bodies: Bodies, seed: int, show_progress=True):
    """Equilibrium forces on the frozen jammed configuration.

    Starts from the forces of the last dynamic step (warm start) when
    :func:`compress` ran on ``bodies``: with friction S has many points and
    this keeps the one the dynamics realised.

    Returns (packing, statistics). The packing's contacts are all pairs with
    gap at most ``jamming.contact_gap_tol``; their gaps are treated as closed
    in the solve (the recorded gaps are the real ones).
    """
    periodic, has_bottom, has_top, has_sides = _flags(scene)
    n = bodies.n
    ints, floats = detect_contacts(bodies.x, bodies.y, bodies.r, n, scene["box.width"],
                                   periodic, has_bottom, has_top, has_sides,
                                   scene["jamming.contact_gap_tol"])
    a, b, nx, ny, gap, ra, rb, mu, keys = contact_arrays(
        ints, floats, bodies.r, n, scene["physics.mu"], scene["physics.plate_mu"])
    image = ints[:, 2].copy()
    touched = np.zeros(n + N_WALL_SLOTS, dtype=bool)
    touched[a] = touched[b] = True
    loose = np.flatnonzero((bodies.fy_ext[:n] != 0) & ~touched[:n])
    if loose.size:
        raise NumericalError(f"disk {loose[0]} feels gravity but touches nothing: the "
                             "configuration is not static (raise jamming.window or lower "
                             "jamming.velocity_tol)")
    if bodies.contacts is not None:  # start from the forces the dynamics ended with
        rn, rt = warm_start(keys, *bodies.contacts)
        rt[mu == 0.0] = 0.0
    else:
        rn = np.zeros(a.shape[0])
        rt = np.zeros(a.shape[0])
    system = FrozenContacts(a=a, b=b, nx=nx, ny=ny, ra=ra, rb=rb, mu=mu, inv_mx=bodies.inv_mx,
                            inv_my=bodies.inv_my, inv_i=bodies.inv_i,
                            v_ext=(np.zeros(n + N_WALL_SLOTS), bodies.fy_ext * bodies.inv_my,
                                   np.zeros(n + N_WALL_SLOTS)))
    packing_of = _packing_view(scene, bodies, a, b, nx, ny, gap, image)
    t0 = time.perf_counter()
    bar = progress(total=None, desc="static solve", unit="sweep", disable=not show_progress)

    def report(sweeps, residual):
        bar.update(sweeps)
        bar.set_postfix(residual=f"{residual:.2e}", refresh=False)

    try:
        res = relax(
            system, rn, rt, lambda rn, rt: packing_of(rn, rt).equilibrium_residual(),
            scene["jamming.static_tolerance"], scene["jamming.static_max_sweeps"], seed,
            chunk=100, max_chunk=20000, on_chunk=report)
    finally:
        bar.close()
    stats = {"static_sweeps": res.sweeps, "static_tangential_updates": res.tangential_updates,
             "static_seconds": time.perf_counter() - t0, "static_residual": res.violation}
    return packing_of(rn, rt), stats


def _packing_view(scene: Scene, bodies: Bodies, a, b, nx, ny, gap, image):
    """A function (rn, rt) -> Packing for the frozen configuration and contacts."""
    n = bodies.n
    pa, pb = packing_body_code(a, n), packing_body_code(b, n)
    x, y, r = bodies.x[:n].copy(), bodies.y[:n].copy(), bodies.r
    normal = np.column_stack([nx, ny])
    # contact point: on a's surface pushed half the gap toward b; walls: on the disk
    point = np.empty((a.shape[0], 2))
    da = a < n
    point[da, 0] = x[a[da]] + (r[a[da]] + 0.5 * gap[da]) * nx[da]
    point[da, 1] = y[a[da]] + (r[a[da]] + 0.5 * gap[da]) * ny[da]
    wa = ~da  # a is a wall: b is a disk
    point[wa, 0] = x[b[wa]] - r[b[wa]] * nx[wa]
    point[wa, 1] = y[b[wa]] - r[b[wa]] * ny[wa]
    if scene["box.periodic_x"]:
        point[:, 0] -= scene["box.width"] * np.floor(point[:, 0] / scene["box.width"])
    sigma = force_unit(scene)
    density = scene["disks.density"]
    if scene["disks.density_ratio"] != 1.0:     # per-disk densities, read off the masses
        density = 1.0 / (bodies.inv_mx[:n] * np.pi * r**2)
    y_top = bodies.y[n + SLOT_TOP] if scene["plates.top"] == "load" else np.nan
    y_bot = bodies.y[n + SLOT_BOTTOM] if scene["plates.bottom"] == "fixed" else np.nan

    def make(rn, rt) -> Packing:
        return Packing(x=x, y=y, r=r, width=scene["box.width"],
                       periodic_x=scene["box.periodic_x"], y_bottom=float(y_bot),
                       y_top=float(y_top),
                       top_force=scene["plates.top_force"] if scene["plates.top"] == "load" else 0.0,
                       gravity=scene["physics.gravity"], density=density,
                       mu=scene["physics.mu"], plate_mu=scene["physics.plate_mu"],
                       a=pa, b=pb, normal=normal, point=point, image=image, gap=gap,
                       fn=rn * sigma, ft=rt * sigma, seed=scene["scene.seed"],
                       scene_text=scene.to_toml(), scene_name=scene.name)
    return make


def build_packing(scene: Scene, show_progress=True, checkpoint=None) -> Packing:
    """Run the whole protocol for ``scene`` and return the static packing.

    ``checkpoint``: file for resumable compression (see :func:`compress`).
    """
    seed = scene["scene.seed"]
    rng = np.random.default_rng(seed)
    x, y, r, height = loose_start(scene, rng)
    density = None
    if scene["disks.density_ratio"] != 1.0:      # log-uniform in [density, density*ratio]
        density = scene["disks.density"] * scene["disks.density_ratio"] ** rng.uniform(0, 1, r.size)
    bodies = make_bodies(scene, x, y, r, height, density)
    t0 = time.perf_counter()
    log = []
    meta = compress(scene, bodies, seed, show_progress, log=log, checkpoint=checkpoint)
    packing, static = static_solve(scene, bodies, seed, show_progress)
    packing.solver_log = np.array(log, dtype=float).reshape(-1, 5)
    meta.update(static)
    meta["wall_seconds"] = time.perf_counter() - t0
    meta["rotation"] = bool(scene.rotation)
    if static["static_residual"] > scene["jamming.static_tolerance"]:
        raise NumericalError(
            f"static solve stopped at residual {static['static_residual']:.3g} > "
            f"jamming.static_tolerance after {static['static_sweeps']} sweeps")
    packing.meta = meta
    return packing


def jam(scene, progress: bool = False, checkpoint=None, **overrides) -> Packing:
    """Jam a packing by the scene's protocol and return it.

    ``scene``: a :class:`~forcespace.scene.Scene` or the path of a scene file;
    ``overrides``: scene keys with dots replaced by double underscores, e.g.
    ``jam("inputs/quick.toml", physics__mu=0.3, disks__n=30)``. ``checkpoint``:
    a file to resume an interrupted compression from.
    """
    from ..model.scene import load_scene

    sc = scene if isinstance(scene, Scene) else load_scene(scene)
    if overrides:
        sc = sc.with_overrides(**{k.replace("__", "."): v for k, v in overrides.items()})
    return build_packing(sc, show_progress=progress, checkpoint=checkpoint)
