"""Jam benchmarks of issue 42: ``paper_fast`` (the protocol before) beside
``paper_certified`` (the jam ended by an exact static certificate), in one interleaved
run, in CPU seconds (user + sys of the jamming subprocess, getrusage of the children; one
BLAS thread); the machine is shared, so both protocols run alternately at every size
(which goes first alternates too) and feel the same load.

Per mu (0.1 and 1; at mu = 1 both with the size study's ``solver.tolerance = 1e-8``,
``size.FULL["protocol_by_mu"]``) and size n (boxes scaled as ``--n N --scale-box``), seed
1: CPU s, steps, how the jam ended, z, packing fraction, rattlers, the static residual, and
per protocol and mu the exponent a of CPU ~ n^a (least squares in log-log over the sizes
recorded). A jam run separately (e.g. the 20 000-disk ones, or the old 5000-disk jam at
mu = 1, 53-133 CPU-min) is added with ``--add PROTOCOL:MU:N:PACKING:CPU_S``.

``--section compaction`` compares ``paper_certified`` (old) with ``paper_fast_compaction``
(new: a doubled time step while the packing compacts) in the same way, into the section
``compaction``. Writes (merges) the section ``certificate`` (or ``compaction``) of
OUT/bench.json; sizes recorded by earlier
runs are kept, the newest run winning per (mu, n, protocol). Usage::

    python -m forcespace_studies.bench_certificate [--sizes 200,800] [--long] [--mus 0.1,1]
        [--section certificate|compaction] [--out studies/out]
        [--add PROTOCOL:MU:N:PACKING:CPU_S ...]

The default sizes (200, 800) take ~6 CPU-min for both protocols and mus; ``--long`` adds
2000 and 5000 disks (CPU-hours: paper_fast at mu = 1 and 5000 disks took 53-133 CPU-min).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from forcespace import read_packing
from forcespace.extend import write_json

from .bench_engine import exponent

PROTOCOLS = {"old": "paper_fast", "new": "paper_certified"}
# --section: the bench.json section and the two scenes it compares (old, new)
SECTIONS = {"certificate": PROTOCOLS,
            "compaction": {"old": "paper_certified", "new": "paper_fast_compaction"}}
SEED = 1
LONG_SIZES = (2000, 5000)    # --long: the sizes of the goals beyond the default
JAM = r"""
import json, sys
from forcespace import jam, load_scene, write_packing
scene_name, n, mu, seed, out, over = sys.argv[1:7]
scene, _ = load_scene(scene_name).scaled_to(int(n))
scene = scene.with_overrides(**{"physics.mu": float(mu), "scene.seed": int(seed),
                                **json.loads(over)})
write_packing(jam(scene), out)
"""


def log(msg: str) -> None:
    print(msg, flush=True)


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def protocol_overrides(mu: float) -> dict:
    """The size study's scene keys at this mu (both protocols jam with them)."""
    from .size import FULL
    return dict(FULL["protocol_by_mu"].get(float(mu), {}))


def packing_stats(path) -> dict:
    """What a jam's packing file says: steps, how it ended, z, packing fraction,
    rattlers, static residual, the static network's source."""
    p = read_packing(path)
    m = p.meta
    return {"steps": int(m["steps"]), "jam_end": m.get("jam_end", "rest"),
            "static_network": m.get("static_network", "sweeps"),
            "z": float(p.coordination()), "packing_fraction": p.packing_fraction(),
            "rattlers": int(p.rattlers().sum()),
            "static_residual": float(p.equilibrium_residual())}


def jam_cpu(scene: str, n: int, mu: float, out: Path) -> dict:
    """CPU seconds and the packing's statistics of one jam of bundled ``scene`` (a
    subprocess)."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    out.unlink(missing_ok=True)
    c0, w0 = children_cpu(), time.perf_counter()
    res = subprocess.run([sys.executable, "-c", JAM, scene, str(n), str(mu),
                          str(SEED), str(out), json.dumps(protocol_overrides(mu))],
                         env=env, capture_output=True, text=True)
    cpu, wall = children_cpu() - c0, time.perf_counter() - w0
    if res.returncode:
        raise RuntimeError(f"jam n={n} mu={mu} ({scene}) failed: {res.stderr[-400:]}")
    return {"cpu_s": cpu, "wall_s": wall, "loadavg": os.getloadavg()[0], **packing_stats(out)}


def recorded(spec: str) -> tuple:
    """(mu, n, protocol, row) of ``PROTOCOL:MU:N:PACKING:CPU_S`` (a jam run separately)."""
    protocol, mu, n, rest = spec.split(":", 3)
    path, cpu = rest.rsplit(":", 1)
    return float(mu), int(n), protocol, {"cpu_s": float(cpu), "packing": Path(path).name,
                                         "cpu_source": "recorded from a separate run",
                                         **packing_stats(path)}


def merge(path: Path, mu: float, n: int, protocol: str, row: dict,
          section: str = "certificate") -> None:
    """Merge one jam into ``section`` (of :data:`SECTIONS`) of the JSON file (atomic),
    with the exponents per (mu, protocol) over the sizes recorded."""
    data = json.loads(path.read_text()) if path.is_file() else {}
    sec = data.setdefault(section, {})
    sec.update(machine=platform.platform(), cpu_count=os.cpu_count(),
               timing="CPU (user + sys) of the jamming process",
               protocols=SECTIONS[section], seed=SEED)
    by_mu = sec.setdefault("jams", {}).setdefault(f"{mu:g}", [])
    rows = {r["n"]: r for r in by_mu}
    rows.setdefault(n, {"n": n})[protocol] = row
    sec["jams"][f"{mu:g}"] = [rows[k] for k in sorted(rows)]
    sec["exponent"] = {m: {pr: exponent([r for r in rs if r["n"] <= 5000], pr)
                           for pr in PROTOCOLS} for m, rs in sec["jams"].items()}
    write_json(path, data, indent=2)      # atomic; NaN as null (strict JSON)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="200,800")
    ap.add_argument("--long", action="store_true", help="add the sizes 2000 and 5000 (hours)")
    ap.add_argument("--mus", default="0.1,1")
    ap.add_argument("--which", default="old,new", help="protocols to jam (old, new)")
    ap.add_argument("--section", default="certificate", choices=sorted(SECTIONS),
                    help="the comparison: certificate (paper_fast, paper_certified) or "
                         "compaction (paper_certified, paper_fast_compaction)")
    ap.add_argument("--out", type=Path, default=Path("studies/out"))
    ap.add_argument("--add", action="append", metavar="PROTOCOL:MU:N:PACKING:CPU_S",
                    help="record a jam run separately (its packing file and CPU s)")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    bench = a.out / "bench.json"
    for spec in a.add or ():
        merge(bench, *recorded(spec), section=a.section)
    sizes = [int(s) for s in a.sizes.split(",")] if a.sizes else []
    sizes += [n for n in LONG_SIZES if a.long and n not in sizes]
    which = a.which.split(",")
    scenes = SECTIONS[a.section]
    with tempfile.TemporaryDirectory() as tmp:
        for p in which:                                # compile the kernel caches
            jam_cpu(scenes[p], 20, 0.1, Path(tmp) / "warm.h5")
        for mu in (float(m) for m in a.mus.split(",")):
            for k, n in enumerate(sizes):
                for p in (which if k % 2 == 0 else which[::-1]):
                    row = jam_cpu(scenes[p], n, mu, Path(tmp) / f"jam_{p}_{n}.h5")
                    merge(bench, mu, n, p, row, a.section)
                    log(f"  mu={mu:g} n={n:5d} {p} ({scenes[p]}): {row['cpu_s']:8.1f} CPU s,"
                        f" {row['steps']} steps, ended by {row['jam_end']}, z {row['z']:.3f}")
    log(f"wrote section '{a.section}' of {bench}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
