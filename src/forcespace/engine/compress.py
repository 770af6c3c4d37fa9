"""Compression until jammed: windows of time steps, the rest criterion, checkpoints.

Orchestration only (numpy, progress, stopping rules); the physics is in the kernels of
:mod:`forcespace.engine.step`. The compression runs windows of ``jamming.window``
steps until no load-bearing disk and not the top plate moved, over a window, by more
than ``jamming.velocity_tol`` * sqrt(F0 rbar / mbar) times the window's duration (a
mean speed, so that overlap-correction jitter averages out while steady sliding does
not), with the plate carried by the packing.

A window runs in several kernel calls of about ``CHUNK_SECONDS`` each (the same
trajectory bit for bit: step seeds count from the window's start), so that Ctrl-C
and the progress bar are served within a second or so.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, NumericalError
from ..io.checkpoint import read_checkpoint, write_checkpoint
from ..model.setup import Setup
from ..model.walls import N_WALL_SLOTS, SLOT_BOTTOM, SLOT_TOP
from ..progress import progress
from .bodies import (Bodies, certificate_settings, compacting_settings, kernel_box,
                     step_settings, velocity_scale)
from .certificate import CertificateSettings, certify, frozen_system
from .interrupts import InterruptFlag
from .records import ContactForces, StepStats
from .static import sphere_certificate
from .step import run_steps, run_steps3
from ..streams import window_seed

CHECKPOINT_SECONDS = 30.0      # [s] wall time between checkpoints of a compression
CHUNK_SECONDS = 0.5            # [s] CPU time aimed at per kernel call


@dataclass
class Run:
    """The state of a compression (what a checkpoint holds besides the bodies).

    steps: steps done; log: one row per window (step, v_mean, v_max [R/T], sweeps per
    step, largest final relative force change); stats: totals over all steps;
    contacts: the last step's contacts; v_ref: the largest window mean speed so far
    [R/T] (the progress measure's origin); phase: "compressing" or "jammed";
    rest_after: the rest criterion is not tested before this many steps (set when a
    jammed run is sent back to compressing, see :func:`unsettle`); retries: how many
    times a failed static solve sent it back (the protocol's count, kept across a
    resume); seconds_before: wall seconds the run took in earlier processes (compression
    and static solves; resumed from a checkpoint; 0 for a fresh run); ended: what ended
    the compression ("rest": the rest criterion, "certificate": a static certificate,
    "" while compressing); certificates: the certificates tried and
    certificate_seconds their CPU seconds (this process); started: this process's
    perf_counter() at the start (not saved).
    """

    steps: int = 0
    log: list = field(default_factory=list)
    stats: StepStats = field(default_factory=StepStats.zero)
    contacts: ContactForces = field(default_factory=ContactForces.empty)
    v_ref: float = float("nan")
    phase: str = "compressing"
    rest_after: int = 0
    retries: int = 0
    seconds_before: float = 0.0
    ended: str = ""
    certificates: int = 0
    certificate_seconds: float = 0.0
    started: float = field(default_factory=time.perf_counter, compare=False, repr=False)

    def seconds(self) -> float:
        """Wall seconds of this run so far, earlier processes included."""
        return self.seconds_before + time.perf_counter() - self.started


def snapshot(bodies: Bodies, run: Run) -> dict:
    """The checkpoint state of ``bodies`` and ``run`` (copies)."""
    state = {k: getattr(bodies, k).copy() for k in bodies.state_fields}
    state.update(keys=run.contacts.keys.copy(), rn=run.contacts.rn.copy(),
                 rt=run.contacts.rt.copy(), log=np.array(run.log, float).reshape(-1, 5),
                 steps=run.steps, phase=run.phase, v_first=run.v_ref,
                 rest_after=run.rest_after, retries=run.retries, seconds=run.seconds(),
                 ended=run.ended, stats=run.stats._asdict())
    return state


def restore(path, setup: Setup, bodies: Bodies) -> Run | None:
    """The run saved in checkpoint ``path`` for ``setup`` (its :attr:`~Setup.identity`;
    bodies restored in place), or None without a checkpoint. InputError for a foreign or
    corrupt file."""
    state = read_checkpoint(path, setup.identity)
    if state is None:
        return None
    first = getattr(bodies, bodies.state_fields[0])
    saved = state.get(bodies.state_fields[0])
    if saved is None or saved.shape != first.shape:
        got = "another dimension" if saved is None else f"{saved.shape[0]} bodies"
        raise InputError(path, "bodies", f"checkpoint has {got}, the scene "
                         f"{first.shape[0]} bodies in {bodies.dim}-D; delete it to start "
                         "afresh")
    for k in bodies.state_fields:
        getattr(bodies, k)[:] = state[k]
    try:
        stats = StepStats(**{k: state["stats"][k] for k in StepStats._fields})
    except KeyError as exc:
        raise InputError(path, f"stats.{exc.args[0]}", "missing; delete the checkpoint to "
                         "start afresh") from None
    return Run(steps=state["steps"], log=[tuple(row) for row in state["log"]], stats=stats,
               contacts=ContactForces(state["keys"].astype(np.int64), state["rn"],
                                      state["rt"]),
               v_ref=state["v_first"], phase=state["phase"],
               rest_after=state.get("rest_after", 0), retries=state.get("retries", 0),
               seconds_before=state.get("seconds", 0.0), ended=state.get("ended", ""))


class JamProgress:
    """Progress of a jam by its own measure: the window mean speed on a log scale from
    the largest one seen (0 %) to the rest tolerance (100 %), never moving back."""

    def __init__(self, v_tol: float, show: bool, run: Run, max_steps: int):
        self.v_tol, self.max_steps = v_tol, max_steps
        self.bar = progress(total=100.0, desc="compressing", unit="%", disable=not show)
        self.bar.bar_format = ("{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}]"
                               "{postfix}")
        self.done = 0.0
        self.update(run)

    def update(self, run: Run) -> None:
        if run.log:
            v = run.log[-1][1]
            frac = 0.0
            if v <= self.v_tol or run.phase == "jammed":
                frac = 1.0
            elif run.v_ref > self.v_tol:
                frac = math.log(run.v_ref / v) / math.log(run.v_ref / self.v_tol)
            frac = min(max(frac, 0.0), 1.0)
            self.bar.set_postfix_str(f"{run.steps}/{self.max_steps} steps, v_mean/v_tol "
                                     f"{v / self.v_tol:.1e}, "
                                     f"{run.log[-1][3]:.0f} sweeps/step", refresh=False)
            self.bar.update(max(100.0 * frac - self.done, 0.0))   # 0: a timed refresh
            self.done = max(self.done, 100.0 * frac)

    def close(self) -> None:
        self.bar.close()


def run_window(window: int, bodies: Bodies, run: Run, seed: int, settings, chunk: list,
               interrupt: InterruptFlag, on_interrupt) -> StepStats:
    """One window of ``window`` steps (``jamming.window``) in chunks of kernel calls
    (in place).

    ``chunk``: [steps per call], adapted to about CHUNK_SECONDS of CPU per call;
    ``on_interrupt()`` runs (and Interrupted is raised) when an interrupt was requested
    after a call.
    """
    box, step, sweep = settings
    wseed = window_seed(seed, run.steps)
    total = StepStats.zero()
    done = 0
    while done < window:
        k = min(chunk[0], window - done)
        t0 = time.process_time()
        steps = run_steps if bodies.dim == 2 else run_steps3
        run.contacts, st = steps(bodies, box, step, sweep, run.contacts, k, wseed, done)
        spent = time.process_time() - t0
        done += k
        total = total.merged(st)
        if spent < 0.5 * CHUNK_SECONDS:
            chunk[0] = min(2 * chunk[0], window)
        elif spent > 2.0 * CHUNK_SECONDS and chunk[0] > 1:
            chunk[0] //= 2
        if interrupt.requested:
            interrupt.check(on_interrupt())
    return total


def start_run(setup: Setup, bodies: Bodies, checkpoint=None) -> Run:
    """The run a compression starts from: the one saved in ``checkpoint`` (bodies
    restored in place) or a fresh one."""
    run = restore(checkpoint, setup, bodies) if checkpoint else None
    return run or Run()


def unsettle(setup: Setup, run: Run, windows: int) -> None:
    """Send a jammed run back to compressing, the rest criterion not tested for the
    next ``windows`` windows (in place): for a rest state whose static solve failed,
    i.e. a configuration that only looked at rest (a slow creep paused for a window)."""
    run.phase = "compressing"
    run.ended = ""
    run.rest_after = run.steps + windows * setup.jamming.window


def compress(setup: Setup, bodies: Bodies, seed: int, show_progress=True, log=None,
             checkpoint=None, interrupt: InterruptFlag | None = None,
             run: Run | None = None) -> dict:
    """Run contact dynamics until jammed (in place). Returns solver statistics.

    Overlaps left by truncated sweeps beyond ``solver.overlap_slop`` are
    removed at the rate ``solver.overlap_correction``; below the slop Unger's
    rule holds exactly, so the jammed state is a true rest state of the rigid
    dynamics.

    ``checkpoint``: a file the state is saved to every ``CHECKPOINT_SECONDS``, when
    jammed (phase "jammed"), at ``jamming.max_steps`` and on an interrupt, and resumed
    from if it exists (bit-identical to an uninterrupted run); the caller removes it
    once the packing is done. ``log`` (a list) receives one row per window.
    ``interrupt``: see :mod:`forcespace.engine.interrupts`. ``run``: continue this run
    (from :func:`start_run`, possibly :func:`unsettle`-d) instead of starting one.

    Raises NumericalError if the state becomes non-finite or max_steps is reached,
    Interrupted on a requested interrupt.
    """
    interrupt = interrupt or InterruptFlag()
    v0 = velocity_scale(setup, bodies)
    v_tol = setup.jamming.velocity_tol * v0
    run = run if run is not None else start_run(setup, bodies, checkpoint)
    settings = (kernel_box(setup.boundary), *step_settings(setup, v0))
    settings = (settings, compacting_settings(setup, settings[2], v0))
    ends = (v_tol, certificate_settings(setup, v0))
    t0 = time.perf_counter()
    bar = JamProgress(v_tol, show_progress, run, setup.jamming.max_steps)
    try:
        _windows(setup, bodies, run, seed, settings, ends, bar, checkpoint, interrupt)
    finally:
        bar.close()
    if log is not None:
        log.extend(run.log)
    bodies.contacts = run.contacts
    s = run.stats
    return {"steps": run.steps, "sweeps_total": int(s.sweeps_total),
            "sweeps_max_step": int(s.sweeps_max_step),
            "normal_updates": int(s.normal_updates),
            "tangential_updates": int(s.tangential_updates),
            "steps_at_sweep_cap": int(s.steps_at_sweep_cap),
            "compress_seconds": time.perf_counter() - t0, "jam_end": run.ended,
            "certificates_tried": run.certificates,
            "certificate_cpu_seconds": run.certificate_seconds}


def certified(setup: Setup, bodies: Bodies, run: Run, settings: CertificateSettings) -> bool:
    """Whether the bodies' configuration admits a static network (an interior-point
    certificate on its closed contacts, :mod:`forcespace.engine.certificate`)."""
    t0 = time.process_time()
    if bodies.dim == 3:
        cert = sphere_certificate(setup, bodies, run.contacts, settings.tol)
    else:
        _c, _image, system, rn0, rt0 = frozen_system(
            bodies, kernel_box(setup.boundary), setup.physics.mu, setup.physics.plate_mu,
            settings.gap_tol, run.contacts)
        cert = certify(system, rn0, rt0, settings.tol)
    run.certificates += 1
    run.certificate_seconds += time.process_time() - t0
    return cert.status == "static"


def _windows(setup: Setup, bodies, run: Run, seed, settings, ends, bar, checkpoint,
             interrupt):
    """The window loop of :func:`compress` (until jammed; run and bodies in place).
    ``settings``: ((box, StepSettings, SweepSettings), :func:`~forcespace.engine.bodies.
    compacting_settings`); ``ends``: (v_tol [R/T] of the rest criterion,
    CertificateSettings)."""
    v_tol, cert = ends
    window = setup.jamming.window
    settings, compacting = settings
    last_save = time.perf_counter()
    chunk = [1]

    def save(state):
        if checkpoint:
            write_checkpoint(checkpoint, setup.identity, state)
        return f"the run resumes from {checkpoint}" if checkpoint else ""

    while run.phase != "jammed":
        if run.steps >= setup.jamming.max_steps:
            save(snapshot(bodies, run))
            raise NumericalError(_not_jammed(setup, run, v_tol, checkpoint))
        before = snapshot(bodies, run)
        now = window_settings(settings, compacting, run)
        st = run_window(window, bodies, run, seed, now, chunk, interrupt,
                        lambda: save(before))
        run.steps += window
        run.stats = run.stats.merged(st)
        check_state(setup, bodies, run.steps)
        v_mean = window_displacement(setup, bodies, before, run.contacts) / (window * now[2].dt)
        run.v_ref = v_mean if not v_mean <= run.v_ref else run.v_ref
        run.log.append((run.steps, v_mean, st.max_speed, st.sweeps_total / window,
                        st.max_rel_change))
        if (run.steps >= run.rest_after and v_mean <= v_tol
                and load_carried(setup, bodies, run.contacts)):
            run.phase, run.ended = "jammed", "rest"
            save(snapshot(bodies, run))
        elif (run.steps >= run.rest_after and v_mean <= cert.speed
              and (run.steps // window) % cert.every == 0
              and load_carried(setup, bodies, run.contacts)
              and certified(setup, bodies, run, cert)):
            run.phase, run.ended = "jammed", "certificate"
            save(snapshot(bodies, run))
        elif checkpoint and time.perf_counter() - last_save > CHECKPOINT_SECONDS:
            save(snapshot(bodies, run))
            last_save = time.perf_counter()
        bar.update(run)


def window_settings(settings, compacting, run: Run):
    """The (box, StepSettings, SweepSettings) of the next window: ``settings``, or with
    ``compacting`` = (SweepSettings, speed [R/T]) its sweep settings (the larger
    ``solver.dt_compacting``) for the first window and after a window whose mean speed
    exceeded the speed (a function of the run's log, so a resumed run continues alike)."""
    if compacting is None or (run.log and not run.log[-1][1] > compacting[1]):
        return settings
    return settings[0], settings[1], compacting[0]


def _not_jammed(setup: Setup, run: Run, v_tol, checkpoint) -> str:
    v_mean = run.log[-1][1] if run.log else float("nan")
    capped = int(run.stats.steps_at_sweep_cap)
    return (f"not jammed after jamming.max_steps = {run.steps} steps "
            f"(last mean speed over a window {v_mean:.3g}, tolerance {v_tol:.3g}; {capped} "
            f"steps hit solver.max_sweeps = {setup.solver.max_sweeps}); raise "
            f"jamming.max_steps" + (", solver.max_sweeps" if capped else "")
            + " or the tolerances"
            + (f"; the run resumes from {checkpoint}" if checkpoint else ""))


def window_displacement(setup: Setup, bodies, start: dict, contacts: ContactForces) -> float:
    """Largest displacement [R] over the last window of a grain that bears load or feels
    gravity (centre displacement + r*|rotation|), or of the top plate; ``start``: the
    :func:`snapshot` at the window's start.

    Jitter from overlap correction averages out over a window; steady sliding does
    not. Left out: free-flying grains (zero gravity); with periodic lateral axes and
    frictionless walls, the uniform lateral drift (a zero mode); and a grain whose one
    force-bearing contact is a wall (a lone disk on the floor), which rolls or slides
    along the flat wall at constant speed without end, touching nothing of the
    packing (rigid disks have no rolling resistance; the case: studies/field_notes.md);
    in 3-D also a sphere with exactly two force-bearing contacts (it swings about their
    chord, below).
    """
    n = bodies.n
    nb = n + N_WALL_SLOTS
    keys, rn = contacts.keys, contacts.rn
    a, b = keys // nb, keys % nb
    on = rn > 0
    disk_ends = np.concatenate([a[on & (a < n)], b[on & (b < n)]])
    loaded = bodies.load[:n] != 0
    loaded[disk_ends] = True
    bearing = np.bincount(disk_ends, minlength=n)     # force-bearing contacts per grain
    on_wall = np.zeros(n, bool)
    wall = on & ((a >= n) | (b >= n))
    on_wall[np.minimum(a, b)[wall]] = True            # (walls are the slots n..nb-1)
    loaded &= ~(on_wall & (bearing == 1))
    if bodies.dim == 3:
        # a sphere held by exactly two contacts swings about the chord through them (the
        # axis of a rotation that moves neither contact point): a floppy mode of rigid
        # frictional spheres that never stops in zero gravity and changes no force to
        # first order (quick3d, mu = 0.5: 2-contact spheres drifting at 1e-5 R/T for 3e5
        # steps while the rest was still); the static solve still checks their balance
        loaded &= bearing != 2
        return _sphere_displacements(setup, bodies, start, loaded, contacts)
    return _disk_displacements(setup, bodies, start, loaded)


def _disk_displacements(setup: Setup, bodies: Bodies, start: dict, loaded) -> float:
    """The largest window displacement of a ``loaded`` disk or the plate (2-D)."""
    n = bodies.n
    x0, y0, th0 = start["x"], start["y"], start["th"]
    dx = bodies.x[:n] - x0[:n]
    (periodic,), (width,) = setup.boundary.periodic, setup.boundary.lateral
    if periodic:
        dx -= width * np.round(dx / width)
    plate = abs(bodies.y[n + SLOT_TOP] - y0[n + SLOT_TOP])
    if not loaded.any():
        return float(plate)
    if periodic and setup.physics.plate_mu == 0.0:
        m = 1.0 / bodies.inv_mx[:n][loaded]      # the kernel's masses (per-disk densities)
        dx = dx - (m * dx[loaded]).sum() / m.sum()
    disp = np.hypot(dx, bodies.y[:n] - y0[:n]) + bodies.r * np.abs(bodies.th[:n] - th0[:n])
    return float(max(disp[loaded].max(), plate))


def _sphere_displacements(setup: Setup, bodies, start: dict, loaded,
                          contacts: ContactForces) -> float:
    """The largest window displacement of a ``loaded`` sphere or the plate (3-D: periodic
    x and y). A sphere's rotation counts by how far it moved its force-bearing contact
    points (the largest |dtheta x arm| over them), not by r |dtheta|: a sphere held by two
    contacts spins freely about the chord through them (a zero mode of rigid frictional
    spheres, which never stops and moves nothing; seen in quick3d at mu = 0.5)."""
    n = bodies.n
    nb = n + N_WALL_SLOTS
    d = bodies.pos[:n] - start["pos"][:n]
    size = np.asarray(setup.boundary.lateral, float)
    d[:, :2] -= size * np.round(d[:, :2] / size)
    plate = abs(bodies.pos[n + SLOT_TOP, 2] - start["pos"][n + SLOT_TOP, 2])
    if not loaded.any():
        return float(plate)
    if setup.physics.plate_mu == 0.0:         # the lateral drift, a zero mode
        m = bodies.masses[loaded]
        d[:, :2] -= (m[:, None] * d[loaded, :2]).sum(0) / m.sum()
    turn = bodies.th[:n] - start["th"][:n]
    on = contacts.rn > 0
    a, b = contacts.keys[on] // nb, contacts.keys[on] % nb
    inner = (a < n) & (b < n)
    normal = np.tile([0.0, 0.0, 1.0], (a.size, 1))      # plate contacts
    sep = bodies.pos[b[inner]] - bodies.pos[a[inner]]
    sep[:, :2] -= size * np.round(sep[:, :2] / size)
    normal[inner] = sep / np.linalg.norm(sep, axis=1)[:, None]
    rolled = np.zeros(n)
    for ends, sign in ((a, 1.0), (b, -1.0)):             # arms r n from a, -r n from b
        s = ends < n
        arm = sign * bodies.r[ends[s], None] * normal[s]
        np.maximum.at(rolled, ends[s], np.linalg.norm(np.cross(turn[ends[s]], arm), axis=1))
    disp = np.linalg.norm(d, axis=1) + rolled
    return float(max(disp[loaded].max(), plate))


def check_state(setup: Setup, bodies: Bodies, steps: int) -> None:
    """NumericalError if the state is non-finite or disks left the box through a
    plate (a time step far too large for the loads: the implicit scheme stays
    stable, but contacts are then missed between steps)."""
    n = bodies.n
    z = bodies.vertical
    if not (np.isfinite(getattr(bodies, bodies.state_fields[0])[:n]).all()
            and np.isfinite(z).all()):
        raise NumericalError(f"non-finite positions after {steps} steps; reduce solver.dt "
                             f"(now {setup.solver.dt:g})")
    y, r, boundary = z[:n], bodies.r, setup.boundary
    below = boundary.bottom and (y + r < z[n + SLOT_BOTTOM]).any()
    above = boundary.top is not None and (y - r > z[n + SLOT_TOP]).any()
    if below or above:
        raise NumericalError(f"grains passed through the {'bottom' if below else 'top'} plate "
                             f"after {steps} steps: solver.dt = {setup.solver.dt:g} is too "
                             f"large for these loads; reduce it")


def load_carried(setup: Setup, bodies: Bodies, contacts: ContactForces) -> bool:
    """Whether the packing carries the top plate: its contacts push up with at least
    half the plate load (a plate that has not reached the disks is not at rest,
    even if it moves slowly). True without a top plate."""
    if setup.boundary.top is None:
        return True
    nb = bodies.n + N_WALL_SLOTS
    on_plate = (contacts.keys % nb) == bodies.n + SLOT_TOP
    return float(contacts.rn[on_plate].sum()) >= -0.5 * bodies.load[bodies.n + SLOT_TOP]
