"""P(f) of the uniform force ensemble against the jammed network's (issue 47 item 11).

Usage::

    python studies/force_distribution.py [--out studies/out/force_distribution]
        [--packings studies/packings] [--target-ess 400] [--replot]

For the paper packing (``inputs/paper.toml``, seed 1) at mu = 0.01, 0.1 and 1
(``PACKINGS/paper_mu{mu}.h5``; the mu = 1 packing is jammed here when missing, with
``forcespace pack paper --mu 1``) and its 28 R slice: uniform samples of S by the
billiard walk (4 chains, until bulk and tail ESS >= ``--target-ess`` and R-hat <= 1.05),
P(f) of all sampled contacts over all samples against the jammed network's, f = fn /
<Fn> (the jammed mean normal force of the slice's contacts), eta with its 95 %
interval from the chains (batch jackknife, ``forcespace.measures.eta_interval``) and
the stress and fabric tensors. Writes OUT/force_distribution.png/.pdf and
OUT/force_distribution.json (every number of the figure and the note).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

MUS = (0.01, 0.1, 1.0)
SLICE = 28.0


def _packing(packings: Path, mu: float):
    import forcespace as fs
    path = packings / f"paper_mu{mu:g}.h5"
    if not path.exists():
        subprocess.run([sys.executable, "-m", "forcespace.cli", "pack", "paper", "--mu", f"{mu:g}",
                        "-o", str(path), "--quiet"], check=True)
    return path, fs.read_packing(path)


def _one(packings: Path, mu: float, target_ess: float) -> dict:
    import forcespace as fs
    path, p = _packing(packings, mu)
    prob = fs.slice_problem(p, SLICE)
    t0 = time.process_time()
    run = fs.BilliardWalk(n=200_000, seed=1, target_ess=target_ess).compute(prob)
    ens = run.ensemble
    pf = ens.force_distribution(edges=np.arange(0.0, 4.05, 0.2))
    net = ens.network_measures(p, prob)
    return {"mu": mu, "packing": path.name, "slice_height_R": SLICE, "dim_S": run.dim,
            "n_contacts": int(prob.n_contacts), "n_samples": ens.n_samples,
            "converged": run.success, "message": run.message,
            "cpu_s": time.process_time() - t0, "eta_interval": ens.eta_interval(),
            "force_distribution": pf, "stress": net["stress"], "fabric": net["fabric"],
            "fraction_beyond_4": {
                "ensemble": float((ens.forces[:, :, 0] > 4 * ens.force_scale).mean()),
                "jammed": float((ens.x_jammed[0::2] > 4 * ens.force_scale).mean())}}


def _figure(rows, out: Path):
    from matplotlib.figure import Figure
    from forcespace.extend import save_figure

    fig = Figure(figsize=(11.0, 3.8))
    axes = fig.subplots(1, len(rows), sharey=True)
    for ax, r in zip(axes, rows):
        pf, ci = r["force_distribution"], r["eta_interval"]
        e = np.asarray(pf["edges"])
        ax.stairs(pf["jammed"], e, color="k", lw=2.4, label="jammed network")
        ax.stairs(pf["ensemble"], e, color="C3", lw=1.2, fill=False,
                  label="uniform ensemble of $S$ (billiard)")
        ax.set_yscale("log")
        ax.set_xlabel(r"$f = f_n / \langle F_n\rangle$")
        ax.set_title(rf"$\mu = {r['mu']:g}$: dim $S$ = {r['dim_S']}, {r['n_contacts']} contacts, "
                     f"{r['n_samples']} samples\n"
                     rf"$\eta = {ci['eta']:.4f}$, 95 % interval [{ci['low']:.4f}, "
                     f"{ci['high']:.4f}]", fontsize=9)
        if r["dim_S"] == 0:
            ax.text(0.97, 0.80, "$S$ is one point:\nthe ensemble is\nthe jammed network",
                    transform=ax.transAxes, ha="right", va="top", fontsize=7.5)
    axes[0].set_ylabel(r"$P(f)$ [1 per unit $f$]")
    axes[-1].legend(loc="upper right", fontsize=7.5, frameon=False)
    fig.suptitle("Force distribution of the paper packing's 28 R slice (seed 1): uniform "
                 "ensemble of S against the jammed network", fontsize=10)
    fig.tight_layout()
    save_figure(fig, out / "force_distribution.png", dpi=150)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("studies/out/force_distribution"))
    ap.add_argument("--packings", type=Path, default=Path("studies/packings"))
    ap.add_argument("--target-ess", type=float, default=400.0)
    ap.add_argument("--replot", action="store_true",
                    help="draw the figure again from OUT/force_distribution.json (no sampling)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    table = args.out / "force_distribution.json"
    if args.replot:
        rows = json.loads(table.read_text())
    else:
        rows = [_one(args.packings, mu, args.target_ess) for mu in MUS]
        table.write_text(json.dumps(rows, indent=1,
                                    default=lambda v: np.asarray(v).tolist()))
    _figure(rows, args.out)
    for r in rows:
        ci = r["eta_interval"]
        print(f"mu = {r['mu']:g}: dim S {r['dim_S']}, {r['n_samples']} samples "
              f"({r['message']}), eta {ci['eta']:.4f} [{ci['low']:.4f}, {ci['high']:.4f}]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
