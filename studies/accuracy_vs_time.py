"""What accuracy costs in wall time: our static solve, LIGGGHTS and pymunk (``make bench``).

On the paper's 200-disk packings (studies/packings/paper_mu0.1.h5, paper_mu0.h5) the
accuracy of a force network is its distance to the plate S of the packing
(``forcespace.plate_problem``; exact projection ``forcespace.extend.distance_to_S``,
rms per contact in units of the rigid <Fn>; soft contacts the rigid packing lacks are
dropped, see ``forcespace_adapters.distance``). Against wall time [s]:

1. our static solve (``forcespace.extend.static_solve``: NLGS on the frozen jammed
   configuration, cold start from zero forces), one solve per sweep cap, with its
   equilibrium residual beside the distance;
2. LIGGGHTS, one run per stiffness kn = K <Fn>/R (kt = 2/7 kn, stop at a residual of
   1e-6 <Fn> or max_steps), its state dumped every N steps (``snapshot_every``); time =
   wall time of the liggghts process up to the dump (``read_snapshots``);
3. pymunk, one run per (solver iterations, dt), the state taken at log-spaced steps;
   time = scene set-up, ramp and stepping (the per-step load assignment in Python
   included, taking the snapshots excluded), no convergence checks.

(NLGS against pymunk per contact-iteration moved to ``python -m
forcespace_studies.bench_engine``: CPU time, the old code beside, interleaved.)

Outputs: OUT/accuracy_vs_time.{png,pdf,md}, key "accuracy_vs_time" of OUT/bench.json
(read-modify-write). The full run also copies figure and table to
studies/accuracy_vs_time/. ``--quick``: mu = 0.1 packing, short ladders (< 1 min),
results under OUT/quick/. BLAS is kept to one thread (before numpy loads): on a
loaded machine the projection's SVDs ran ~10x slower with threads.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from forcespace import read_packing  # noqa: E402
from forcespace.extend import write_json  # noqa: E402

HERE = Path(__file__).resolve().parent
OUT = HERE / "out"
KEEP = HERE / "accuracy_vs_time"
LEVELS = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-8)   # accuracies of the table [<Fn>]

FULL = {"packings": ("paper_mu0.1", "paper_mu0"),
        "static_caps": (10, 30, 100, 300, 1000, 3000, 10_000, 30_000, 100_000, 300_000,
                        1_000_000),
        "liggghts": ((1e4, 1_500_000), (1e5, 1_500_000), (1e6, 1_500_000), (1e7, 1_500_000)),
        "pymunk": [(it, dt) for dt in (0.01, 0.003) for it in (5, 10, 30, 100)],
        "pymunk_steps": 5000, "points": 12, "tiles": (1, 25), "repeats": 7}
QUICK = {"packings": ("paper_mu0.1",), "static_caps": (30, 300, 3000, 30_000, 300_000),
         "liggghts": ((1e4, 100_000),), "pymunk": [(5, 0.01), (30, 0.01)],
         "pymunk_steps": 1000, "points": 4, "tiles": (1, 5), "repeats": 3}


def log(msg: str) -> None:
    print(msg, flush=True)


def accuracy(p, S, soft) -> dict:
    """Distance of ``soft``'s forces to S [<Fn>, rms per contact] and its contact mismatch
    (``forcespace_adapters.distance.compare``; NaN where the projection fails)."""
    from forcespace.errors import NumericalError
    from forcespace_adapters.distance import compare
    try:
        c = compare(p, soft, S)
    except NumericalError:
        return {"distance": math.nan, "extra_contacts": -1, "lost_contacts": -1}
    return {"distance": c["relative_distance"], "extra_contacts": c["unmatched_contacts"],
            "lost_contacts": c["lost_contacts"]}


def _log_pick(n: int, k: int) -> np.ndarray:
    """About ``k`` log-spaced indices of 0..n-1, the last one included."""
    return np.unique(np.round(np.geomspace(1, n, k)).astype(int) - 1) if n else np.zeros(0, int)


def static_curve(p, S, caps, seed=1) -> list:
    """Cold-start static solves on the packing's configuration, one per sweep cap
    (tolerance 1e-13, stop at the first cap the solve converges under). Rows: cap,
    sweeps, seconds [s], residual (relative equilibrium residual), distance [<Fn>]."""
    from forcespace.extend import make_bodies, parse_scene_text, Setup, static_solve
    scene = parse_scene_text(p.scene_text)

    def solve(cap):
        s = scene.with_overrides(**{"jamming.static_max_sweeps": int(cap),
                                    "jamming.static_tolerance": 1e-13})
        setup = Setup.from_scene(s)
        bodies = make_bodies(setup, p.x, p.y, p.r, p.y_top, density=p.density)
        t0 = time.perf_counter()
        q, st = static_solve(setup, bodies, seed, show_progress=False)
        return time.perf_counter() - t0, q, st

    solve(10)                                  # compile
    rows = []
    for cap in caps:
        sec, q, st = solve(cap)
        if sec < 0.05:                         # short solves: best of 3 (deterministic)
            sec = min(sec, *(solve(cap)[0] for _ in range(2)))
        rows.append({"cap": int(cap), "sweeps": int(st["static_sweeps"]), "seconds": sec,
                     "residual": float(st["static_residual"]), **accuracy(p, S, q)})
        log(f"    static cap {cap:>8}: {sec:8.3f} s  residual {st['static_residual']:.2e}  "
            f"distance {rows[-1]['distance']:.2e}")
        if st["static_sweeps"] < cap:
            break
    return rows


def liggghts_curve(p, S, K, work, max_steps, points, reuse=False) -> dict:
    """One LIGGGHTS run at kn = K <Fn>/R dumping every ~max_steps/150 steps; rows at
    ``points`` log-spaced dumps plus the final state (velocities zeroed). ``reuse``: read
    the finished run with these options in the run folder instead of running it."""
    from dataclasses import asdict

    from forcespace_adapters import liggghts as L
    from forcespace_adapters.problem import soft_problem
    prob = soft_problem(p, top="plate")
    every = max(1000, int(round(max_steps / 150, -3)))
    d = Path(work) / f"lig_K{K:g}"
    opt = L.LiggghtsOptions(kn=K, tolerance=1e-6, max_steps=max_steps,
                            snapshot_every=every)
    if reuse:
        if json.loads((d / "deck.json").read_text())["options"] != asdict(opt):
            raise ValueError(f"{d}: run with other options than K={K:g}, {max_steps} steps")
        status = json.loads((d / "status.json").read_text())
    else:
        L.write_deck(prob, d, opt)
        status = L.run_deck(d)
    snaps = L.read_snapshots(d, p)
    rows = [{"step": snaps[k][0], "seconds": snaps[k][1], **accuracy(p, S, snaps[k][2])}
            for k in _log_pick(len(snaps), points)]
    soft, _ = L.read_result(d, p)
    rows.append({"step": status["steps"], "seconds": status["wall_time_s"], "final": True,
                 **accuracy(p, S, soft)})
    log(f"    liggghts K={K:g}: {status['steps']} steps, {status['wall_time_s']:.1f} s, "
        f"converged {status['converged']}, distance {rows[-1]['distance']:.2e} "
        f"({rows[-1]['extra_contacts']} extra contacts)")
    return {"K": K, "converged": bool(status["converged"]), "steps": status["steps"],
            "wall_s": status["wall_time_s"], "snapshot_every": every, "points": rows}


def pymunk_curve(p, S, iterations, dt, max_steps, points) -> dict:
    """One pymunk run (load-controlled plate) to ``max_steps``, rows at log-spaced steps."""
    from forcespace_adapters.problem import soft_problem
    from forcespace_adapters.pymunk_sim import PymunkOptions, PymunkScene
    t0 = time.perf_counter()
    sc = PymunkScene(soft_problem(p, top="plate"),
                     PymunkOptions(iterations=iterations, dt=dt, max_steps=max_steps))
    sc.ramp()
    spent = time.perf_counter() - t0
    rows = []
    for target in np.unique(np.geomspace(sc.steps, max_steps, points).astype(int)):
        t0 = time.perf_counter()
        sc.step(int(target) - sc.steps)
        spent += time.perf_counter() - t0
        rows.append({"step": sc.steps, "seconds": spent, **accuracy(p, S, sc.soft_packing())})
    log(f"    pymunk {iterations:3d} it, dt {dt:g}: {sc.steps} steps, {spent:.2f} s, "
        f"distance {rows[-1]['distance']:.2e} ({rows[-1]['extra_contacts']} extra contacts)")
    return {"iterations": iterations, "dt": dt, "points": rows}


def _within(row, level) -> bool:
    return row["distance"] is not None and row["distance"] <= level


def cost_table(curves: dict, levels=LEVELS) -> dict:
    """{code: {level: [seconds, setting] or None}}: least wall time at which some setting
    of the code first came within ``level`` of S."""
    out = {}
    for code, runs in curves.items():
        row = {}
        for lev in levels:
            hits = [(next(r["seconds"] for r in pts if _within(r, lev)), label)
                    for label, pts in runs if any(_within(r, lev) for r in pts)]
            row[f"{lev:g}"] = list(min(hits)) if hits else None
        out[code] = row
    return out


def packing_cost(st: dict) -> dict:
    """:func:`cost_table` of one packing's results (static solves, LIGGGHTS, pymunk)."""
    return cost_table({
        "static solve": [(f"cap {r['cap']}", [r]) for r in st["static"]],
        "LIGGGHTS": [(f"K={c['K']:g}", c["points"]) for c in st["liggghts"]],
        "pymunk": [(f"{c['iterations']} it, dt={c['dt']:g}", c["points"]) for c in st["pymunk"]]})


def _load(name):
    """(packing, its plate S) of studies/packings/NAME.h5."""
    from forcespace import plate_problem
    p = read_packing(HERE / "packings" / f"{name}.h5")
    return p, plate_problem(p)


def accuracy_study(name, cfg, work) -> dict:
    """The three codes' accuracy-vs-time curves and cost table on one packing."""
    p, S = _load(name)
    log(f"  {name}: {p.n_disks} disks, {S.n_contacts} contacts of S, mu = {p.mu:g}")
    st = {"mu": p.mu, "n_disks": p.n_disks, "n_contacts": S.n_contacts,
          "static": static_curve(p, S, cfg["static_caps"]),
          "liggghts": [liggghts_curve(p, S, K, Path(work) / name, steps, cfg["points"])
                       for K, steps in cfg["liggghts"]],
          "pymunk": [pymunk_curve(p, S, it, dt, cfg["pymunk_steps"], cfg["points"])
                     for it, dt in cfg["pymunk"]],
          "loadavg": os.getloadavg()}
    st["cost"] = packing_cost(st)
    return st


# ----------------------------------------------------------------------------------------
def _json_ready(v):
    if isinstance(v, dict):
        return {str(k): _json_ready(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_ready(x) for x in v]
    if isinstance(v, (np.integer, np.floating)):
        v = v.item()
    return None if isinstance(v, float) and not math.isfinite(v) else v


def merge_json(path: Path, key: str, value) -> None:
    """Set ``key`` of the JSON object in ``path`` (other keys kept; atomic replace)."""
    data = json.loads(path.read_text()) if path.is_file() else {}
    data[key] = _json_ready(value)
    write_json(path, data, indent=2)      # atomic; NaN as null (strict JSON)


def _num(v, fmt: str) -> str:
    return "-" if v is None or not math.isfinite(v) else format(v, fmt)


def table_md(res: dict) -> str:
    """The cost table per packing and the per-contact-iteration ratios (markdown)."""
    lines = ["# Accuracy vs wall time (studies/accuracy_vs_time.py)", "",
             "Least wall time [s] at which a code's state came within X of S (distance "
             "rms per contact in units of <Fn>), over the settings tried (setting in "
             "brackets); '-' = never reached (best distance reached in brackets).", ""]
    for name, st in res["packings"].items():
        levels = list(next(iter(st["cost"].values())))
        lines += [f"## {name} (mu = {st['mu']:g}, {st['n_contacts']} contacts of S; load "
                  f"average {st['loadavg'][0]:.1f})", "",
                  "| code | " + " | ".join(f"X = {lev}" for lev in levels) + " |",
                  "|---|" + "---|" * len(levels)]
        best = {"static solve": [r["distance"] for r in st["static"]],
                "LIGGGHTS": [r["distance"] for c in st["liggghts"] for r in c["points"]],
                "pymunk": [r["distance"] for c in st["pymunk"] for r in c["points"]]}
        best = {k: min((x for x in v if x is not None), default=math.nan)
                for k, v in best.items()}
        for code, row in st["cost"].items():
            cells = [f"{v[0]:.3g} s ({v[1]})" if v else f"- ({best[code]:.1e})"
                     for v in row.values()]
            lines.append(f"| {code} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines) + "\n"


def _curve(ax, pts, style, color, label):
    """One accuracy-vs-time curve; hollow markers where the state has contacts S lacks."""
    pts = [r for r in pts if r["distance"] is not None and math.isfinite(r["distance"])]
    t, d = [r["seconds"] for r in pts], [r["distance"] for r in pts]
    ax.loglog(t, d, style[1:], color=color, label=label)
    for extra in (False, True):
        sel = [k for k, r in enumerate(pts) if (r.get("extra_contacts", 0) > 0) == extra]
        ax.loglog([t[k] for k in sel], [d[k] for k in sel], style[0], ms=4, color=color,
                  mfc="none" if extra else color)


def plot(res: dict, path: Path) -> None:
    """Distance to S vs wall time, one panel per packing, all three codes."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from forcespace.extend import save_figure
    names = list(res["packings"])
    fig, axes = plt.subplots(1, len(names), figsize=(6.2 * len(names), 4.8), squeeze=False)
    for ax, name in zip(axes[0], names):
        st = res["packings"][name]
        h = st["static"]
        _curve(ax, h, "o-", "k", "static solve (NLGS)")
        ax.loglog([r["seconds"] for r in h], [r["residual"] for r in h], "k:", lw=1,
                  label="static solve: max eq. residual")
        blues = plt.cm.Blues(np.linspace(0.45, 1.0, max(1, len(st["liggghts"]))))
        for c, col in zip(st["liggghts"], blues):
            _curve(ax, c["points"], "s-", col, f"LIGGGHTS K={c['K']:g}")
        its = sorted({c["iterations"] for c in st["pymunk"]})
        reds = dict(zip(its, plt.cm.Oranges(np.linspace(0.45, 1.0, len(its)))))
        dts = sorted({c["dt"] for c in st["pymunk"]}, reverse=True)
        for c in st["pymunk"]:
            _curve(ax, c["points"], "^" + ("-", "--", "-.")[dts.index(c["dt"]) % 3],
                   reds[c["iterations"]], f"pymunk {c['iterations']} it, dt={c['dt']:g}")
        ax.set_xlabel("wall time [s]")
        ax.set_ylabel("distance to S [<Fn>, rms per contact]\n(hollow: extra soft contacts)")
        ax.set_title(f"{name}: mu = {st['mu']:g}, {st['n_disks']} disks")
        ax.grid(True, which="major", alpha=0.3)
    axes[0][-1].legend(fontsize=6, ncol=2, loc="lower left")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def _write_outputs(res: dict, out: Path, keep: bool) -> None:
    """Table and figure into ``out``; with ``keep`` copied to studies/accuracy_vs_time/."""
    (out / "accuracy_vs_time.md").write_text(table_md(res))
    plot(res, out / "accuracy_vs_time.png")
    if keep:
        KEEP.mkdir(exist_ok=True)
        for f in ("accuracy_vs_time.png", "accuracy_vs_time.pdf", "accuracy_vs_time.md"):
            shutil.copyfile(out / f, KEEP / f)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short ladders, mu = 0.1 only (< 1 min)")
    ap.add_argument("--replot", action="store_true",
                    help="only redraw figure and table from OUT/bench.json")
    ap.add_argument("--reread-liggghts", action="store_true",
                    help="only measure the LIGGGHTS curves of OUT/bench.json again from their "
                    "finished runs in OUT/accuracy_vs_time_work (after a reader change; wall "
                    "times stay those recorded), keep the rest")
    ap.add_argument("--out", type=Path, help="output folder (default studies/out, "
                    "studies/out/quick with --quick)")
    args = ap.parse_args(argv)
    cfg = QUICK if args.quick else FULL
    out = args.out or (OUT / "quick" if args.quick else OUT)
    out.mkdir(parents=True, exist_ok=True)
    keep = not args.quick and args.out is None
    if args.replot or args.reread_liggghts:
        res = json.loads((out / "bench.json").read_text())["accuracy_vs_time"]
        if args.reread_liggghts:
            for name, st in res["packings"].items():
                p, S = _load(name)
                st["liggghts"] = [liggghts_curve(p, S, K, out / "accuracy_vs_time_work" / name,
                                                 steps, cfg["points"], reuse=True)
                                  for K, steps in cfg["liggghts"]]
                st["cost"] = packing_cost(st)
            res["liggghts_reread"] = True
            merge_json(out / "bench.json", "accuracy_vs_time", res)
        _write_outputs(_json_ready(res), out, keep=keep and args.reread_liggghts)
        return 0
    if shutil.which("liggghts") is None:
        log("LIGGGHTS binary missing: its curves are skipped (make liggghts)")
        cfg = dict(cfg, liggghts=())
    res = {"quick": args.quick, "repeats": cfg["repeats"], "loadavg_start": os.getloadavg(),
           "packings": {}}
    t0 = time.perf_counter()
    log("accuracy vs wall time ...")
    for name in cfg["packings"]:
        res["packings"][name] = accuracy_study(name, cfg, out / "accuracy_vs_time_work")
    res["loadavg_end"] = os.getloadavg()
    res["wall_s"] = time.perf_counter() - t0
    merge_json(out / "bench.json", "accuracy_vs_time", res)
    _write_outputs(_json_ready(res), out, keep=keep)
    log(f"wrote {out / 'accuracy_vs_time.png'} (+ .pdf, .md) and key 'accuracy_vs_time' of "
        f"{out / 'bench.json'} in {res['wall_s']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
