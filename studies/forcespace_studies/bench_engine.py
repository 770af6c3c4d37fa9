"""Engine benchmarks (issue 22), each figure beside the code as it was when the issue was
filed (commit 938734f, exported from git and run from its sources), interleaved in one run,
in CPU seconds (user + sys; a shared machine misleads wall-clock ratios by up to 2x).

1. **Contact updates**: CPU ns per single-contact update of the Gauss-Seidel solver,
   frictional (mu = 0.1) and frictionless, on the committed 200-disk paper packing
   (studies/packings/paper_mu0.1.h5) and the committed 5000-disk paper_fast packing
   (studies/big_slice/), in the paper's sweep order (single contacts, random) and the
   fast one (runs of 64 contacts in spatial order), statics mode (dt = 1, gaps closed)
   from the jammed forces. Beside it pymunk's solver on the same packing
   (``space.step`` at 100 and 1 iterations, solver share (t(100) - t(1)) / 99 per
   contact-iteration), measured in the same rounds: new, old, pymunk, new, ...
2. **Jams**: CPU seconds of jamming each code's inputs/paper_fast.toml with N disks (the
   box scaled as ``forcespace pack --n N --scale-box``), mu = 0.1, seed 1, by the
   protocol's ``build_packing`` (subprocesses, getrusage of the children), old and new
   alternately per size, with steps, contact updates and z, and the exponent of
   CPU ~ n^a fitted (least squares in log-log) over the sizes recorded.

Writes (merges) the section ``engine`` of OUT/bench.json; other sections and sizes
recorded by earlier runs are kept (so the 5000-disk jam may be recorded by a separate
``--jams 5000`` run). Usage::

    python -m forcespace_studies.bench_engine [--updates] [--jams 200,800,2000]
        [--old-src DIR] [--out studies/out] [--rounds 3]

With neither ``--updates`` nor ``--jams``: the updates and the jams at 200, 800, 2000.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from forcespace import read_packing
from forcespace.extend import (add_contact_velocities, Contacts, kernel_body_index, Motion,
                               N_WALL_SLOTS, nlgs_solve as solve, row_order, SLOT_TOP,
                               SweepSettings, write_json)

OLD_COMMIT = "938734f"
PACKINGS = {200: "studies/packings/paper_mu0.1.h5",
            5000: "studies/big_slice/paper_fast_n5000_mu0.1_s1.h5"}
UPDATES_PER_TIMING = 6e5
PYMUNK_ITERATIONS = 100

OLD_TIMER = r"""
import json, sys, time
import numpy as np
from forcespace.nlgs import add_contact_velocities, effective_masses, nlgs_solve
d = np.load(sys.argv[1])
sweeps, block, reps = int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
a, b, nx, ny, ra, rb = d["a"], d["b"], d["nx"], d["ny"], d["ra"], d["rb"]
imx, imy, ii, mu = d["inv_mx"], d["inv_my"], d["inv_i"], d["mu"]
mn, mt = effective_masses(a, b, nx, ny, ra, rb, imx, imy, ii)
gap = np.zeros(a.size)
out = []
for rep in range(reps + 1):
    rn, rt = d["rn"].copy(), d["rt"].copy()
    vx, vy, w = d["vx"].copy(), d["vy"].copy(), d["w"].copy()
    add_contact_velocities(a, b, nx, ny, ra, rb, rn, rt, imx, imy, ii, 1.0, vx, vy, w)
    t0 = time.process_time()
    nlgs_solve(a, b, nx, ny, ra, rb, gap, mu, mn, mt, rn, rt, vx, vy, w, imx, imy, ii,
               1.0, 0.0, sweeps if rep else 2, rep, 0.0, 0.0, 1.0, block)
    if rep:
        out.append(time.process_time() - t0)
print(json.dumps(out))
"""


def log(msg: str) -> None:
    print(msg, flush=True)


def renumbered(p):
    """The packing with disks numbered row by row and contacts sorted by their lower disk
    index (the memory order of ``solver.sweep_block`` > 0; same geometry and forces)."""
    n = p.n_disks
    perm = row_order(p.x, p.y, p.r)
    new = np.empty(n, np.int64)
    new[perm] = np.arange(n)
    a = np.where(p.a >= 0, new[np.maximum(p.a, 0)], p.a)
    b = np.where(p.b >= 0, new[np.maximum(p.b, 0)], p.b)
    key = np.where((a >= 0) & (b >= 0), np.minimum(a, b), np.maximum(a, b))
    order = np.argsort(key, kind="stable")
    dens = p.density if np.isscalar(p.density) else np.asarray(p.density)[perm]
    return replace(p, x=p.x[perm], y=p.y[perm], r=p.r[perm], density=dens, a=a[order],
                   b=b[order], **{k: getattr(p, k)[order]
                                  for k in ("normal", "point", "image", "gap", "fn", "ft")})


def statics_arrays(p, mu: float) -> dict:
    """Solver arrays of a packing in statics mode: walls fixed, top plate movable
    vertically (inverse mass 0.1), the plate load and the jammed forces."""
    n = p.n_disks
    nb = n + N_WALL_SLOTS
    inv_m = np.zeros(nb)
    inv_m[:n] = 1.0 / p.mass
    inv_my = inv_m.copy()
    inv_my[n + SLOT_TOP] = 0.1
    inv_i = np.zeros(nb)
    if mu > 0:
        inv_i[:n] = 1.0 / (0.5 * p.mass * p.r**2)
    vy = np.zeros(nb)
    vy[n + SLOT_TOP] = -p.top_force * inv_my[n + SLOT_TOP]
    return {"a": kernel_body_index(p.a, n), "b": kernel_body_index(p.b, n),
            "nx": p.normal[:, 0].copy(), "ny": p.normal[:, 1].copy(),
            "ra": np.where(p.a >= 0, p.r[np.maximum(p.a, 0)], 0.0),
            "rb": np.where(p.b >= 0, p.r[np.maximum(p.b, 0)], 0.0),
            "mu": np.full(p.n_contacts, mu), "inv_mx": inv_m, "inv_my": inv_my,
            "inv_i": inv_i, "rn": p.fn.copy(), "rt": p.ft.copy() * (mu > 0),
            "vx": np.zeros(nb), "vy": vy, "w": np.zeros(nb)}


def new_timer(d: dict, sweeps: int, block: int):
    """() -> CPU seconds of ``sweeps`` sweeps of :func:`forcespace.engine.nlgs.solve` on the
    arrays ``d``, from the same start each call (compiled and run once here)."""
    nc = d["a"].size
    c = Contacts(d["a"], d["b"], d["nx"], d["ny"], np.zeros(nc), d["ra"], d["rb"], d["mu"],
                 np.zeros(nc, np.int64))
    calls = [0]

    def run(n_sweeps=sweeps) -> float:
        rn, rt = d["rn"].copy(), d["rt"].copy()
        m = Motion(d["vx"].copy(), d["vy"].copy(), d["w"].copy(), d["inv_mx"], d["inv_my"],
                   d["inv_i"])
        add_contact_velocities(c, rn, rt, m, 1.0)
        calls[0] += 1
        t0 = time.process_time()
        solve(c, m, rn, rt, SweepSettings(1.0, 0.0, n_sweeps, 1.0, block), calls[0])
        return time.process_time() - t0

    run(2)
    return run


def old_timer(old_src: Path, npz: Path, sweeps: int, block: int, reps: int = 1) -> float:
    """Best CPU seconds of ``reps`` runs of the old ``nlgs_solve`` (a subprocess)."""
    env = dict(os.environ, PYTHONPATH=str(old_src / "src"), OMP_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", OLD_TIMER, str(npz), str(sweeps), str(block),
                          str(reps)], env=env, capture_output=True, text=True)
    if out.returncode:
        raise RuntimeError(f"old timer failed: {out.stderr.strip().splitlines()[-1:]}")
    return min(json.loads(out.stdout.strip().splitlines()[-1]))


def pymunk_timer(p, mu: float):
    """() -> (CPU seconds of one step at PYMUNK_ITERATIONS, at 1 iteration, contacts)."""
    from forcespace_adapters.problem import soft_problem
    from forcespace_adapters.pymunk_sim import PymunkOptions, PymunkScene
    sc = PymunkScene(soft_problem(replace(p, mu=mu), top="plate"),
                     PymunkOptions(iterations=PYMUNK_ITERATIONS))
    sc.step(20)
    n_pym = len(sc.contacts())
    steps = max(2, int(UPDATES_PER_TIMING / (n_pym * PYMUNK_ITERATIONS)))

    def per_step(it):
        sc.space.iterations = it
        total = 0.0
        for _ in range(steps):
            sc.apply_loads()
            t0 = time.process_time()
            sc.space.step(sc.dt)
            total += time.process_time() - t0
        return total / steps

    return lambda: (per_step(PYMUNK_ITERATIONS), per_step(1), n_pym)


def update_case(p, mu, order, old_src, work: Path, rounds: int, pym) -> dict:
    """ns per contact update, new and old, and pymunk's solver, best of ``rounds``
    interleaved rounds (new, old, pymunk)."""
    block = 64 if order == "block64" else 0
    q = renumbered(p) if block else p
    d = statics_arrays(q, mu)
    npz = work / f"arrays_{p.n_disks}_{mu}_{order}.npz"
    np.savez(npz, **d)
    sweeps = max(10, int(UPDATES_PER_TIMING / q.n_contacts))
    new = new_timer(d, sweeps, block)
    best = {"new": math.inf, "old": math.inf, "pym": math.inf, "pym1": math.inf}
    n_pym = 0
    for _ in range(rounds):
        best["new"] = min(best["new"], new())
        best["old"] = min(best["old"], old_timer(old_src, npz, sweeps, block))
        t100, t1, n_pym = pym()
        best["pym"], best["pym1"] = min(best["pym"], t100), min(best["pym1"], t1)
    upd = q.n_contacts * sweeps
    diff = best["pym"] - best["pym1"]
    pym_ns = 1e9 * diff / (n_pym * (PYMUNK_ITERATIONS - 1)) if diff > 0 else math.nan
    row = {"n_disks": p.n_disks, "n_contacts": q.n_contacts, "mu": mu, "order": order,
           "sweeps": sweeps, "new_ns": 1e9 * best["new"] / upd,
           "old_ns": 1e9 * best["old"] / upd, "pymunk_contacts": n_pym,
           "pymunk_solver_ns": pym_ns,
           "pymunk_raw_ns": 1e9 * best["pym"] / (n_pym * PYMUNK_ITERATIONS)}
    row["speedup_new_over_old"] = row["old_ns"] / row["new_ns"]
    row["ratio_new_vs_pymunk"] = pym_ns / row["new_ns"]
    row["ratio_old_vs_pymunk"] = pym_ns / row["old_ns"]
    log(f"  n={p.n_disks:5d} mu={mu:g} {order:8s}: new {row['new_ns']:6.1f} ns, old "
        f"{row['old_ns']:6.1f} ns ({row['speedup_new_over_old']:.2f}x); pymunk solver "
        f"{pym_ns:6.1f} ns -> {row['ratio_new_vs_pymunk']:.2f}x (old "
        f"{row['ratio_old_vs_pymunk']:.2f}x); load {os.getloadavg()[0]:.1f}")
    return row


def updates(old_src: Path, rounds: int) -> list:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n, path in PACKINGS.items():
            p = read_packing(path)
            for mu in (0.0, 0.1):
                pym = pymunk_timer(p, mu)
                for order in ("random", "block64"):
                    rows.append(update_case(p, mu, order, old_src, Path(tmp), rounds, pym))
    return rows


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


JAM = r"""
import sys
n, mu, seed, scene_file, out, new = sys.argv[1:7]
if new == "1":
    from forcespace.model.scene import load_scene
    from forcespace.engine.protocol import build_packing
    from forcespace.io.packing_file import write_packing
else:                                         # the flat layout of 938734f
    from forcespace.scene import load_scene
    from forcespace.jamming import build_packing
    from forcespace.packing_file import write_packing
scene, _ = load_scene(scene_file).scaled_to(int(n))
scene = scene.with_overrides(**{"physics.mu": float(mu), "scene.seed": int(seed)})
write_packing(build_packing(scene, show_progress=False), out)
"""


def jam_cpu(src: Path, scene: Path, n: int, out: Path, new: bool) -> dict:
    """CPU seconds of jamming ``scene`` with n disks (box scaled as ``--n n --scale-box``),
    mu = 0.1, seed 1, by the protocol's ``build_packing`` of the new code or of the old
    sources ``src`` (a subprocess, getrusage of the children); the packing's statistics."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if not new:
        env["PYTHONPATH"] = str(src / "src")
    out.unlink(missing_ok=True)
    c0, w0 = _children_cpu(), time.perf_counter()
    res = subprocess.run([sys.executable, "-c", JAM, str(n), "0.1", "1", str(scene), str(out),
                          "1" if new else "0"], env=env, capture_output=True, text=True)
    cpu, wall = _children_cpu() - c0, time.perf_counter() - w0
    if res.returncode:
        raise RuntimeError(f"pack n={n} ({'new' if new else 'old'}) failed: {res.stderr[-400:]}")
    p = read_packing(out)
    m = p.meta
    return {"cpu_s": cpu, "wall_s": wall, "steps": int(m["steps"]),
            "sweeps": int(m["sweeps_total"]), "steps_at_sweep_cap": int(m["steps_at_sweep_cap"]),
            "updates": int(m["normal_updates"] + m["tangential_updates"]),
            "z": float(p.coordination()), "packing_fraction": p.packing_fraction(),
            "rattlers": int(p.rattlers().sum()), "loadavg": os.getloadavg()[0]}


def jams(sizes, old_src: Path, repo: Path, work: Path, codes=("old", "new"),
         record=None) -> list:
    """Jam each size with each code (alternating which goes first), in subprocesses;
    ``record(row)`` is called after each size (e.g. to merge it into the JSON file)."""
    rows = []
    for k, n in enumerate(sizes):
        row = {"n": n}
        for which in (codes if k % 2 == 0 else tuple(reversed(codes))):
            new = which == "new"
            scene = (repo if new else old_src) / "inputs" / "paper_fast.toml"
            row[which] = jam_cpu(old_src, scene, n, work / f"jam_{which}_{n}.h5", new)
            log(f"  n={n:5d} {which}: {row[which]['cpu_s']:8.1f} CPU s, "
                f"{row[which]['steps']} steps, {row[which]['updates']:.3g} updates, "
                f"z {row[which]['z']:.3f}")
        rows.append(row)
        if record is not None:
            record(row)
    return rows


def old_5000_from_meta() -> dict:
    """The old code's 5000-disk paper_fast jam (mu = 0.1, seed 1) as committed in
    studies/big_slice (made by 664c1bb, the same engine numbers as 938734f): steps,
    updates, z from the file; CPU seconds as measured for issue 22 (about 54 CPU
    minutes; the file records 4478 s of wall time on a shared machine)."""
    p = read_packing(PACKINGS[5000])
    m = p.meta
    return {"cpu_s": 54 * 60.0, "cpu_source": "issue 22 (about 54 CPU minutes)",
            "wall_s": float(m["wall_seconds"]), "steps": int(m["steps"]),
            "sweeps": int(m["sweeps_total"]), "steps_at_sweep_cap": int(m["steps_at_sweep_cap"]),
            "updates": int(m["normal_updates"] + m["tangential_updates"]),
            "z": float(p.coordination()), "packing_fraction": p.packing_fraction(),
            "rattlers": int(p.rattlers().sum()), "source": PACKINGS[5000]}


def recorded(spec: str) -> dict:
    """A row {"n", CODE} from ``CODE:N:PACKING:CPU_S`` (a jam run separately)."""
    code, n, rest = spec.split(":", 2)
    path, cpu = rest.rsplit(":", 1)
    p = read_packing(path)
    m = p.meta
    return {"n": int(n), code: {
        "cpu_s": float(cpu), "cpu_source": "recorded from a separate run (user + sys)",
        "steps": int(m["steps"]), "sweeps": int(m["sweeps_total"]),
        "steps_at_sweep_cap": int(m["steps_at_sweep_cap"]),
        "updates": int(m["normal_updates"] + m["tangential_updates"]),
        "z": float(p.coordination()), "packing_fraction": p.packing_fraction(),
        "rattlers": int(p.rattlers().sum())}}


def exponent(rows, which: str, key: str = "cpu_s"):
    pts = [(r["n"], r[which][key]) for r in rows if which in r]
    if len(pts) < 2:
        return None
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def old_sources(repo: Path, dest: Path, commit: str = OLD_COMMIT) -> Path:
    """The sources (src/, inputs/) of ``commit`` exported from ``repo``'s git."""
    if (dest / "src" / "forcespace" / "__init__.py").is_file():
        return dest
    dest.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(repo), "archive", commit, "src", "inputs"],
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    return dest


def merge(path: Path, section: dict) -> None:
    """Merge ``section`` into key "engine" of the JSON file (other keys kept; jams merged
    by size, the newest run winning)."""
    data = json.loads(path.read_text()) if path.is_file() else {}
    old = data.get("engine", {})
    if "jams" in section:
        by_n = {r["n"]: dict(r) for r in old.get("jams", [])}
        for r in section["jams"]:          # per size and code: the newest run wins
            by_n.setdefault(r["n"], {}).update(r)
        section["jams"] = [by_n[n] for n in sorted(by_n)]
    if "jams" in section:
        section["jam_exponent"] = {w: exponent(section["jams"], w) for w in ("old", "new")}
        section["jam_updates_exponent"] = {w: exponent(section["jams"], w, "updates")
                                           for w in ("old", "new")}
    data["engine"] = {**old, **section}
    write_json(path, data, indent=2)      # atomic; NaN as null (strict JSON)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--updates", action="store_true", help="contact updates against pymunk")
    ap.add_argument("--jams", default=None, help="comma-separated sizes to jam (e.g. 5000)")
    ap.add_argument("--old-src", type=Path, default=None,
                    help=f"sources of the old code (default: exported from git at {OLD_COMMIT})")
    ap.add_argument("--out", type=Path, default=Path("studies/out"))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--which", default="old,new", help="which codes to jam (old, new)")
    ap.add_argument("--add", action="append", metavar="CODE:N:PACKING:CPU_S",
                    help="record a jam of CODE (old or new) run separately (e.g. in the "
                         "background with /usr/bin/time): its packing file and CPU s")
    ap.add_argument("--old-5000-from-meta", action="store_true",
                    help="record the old 5000-disk jam from the committed packing's metadata "
                         "(steps, updates, z; its time was wall time on a shared machine) "
                         "and issue 22's CPU figure, instead of running it (~1 CPU hour)")
    a = ap.parse_args(argv)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    repo = Path.cwd()
    a.out.mkdir(parents=True, exist_ok=True)
    old_src = a.old_src or old_sources(repo, a.out / f"old_engine_{OLD_COMMIT}")
    recording = bool(a.old_5000_from_meta or a.add)
    do_updates = a.updates or (a.jams is None and not recording)
    default_sizes = [] if a.updates or recording else [200, 800, 2000]
    sizes = [int(s) for s in a.jams.split(",")] if a.jams else default_sizes
    section = {"old_commit": OLD_COMMIT, "machine": platform.platform(),
               "cpu_count": os.cpu_count(), "timing": "CPU (user + sys)"}
    if do_updates:
        log("contact updates: new, old and pymunk interleaved ...")
        merge(a.out / "bench.json", {**section, "updates": updates(old_src, a.rounds)})
    if sizes:
        log(f"jams of inputs/paper_fast.toml at mu = 0.1, seed 1, n = {sizes} ...")
        with tempfile.TemporaryDirectory() as tmp:
            which = tuple(a.which.split(","))
            jams([20], old_src, repo, Path(tmp), which)   # compiles the kernel caches
            jams(sizes, old_src, repo, Path(tmp), which,
                 lambda row: merge(a.out / "bench.json", {**section, "jams": [row]}))
    extra = [{"n": 5000, "old": old_5000_from_meta()}] if a.old_5000_from_meta else []
    for spec in a.add or ():
        extra.append(recorded(spec))
    if extra:
        merge(a.out / "bench.json", {**section, "jams": extra})
    log(f"wrote section 'engine' of {a.out / 'bench.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
