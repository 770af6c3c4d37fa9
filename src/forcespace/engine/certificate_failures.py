"""Why a jam's static certificates fail in the settled creep (issue 42, jam_profile.md
"Sixth session"): one jam of a bundled scene (as ``forcespace.engine.jam_profile``: the
scene scaled to ``--n`` disks, ``--mu``, seed ``--seed``, keys by ``--set``) with the
engine's certificate test (:func:`forcespace.engine.compress.certified`) wrapped, not
changed: every attempt is decided exactly as the engine decides it, and each one is also
logged with what the frozen configuration looks like:

- the window's mean speed [R/T] and the certificate speed; the engine's answer (status,
  interior-point iterations, CPU s) on the closed contacts (gap <= jamming.contact_gap_tol);
- the dynamics' contacts bearing force whose gap exceeds the gap tolerance (left out of
  the certificate): count, share of the total normal force, largest gap [R];
- the same certificate on the contacts within larger gaps (``GAPS`` [R]) and at a looser
  solver tolerance (1e-8);
- the infeasibility measure: the least total equation residual sum |A f - b| over
  admissible networks (an LP, Clarabel), in units of the largest load, and the number of
  body rows it falls on.

A diagnostic of the engine beside :mod:`forcespace.engine.jam_profile` and
:mod:`forcespace.engine.sweep_acceleration` (it wraps an engine function, which the studies
may not import).

Writes OUT/certificate_failures_N_muMU_sSEED.json (one row per attempt, units above) and
prints a table. A diagnostic, not part of the protocol. Usage::

    python -m forcespace.engine.certificate_failures --n 2000 --mu 1 --seed 1 \
        --scene paper_fast_compaction --set solver.tolerance=1e-8 [--out DIR]
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..io.h5 import atomic_path

GAPS = (1e-5, 1e-4, 1e-3, 1e-2)        # [R] larger contact gap tolerances tried


def least_residual(system) -> np.ndarray:
    """The rows' residuals |A f - b| (rows,) of the network f that minimises their sum
    over the Coulomb cones (an LP), in units of max |b|."""
    import clarabel

    from forcespace.engine.certificate import cone_rows

    A, b, mu = system.A, system.b, system.mu
    scale = float(np.abs(b).max(initial=0.0)) or 1.0
    m, r = A.shape[1], A.shape[0]
    Z, G = cone_rows(mu)
    eye = sp.identity(r, format="csr")
    E = sp.vstack([sp.hstack([A, -eye, eye]),
                   sp.hstack([Z, sp.csr_matrix((Z.shape[0], 2 * r))])])
    Gx = sp.vstack([sp.hstack([G, sp.csr_matrix((G.shape[0], 2 * r))]),
                    sp.hstack([sp.csr_matrix((2 * r, m)), -sp.identity(2 * r)])])
    s = clarabel.DefaultSettings()
    s.verbose, s.max_threads, s.max_iter = False, 1, 400
    s.tol_feas = s.tol_gap_abs = s.tol_gap_rel = 1e-9
    sol = clarabel.DefaultSolver(
        sp.csc_matrix((m + 2 * r, m + 2 * r)),
        np.concatenate([np.zeros(m), np.ones(2 * r)]),
        sp.vstack([E, Gx]).tocsc(),
        np.concatenate([b / scale, np.zeros(Z.shape[0] + Gx.shape[0])]),
        [clarabel.ZeroConeT(E.shape[0]), clarabel.NonnegativeConeT(Gx.shape[0])], s).solve()
    x = np.asarray(sol.x)
    return np.abs(x[m:m + r] - x[m + r:])


def residual_bodies(res, system, c, n) -> dict:
    """Where the least residual ``res`` (rows,) falls: its sum, its rows above 1e-6,
    the plate's share, and the closed-contact counts of the disks it falls on."""
    bad = res > 1e-6
    ends = np.concatenate([c.a, c.b])
    z = np.bincount(ends, minlength=system.body.max() + 1)
    disks = np.unique(system.body[bad & (system.body < n)])
    plate = res[system.body >= n].sum()
    return {"least_residual": float(res.sum()), "residual_rows": int(bad.sum()),
            "residual_plate_share": float(plate / (res.sum() or 1.0)),
            "residual_disks": int(disks.size),
            "residual_disk_contacts": {str(k): int((z[disks] == k).sum())
                                       for k in range(0, 7)},
            "residual_by_direction": [float(res[system.direction == d].sum())
                                      for d in range(3)]}


def dropped_force(bodies, box, setup, gap_tol, forces) -> dict:
    """The dynamics' force-bearing contacts whose gap exceeds ``gap_tol`` [R]."""
    from forcespace.engine.contacts import detect_contacts
    from forcespace.engine.step import contact_list, warm_start

    ints, floats = detect_contacts(bodies.x, bodies.y, bodies.r, box,
                                   setup.solver.contact_margin)
    c = contact_list(ints, floats, bodies.r, setup.physics.mu, setup.physics.plate_mu)
    rn0, _ = warm_start(c.keys, forces)
    gap = floats[:, 2]
    out = (rn0 > 0) & (gap > gap_tol)
    total = float(rn0.sum()) or 1.0
    return {"bearing": int((rn0 > 0).sum()), "dropped": int(out.sum()),
            "dropped_force_share": float(rn0[out].sum() / total),
            "dropped_max_gap": float(gap[out].max(initial=0.0)),
            "closed": int((gap <= gap_tol).sum()),
            "gap_counts": {f"{g:g}": int((gap <= g).sum()) for g in GAPS}}


def diagnose(setup, bodies, run, settings) -> dict:
    """The engine's certificate of the current state and the diagnostics of the module
    doc; ``row["engine"]`` is the engine's status."""
    from forcespace.engine.bodies import kernel_box
    from forcespace.engine.certificate import certify, frozen_system

    box = kernel_box(setup.boundary)

    def attempt(gap_tol, tol):
        t0 = time.process_time()
        c, _i, system, rn0, rt0 = frozen_system(bodies, box, setup.physics.mu,
                                                 setup.physics.plate_mu, gap_tol,
                                                 run.contacts)
        cert = certify(system, rn0, rt0, tol)
        f0 = np.zeros(system.A.shape[1])
        f0[0::2], f0[1::2] = rn0, rt0
        return cert, system, f0, time.process_time() - t0, c

    cert, system, f0, cpu, c = attempt(settings.gap_tol, settings.tol)
    row = {"steps": run.steps, "v_mean": float(run.log[-1][1]), "speed": settings.speed,
           "engine": cert.status, "iterations": cert.iterations, "cpu_s": cpu,
           "contacts": int(system.mu.shape[0]), "rows": int(system.A.shape[0]),
           "dyn_residual": float(np.abs(system.A @ f0 - system.b).max()
                                 / (np.abs(system.b).max() or 1.0))}
    row.update(dropped_force(bodies, box, setup, settings.gap_tol, run.contacts))
    if cert.status != "static":
        row.update(residual_bodies(least_residual(system), system, c, bodies.r.shape[0]))
        row["tol_1e-8"] = attempt(settings.gap_tol, 1e-8)[0].status
        for g in GAPS:
            c2 = attempt(g, settings.tol)[0]
            row[f"gap_{g:g}"] = c2.status
    return row


def run(setup) -> list[dict]:
    """Jam ``setup`` (model.setup.Setup) once with every certificate attempt diagnosed;
    the rows."""
    from forcespace.engine import compress, protocol

    rows, engine_certified, runs = [], compress.certified, []

    def logged(setup_, bodies, run_, cert_settings):
        runs[:] = [run_]
        ok = engine_certified(setup_, bodies, run_, cert_settings)
        row = diagnose(setup_, bodies, run_, cert_settings)
        row["accepted"] = bool(ok)
        rows.append(row)
        print(json.dumps(row), flush=True)
        return ok

    compress.certified = logged
    try:
        packing = protocol.build_packing(setup, show_progress=False)
    finally:
        compress.certified = engine_certified
    rows.append({"jam_end": packing.meta["jam_end"], "steps": int(packing.meta["steps"]),
                 "windows": [list(map(float, w)) for w in runs[0].log] if runs else []})
    return rows


def summary(doc: dict) -> list[str]:
    """Markdown rows, one per certificate attempt of a written ``doc``, and a last row
    counting the windows after the first attempt by what stopped them."""
    att = [r for r in doc["attempts"] if "engine" in r]
    out = ["| step | v_mean [R/T] | dyn. residual | closed | status | least residual "
           "(rows, plate share) | contacts of residual disks 1/2/3 | gap 1e-5 / 1e-4 / "
           "1e-3 / 1e-2 |", "|---|---|---|---|---|---|---|---|"]
    for r in att:
        z = r.get("residual_disk_contacts", {})
        lr = (f"{r['least_residual']:.3g} ({r['residual_rows']}, "
              f"{r.get('residual_plate_share', float('nan')):.2f})"
              if "least_residual" in r else "")
        gaps = " / ".join(r.get(f"gap_{g:g}", "-") for g in GAPS)
        out.append(f"| {r['steps']} | {r['v_mean']:.2g} | {r['dyn_residual']:.2g} | "
                   f"{r['closed']} | {r['engine']} | {lr} | "
                   f"{'/'.join(str(z.get(str(k), '')) for k in (1, 2, 3))} | {gaps} |")
    end = doc["attempts"][-1]
    w = end.get("windows", [])
    if att and w:
        speed, first = att[0]["speed"], att[0]["steps"]
        later = [x for x in w if x[0] >= first]
        fast = sum(x[1] > speed for x in later)
        out.append(f"| windows from step {first}: {len(later)}; above the certificate "
                   f"speed {speed:.2g}: {fast}; attempts {len(att)} ({sum(r['accepted'] for r in att)} "
                   f"accepted); other {len(later) - fast - len(att)} | | | | | | | |")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--mu", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scene", default="paper_fast_compaction")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--out", type=Path, default=Path("."))
    ap.add_argument("--summary", type=Path, help="print the table of a written file")
    a = ap.parse_args(argv)
    if a.summary:
        print("\n".join(summary(json.loads(a.summary.read_text()))))
        return 0
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    settings = {k: json.loads(v) for k, v in (s.split("=", 1) for s in a.set)}
    from forcespace.engine.jam_profile import scene_for
    from forcespace.model.setup import Setup
    rows = run(Setup.from_scene(scene_for(a.scene, a.n, a.mu,
                                          {**settings, "scene.seed": a.seed})))
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / f"certificate_failures_{a.n}_mu{a.mu:g}_s{a.seed}.json"
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps({"scene": a.scene, "n": a.n, "mu": a.mu,
                                         "seed": a.seed, "settings": settings,
                                         "attempts": rows}, indent=1))
    print("\n".join(summary(json.loads(path.read_text()))))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
