"""The report of ``studies/spheres_fig1.py``: the table per mu, the figure and the verdicts
by the rules fixed in that script's docstring (n = 100 spheres throughout)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from forcespace_studies.rows import read_rows


def by_mu(rows):
    """{mu: [rows]} (one row per packing; the last one wins)."""
    uniq = {(r["mu"], r["seed"]): r for r in rows}
    out = {}
    for (mu, _), r in sorted(uniq.items()):
        out.setdefault(mu, []).append(r)
    return out


def mean_se(v):
    v = np.asarray(v, float)
    if v.size == 0:
        return np.nan, np.nan
    return float(v.mean()), float(v.std(ddof=1) / np.sqrt(v.size)) if v.size > 1 else np.nan


def table(groups) -> str:
    head = ("| μ | packings | z | N_c | 3N_c − 6n | dim S (whole) | dim S / N_c | "
            "(3N_c − 6n) / N_c | dim S = 0 | η (whole, billiard; mean ± s.e.) | "
            "min ESS | max R-hat |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    lines = []
    for mu, rs in groups.items():
        def ms(key, fmt, rs=rs):
            m, s = mean_se([r[key] for r in rs])
            return f"{m:{fmt}}" + ("" if not np.isfinite(s) else f" ± {s:{fmt}}")
        ratio = ms_of([r["dim_S"] / r["n_contacts"] for r in rs])
        deg = ms_of([r["count_3Nc_minus_6n"] / r["n_contacts"] for r in rs])
        ess = [r["ess"] for r in rs if r["ess"] is not None]
        rh = [r["rhat"] for r in rs if r["rhat"] is not None]
        lines.append(f"| {mu:g} | {len(rs)} | {ms('z', '.3f')} | {ms('n_contacts', '.0f')} | "
                     f"{ms('count_3Nc_minus_6n', '.0f')} | {ms('dim_S', '.1f')} | {ratio} | "
                     f"{deg} | {sum(r['dim_S'] == 0 for r in rs)} of {len(rs)} | "
                     f"{ms('eta', '.4g')} | "
                     f"{min(ess):.0f} | {max(rh):.3f} |" if ess else
                     f"| {mu:g} | {len(rs)} | {ms('z', '.3f')} | {ms('n_contacts', '.0f')} | "
                     f"{ms('count_3Nc_minus_6n', '.0f')} | {ms('dim_S', '.1f')} | {ratio} | "
                     f"{deg} | {sum(r['dim_S'] == 0 for r in rs)} of {len(rs)} | "
                     f"{ms('eta', '.4g')} | – | – |")
    return head + "\n".join(lines) + "\n"


def ms_of(v) -> str:
    m, s = mean_se(v)
    return f"{m:.3f}" + ("" if not np.isfinite(s) else f" ± {s:.3f}")


def slope_rule(rows) -> str:
    pts = [(r["mu"], r["eta"]) for r in rows if 0 < r["mu"] <= 0.01 and r["eta"] > 0]
    if len({m for m, _ in pts}) < 2:
        return ("| 1 | eta ∝ mu at small mu (mu <= 0.01) | fewer than two mu values | "
                "**not decidable** |")
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    slope = np.polyfit(x, y, 1)[0]
    rng = np.random.default_rng(0)
    boots = []
    for _ in range(2000):
        i = rng.integers(0, len(x), len(x))
        if np.ptp(x[i]) > 0:
            boots.append(np.polyfit(x[i], y[i], 1)[0])
    lo, hi = np.percentile(boots, [2.5, 97.5])
    verdict = "reproduced" if lo <= 1 <= hi and lo > 0 else \
        "refuted" if not lo <= 1 <= hi else "not decidable"
    return (f"| 1 | eta ∝ mu at small mu (mu <= 0.01) | d log eta / d log mu = {slope:.3f} "
            f"(95 %: {lo:.3f} to {hi:.3f}), {len(pts)} packings | **{verdict}** |")


def maximum_rules(groups) -> list[str]:
    from scipy.stats import kendalltau
    mus = [m for m in groups if m > 0]
    if len(mus) < 3 or max(mus) < PLANNED_TOP:
        return [f"| 2 | eta largest at an intermediate mu (2-D: ~0.1) | the planned range "
                f"ends at mu = {PLANNED_TOP:g}, the data at mu = {max(mus, default=0):g} "
                "(larger mu not yet jammed) | **not decidable** |"]
    stats = {m: mean_se([r["eta"] for r in groups[m]]) for m in mus}
    top = max(mus, key=lambda m: stats[m][0])
    ends = (mus[0], mus[-1])

    def se(m):
        return stats[m][1] if np.isfinite(stats[m][1]) else np.inf
    if top in ends:
        v2 = "refuted"
    elif all(stats[top][0] - stats[e][0] > 2 * np.hypot(se(top), se(e)) for e in ends):
        v2 = "reproduced"
    else:
        v2 = "not decidable"
    means = ", ".join(f"{m:g}: {stats[m][0]:.4g}" for m in mus)
    out = [f"| 2 | eta largest at an intermediate mu (2-D: ~0.1) | largest mean eta at mu = "
           f"{top:g} (means {means}) | **{v2}** |"]
    pts = [(r["mu"], r["eta"]) for m in mus if m >= top for r in groups[m]]
    if len({m for m, _ in pts}) >= 2:
        tau, p = kendalltau([a for a, _ in pts], [b for _, b in pts])
        p1 = p / 2 if tau < 0 else 1 - p / 2
        v3 = "reproduced" if tau < 0 and p1 < 0.05 else \
            "refuted" if tau > 0 and 1 - p1 < 0.05 else "not decidable"
        out.append(f"| 3 | eta decreases beyond the maximum | Kendall tau = {tau:.2f} "
                   f"(one-sided p = {p1:.2g}) over {len(pts)} packings at mu >= {top:g} | "
                   f"**{v3}** |")
    else:                  # tau is undefined over a single mu: the rule's "else"
        out.append(f"| 3 | eta decreases beyond the maximum | no mu beyond the largest mean "
                   f"(mu = {top:g}, the design's largest): {len(pts)} packings at one mu, "
                   "no trend to test | **not decidable** |")
    return out


def determinate_rule(groups) -> str:
    big = [r for m, rs in groups.items() if m >= 1 for r in rs]
    small = [r for m, rs in groups.items() if 0 < m <= 0.01 for r in rs]
    nb, ns = sum(r["dim_S"] == 0 for r in big), sum(r["dim_S"] == 0 for r in small)
    verdict = "reproduced" if nb and not ns else "refuted" if len(big) >= 5 and not nb \
        and max(groups) >= PLANNED_TOP else "not decidable"
    per = ", ".join(f"{sum(r['dim_S'] == 0 for r in rs)} of {len(rs)} at mu = {m:g}"
                    for m, rs in groups.items() if m >= 1)
    return (f"| 4 | determinate packings (dim S = 0, whole problem) at large mu | {per}; "
            f"{ns} of {len(small)} at 0 < mu <= 0.01"
            + ("" if max(groups) >= PLANNED_TOP else f" (no packing above mu = "
               f"{max(groups):g} yet)") + f" | **{verdict}** |")


def count_rule(rows, n: int = 100, rule: str = "5") -> str:
    """Rule 5 (and 5', the same rule on the n = 500 rows) over 0 < mu <= 0.01."""
    small = [r for r in rows if 0 < r["mu"] <= 0.01]
    claim = (f"| {rule} | 3N_c - 6n ~ N_c and dim S ~ N_c at small mu (0 < mu <= 0.01)"
             + ("" if n == 100 else f", n = {n}") + " | ")
    if len(small) < 3:
        return claim + f"{len(small)} packings (< 3) | **not decidable** |"
    deg, dim, bulk, _ = count_ratios(small)
    verdict = "reproduced" if abs(deg.mean() - 1) <= 0.1 else "refuted"
    return (claim + f"(3N_c - 6n) / N_c = {deg.mean():.3f} ± {deg.std(ddof=1):.3f}; "
            f"dim S / N_c = {dim.mean():.3f} ± {dim.std(ddof=1):.3f}; dim S / (N_c - 2 "
            f"(N_bottom + N_top)) = {bulk.mean():.3f} ± {bulk.std(ddof=1):.3f} "
            f"({len(small)} packings) | **{verdict}** |")


def count_ratios(rows):
    """(3N_c - 6n) / N_c, dim S / N_c, dim S / (N_c - 2 (N_bottom + N_top)) and the
    plates' share 2 (N_bottom + N_top) / N_c per row (arrays)."""
    nc = np.array([r["n_contacts"] for r in rows], float)
    plates = np.array([r["n_contacts"] - r["Nc_minus_2_plates"] for r in rows], float)
    return (np.array([r["count_3Nc_minus_6n"] for r in rows]) / nc,
            np.array([r["dim_S"] for r in rows]) / nc,
            np.array([r["dim_S"] for r in rows]) / (nc - plates), plates / nc)


def n500_section(rows100, rows500) -> str:
    """Rule 5' at n = 500: the rows per packing, and the ratios at n = 100 and 500."""
    if not rows500:
        return ""
    head = ("## Rule 5' at n = 500 (issue 43's packings, paper3d_certified; whole problem, "
            "dim S exact)\n\n| packing | n (non-rattlers) | N_c | 3N_c − 6n | rank A | dim S | "
            "(3N_c − 6n) / N_c | dim S / N_c | plates' share 2 (N_b + N_t) / N_c | dim S / "
            "(N_c − 2 (N_b + N_t)) | CPU s |\n|---|---|---|---|---|---|---|---|---|---|---|\n")
    lines = []
    for r in sorted(rows500, key=lambda r: (r["mu"], r["seed"])):
        deg, dim, bulk, share = (float(a[0]) for a in count_ratios([r]))
        lines.append(f"| mu = {r['mu']:g}, seed {r['seed']} | {r['n_interior']} | "
                     f"{r['n_contacts']} | {r['count_3Nc_minus_6n']} | {r['rank_A']} | "
                     f"{r['dim_S']} | {deg:.3f} | {dim:.3f} | {share:.3f} | {bulk:.3f} | "
                     f"{r['cpu_seconds']:.1f} |")
    cmp = ["", "| set | packings | (3N_c − 6n) / N_c | dim S / N_c | dim S / (N_c − "
           "plates) | plates' share |", "|---|---|---|---|---|---|"]
    sets = [("n = 100, 0 < mu <= 0.01 (rule 5)", rows100, lambda m: 0 < m <= 0.01),
            ("n = 100, mu = 0.01", rows100, lambda m: m == 0.01),
            ("n = 500, mu = 0.01 (rule 5')", rows500, lambda m: m == 0.01),
            ("n = 100, mu = 0 (beside)", rows100, lambda m: m == 0),
            ("n = 500, mu = 0 (beside)", rows500, lambda m: m == 0)]
    for name, rows, keep in sets:
        rs = [r for r in rows if keep(r["mu"])]
        if rs:
            cols = " | ".join(f"{a.mean():.3f} ± {a.std(ddof=1) if a.size > 1 else 0:.3f}"
                              for a in count_ratios(rs))
            cmp.append(f"| {name} | {len(rs)} | {cols} |")
    return head + "\n".join(lines) + "\n" + "\n".join(cmp) + \
        "\n\n(mean ± sd over packings; plates' share = 2 (N_bottom + N_top) / N_c)\n"


def z_rule(groups) -> str:
    if 0.0 not in groups or max(groups) < 3:
        return "| 6 | z -> 6 as mu -> 0, -> 4 at large mu | missing mu | **not decidable** |"
    top = max(groups)
    z0 = np.mean([r["z"] for r in groups[0.0]])
    zt = np.mean([r["z"] for r in groups[top]])
    verdict = "reproduced" if abs(z0 - 6) <= 0.1 and abs(zt - 4) <= 0.3 else "refuted"
    return (f"| 6 | z -> 6 as mu -> 0 and falls towards 4 at large mu | z = {z0:.3f} at mu = 0, "
            f"{zt:.3f} at mu = {top:g} | **{verdict}** |")


def figure(groups, path: Path, rows500=(), disks=None) -> None:
    """fig1.png/pdf: eta and z against mu (the 2-D disks' eta beside, if ``disks``: rows
    of ``results/fig1/fig1_by_mu.csv``), dim S and 3N_c - 6n against N_c, and the ratios
    against the plates' share at n = 100 and (rule 5') n = 500."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b, c, d) = plt.subplots(1, 4, figsize=(19, 4.6))
    mus = [m for m in groups if m > 0]
    for ax, key in ((a, "eta"), (b, "z")):
        for m in mus:
            v = [r[key] for r in groups[m] if key != "eta" or r[key] > 0]
            ax.plot([m] * len(v), v, ".", color="0.6")
        st = [mean_se([r[key] for r in groups[m]]) for m in mus]
        ax.errorbar(mus, [s[0] for s in st], [s[1] if np.isfinite(s[1]) else 0 for s in st],
                    fmt="o-", color="C0", capsize=3,
                    label="spheres n = 100: mean ± s.e." + (" (η = 0 included)"
                                                           if key == "eta" else ""))
        ax.set_xscale("log")
        ax.set_xlabel(r"friction coefficient $\mu$")
    eta_panel(a, groups, mus, disks)
    b.set_ylabel("z: contacts per non-rattler sphere")
    if 0.0 in groups:
        b.axhline(np.mean([r["z"] for r in groups[0.0]]), color="C1", ls="--",
                  label=r"spheres, $\mu = 0$")
    b.legend(fontsize=8)
    dim_panel(c, groups)
    ratio_panel(d, [r for rs in groups.values() for r in rs], list(rows500))
    fig.suptitle("Spheres (paper3d, n = 100; rule 5': paper3d_certified, n = 500): "
                 "the paper's Fig. 1 in 3-D")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    fig.savefig(path.with_suffix(".pdf"))
    plt.close(fig)


def eta_panel(ax, groups, mus, disks) -> None:
    """Log axis: determinate packings (eta = 0) drawn as triangles on the bottom edge;
    the 2-D disks' mean eta (hit-and-run, 95 % band) beside."""
    if disks:
        m2 = np.array([float(r["mu"]) for r in disks])
        e2 = np.array([float(r["eta_hit_and_run_mean"]) for r in disks])
        lo = np.array([float(r["eta_hit_and_run_lo"]) for r in disks])
        hi = np.array([float(r["eta_hit_and_run_hi"]) for r in disks])
        keep = m2 > 0
        ax.plot(m2[keep], e2[keep], "s--", color="0.35", ms=4,
                label="2-D disks (fig1, 200 disks, middle slice): mean")
        ax.fill_between(m2[keep], np.maximum(lo[keep], ETA_AXIS[0]), hi[keep], color="0.8",
                        alpha=0.6,
                        label="2-D disks: 95 % bootstrap band")
    ax.set_yscale("log")
    ax.set_ylim(ETA_AXIS)           # a mean whose s.e. reaches 0 is cut at the bottom edge
    zero = [m for m in mus for r in groups[m] if r["eta"] == 0]
    if zero:
        ax.plot(zero, [ETA_AXIS[0] * 1.6] * len(zero), "v", color="C3", ms=8,
                label=r"spheres: determinate (dim S = 0, $\eta$ = 0)")
    ax.set_ylabel(r"$\eta$ (dimensionless; uniform sampling of S)")
    ax.legend(fontsize=7, loc="upper left")


def dim_panel(c, groups) -> None:
    for k, (m, rs) in enumerate(groups.items()):
        c.plot([r["n_contacts"] for r in rs], [r["dim_S"] for r in rs], "o", color=f"C{k}",
               label=rf"$\mu$ = {m:g}")
        c.plot([r["n_contacts"] for r in rs], [r["count_3Nc_minus_6n"] for r in rs], "o",
               mfc="none", color=f"C{k}")
    c.plot([], [], "o", mfc="none", color="0.3", label=r"$3N_c - 6n$ (open)")
    lim = max(r["n_contacts"] for rs in groups.values() for r in rs)
    c.plot([0, lim], [0, lim], "k:", label=r"dim S = $N_c$")
    c.set_xlabel(r"contacts $N_c$ (whole problem, n = 100)")
    c.set_ylabel(r"dim S (exact, filled); $3N_c - 6n$ (open)")
    c.legend(fontsize=7, ncol=2)


def ratio_panel(d, rows100, rows500) -> None:
    """Rule 5 and 5': dim S / N_c and (3N_c - 6n) / N_c at 0 < mu <= 0.01 against the
    plates' share 2 (N_bottom + N_top) / N_c, n = 100 and n = 500."""
    for rows, n, mk in ((rows100, 100, "o"), (rows500, 500, "D")):
        small = [r for r in rows if 0 < r["mu"] <= 0.01]
        if not small:
            continue
        deg, dim, _, share = count_ratios(small)
        d.plot(share, dim, mk, color="C0", label=f"dim S / $N_c$, n = {n}")
        d.plot(share, deg, mk, mfc="none", color="C1", label=f"$(3N_c - 6n) / N_c$, n = {n}")
    d.axhline(1, color="k", ls=":", label="the paper's count: 1")
    d.axhspan(0.9, 1.1, color="0.9", label="rule 5: within 0.1 of 1")
    d.set_xlim(left=0)
    d.set_xlabel(r"plates' share of the contacts $2(N_{bottom} + N_{top}) / N_c$")
    d.set_ylabel(r"ratio at $0 < \mu \leq 0.01$")
    d.legend(fontsize=7, loc="lower left")


ETA_AXIS = (1e-5, 3.0)   # the eta axis of the figure (log)
PLANNED_TOP = 10.0       # the largest mu of the design: rules 2-4 need the range to it
ETA_RULES = ("1", "2", "3")      # claims about S, judged on the billiard walk's samples


def verdict_rows(rows, rows500=()) -> list[str]:
    """The markdown rows "| rule | claim | measured | **verdict** |" of the six rules and,
    with n = 500 rows, rule 5'."""
    groups = by_mu(rows)
    flat = [r for rs in groups.values() for r in rs]
    return [slope_rule(flat), *maximum_rules(groups), determinate_rule(groups),
            count_rule(flat), *([count_rule(rows500, 500, "5'")] if rows500 else []),
            z_rule(groups)]


def write_verdicts(rows, rows500, out: Path) -> None:
    """OUT/verdicts.json and OUT/REPORT.md through the studies' report (so that
    ``forcespace study report ... studies/results/spheres_fig1`` shows these rows)."""
    from forcespace_studies.report import Verdict, write_section

    verdicts = []
    for line in verdict_rows(rows, rows500):
        rule, claim, ours, verdict = [c.strip() for c in line.strip("|").split(" | ")]
        n = 500 if rule == "5'" else 100
        claim = claim.replace(f", n = {n}", "")         # said once, in front
        verdicts.append(Verdict("spheres_fig1", f"spheres (n = {n}): {claim}", ours,
                                verdict.strip("*"),
                                sampler="billiard" if rule in ETA_RULES else "",
                                rule=f"rule {rule} of studies/spheres_fig1.py"))
    n = len(by_mu(rows))
    text = (f"100 spheres (paper3d scaled to n = 100), {len(rows)} packings at {n} values of "
            "mu; eta of the whole problem by the uniform billiard walk on the conic S; dim "
            "S exact (Clarabel). Rule 5' (pre-declared): rule 5 on issue 43's 500-sphere "
            "packings at mu = 0.01 (analysis only). Rules 2 and 4 were amended after the "
            "run had started (before any packing above mu = 1 was done; the amendment only "
            "makes them not decidable while the data end below mu = 10, so it changes no "
            "verdict on the complete set). Per mu (mean ± s.e. over packings; also in "
            "spheres_fig1.md, beside the n = 500 rows of rule 5'):\n\n"
            + table(by_mu(rows)).strip())
    reading = out / "reading.md"            # the study's reading, written by hand
    if reading.is_file():
        text += "\n\n" + reading.read_text().strip()
    write_section(out, "spheres_fig1", "Spheres: the paper's Fig. 1 in 3-D", text, verdicts,
                  {}, ["fig1.png"])


def disks_fig1(d: Path):
    """The 2-D disks' fig1 per mu (``fig1_by_mu.csv``) if that study's results are there."""
    import csv
    f = d / "fig1_by_mu.csv"
    return list(csv.DictReader(f.open())) if f.is_file() else None


def write_report(rows, out: Path) -> None:
    """OUT/spheres_fig1.md, fig1.png/pdf, verdicts.json, REPORT.md from the n = 100 rows
    and, if there, OUT/rule5_n500_rows.jsonl (rule 5')."""
    rows500 = read_rows(out / "rule5_n500_rows.jsonl")
    groups = by_mu(rows)
    verdicts = ["| rule | claim | measured (n = 100 spheres unless said) | verdict |",
                "|---|---|---|---|", *verdict_rows(rows, rows500)]
    figure(groups, out / "fig1.png", rows500, disks_fig1(out.parent / "fig1"))
    (out / "spheres_fig1.md").write_text(
        "# Spheres' Fig. 1 (n = 100; rules in studies/spheres_fig1.py)\n\n" + table(groups)
        + "\n" + "\n".join(verdicts) + "\n\n" + n500_section(rows, rows500)
        + "\n![fig1.png](fig1.png)\n")
    write_verdicts(rows, rows500, out)
