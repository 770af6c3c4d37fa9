"""Frictional spheres by the paper's protocol in 3-D: z, packing fraction and rattlers
against mu, judged (issue 43).

The packings are jammed by ``studies/spheres3d.py`` (one row per packing in
``OUT/rows.jsonl``); :func:`summarize` turns the rows into the study's table (mean ± s.e.
over the seeds of each mu), ``OUT/verdicts.json`` and ``OUT/REPORT.md`` (through
:func:`forcespace_studies.report.write_section`), so that ``forcespace study report``
puts its verdicts into ``studies/REPORT.md`` beside the disks' studies.

Readings (fixed before the 500-sphere set beyond its first seed was run):

* "z ≈ 6 as mu → 0" (the premise of the paper's 3-D count, N_c ≈ 3n: frictionless
  spheres are isostatic) — the mean z (non-rattlers, plate contacts counted, as
  ``forcespace info``) at the smallest mu within 0.05 of 6, the 2-D study's reading of
  "z ≈ 4" (fig1) carried to 3-D.
* "z falls towards ≈ 4 at large mu" (ours: the issue's statement; 4 = d + 1, the
  frictional isostatic count) — z decreases with mu over every packing (Kendall's tau,
  one-sided p < 0.01, the trend test of the disks' studies) and the mean at the largest mu
  lies nearer 4 than 6 and not below 4 by more than 0.1: in [3.9, 5). Its 2-D
  counterpart's window ([2.9, 3.35] about 3) is judged at mu = 10; this set ends at mu = 1.
* "every packing static" (ours) — equilibrium residual <= 1e-10 <Fn> and Coulomb excess
  <= 1e-10 <Fn> on every packing.

Fewer than 5 seeds at a mu is said in the number; no verdict needs it.
"""
from __future__ import annotations

import numpy as np

from . import stats
from .report import RULES_VERSION, Verdict, write_section

Z_SMALL_MU = (6.0, 0.05)          # z within 0.05 of 6 at the smallest mu
Z_LARGE_MU = (3.9, 5.0)           # [3.9, 5): nearer 4 than 6, not below 4 - 0.1
STATIC_TOL = 1e-10                # <Fn>, residual and Coulomb excess
TREND_LEVEL = 0.01
SEEDS_WANTED = 5
QUANTITIES = (("z", "z (non-rattlers)", "{:.3f}"), ("packing_fraction", "φ", "{:.4f}"),
              ("rattler_fraction", "rattler fraction", "{:.3f}"))


def packings(rows) -> list[dict]:
    """One row per (mu, seed), the last written winning."""
    return list({(r["mu"], r["seed"]): r for r in rows}.values())


def per_mu(rows) -> dict:
    """{mu: {seeds, n, z, packing_fraction, rattler_fraction: [mean, s.e.], residual,
    coulomb, cpu_median}} over the packings of each mu (s.e. nan below 2 seeds)."""
    out = {}
    for mu in sorted({r["mu"] for r in rows}):
        rs = [r for r in rows if r["mu"] == mu]
        d = {"seeds": len(rs), "n": rs[0]["n"]}
        for key, _, _ in QUANTITIES:
            v = np.array([r[key] for r in rs], float)
            se = v.std(ddof=1) / np.sqrt(v.size) if v.size > 1 else float("nan")
            d[key] = [float(v.mean()), float(se)]
        d["residual"] = float(max(r["residual"] for r in rs))
        d["coulomb"] = float(max(0.0, max(r["coulomb_violation"] for r in rs)))
        d["cpu_median"] = float(np.median([r["cpu_seconds"] for r in rs]))
        out[mu] = d
    return out


def table(rows) -> str:
    """The markdown table: one line per mu, mean ± standard error over the seeds (the value
    alone where one packing has no standard error)."""
    lines = ["| μ | seeds | n | z (non-rattlers) | packing fraction φ | rattler fraction | "
             "largest static residual [⟨Fn⟩] | largest Coulomb excess [⟨Fn⟩] | "
             "CPU s per jam (median) |", "|---|---|---|---|---|---|---|---|---|"]
    for mu, d in per_mu(packings(rows)).items():
        cells = [fmt.format(d[k][0]) + (f" ± {fmt.format(d[k][1])}" if d["seeds"] > 1 else "")
                 for k, _, fmt in QUANTITIES]
        lines.append(f"| {mu:g} | {d['seeds']} | {d['n']} | {' | '.join(cells)} | "
                     f"{d['residual']:.1e} | {d['coulomb']:.1e} | {d['cpu_median']:.0f} |")
    return "\n".join(lines) + "\n"


def _seeds_note(d: dict) -> str:
    n = d["seeds"]
    return "" if n >= SEEDS_WANTED else f" (only {n} seed{'s' if n > 1 else ''})"


def verdicts(rows) -> tuple[list[Verdict], dict]:
    """The study's three verdicts (module docstring) and the numbers behind them."""
    rows = packings(rows)
    pm = per_mu(rows)
    lo, hi = min(pm), max(pm)
    numbers = {"per_mu": {f"{m:g}": d for m, d in pm.items()}}
    z_lo, se_lo = pm[lo]["z"]
    out = [Verdict("spheres3d", "z ≈ 6 as mu → 0 (isostatic frictionless spheres: N_c ≈ 3n, "
                   "the premise of the paper's 3-D count)",
                   f"z = {z_lo:.3f} ± {se_lo:.3f} (s.e.) at mu = {lo:g}, {pm[lo]['seeds']} "
                   f"packings of {pm[lo]['n']} spheres{_seeds_note(pm[lo])}",
                   "reproduced" if abs(z_lo - Z_SMALL_MU[0]) < Z_SMALL_MU[1] else "refuted",
                   rule=f"mean within {Z_SMALL_MU[1]:g} of 6 at the smallest mu (fig1's "
                        "reading of z ≈ 4, in 3-D)")]
    t = stats.trend_test([r["mu"] for r in rows], [r["z"] for r in rows], TREND_LEVEL)
    numbers["z_trend"] = t
    z_hi, se_hi = pm[hi]["z"]
    inside = Z_LARGE_MU[0] <= z_hi < Z_LARGE_MU[1]
    call = ("supported" if t["call"] == "decreases" and inside else
            "not supported" if t["call"] == "increases" or (hi >= 1 and not inside) else
            "not decidable")
    out.append(Verdict(
        "spheres3d", "z falls towards ≈ 4 (frictional isostaticity, d + 1) at large mu",
        f"Kendall tau(mu, z) = {t['tau']:.2f} (one-sided p = {t['p_decreasing']:.1e} for a "
        f"decrease) over {t['points']} packings; z = " + ", ".join(
            f"{d['z'][0]:.3f} ± {d['z'][1]:.3f}" for d in pm.values()) + " at mu = " +
        ", ".join(f"{m:g}" for m in pm) + f"; at mu = {hi:g}: {z_hi:.3f} ± {se_hi:.3f}"
        + _seeds_note(pm[hi]),
        call, kind="ours",
        rule=f"trend test over every packing (one-sided p < {TREND_LEVEL:g}) and the mean at "
             f"the largest mu in [{Z_LARGE_MU[0]:g}, {Z_LARGE_MU[1]:g}): nearer 4 than 6, "
             "not below 4 by more than 0.1"))
    res = max(d["residual"] for d in pm.values())
    cou = max(d["coulomb"] for d in pm.values())
    out.append(Verdict(
        "spheres3d", "every packing is static: equilibrium and Coulomb to 1e-10 <Fn>",
        f"largest residual {res:.1e} <Fn>, largest Coulomb excess {cou:.1e} <Fn> over "
        f"{len(rows)} packings",
        "supported" if res <= STATIC_TOL and cou <= STATIC_TOL else "not supported",
        kind="ours", rule="the largest of every packing's residual and Coulomb excess"))
    return out, numbers


def summarize(rows, out, scene: str) -> dict:
    """Write the table (``OUT/spheres3d.md``), ``OUT/verdicts.json`` and ``OUT/REPORT.md``
    of the rows of one study directory; returns the numbers."""
    from pathlib import Path

    out = Path(out)
    (out / "spheres3d.md").write_text(table(rows))
    vs, numbers = verdicts(rows)
    pm = per_mu(packings(rows))
    text = (f"Spheres jammed by the bundled scene `{scene}` (radii uniform in [R, 2R], "
            "periodic in x and y, compressed along z by a constant load on the top plate, no "
            "gravity), one packing per (mu, seed); rows in `rows.jsonl`, the table in "
            "`spheres3d.md` (mean ± standard error over the seeds). z counts the plate "
            "contacts and leaves the rattlers out, as `forcespace info`.\n\n" + table(rows)
            + "\nCPU s of a jam: its process's CPU time (a jam resumed from a checkpoint "
            "counts only its last part). Seeds per mu: "
            + ", ".join(f"{d['seeds']} at mu = {m:g}" for m, d in pm.items()) + ".")
    write_section(out, "spheres3d", "Frictional spheres (3-D): z, packing fraction, "
                  "rattlers against mu", text, vs, numbers, [], rules_version=RULES_VERSION)
    return numbers
