"""One large checkpointed jam (issue 42: 20 000 disks), resumable across sessions, with its
CPU time summed over every process that worked on it.

``python -m forcespace_studies.big_jam SCENE --n N --mu MU --seed S [--set key=value ...]
[--out DIR]`` jams ``SCENE`` scaled to N disks (box as ``forcespace pack --n N
--scale-box``) at mu = MU, seed S (at mu = 1 the size study's ``solver.tolerance = 1e-8``
unless ``--set`` says otherwise). The compression checkpoints to
``DIR/packings/NAME.checkpoint.h5`` every 30 s and on SIGINT (stop it with ``kill -INT
PID``; a SIGKILL loses up to 30 s of work and this process's CPU log line); rerunning the
same command resumes it. Every process appends one line to ``DIR/NAME.cpu.jsonl`` when it stops
(process CPU s, user + sys, one BLAS thread; the steps reached), so the jam's cost is the
sum of that column. When the jam ends the packing goes to ``studies/packings/NAME.h5``
(``--packings``; the issue's 20 000-disk packings are committed there) and one row (cost, steps, how it ended, static residual, z, packing fraction, rattlers) to
``DIR/rows.jsonl``. ``--status`` prints the CPU so far and the checkpoint's steps, no work;
``--status --bench FILE`` also records them as the jam's row (``new`` when SCENE is
``paper_fast_compaction``, else ``old``) of the section ``compaction`` of FILE (e.g.
``studies/out/bench.json``): finished (from ``rows.jsonl``) or in progress.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

from .rows import append_row, read_rows


def name_of(scene: str, n: int, mu: float, seed: int) -> str:
    """File stem of one jam, e.g. ``paper_fast_compaction_n20000_mu0.1_s1``."""
    return f"{scene}_n{n}_mu{mu:g}_s{seed}"


def parse_sets(items: list) -> dict:
    """``["solver.tolerance=1e-8"]`` -> ``{"solver.tolerance": 1e-8}`` (ints stay ints)."""
    out = {}
    for item in items:
        key, _, value = item.partition("=")
        if not key or not value:
            raise SystemExit(f"big_jam: --set {item!r}: expected key=value, e.g. solver.tolerance=1e-8")
        out[key] = int(value) if value.lstrip("-").isdigit() else float(value)
    return out


def checkpoint_steps(path: Path) -> int | None:
    """Time steps stored in a compression checkpoint (None without one)."""
    if not path.is_file():
        return None
    import h5py
    with h5py.File(path, "r") as f:
        return int(f.attrs["steps"])


def cpu_so_far(log: Path) -> tuple[float, int]:
    """CPU s summed over the processes logged in ``log`` and their number."""
    rows = read_rows(log)
    return sum((r["cpu_s"] for r in rows), 0.0), len(rows)


def jam(args, out: Path, name: str) -> None:
    """Build (or resume) the packing; log this process's CPU whatever happens."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from forcespace import load_scene
    from forcespace.extend import Setup, build_packing
    from forcespace import write_packing
    from .size import FULL
    overrides = {**FULL["protocol_by_mu"].get(args.mu, {}), **parse_sets(args.set)}
    scene, _ = load_scene(args.scene).scaled_to(args.n)
    scene = scene.with_overrides(**{"physics.mu": args.mu, "scene.seed": args.seed, **overrides})
    check = out / "packings" / f"{name}.checkpoint.h5"
    check.parent.mkdir(parents=True, exist_ok=True)
    t0, packing = time.process_time(), None
    try:
        packing = build_packing(Setup.from_scene(scene), show_progress=True, checkpoint=str(check))
    finally:
        steps = packing.meta["steps"] if packing is not None else checkpoint_steps(check)
        append_row(out / f"{name}.cpu.jsonl", {
            "cpu_s": time.process_time() - t0, "steps": steps, "finished": packing is not None,
            "utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())})
    Path(args.packings).mkdir(parents=True, exist_ok=True)
    write_packing(packing, Path(args.packings) / f"{name}.h5")
    cpu, processes = cpu_so_far(out / f"{name}.cpu.jsonl")
    m = packing.meta
    row = {"scene": args.scene, "n": args.n, "mu": args.mu, "seed": args.seed, "overrides": overrides,
           "jam_cpu_s": cpu, "processes": processes, "steps": int(m["steps"]), "jam_end": m["jam_end"],
           "static_residual": float(m["static_residual"]), "z": float(packing.coordination()),
           "phi": float(packing.packing_fraction()), "rattler_fraction": float(packing.rattlers().mean())}
    append_row(out / "rows.jsonl", row)
    print(json.dumps(row))


def bench_row(out: Path, name: str, args) -> dict:
    """The jam's row for bench.json: the finished row of rows.jsonl, else its progress."""
    rows = read_rows(out / "rows.jsonl")
    done = [r for r in rows if name_of(r["scene"], r["n"], r["mu"], r["seed"]) == name]
    if done:
        r = done[-1]
        return {"cpu_s": r["jam_cpu_s"], "steps": r["steps"], "jam_end": r["jam_end"],
                "z": r["z"], "packing_fraction": r["phi"], "static_residual": r["static_residual"],
                "cpu_source": f"sum over {r['processes']} processes (forcespace_studies.big_jam)"}
    cpu, processes = cpu_so_far(out / f"{name}.cpu.jsonl")
    steps = checkpoint_steps(out / "packings" / f"{name}.checkpoint.h5")
    return {"cpu_s": cpu, "steps": steps, "jam_end": "not finished (checkpointed, resumes)",
            "cpu_source": f"sum over {processes} processes so far (forcespace_studies.big_jam)",
            "as_of": time.strftime("%Y-%m-%dT%H:%MZ", time.gmtime())}


def record_bench(path: Path, row: dict, args) -> None:
    """Merge the jam's row into bench.json's section compaction (atomic)."""
    from .bench_certificate import SECTIONS, merge
    which = [k for k, v in SECTIONS["compaction"].items() if v == args.scene]
    if not which:
        raise SystemExit(f"big_jam: --bench: scene {args.scene!r} is neither of the compaction "
                         f"section's {sorted(SECTIONS['compaction'].values())}")
    merge(path, args.mu, args.n, which[0], row, section="compaction")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--n", type=int, required=True)
    ap.add_argument("--mu", type=float, required=True)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--out", default="studies/results/big_jam")
    ap.add_argument("--packings", default="studies/packings", help="where the finished packing goes")
    ap.add_argument("--status", action="store_true", help="print CPU so far and steps; no work")
    ap.add_argument("--bench", type=Path, default=None,
                    help="with --status: record the jam's row in this bench.json (section compaction)")
    args = ap.parse_args(argv)
    out, name = Path(args.out), name_of(args.scene, args.n, args.mu, args.seed)
    if args.status:
        cpu, processes = cpu_so_far(out / f"{name}.cpu.jsonl")
        steps = checkpoint_steps(out / "packings" / f"{name}.checkpoint.h5")
        print(f"{name}: {cpu:.0f} CPU s over {processes} processes, checkpoint at {steps} steps")
        if args.bench:
            record_bench(args.bench, bench_row(out, name, args), args)
        return
    out.mkdir(parents=True, exist_ok=True)
    try:
        jam(args, out, name)
    except KeyboardInterrupt as exc:     # Ctrl-C / kill -INT: one line, as the CLI says it
        print("interrupted" + (f"; {exc}" if str(exc) else ""), file=sys.stderr)
        raise SystemExit(130) from None


if __name__ == "__main__":
    main()
