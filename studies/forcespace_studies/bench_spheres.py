"""Sphere benchmarks of issue 43: the CPU seconds of a sphere jam (``paper3d_certified``,
the jam ended by the exact static certificate) at 500 spheres (``--long`` adds 2000: tens of
CPU minutes, hours of wall time on a shared machine), and the cost of one single-contact
update, spheres beside disks.

Jams: per mu and size n (the box scaled as ``--n N --scale-box``: lateral extents by
(n/500)^(1/3)), seed 1, one subprocess each with one BLAS thread, CPU = user + sys of the
child (getrusage), with steps, how the jam ended, z, packing fraction, rattlers and the
static residual. A jam run separately (e.g. by ``studies/spheres3d.py``) is added with
``--add MU:N:PACKING:CPU_S``; the cost of a slice's exact analysis and converged uniform
sampling (``studies/spheres_slice_cost.py``, issue 44) with ``--add-slice-cost JSON``
(under ``slice_cost``, keyed by the number of spheres; a ``--ranges`` file, the per-contact
ranges with |f_t| max new beside old, under ``range_cost``).

Updates: CPU ns per single-contact Gauss-Seidel update of a frozen plate problem (the
static solve's sweep: single contacts in random order, no over-relaxation; ``--sweeps``
sweeps from zero forces at tolerance 0), disks and spheres, with their friction and with
mu = 0 (the tangential code never runs), the four cases interleaved round by round, the
median over ``--rounds`` rounds (the machine is shared).

Writes (merges) the section ``spheres`` of OUT/bench.json. Usage::

    python -m forcespace_studies.bench_spheres [--sizes 500] [--long] [--mus 0.1]
        [--disks studies/packings/paper_mu0.1.h5] [--spheres SPHERES.h5] [--out studies/out]
        [--add MU:N:PACKING:CPU_S ...]
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from forcespace.extend import write_json

from .bench_certificate import JAM, children_cpu

SCENE = "paper3d_certified"
SEED = 1
DISKS = "studies/packings/paper_mu0.1.h5"


def log(msg: str) -> None:
    print(msg, flush=True)


def sphere_stats(path) -> dict:
    """What a sphere jam's packing file says (steps, end, z, phi, rattlers, residual)."""
    from forcespace import read_packing

    p = read_packing(path)
    s, m = p.summary(), p.meta
    return {"steps": int(m["steps"]), "jam_end": m.get("jam_end", "rest"),
            "static_network": m.get("static_network", "sweeps"), "z": float(s["z"]),
            "packing_fraction": float(s["packing_fraction"]),
            "rattlers": int(s["n_rattlers"]), "n_contacts": int(s["n_contacts"]),
            "static_residual": float(s["equilibrium_residual"])}


def jam_cpu(n: int, mu: float, out: Path) -> dict:
    """CPU seconds and the packing's statistics of one sphere jam (a subprocess)."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    out.unlink(missing_ok=True)
    c0, w0 = children_cpu(), time.perf_counter()
    res = subprocess.run([sys.executable, "-c", JAM, SCENE, str(n), str(mu), str(SEED),
                          str(out), "{}"], env=env, capture_output=True, text=True)
    cpu, wall = children_cpu() - c0, time.perf_counter() - w0
    if res.returncode:
        raise RuntimeError(f"sphere jam n={n} mu={mu} failed: {res.stderr[-400:]}")
    return {"cpu_s": cpu, "wall_s": wall, "loadavg": os.getloadavg()[0], **sphere_stats(out)}


def update_cases(disks_path: str, spheres_path: str) -> dict:
    """{name: (frozen system, description)} of the four timed update cases."""
    import forcespace as fs
    from forcespace.extend import frozen_contacts, frozen_contacts3

    disks, spheres = fs.read_packing(disks_path), fs.read_packing(spheres_path)
    if getattr(disks, "dim", 2) != 2 or getattr(spheres, "dim", 2) != 3:
        raise SystemExit(f"{disks_path} must hold disks and {spheres_path} spheres")
    out = {}
    for mu, tag in ((None, "frictional"), (0.0, "frictionless")):
        d = fs.plate_problem(disks, mu=mu)
        s = fs.sphere_plate_problem(spheres, mu=mu)
        out[f"disks {tag}"] = (frozen_contacts(d), f"{disks.n_disks} disks, "
                               f"{d.n_contacts} contacts, mu {disks.mu if mu is None else mu:g}")
        out[f"spheres {tag}"] = (frozen_contacts3(s), f"{spheres.n_spheres} spheres, "
                                 f"{s.n_contacts} contacts, "
                                 f"mu {spheres.mu if mu is None else mu:g}")
    return out


def time_case(system, sweeps: int, seed: int) -> tuple[float, int, int]:
    """(CPU s, normal updates, tangential updates) of ``sweeps`` sweeps from zero forces."""
    nc = system.mu.shape[0]
    rn = np.zeros(nc)
    rt = np.zeros((nc, 3)) if system.__class__.__name__.endswith("3") else np.zeros(nc)
    motion = system.velocities(rn, rt)
    t0 = time.process_time()
    st = system.sweep(rn, rt, motion, sweeps, seed)
    return time.process_time() - t0, int(st.normal_updates), int(st.tangential_updates)


def update_costs(disks_path: str, spheres_path: str, sweeps: int, rounds: int) -> dict:
    """{case: {what, ns_per_update_median, tangential_updates, rounds}}."""
    systems = update_cases(disks_path, spheres_path)
    for system, _ in systems.values():          # compile every kernel first
        time_case(system, 2, 0)
    runs = {name: [] for name in systems}
    for k in range(rounds):
        for name, (system, _) in systems.items():
            cpu, normal, tangential = time_case(system, sweeps, k + 1)
            runs[name].append({"cpu_s": cpu, "normal_updates": normal,
                               "tangential_updates": tangential,
                               "ns_per_update": 1e9 * cpu / normal})
        log(f"round {k + 1}/{rounds}: " + ", ".join(
            f"{n} {runs[n][-1]['ns_per_update']:.0f} ns" for n in runs))
    return {name: {"what": systems[name][1],
                   "ns_per_update_median": float(np.median([r["ns_per_update"]
                                                            for r in runs[name]])),
                   "tangential_updates": runs[name][0]["tangential_updates"],
                   "rounds": runs[name]} for name in runs}


def merge(path: Path, key: str, value) -> None:
    """Set ``key`` of section "spheres" of the JSON file (atomic); jams merge per (mu, n)."""
    data = json.loads(path.read_text()) if path.is_file() else {}
    sec = data.setdefault("spheres", {})
    sec.update(machine=platform.platform(), cpu_count=os.cpu_count(), scene=SCENE, seed=SEED,
               timing="CPU (user + sys)")
    if key == "slice_cost":     # a --ranges file: the per-contact ranges, old beside new
        part = "range_cost" if "ranges" in value else "slice_cost"
        sec.setdefault(part, {})[str(value["n_spheres"])] = value
    elif key == "jams":
        mu, n, row = value
        rows = {r["n"]: r for r in sec.setdefault("jams", {}).get(f"{mu:g}", [])}
        rows[n] = {"n": n, **row}
        sec["jams"][f"{mu:g}"] = [rows[k] for k in sorted(rows)]
    else:
        sec[key] = value
    write_json(path, data, indent=2)      # atomic; NaN as null (strict JSON)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="500")
    ap.add_argument("--long", action="store_true", help="add the 2000-sphere jam")
    ap.add_argument("--mus", default="0.1")
    ap.add_argument("--disks", default=DISKS)
    ap.add_argument("--spheres", default=None,
                    help="the sphere packing of the update benchmark (default: the first "
                         "jam of this run)")
    ap.add_argument("--sweeps", type=int, default=200)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", type=Path, default=Path("studies/out"))
    ap.add_argument("--add", action="append", metavar="MU:N:PACKING:CPU_S",
                    help="record a sphere jam run separately (its packing file and CPU s)")
    ap.add_argument("--add-slice-cost", action="append", metavar="JSON", default=[],
                    help="record the cost of a slice's exact analysis and converged sampling "
                         "measured by studies/spheres_slice_cost.py (its JSON file)")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    bench = a.out / "bench.json"
    for f in a.add_slice_cost:
        merge(bench, "slice_cost", json.loads(Path(f).read_text()))
    for spec in a.add or ():
        mu, n, rest = spec.split(":", 2)
        path, cpu = rest.rsplit(":", 1)
        merge(bench, "jams", (float(mu), int(n), {
            "cpu_s": float(cpu), "packing": Path(path).name,
            "cpu_source": "recorded from a separate run", **sphere_stats(path)}))
    sizes = [int(s) for s in a.sizes.split(",")] if a.sizes else []
    sizes += [2000] if a.long and 2000 not in sizes else []
    spheres = a.spheres
    with tempfile.TemporaryDirectory() as tmp:
        for mu in (float(m) for m in a.mus.split(",")):
            for n in sizes:
                out = Path(tmp) / f"jam_{n}_{mu:g}.h5"
                row = jam_cpu(n, mu, out)
                merge(bench, "jams", (mu, n, row))
                log(f"  mu={mu:g} n={n:5d} ({SCENE}): {row['cpu_s']:8.1f} CPU s, "
                    f"{row['steps']} steps, ended by {row['jam_end']}, z {row['z']:.3f}")
                if spheres is None:
                    spheres = str(Path(a.out) / "bench_spheres_packing.h5")
                    out.replace(spheres)
        if spheres:
            merge(bench, "updates", {
                "units": "CPU ns per single-contact update (median over rounds)",
                "sweeps": a.sweeps, "rounds": a.rounds, "packings": [
                    Path(a.disks).name, Path(spheres).name],
                "cases": update_costs(a.disks, spheres, a.sweeps, a.rounds)})
    log(f"wrote section 'spheres' of {bench}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
