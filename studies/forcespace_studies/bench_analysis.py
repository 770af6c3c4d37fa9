"""Exact-analysis benchmark (issue 22): ``forcespace analyze --slice H`` on the committed
5000-disk packing (studies/big_slice/) cut at several heights, on the 200-disk paper
packing and on an 800-disk mu = 1 packing (a thin S), new code beside the code as it was
when the issue was filed (commit 938734f; the thin case beside 021aa83, before its range
LPs moved to the affine hull's coordinates), exported from git and run from its sources,
alternating which goes first, in CPU seconds (user + sys of the child process, getrusage).

Each command runs once untimed first (numba caches, file cache), then ``--rounds`` times
per code; the figure is the median. Every timed run must report the same dim S and the
same number of varying contacts for both codes, else the section records the mismatch.
The times include Python's start and imports (~1-2 CPU s).

Writes (merges) the section ``analysis`` of OUT/bench.json. Usage::

    python -m forcespace_studies.bench_analysis [--rounds 3] [--out studies/out]
        [--heights 50,80,140] [--old-src DIR]
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

from forcespace.extend import write_json

from .bench_engine import OLD_COMMIT, PACKINGS, _children_cpu, log, old_sources

# the CLI without its plug-ins (the old CLI cannot load today's studies plug-in; neither
# code needs one for analyze)
CLI = ("import sys, importlib.metadata as m; m.entry_points = lambda **kw: []; "
       "from forcespace.cli import main; sys.exit(main(sys.argv[1:]))")


def analyze_cpu(src: Path | None, packing: Path, height: float) -> dict:
    """One ``analyze --slice height --json`` in a child process (``src``: old sources on
    PYTHONPATH; None: the installed code): CPU s and what it found."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if src is not None:
        env["PYTHONPATH"] = str(src / "src")
    args = [sys.executable, "-c", CLI, "analyze", str(packing), "--slice", f"{height:g}",
            "--json"]
    if src is None:
        args.append("--quiet")
    c0, w0 = _children_cpu(), time.perf_counter()
    res = subprocess.run(args, capture_output=True, text=True, env=env)
    cpu, wall = _children_cpu() - c0, time.perf_counter() - w0
    if res.returncode != 0:
        raise RuntimeError(f"analyze exited {res.returncode}: {res.stderr[-500:]}")
    out = json.loads(res.stdout[res.stdout.index("{"):])
    return {"cpu_s": cpu, "wall_s": wall, "dim_S": out.get("dim_S"),
            "n_varying": out.get("n_varying_contacts"), "n_contacts": out.get("n_contacts"),
            "max_sum_fn": out.get("max_sum_fn")}


HEIGHTS = (50.0, 80.0, 140.0)   # [R] slices of the 5000-disk packing: dim S 537, 953, 1714


# a thin S: mu = 1, n = 800, the size study's scaled slice (dim S 11 of 620 contacts, most
# contacts decided by range LPs), against the code before those LPs were asked in the
# affine hull's coordinates (OLD_COMMIT's analysis fails on it: its Chebyshev-centre LP)
THIN = ("paper_fast mu1 n800 slice 56", "studies/packings/paper_fast_n800_mu1_s1.h5", 56.0)
THIN_OLD_COMMIT = "021aa83"


def cases(heights) -> list[tuple[str, Path, float, str]]:
    """(name, packing, slice height [R], old commit) of each case."""
    big = Path(PACKINGS[5000])
    return [("paper_mu0.1 n200 slice 28", Path(PACKINGS[200]), 28.0, OLD_COMMIT),
            (THIN[0], Path(THIN[1]), THIN[2], THIN_OLD_COMMIT)] + [
        (f"paper_fast n5000 slice {h:g}", big, h, OLD_COMMIT) for h in heights]


def bench(old_srcs: dict, rounds: int, heights=HEIGHTS) -> list[dict]:
    """``old_srcs``: {commit: its exported sources}."""
    rows = []
    for name, packing, height, commit in cases(heights):
        old_src = old_srcs[commit]
        for src in (None, old_src):                  # untimed: caches warm
            analyze_cpu(src, packing, height)
        runs = {"new": [], "old": []}
        for k in range(rounds):
            order = ("new", "old") if k % 2 == 0 else ("old", "new")
            for which in order:
                runs[which].append(analyze_cpu(None if which == "new" else old_src,
                                               packing, height))
        row = {"case": name, "packing": str(packing), "slice_height": height,
               "old_commit": commit}
        for which, rs in runs.items():
            row[which] = {"cpu_s": float(np.median([r["cpu_s"] for r in rs])),
                          "cpu_s_runs": [r["cpu_s"] for r in rs],
                          "dim_S": rs[0]["dim_S"], "n_varying": rs[0]["n_varying"]}
        ref = runs["new"][0]
        row["same_result"] = all(
            r["dim_S"] == ref["dim_S"] and r["n_varying"] == ref["n_varying"]
            and abs(r["max_sum_fn"] - ref["max_sum_fn"]) <= 1e-6 * abs(ref["max_sum_fn"])
            for rs in runs.values() for r in rs)
        row["speedup_cpu"] = row["old"]["cpu_s"] / row["new"]["cpu_s"]
        log(f"  {name}: dim S {row['new']['dim_S']}, CPU s old {row['old']['cpu_s']:.1f}, "
            f"new {row['new']['cpu_s']:.1f} ({row['speedup_cpu']:.1f}x), same result "
            f"{row['same_result']}")
        rows.append(row)
    return rows


def merge_analysis(path: Path, section: dict) -> None:
    """Write ``section`` as key "analysis" of the JSON file, other keys kept (atomic)."""
    data = json.loads(path.read_text()) if path.is_file() else {}
    data["analysis"] = section
    write_json(path, data, indent=2)      # atomic; NaN as null (strict JSON)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=Path("studies/out"))
    ap.add_argument("--heights", default=",".join(f"{h:g}" for h in HEIGHTS),
                    help="slice heights [R] of the 5000-disk packing")
    ap.add_argument("--old-src", type=Path, default=None,
                    help=f"sources of the old code (default: exported from git at {OLD_COMMIT})")
    a = ap.parse_args(argv)
    heights = tuple(float(h) for h in a.heights.split(","))
    a.out.mkdir(parents=True, exist_ok=True)
    here = Path.cwd()
    old_srcs = {OLD_COMMIT: a.old_src or old_sources(here, a.out / f"old_engine_{OLD_COMMIT}"),
                THIN_OLD_COMMIT: old_sources(here, a.out / f"old_code_{THIN_OLD_COMMIT}",
                                             THIN_OLD_COMMIT)}
    log(f"analyze --slice, new against {OLD_COMMIT} ({THIN_OLD_COMMIT} on the thin case), "
        f"{a.rounds} rounds, CPU s ...")
    rows = bench(old_srcs, a.rounds, heights)
    merge_analysis(a.out / "bench.json", {
        "old_commit": OLD_COMMIT, "machine": platform.platform(), "cpu_count": os.cpu_count(),
        "timing": "CPU (user + sys) of the child process, median of the rounds",
        "command": "forcespace analyze PACKING --slice H --json", "cases": rows})
    log(f"wrote section 'analysis' of {a.out / 'bench.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
