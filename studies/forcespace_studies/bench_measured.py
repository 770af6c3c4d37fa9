"""Measured-network benchmark (issue 41): a 1000-particle frame read and checked.

The committed 1000-disk packing (studies/packings/paper_fast_n1000_mu0.5_s1.h5) written
as a CSV pair (a measured frame: positions, contacts, forces), then, in child processes:
``forcespace convert csv`` and ``forcespace check --json`` (region: the frame minus one
rim layer; imbalance, Coulomb, distance and nearest network, per-contact ranges of fn
and ft, dim S and domains; no sampling), and the same check with uniform samples of S
(``--samples 100000``: the billiard walk's 4 chains until ESS 100 and R-hat <= 1.05 on
every tracked statistic). CPU seconds (user + sys of the children, getrusage), median of
``--rounds`` rounds after one untimed run (caches); Python's start and imports are
included. Budgets of the issue: 30 CPU s without sampling, 180 CPU s with it. There is
no old code to run beside: before this issue forcespace read no measured frame.

Writes (merges) the section ``measured`` of OUT/bench.json. Usage::

    python -m forcespace_studies.bench_measured [--rounds 3] [--out studies/out]
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from forcespace import read_packing
from forcespace.extend import write_csv_pair, write_json

from .bench_engine import _children_cpu, log

FRAME = "studies/packings/paper_fast_n1000_mu0.5_s1.h5"
BUDGET = {"check": 30.0, "check_sampled": 180.0}     # [CPU s] issue 41


def run(args) -> tuple[float, float, str]:
    """(CPU s, wall s, stdout) of one forcespace command in a child process."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    c0, w0 = _children_cpu(), time.perf_counter()
    res = subprocess.run([sys.executable, "-m", "forcespace.cli", *args], capture_output=True,
                         text=True, env=env)
    if res.returncode != 0:
        raise RuntimeError(f"forcespace {args[0]} exited {res.returncode}: {res.stderr[-400:]}")
    return _children_cpu() - c0, time.perf_counter() - w0, res.stdout


def one_round(frame: Path, work: Path, samples: int) -> dict:
    """Convert and check once: {cpu_s, wall_s, and what the check found}."""
    p = read_packing(frame)
    h5 = work / "frame.h5"
    h5.unlink(missing_ok=True)
    c1, w1, _ = run(["convert", "csv", str(work / "particles.csv"), str(work / "contacts.csv"),
                     "--mu", f"{p.mu!r}", "--width", f"{p.width!r}", "-o", str(h5)])
    args = ["check", str(h5), "--json", "--quiet"] + (["--samples", str(samples)]
                                                       if samples else [])
    c2, w2, out = run(args)
    doc = json.loads(out)
    return {"cpu_s": c1 + c2, "wall_s": w1 + w2, "convert_cpu_s": c1, "check_cpu_s": c2,
            **{k: doc.get(k) for k in ("n_region_disks", "n_unknown_contacts", "dim",
                                       "feasible", "loads", "distance", "eta", "n_samples",
                                       "min_ess", "max_rhat")}}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=Path("studies/out"))
    ap.add_argument("--samples", type=int, default=100_000,
                    help="sample cap of the sampled check (it stops at ESS 100)")
    a = ap.parse_args(argv)
    work = a.out / "bench_measured"
    work.mkdir(parents=True, exist_ok=True)
    write_csv_pair(read_packing(FRAME), work)
    cases = {}
    for name, samples in (("check", 0), ("check_sampled", a.samples)):
        one_round(Path(FRAME), work, samples)                  # untimed: caches warm
        rounds = [one_round(Path(FRAME), work, samples) for _ in range(a.rounds)]
        cpu = float(np.median([r["cpu_s"] for r in rounds]))
        cases[name] = {"cpu_s": cpu, "cpu_s_runs": [r["cpu_s"] for r in rounds],
                       "budget_cpu_s": BUDGET[name], "within_budget": cpu <= BUDGET[name],
                       **{k: v for k, v in rounds[0].items() if k not in ("cpu_s",)}}
        log(f"  {name}: {cpu:.1f} CPU s (budget {BUDGET[name]:g}), dim S {rounds[0]['dim']}, "
            f"{rounds[0]['n_region_disks']} region disks" + (
                f", ESS {rounds[0]['min_ess']:.0f}, R-hat {rounds[0]['max_rhat']:.3f}"
                if samples else ""))
    path = a.out / "bench.json"
    data = json.loads(path.read_text()) if path.is_file() else {}
    data["measured"] = {"frame": FRAME, "machine": platform.platform(),
                        "cpu_count": os.cpu_count(), "rounds": a.rounds,
                        "timing": "CPU (user + sys) of the child processes, median of rounds",
                        "commands": "forcespace convert csv particles.csv contacts.csv ...; "
                                    "forcespace check frame.h5 --json [--samples N]",
                        "cases": cases}
    write_json(path, data, indent=2)      # atomic; NaN as null (strict JSON)
    log(f"wrote section 'measured' of {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
