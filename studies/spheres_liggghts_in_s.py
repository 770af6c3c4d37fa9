"""LIGGGHTS in S of spheres: the 3-D ladder's soft networks against the conic S (issue 44).

Usage::

    python studies/spheres_liggghts_in_s.py [--ladders studies/results/liggghts_ladder3d
        studies/results/liggghts_ladder3d_n100] [--rerun] [--out studies/results/spheres_liggghts_in_s]

Input: the 3-D LIGGGHTS stiffness ladders of issue 43 (``studies/liggghts_ladder.py``:
sphere packings of the engine, each run natively in 3-D by LIGGGHTS 3.8 at K = kn R/<Fn>
from 1e3 to 1e7, kt = 2/7 kn, the load-controlled top plate). Every run of a ladder (its
``runs/*.json``) is measured again here from its soft network (the LIGGGHTS dumps in
``work/PACKING__KK``): the soft forces mapped onto the rigid packing's contacts
(``forcespace_adapters``: matched contacts, forces in the rigid contact frames, a lost
contact carries 0) give a network x of the rigid packing's plate problem, whose S has the
circular Coulomb cones; its distance to S and the nearest point of S are the conic
analysis's (``fs.ForceSpace(...).distance``: the SOCP of ``nearest_admissible``). A run whose work directory is gone is run again by LIGGGHTS with
``--rerun`` (the same deck: ``liggghts_ladder.run_one``), else it keeps the ladder's stored
distance (same measure, earlier code; marked ``stored``).

Quantities, per (packing, K): relative distance = |x - nearest| / (<Fn> sqrt(N_c)), the rms
per contact in <Fn> (<Fn>: the rigid packing's mean normal force); the soft code's own
accuracy: its force-balance residual (largest per-sphere force and torque imbalance of
the soft network, velocities zeroed, / <Fn>: ``static_residual``) and
max(max overlap / r_min, residual) (``forcespace_adapters.verdict``).

Rules (fixed before this run; the ladders' numbers were already in their READMEs, see
the study's README):

* Entry: a run enters when LIGGGHTS met its own stop test (``converged``) and its soft
  network is one of the rigid packing (``compare`` accepted it: no sphere moved by half a
  radius). A packing enters rule 1 with at least 3 entered rungs, rule 2 when its run at
  the ladder's stiffest rung (K = 1e7) entered.
* Rule 1, "the distance to S falls as the stiffness grows": within every entered packing,
  Kendall's S statistic between K and the relative distance (sum of sign((K_j - K_i)
  (d_j - d_i)) over its pairs of rungs), summed over the packings; one-sided p of a fall
  by permuting the distances within each packing (20 000 permutations, seed 0).
  Supported when at least 3 packings enter and p < 0.01; not supported when the sum is
  >= 0; else not decidable.
* Rule 2, "inside S at the soft code's accuracy at the stiffest rung": at K = 1e7 the
  relative distance is at most 10 x the soft code's accuracy (the adapters' verdict, fixed
  in issue 25 for the 2-D ladder). Supported when at least 3 packings enter and every one
  is inside; not supported when at least half are outside; else not decidable. The ratio
  distance / residual is reported beside it (not a rule).

Writes OUT/rows.jsonl (one row per run), OUT/table.md, OUT/distance_vs_stiffness.png
(+ .pdf), OUT/verdicts.json and OUT/REPORT.md (``forcespace_studies.report``).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

LADDERS = ("studies/results/liggghts_ladder3d", "studies/results/liggghts_ladder3d_n100")
STIFFEST = 1e7          # [<Fn>/R] the ladders' stiffest rung
INSIDE_FACTOR = 10.0    # distance <= this x accuracy: inside S (forcespace_adapters.verdict)
MIN_RUNGS, MIN_PACKINGS = 3, 3
LEVEL, N_PERM = 0.01, 20_000


def measure(ladder: Path, rec: dict, rerun: bool) -> dict:
    """One run measured again from its soft network (or re-run, or its stored numbers)."""
    import forcespace as fs
    from forcespace.errors import InputError
    from forcespace_adapters import liggghts3d as L3, make_problem, verdict
    from forcespace_adapters.distance import soft_vector

    name, K = rec["packing"], float(rec["K"])
    packing = ladder / "packings" / f"{name}.h5"
    work = ladder / "work" / f"{name}__K{K:g}"
    row = {"ladder": ladder.name, "packing": name, "mu": rec["mu"], "seed": rec["seed"],
           "K": K, "steps": rec["steps"], "converged": bool(rec["converged"]),
           "static_residual": rec["static_residual"], "tolerance_used": rec["tolerance_used"],
           "stored_relative_distance": rec["relative_distance"]}
    source = "measured"
    if not (work / "status.json").is_file() and rerun:
        sys.path.insert(0, str(Path(__file__).parent))
        from liggghts_ladder import run_one
        new = run_one(str(packing), K, rec["tolerance"], str(work))
        row.update(steps=new["steps"], converged=bool(new["converged"]),
                   static_residual=new["static_residual"])
        source = "re-run"
    if not (work / "status.json").is_file():
        inside = rec["inside_S"]
        return dict(row, source="stored", relative_distance=rec["relative_distance"],
                    comparable=rec["relative_distance"] is not None,
                    max_overlap=rec["max_overlap"], inside_S=inside,
                    accuracy=None, lost=rec.get("lost_contacts"),
                    unmatched=rec.get("unmatched_contacts"))
    rigid = fs.read_packing(packing)
    soft, info = L3.read_result3(work, rigid)
    prob = make_problem(rigid, "plate")
    try:
        prob, x, match = soft_vector(rigid, soft, prob)
    except InputError as exc:       # rearranged: not a soft network of this packing
        return dict(row, source=source, comparable=False, relative_distance=None,
                    inside_S=False, accuracy=None, why=str(exc))
    S = analysis(packing, prob)
    d = S.distance(x)
    v = verdict(d.relative, soft)
    summary = match.summary(prob.force_scale)
    return dict(row, source=source,
                comparable=True, relative_distance=d.relative,
                absolute_distance_F0=d.absolute, force_scale_F0=prob.force_scale,
                nearest_violation=d.max_violation, n_contacts=prob.n_contacts, dim_S=S.dim,
                max_overlap=soft.max_overlap(), accuracy=v["accuracy"],
                residual_scale=v["residual_scale"], overlap_scale=v["overlap_scale"],
                inside_S=bool(v["inside_S"]) and row["converged"],
                lost=summary["lost_contacts"], unmatched=summary["unmatched_contacts"])


_ANALYSES = {}


def analysis(packing: Path, prob):
    """S of a rigid packing's plate problem, analysed once (the conic ForceSpace)."""
    import forcespace as fs
    if packing not in _ANALYSES:
        _ANALYSES[packing] = fs.ForceSpace().compute(prob)
    return _ANALYSES[packing]


def stratified_kendall(groups, n_perm: int = N_PERM, seed: int = 0) -> dict:
    """{S, p_fall, packings, pairs}: Kendall's S between K and distance summed over the
    groups [(K (k,), d (k,)), ...], one-sided p of a fall (S as low or lower) with the
    distances permuted within each group."""
    def s_stat(K, d):
        return float(np.sign(np.subtract.outer(K, K) * np.subtract.outer(d, d))[
            np.triu_indices(len(K), 1)].sum())
    S = sum(s_stat(K, d) for K, d in groups)
    rng = np.random.default_rng(seed)
    null = np.zeros(n_perm)
    for K, d in groups:
        null += [s_stat(K, rng.permutation(d)) for _ in range(n_perm)]
    return {"S": S, "p_fall": float((1 + np.sum(null <= S)) / (n_perm + 1)),
            "packings": len(groups), "pairs": int(sum(len(K) * (len(K) - 1) // 2
                                                      for K, _ in groups))}


def judge(rows) -> tuple[list, dict]:
    """The two verdicts (forcespace_studies.report.Verdict) and their numbers."""
    from forcespace_studies.report import Verdict

    entered = [r for r in rows if r["converged"] and r["comparable"]]
    by_packing = {}
    for r in entered:
        by_packing.setdefault((r["ladder"], r["packing"]), []).append(r)
    groups = {k: v for k, v in by_packing.items() if len(v) >= MIN_RUNGS}
    t = stratified_kendall([(np.array([r["K"] for r in v]),
                             np.array([r["relative_distance"] for r in v]))
                            for v in groups.values()])
    v1 = ("supported" if len(groups) >= MIN_PACKINGS and t["p_fall"] < LEVEL else
          "not supported" if t["S"] >= 0 else "not decidable")
    top = [r for r in entered if r["K"] == STIFFEST]
    inside = [r for r in top if r["inside_S"]]
    v2 = ("supported" if len(top) >= MIN_PACKINGS and len(inside) == len(top) else
          "not supported" if top and len(top) - len(inside) >= len(top) / 2 else
          "not decidable")
    ratios = [r["relative_distance"] / r["static_residual"] for r in top]
    tops = "; ".join(f"{label(r)}: {r['relative_distance']:.2g} <Fn> (accuracy "
                     f"{cell(r.get('accuracy'), '{:.2g}')}, residual "
                     f"{r['static_residual']:.2g})" for r in top)
    verdicts = [
        Verdict("spheres_liggghts_in_s", "the 3-D LIGGGHTS ladder's soft networks approach S "
                "of spheres (circular Coulomb cones) as the stiffness grows",
                f"Kendall S = {t['S']:.0f} over {t['pairs']} pairs of rungs in {t['packings']} "
                f"packings (one-sided permutation p = {t['p_fall']:.2g} for a fall); "
                f"relative distance {fmt_range(rows, 1e3)} at K = 1e3, "
                f"{fmt_range(rows, STIFFEST)} at K = 1e7",
                v1, kind="ours",
                rule=f"within-packing Kendall S between K and the rms distance per contact, "
                     f"summed over packings with >= {MIN_RUNGS} converged, comparable rungs; "
                     f"permutation p < {LEVEL} and >= {MIN_PACKINGS} packings"),
        Verdict("spheres_liggghts_in_s", "at the stiffest rung (K = kn R/<Fn> = 1e7) every "
                "converged soft network is inside S of spheres at the soft code's accuracy",
                f"{len(inside)} of {len(top)} inside ({tops}); distance / residual "
                f"{min(ratios, default=float('nan')):.2g}-{max(ratios, default=float('nan')):.2g}",
                v2, kind="ours",
                rule=f"relative distance <= {INSIDE_FACTOR:g} x max(max overlap / r_min, "
                     f"force-balance residual), the adapters' verdict (issue 25); every one "
                     f"of >= {MIN_PACKINGS} packings"),
    ]
    again = [abs(r["relative_distance"] - r["stored_relative_distance"])
             / r["stored_relative_distance"] for r in rows if r["source"] != "stored"
             and r["relative_distance"] and r["stored_relative_distance"]]
    numbers = {"trend": t, "stiffest": {"entered": len(top), "inside": len(inside),
                                        "distance_over_residual": ratios},
               "measured_again": {"runs": len(again),
                                  "largest_relative_change_from_stored": max(again, default=0)},
               "packings_in_trend": [f"{a}/{b}" for a, b in groups]}
    return verdicts, numbers


def label(r) -> str:
    n = "60" if r["ladder"] == "liggghts_ladder3d" else "100"
    return f"n = {n}, mu = {r['mu']:g}, seed {r['seed']}"


def fmt_range(rows, K) -> str:
    d = [r["relative_distance"] for r in rows if r["K"] == K and r["converged"]
         and r["comparable"]]
    return f"{min(d):.2g}-{max(d):.2g} <Fn>" if d else "none converged"


def cell(v, fmt="{:.1e}") -> str:
    return "—" if v is None else fmt.format(v)


def table(rows) -> str:
    lines = ["| packing | K = kn R/⟨Fn⟩ | converged | comparable | source | lost / unmatched "
             "contacts | relative distance to S [⟨Fn⟩] | soft residual [⟨Fn⟩] | max overlap "
             "[R] | accuracy [⟨Fn⟩] | distance / residual | inside S at its accuracy |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        d, res = r["relative_distance"], r["static_residual"]
        lines.append(
            f"| {label(r)} | {r['K']:.0e} | {'yes' if r['converged'] else '**no**'} | "
            f"{'yes' if r['comparable'] else '**no** (rearranged)'} | {r['source']} | "
            f"{r.get('lost', '—')} / {r.get('unmatched', '—')} | "
            f"{'—' if d is None else f'{d:.2e}'} | {res:.1e} | "
            f"{cell(r.get('max_overlap'))} | {cell(r.get('accuracy'))} | "
            f"{'—' if d is None else f'{d / res:.2g}'} | {'yes' if r['inside_S'] else 'no'} |")
    return "\n".join(lines) + "\n"


def figure(rows, path: Path) -> None:
    """Log-log: relative distance to S against K per packing (filled: converged and
    comparable; open: not converged), and the distance over the soft code's residual."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from forcespace.extend import save_figure

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.4))
    keys = sorted({(r["ladder"], r["packing"]) for r in rows})
    cmap = plt.get_cmap("tab10")
    for i, k in enumerate(keys):
        rr = sorted([r for r in rows if (r["ladder"], r["packing"]) == k
                     and r["relative_distance"] is not None], key=lambda r: r["K"])
        if not rr:
            continue
        K = np.array([r["K"] for r in rr])
        d = np.array([r["relative_distance"] for r in rr])
        ok = np.array([r["converged"] for r in rr])
        res = np.array([r["static_residual"] for r in rr])
        mark = "o" if rr[0]["ladder"] == "liggghts_ladder3d" else "s"
        for a, y in ((ax, d), (bx, d / res)):
            a.plot(K, y, "-", color=cmap(i % 10), lw=1, alpha=0.7)
            a.plot(K[ok], y[ok], mark, color=cmap(i % 10),
                   label=label(rr[0]) if a is ax else None)
            a.plot(K[~ok], y[~ok], mark, mfc="none", color=cmap(i % 10))
    Kl = np.array([1e3, 1e7])
    ax.plot(Kl, 1e-1 * (Kl / 1e3) ** -1, "k:", lw=1, label="∝ 1/K")
    bx.axhline(1.0, color="k", lw=1, ls="--", label="distance = residual")
    bx.axhline(INSIDE_FACTOR, color="grey", lw=1, ls=":", label=f"{INSIDE_FACTOR:g} × residual")
    ax.set(xscale="log", yscale="log", xlabel="stiffness K = kn R / ⟨Fn⟩",
           ylabel="distance to S, rms per contact [⟨Fn⟩]",
           title="LIGGGHTS soft networks to S of spheres (conic)")
    bx.set(xscale="log", yscale="log", xlabel="stiffness K = kn R / ⟨Fn⟩",
           ylabel="distance to S / soft force-balance residual",
           title="against the soft code's own residual")
    ax.legend(fontsize=7, loc="lower left", title="filled: converged; open: not",
              title_fontsize=7)
    bx.legend(fontsize=7, loc="lower left")
    save_figure(fig, path, tight=True)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ladders", nargs="+", default=list(LADDERS))
    ap.add_argument("--rerun", action="store_true",
                    help="run LIGGGHTS again where a run's work directory is gone")
    ap.add_argument("--out", default="studies/results/spheres_liggghts_in_s")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for lad in map(Path, args.ladders):
        for f in sorted((lad / "runs").glob("*.json")):
            rec = json.loads(f.read_text())
            rows.append(measure(lad, rec, args.rerun))
            r = rows[-1]
            print(f"{label(r)} K {r['K']:.0e}: {r['source']}, distance "
                  f"{r['relative_distance']}", flush=True)
    rows.sort(key=lambda r: (r["ladder"], r["seed"], r["K"]))
    (out / "rows.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    (out / "table.md").write_text(table(rows))
    figure(rows, out / "distance_vs_stiffness.png")
    verdicts, numbers = judge(rows)
    write_report(out, rows, verdicts, numbers)
    for v in verdicts:
        print(f"{v.verdict}: {v.ours}")
    return 0


def write_report(out: Path, rows, verdicts, numbers) -> None:
    from forcespace_studies.report import RULES_VERSION, write_section

    text = ("The 3-D LIGGGHTS ladders of issue 43 (`results/liggghts_ladder3d`: 6 packings of "
            "60 spheres, mu = 0.3; `results/liggghts_ladder3d_n100`: 3 packings of 100 spheres, "
            "mu = 0.1; K = kn R/<Fn> = 1e3 to 1e7, kt = 2/7 kn), each soft network mapped onto "
            "its rigid packing's contacts and measured against S of the plate problem with the "
            "circular Coulomb cones (distance and nearest point by the conic analysis's SOCP). "
            "Relative distance: rms per contact in <Fn>; the soft code's residual: its largest "
            "per-sphere force-balance imbalance with velocities zeroed, in <Fn>. Rules in "
            "`studies/spheres_liggghts_in_s.py` (fixed before the run); the table is "
            "`table.md`, one row per run in `rows.jsonl`; the reading in `README.md` (a "
            "network inside S at K = 1e7 sits at 0.8-1.4 x its own residual; one outside "
            "keeps a soft contact across a rigid gap smaller than its overlap).\n\n"
            + table(rows))
    write_section(out, "spheres_liggghts_in_s", "LIGGGHTS in S of spheres: the 3-D "
                  "ladder's soft networks against the conic S", text, verdicts,
                  numbers, ["distance_vs_stiffness.png"],
                  rules_version=RULES_VERSION)


if __name__ == "__main__":
    sys.exit(main())
