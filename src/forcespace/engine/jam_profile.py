"""Where the CPU of a jam goes (issue 42): one jam of a bundled scene (default
``paper_certified``; the box scaled as ``--n N --scale-box``, seed 1, scene keys set by
``--set``), profiled by phase in process CPU seconds (user + sys, one BLAS thread):

- the compression's windows of time steps, split by stage: the top plate moving faster
  than ``solver.moving_speed`` (compaction: the sweeps stop at ``solver.tolerance_moving``)
  and settled (the sweeps aim at ``solver.tolerance``), with the mean sweeps per step
  and the share of steps whose sweeps hit the cap unconverged;
- contact detection (the cell list rebuilt every step), timed on the current
  configuration every 10th window (20 rebuilds) and multiplied out over all steps (it is
  part of the windows' CPU);
- the certificate attempts (interior point) and the static network (the certificate's
  network polished by static sweeps);
- the windows again by the stage of the compaction (:func:`compaction_phases`: the plate
  at its steady speed, decelerating, settled).

The windows are timed by wrapping :func:`forcespace.engine.compress.run_window`; the
packing is the protocol's own (same trajectory). Writes OUT/profile_N_muMU.json (per
window: steps, CPU s, sweeps per step, capped steps, plate speed, contacts) and prints a
markdown table row per stage. A diagnostic of the engine, not part of the protocol. Usage::

    python -m forcespace.engine.jam_profile --n 2000 --mu 0.1 [--scene NAME] [--out DIR]
        [--set KEY=VALUE ...]
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from ..io.h5 import atomic_path

DETECT_EVERY = 10      # windows between two detection timings
DETECT_REPEATS = 20


def scene_for(name: str, n: int, mu: float, settings: dict):
    """The profiled scene: bundled scene ``name`` scaled to n disks, seed 1, mu, then
    ``settings`` (scene keys)."""
    from ..model.scene import load_scene
    scene, _ = load_scene(name).scaled_to(n)
    return scene.with_overrides(**{"physics.mu": mu, "scene.seed": 1, **settings})


def profile(setup) -> dict:
    """Jam ``setup`` (a Setup) once with the windows, detections and static phase timed
    (see the module doc); the profile as a dict."""
    from . import compress, protocol
    from .contacts import detect_kernel

    rows, static = [], [0.0]
    run_window, static_network = compress.run_window, protocol.static_network

    def timed_window(window, bodies, run, *args):
        t0 = time.process_time()
        st = run_window(window, bodies, run, *args)
        cpu = time.process_time() - t0
        det = float("nan")
        if len(rows) % DETECT_EVERY == 0:
            box, step = args[1][0], args[1][1]
            detect_kernel(bodies.x, bodies.y, bodies.r, box, step.margin)  # warm
            t1 = time.process_time()
            for _ in range(DETECT_REPEATS):
                detect_kernel(bodies.x, bodies.y, bodies.r, box, step.margin)
            det = (time.process_time() - t1) / DETECT_REPEATS
        rows.append({"steps": run.steps + window, "cpu_s": cpu,
                     "sweeps_per_step": st.sweeps_total / window,
                     "capped_steps": int(st.steps_at_sweep_cap),
                     "plate_speed": float(st.max_top_speed),
                     "contacts": int(run.contacts.keys.shape[0]), "detect_s": det})
        return st

    def timed_static(*args, **kw):
        t0 = time.process_time()
        out = static_network(*args, **kw)
        static[0] += time.process_time() - t0
        return out

    compress.run_window, protocol.static_network = timed_window, timed_static
    try:
        t0 = time.process_time()
        packing = protocol.build_packing(setup, show_progress=False)
        total = time.process_time() - t0
    finally:
        compress.run_window, protocol.static_network = run_window, static_network
    m = packing.meta
    return {"n": int(setup.grains.n), "mu": setup.physics.mu, "cpu_s": total, "static_cpu_s": static[0],
            "certificate_cpu_s": float(m["certificate_cpu_seconds"]),
            "certificates_tried": int(m["certificates_tried"]), "jam_end": m["jam_end"],
            "steps": int(m["steps"]), "sweep_cap": setup.solver.max_sweeps,
            "moving_speed": moving_speed(setup), "windows": rows}


def moving_speed(setup) -> float:
    """The plate speed [R/T] above which the sweeps stop at solver.tolerance_moving."""
    from .bodies import velocity_scale
    from .protocol import start_bodies
    return setup.solver.moving_speed * velocity_scale(setup, start_bodies(setup))


def table(p: dict) -> list[str]:
    """Markdown rows: CPU s and share per phase of one profile."""
    w = p["windows"]
    cpu = np.array([r["cpu_s"] for r in w])
    sweeps = np.array([r["sweeps_per_step"] for r in w])
    capped = np.array([r["capped_steps"] for r in w])
    steps = w[1]["steps"] - w[0]["steps"] if len(w) > 1 else w[0]["steps"]
    moving = np.array([r["plate_speed"] for r in w]) > p["moving_speed"]
    det = np.nanmean([r["detect_s"] for r in w]) * p["steps"]
    total = p["cpu_s"]
    out = []
    for name, sel in (("windows, plate moving (compaction)", moving),
                      ("windows, plate settled", ~moving)):
        k = int(sel.sum())
        out.append(f"| {name} | {k} | {cpu[sel].sum():.1f} | {100 * cpu[sel].sum() / total:.0f} % "
                   f"| {sweeps[sel].mean() if k else 0:.0f} | "
                   f"{100 * capped[sel].sum() / max(k * steps, 1):.0f} % |")
    out.append(f"| of these: contact detection (cell list every step) | | {det:.1f} | "
               f"{100 * det / total:.0f} % | | |")
    out.append(f"| certificate attempts ({p['certificates_tried']}) | | "
               f"{p['certificate_cpu_s']:.2f} | {100 * p['certificate_cpu_s'] / total:.1f} % | | |")
    out.append(f"| static network (certificate's, polished) | | {p['static_cpu_s']:.2f} | "
               f"{100 * p['static_cpu_s'] / total:.1f} % | | |")
    out.append(f"| total ({p['steps']} steps, ended by {p['jam_end']}) | {len(w)} | "
               f"{total:.1f} | 100 % | {sweeps.mean():.0f} (cap {p['sweep_cap']}) | "
               f"{100 * capped.sum() / max(len(w) * steps, 1):.0f} % |")
    return out


def compaction_phases(p: dict) -> list[str]:
    """Markdown rows: the windows of one profile split by the top plate's largest speed
    in the window: steady compaction (above half the largest of the jam), deceleration
    (down to ``moving_speed``) and settled; windows, steps, CPU s and share, mean sweeps
    per step, mean contacts and mean sweeps x contacts per step (contact updates)."""
    w = p["windows"]
    v = np.array([r["plate_speed"] for r in w])
    cpu = np.array([r["cpu_s"] for r in w])
    sweeps = np.array([r["sweeps_per_step"] for r in w])
    contacts = np.array([r["contacts"] for r in w], float)
    steps = np.diff([0] + [r["steps"] for r in w])
    stage = np.where(v > 0.5 * v.max(), 0, np.where(v > p["moving_speed"], 1, 2))
    out = []
    for k, name in enumerate(("steady compaction (plate > half its top speed)",
                              "deceleration", "settled")):
        s = stage == k
        if not s.any():
            continue
        out.append(f"| {name} | {int(s.sum())} | {int(steps[s].sum())} | {cpu[s].sum():.1f} | "
                   f"{100 * cpu[s].sum() / p['cpu_s']:.0f} % | {sweeps[s].mean():.0f} | "
                   f"{contacts[s].mean():.0f} | {(sweeps[s] * contacts[s]).mean():.3g} |")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--mu", type=float, default=0.1)
    ap.add_argument("--scene", default="paper_certified")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a scene key of the profiled jam (value parsed as JSON)")
    ap.add_argument("--out", type=Path, default=Path("."))
    a = ap.parse_args(argv)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    settings = {k: json.loads(v) for k, v in (s.split("=", 1) for s in a.set)}
    from ..model.setup import Setup
    setup = Setup.from_scene(scene_for(a.scene, a.n, a.mu, settings))
    p = dict(profile(setup), scene=a.scene, settings=settings)
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / f"profile_{a.n}_mu{a.mu:g}.json"
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(p, indent=1))
    print("| phase | windows | CPU s | share | sweeps / step | steps at cap |")
    print("|---|---|---|---|---|---|")
    print("\n".join(table(p)))
    print("\n| stage | windows | steps | CPU s | share | sweeps / step | contacts | "
          "contact updates / step |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(compaction_phases(p)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
