"""Where in S a soft code lands: the elastic selection against LIGGGHTS and pymunk.

Tasks: one per (mu, seed): a packing (the committed seed-1 paper packings
``studies/packings/paper_mu*.h5`` when they match, else jammed), its plate S
(``forcespace.statics.plate_problem``: the S of the soft runs, whose top plate
is load-controlled), and per kt/kn:

* ``lig``: LIGGGHTS (hooke/stiffness, tangential history, load ramped in),
  the stiffest kn of the ladder whose network has no contact outside the
  rigid one and lies within 1e-4 <Fn> of S ("converged" in the network);
* ``sel``: :func:`forcespace.select` -- minimum complementary energy over S,
  springs starting stress-free (depends on kt/kn only);
* ``sel_ov``: the same with the springs starting from the rigid packing's own
  overlaps/gaps at LIGGGHTS' kn (that is what the soft run starts from:
  overlaps ~1e-7 R are ~kn 1e-7 = O(<Fn>) at kn = 1e7 <Fn>/R);

* ``na_lig``, ``na_sel``: the same springs and initial overlaps with *true*
  (non-associated) Coulomb sliding -- free slip, no dilatancy -- on the
  sliding and open contacts of LIGGGHTS (resp. of ``sel_ov``): a linear
  system, :func:`nonassociated`. ``lig`` vs ``na_lig`` tests elasticity once
  the history has decided which contacts slide; ``na_sel`` is a prediction
  that needs no soft run;

and once per packing ``pym`` (pymunk, 100 iterations, dt = 0.003: impulses,
no stiffness), ``cd`` (the jammed contact-dynamics state) and ``centre``
(Chebyshev centre of S). Soft networks are projected onto S first. Every
distance is the rms per-contact difference in units of <Fn>. Sliding
contacts (|ft| >= mu fn (1 - 1e-4)) are counted in each network.

The tasks import ``forcespace_adapters`` (installed alongside forcespace)
inside the task function only: forcespace itself never imports the adapters.
"""
from __future__ import annotations

from itertools import combinations
from pathlib import Path

import numpy as np

import forcespace as fs
from forcespace.space.force_space import chebyshev_centre, implicit_equalities
from forcespace.space.projection import distance_to_S
from forcespace.space.selection import packing_overlaps
from forcespace.sweep import Task

# landed_tol: a LIGGGHTS network counts when it has no contact outside the rigid
# network and lies this close to S (/ <Fn>); at K = 1e5 the geometry change alone
# puts it ~1e-3 away (quick), from K = 1e6 on below 1e-4 (soft_vs_rigid.md)
QUICK = dict(scene="quick", n_disks=30, mus=(0.1, 0.5), seeds=(1,), kt_ratios=(2 / 7, 1.0),
             K=(1e5,), pymunk=(30, 0.01), max_steps=300_000, landed_tol=1e-2)
FULL = dict(scene="paper", n_disks=200, mus=(0.0, 0.1, 0.5), seeds=(1, 2, 3),
            kt_ratios=(2 / 7, 1.0), K=(1e7, 3e6, 1e6), pymunk=(100, 0.003), max_steps=1_500_000,
            landed_tol=1e-4)
NETWORKS = ("lig", "pym", "sel", "sel_ov", "na_sel", "na_lig", "cd", "centre")
SLIDE_TOL = 1e-2      # sliding: |ft| >= mu fn (1 - SLIDE_TOL) (soft forces are mapped onto
#                       the rigid frames, which turns ft by ~overlap/R: 1e-5..1e-3 of mu fn)


def tasks(quick: bool = False) -> list[Task]:
    cfg = QUICK if quick else FULL
    out = []
    for mu in cfg["mus"]:
        # without friction kt never enters (no tangential force in any network):
        # one ratio is the whole answer, the second would repeat it bit for bit
        ratios = list(cfg["kt_ratios"]) if mu > 0 else list(cfg["kt_ratios"])[:1]
        for seed in cfg["seeds"]:
            out.append(Task(f"mu{mu:g}_s{seed}", "forcespace_studies.selection:landing_task",
                            dict(scene=cfg["scene"], n_disks=cfg["n_disks"], mu=mu, seed=seed,
                                 kt_ratios=ratios, K=list(cfg["K"]),
                                 pymunk=list(cfg["pymunk"]), max_steps=cfg["max_steps"],
                                 landed_tol=cfg["landed_tol"])))
    return out


def _packing(scene, n_disks, mu, seed, wd: Path):
    pfile = wd / "packing.h5"
    if pfile.is_file():
        return fs.read_packing(pfile), "reused"
    p = fs.jam(scene, physics__mu=mu, scene__seed=seed, disks__n=n_disks)
    fs.write_packing(p, pfile)
    return p, "jammed"


def _sliding(x, mu, scale):
    fn, ft = x[0::2], x[1::2]
    return (mu > 0) & (fn > 1e-6 * scale) & (np.abs(ft) >= mu * fn * (1 - SLIDE_TOL))


def nonassociated(S, kn, kt, overlap, sliding, sign, opened):
    """Linear springs with true (non-associated) Coulomb sliding on a given set.

    Sticking contacts: fn/kn = overlap + n.(u_a - u_b), ft/kt from the slip
    (the compatibility rows of :mod:`forcespace.selection`); ``sliding`` (m,)
    contacts: fn as before, ft = sign mu fn (free slip, no dilatancy);
    ``opened`` contacts: fn = ft = 0. A square linear system in (x, u),
    solved by least squares (mechanisms leave u, not x, undetermined).
    Returns (x (2m,) [F0], residual / <Fn>).
    """
    sc = S.force_scale
    m, r = S.n_contacts, S.A.shape[0]
    k0 = float(np.mean(kn))
    A = S.A.toarray()
    M = np.zeros((r + 2 * m, 2 * m + r))
    rhs = np.zeros(r + 2 * m)
    M[:r, :2 * m] = A
    rhs[:r] = S.b / sc
    for j in range(m):
        rn, rt = r + 2 * j, r + 2 * j + 1
        if opened[j]:
            M[rn, 2 * j] = 1.0
            M[rt, 2 * j + 1] = 1.0
            continue
        M[rn, 2 * j] = k0 / kn[j]
        M[rn, 2 * m:] = -A[:, 2 * j]
        rhs[rn] = overlap[j] * k0 / sc
        if S.mu[j] == 0.0:
            M[rt, 2 * j + 1] = 1.0
        elif sliding[j]:
            M[rt, 2 * j + 1] = 1.0
            M[rt, 2 * j] = -sign[j] * S.mu[j]
        else:
            M[rt, 2 * j + 1] = k0 / kt[j]
            M[rt, 2 * m:] = -A[:, 2 * j + 1]
    y = np.linalg.lstsq(M, rhs, rcond=None)[0]
    return y[:2 * m] * sc, float(np.abs(M @ y - rhs).max())


def incompatibility(S, x, kn, kt, overlap, sliding, opened):
    """How far a network is from any elastic state of the springs.

    Rows: normal fn/kn - overlap = (A^T lam)_n for contacts not open, and
    tangential ft/kt = (A^T lam)_t for sticking frictional contacts, lam the
    displacements (and rotations) of the disks and the plate. Normal springs
    have no memory, so the normal rows are fitted exactly first (their
    residual r_n is a check: LIGGGHTS' normal forces are kn times the
    geometric overlap); the tangential rows are then fitted by least squares
    over what the normal rows leave free (mostly the rotations). Returns
    (|r_t| / |w|, |r_n| / |w|), w the deformations on the rows: r_t is the
    smallest tangential slip that the network needs on top of an elastic
    state -- 0 for the selection without sliding, the slip history of a soft
    run otherwise.
    """
    import scipy.linalg as sla

    normal = np.flatnonzero(~opened)
    tang = np.flatnonzero(~opened & ~sliding & (S.mu > 0))
    A = S.A.toarray()
    Bn, Bt = A[:, 2 * normal].T, A[:, 2 * tang + 1].T
    wn = x[2 * normal] / kn[normal] - overlap[normal]
    wt = x[2 * tang + 1] / kt[tang]
    lam0 = np.linalg.lstsq(Bn, wn, rcond=None)[0]
    rn = wn - Bn @ lam0
    N = sla.null_space(Bn, rcond=1e-12)
    rt = wt - Bt @ lam0
    if N.shape[1] and tang.size:
        rt = rt - Bt @ N @ np.linalg.lstsq(Bt @ N, rt, rcond=None)[0]
    nw = max(np.sqrt(wn @ wn + wt @ wt), 1e-300)
    return float(np.linalg.norm(rt) / nw), float(np.linalg.norm(rn) / nw)


def landing_task(scene: str, n_disks: int, mu: float, seed: int, kt_ratios, K, pymunk,
                 max_steps: int, workdir, landed_tol: float = 1e-4) -> dict:
    """One packing: the six networks of the module docstring and their distances."""
    from forcespace_adapters import liggghts as L
    from forcespace_adapters.distance import run_status, soft_vector
    from forcespace_adapters.problem import soft_problem
    from forcespace_adapters.pymunk_sim import PymunkOptions, simulate

    wd = Path(workdir)
    p, origin = _packing(scene, n_disks, mu, seed, wd)
    S = fs.plate_problem(p)
    scale = S.force_scale
    # the centre only (analyze() would also decide, by LP, which contacts vary)
    imp = implicit_equalities(S)
    centre, radius = chebyshev_centre(S, implicit_rows=imp)
    soft_prob = soft_problem(p, top="plate")
    base = {"mu": mu, "seed": seed, "packing": origin, "n_disks": p.n_disks,
            "n_contacts": S.n_contacts, "n_implicit_rows": int(imp.size),
            "centre_radius": radius / scale,
            "force_scale": scale, "jammed_violation": S.violation(S.x_jammed),
            "max_rigid_overlap": p.max_overlap()}

    def landed(soft):
        """(projection onto S, the numbers `forcespace distance` reports)."""
        _, x, match = soft_vector(p, soft, S)
        d = distance_to_S(S, x)
        return d.nearest, {"relative_distance": d.relative,
                           "unmatched_contacts": len(match.unmatched),
                           "lost_contacts": len(match.lost), "max_overlap": soft.max_overlap(),
                           "soft_run_converged": run_status(soft.meta)[0]}

    # pymunk: one run (no stiffness, kt does not enter)
    it, dt = pymunk
    pfile = wd / "pymunk.h5"
    if pfile.is_file():
        soft = fs.read_packing(pfile, kind="soft_network")
    else:
        soft, info = simulate(soft_prob, PymunkOptions(iterations=int(it), dt=float(dt),
                                                       max_steps=20000))
        soft.meta.update({k: v for k, v in info.items()
                          if isinstance(v, (bool, int, float, str))})
        fs.write_packing(soft, pfile, kind="soft_network")
    x_pym, c_pym = landed(soft)
    base.update({"pym_distance_to_S": c_pym["relative_distance"],
                 "pym_unmatched": c_pym["unmatched_contacts"],
                 "pym_converged": c_pym["soft_run_converged"]})

    rows, kept = [], {}
    for ratio in kt_ratios:
        lig, tried = None, []
        for k in sorted(K, reverse=True):               # stiffest first
            d = wd / f"lig_K{k:g}_kt{ratio:.3f}"
            kn = k * soft_prob.force_scale
            if not (d / "status.json").is_file():
                L.write_deck(soft_prob, d, L.LiggghtsOptions(kn=k, kt_ratio=ratio,
                                                             tolerance=1e-6, max_steps=max_steps))
                L.run_deck(d)
            soft, info = L.read_result(d, p)
            xl, c = landed(soft)
            rec = {"K": k, "kn": kn, "converged": bool(info.get("converged")),
                   "steps": info.get("steps"), "distance_to_S": c["relative_distance"],
                   "unmatched": c["unmatched_contacts"], "lost": c["lost_contacts"],
                   "max_overlap": c["max_overlap"]}
            tried.append(rec)
            if c["unmatched_contacts"] == 0 and c["relative_distance"] < landed_tol:
                lig = (xl, rec)
                break
        sel = fs.Selection(kt_ratio=ratio).compute(S)
        xs = {"pym": x_pym, "sel": sel.x, "cd": S.x_jammed, "centre": centre}
        row = dict(base, kt_ratio=ratio, lig_runs=tried, n_sliding_sel=int(sel.sliding_contacts.size))
        if lig is not None:
            xs["lig"] = lig[0]
            row.update({f"lig_{k}": v for k, v in lig[1].items()})
            ov = packing_overlaps(p, S)
            sov = fs.Selection(kt_ratio=ratio, kn=lig[1]["kn"], overlap=ov).compute(S)
            xs["sel_ov"] = sov.x
            row["n_sliding_sel_ov"] = int(sov.sliding_contacts.size)
            # non-associated Coulomb, with the sliding/open sets of LIGGGHTS or of sel_ov
            knv = np.full(S.n_contacts, lig[1]["kn"])
            for tag, xref in (("na_lig", lig[0]), ("na_sel", sov.x)):
                sl = _sliding(xref, S.mu, scale)
                op = xref[0::2] <= 1e-6 * scale
                if tag == "na_lig":
                    inc = incompatibility(S, xref, knv, ratio * knv, ov, sl, op)
                    row.update(lig_slip=inc[0], lig_normal_misfit=inc[1])
                xna, res = nonassociated(S, knv, ratio * knv, ov, sl & ~op,
                                         np.sign(xref[1::2]), op)
                xs[tag] = xna
                row[f"{tag}_residual"] = res
                row[f"{tag}_violation"] = S.violation(xna)
        norm = scale * np.sqrt(S.n_contacts)
        for a, b in combinations(NETWORKS, 2):
            if a in xs and b in xs:
                row[f"d_{a}_{b}"] = float(np.linalg.norm(xs[a] - xs[b]) / norm)
        slide = {k: _sliding(v, S.mu, scale) for k, v in xs.items()
                 if k not in ("centre", "na_lig", "na_sel")}
        one = np.ones(S.n_contacts)
        for k in ("pym", "cd", "centre", "sel"):   # the same measure, stress-free springs
            row[f"{k}_slip"], row[f"{k}_normal_misfit"] = incompatibility(
                S, xs[k], one, ratio * one, 0 * one, _sliding(xs[k], S.mu, scale),
                xs[k][0::2] <= 1e-6 * scale)
        for k, v in slide.items():
            row[f"n_sliding_{k}"] = int(v.sum())
        if "lig" in xs:
            # where the LIGGGHTS-selection difference sits: contacts sliding in either network
            for ref in ("sel", "sel_ov"):
                either = slide["lig"] | slide[ref]
                diff = (xs["lig"] - xs[ref]).reshape(-1, 2)
                sq = (diff ** 2).sum(1)
                row[f"share_sliding_{ref}"] = float(sq[either].sum() / max(sq.sum(), 1e-300))
                row[f"d_lig_{ref}_sticking"] = float(np.sqrt(sq[~either].sum()) / norm)
                row[f"n_sliding_lig_and_{ref}"] = int((slide["lig"] & slide[ref]).sum())
        rows.append(row)
        kept[ratio] = xs
    # does the selection predict how kt/kn moves the soft network? (first two ratios)
    if len(kt_ratios) >= 2 and all("lig" in kept[r] for r in kt_ratios[:2]):
        r1, r2 = kt_ratios[:2]
        norm = scale * np.sqrt(S.n_contacts)
        dl, ds = kept[r2]["lig"] - kept[r1]["lig"], kept[r2]["sel"] - kept[r1]["sel"]
        rows[-1].update(kt_effect_lig=float(np.linalg.norm(dl) / norm),
                        kt_effect_sel=float(np.linalg.norm(ds) / norm),
                        kt_effect_cosine=float(dl @ ds / max(np.linalg.norm(dl)
                                                             * np.linalg.norm(ds), 1e-300)))
    return {"rows": rows}


PAIRS = [("lig", "sel"), ("lig", "sel_ov"), ("lig", "na_sel"), ("lig", "na_lig"), ("lig", "cd"),
         ("lig", "centre"), ("lig", "pym"), ("pym", "sel"), ("pym", "cd"), ("sel", "cd"),
         ("sel", "centre"), ("cd", "centre")]


MARKERS = "o^sv<>Dph*PX"


def summarize(results: list[dict], out) -> dict:
    """selection.csv (one row per packing and kt/kn), selection_table.md (means
    over seeds) and selection.png/.pdf (the distances per mu and kt/kn)."""
    from matplotlib.figure import Figure

    from forcespace.plot import save_figure
    from .report import write_csv

    out = Path(out)
    rows = [r for res in results if res.get("ok") for r in res["rows"]]
    keys = ["mu", "seed", "kt_ratio", "packing", "n_contacts", "centre_radius", "lig_K", "lig_converged",
            "lig_distance_to_S", "pym_distance_to_S"] + [f"d_{a}_{b}" for a, b in PAIRS] + [
        "n_sliding_lig", "n_sliding_sel", "n_sliding_sel_ov", "n_sliding_cd", "n_sliding_pym",
        "n_sliding_lig_and_sel_ov", "share_sliding_sel_ov", "d_lig_sel_ov_sticking",
        "d_lig_sel_sticking", "na_lig_violation", "na_sel_violation", "na_lig_residual",
        "lig_slip", "lig_normal_misfit", "sel_slip", "sel_normal_misfit", "pym_slip",
        "pym_normal_misfit", "cd_slip", "cd_normal_misfit", "centre_slip",
        "centre_normal_misfit", "kt_effect_lig", "kt_effect_sel", "kt_effect_cosine"]
    write_csv(out / "selection.csv", rows, keys)
    groups = sorted({(r["mu"], r["kt_ratio"]) for r in rows})

    def mean(vals):
        v = [x for x in vals if x is not None and np.isfinite(x)]
        return (float(np.mean(v)), float(np.std(v)), len(v)) if v else (np.nan, np.nan, 0)

    lines = ["| mu | kt/kn | seeds | " + " | ".join(f"{a}–{b}" for a, b in PAIRS)
             + " | sliding lig / sel / sel_ov / cd |",
             "|" + "---|" * (len(PAIRS) + 4)]
    for mu, ratio in groups:
        g = [r for r in rows if r["mu"] == mu and r["kt_ratio"] == ratio]
        cells = []
        for a, b in PAIRS:
            m, s, n = mean([r.get(f"d_{a}_{b}") for r in g])
            cells.append("–" if n == 0 else f"{m:.3g} ± {s:.2g}" if n > 1 else f"{m:.3g}")
        sl = " / ".join(f"{mean([r.get(k) for r in g])[0]:.3g}" for k in
                        ("n_sliding_lig", "n_sliding_sel", "n_sliding_sel_ov", "n_sliding_cd"))
        lines.append(f"| {mu:g} | {ratio:.3g} | {len(g)} | " + " | ".join(cells) + f" | {sl} |")
    (out / "selection_table.md").write_text(
        "rms per-contact distance / <Fn> (mean ± std over seeds)\n\n" + "\n".join(lines) + "\n")

    fig = Figure(figsize=(11, 4.5))
    ax = fig.subplots()
    xt = np.arange(len(groups))
    for i, (a, b) in enumerate(PAIRS):
        for k, (mu, ratio) in enumerate(groups):
            v = [r.get(f"d_{a}_{b}") for r in rows if r["mu"] == mu and r["kt_ratio"] == ratio]
            v = [x for x in v if x is not None]
            if v:
                ax.plot(np.full(len(v), k + (i - len(PAIRS) / 2) * 0.07), np.maximum(v, 1e-12),
                        MARKERS[i % len(MARKERS)], color=f"C{i % 10}", mfc="none")
        ax.plot([], [], MARKERS[i % len(MARKERS)], color=f"C{i % 10}", mfc="none",
                label=f"{a}–{b}")
    ax.set_xticks(xt, [f"mu={mu:g}\nkt/kn={ratio:.2g}" for mu, ratio in groups])
    ax.set_yscale("log")
    ax.set_ylabel("rms distance per contact / <Fn>")
    ax.set_title("Where in S the networks land (lig: LIGGGHTS, pym: pymunk, sel: elastic "
                 "selection, sel_ov: from the rigid overlaps, na_*: true Coulomb on given "
                 "sliding sets, cd: jammed, centre of S)", fontsize=7)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    save_figure(fig, out / "selection.png", tight=True)
    _report(rows, out, "\n".join(lines))
    return {"tasks": len(results), "failed": sum(not r.get("ok") for r in results),
            "rows": len(rows), "table": str(out / "selection.csv"),
            "markdown": str(out / "selection_table.md"), "figure": str(out / "selection.png")}


def _report(rows, out, table: str) -> None:
    """The study's section of REPORT.md: does elasticity predict where LIGGGHTS lands?"""
    from .report import Verdict, write_section

    verdicts = []
    # per mu with friction: at mu = 0 S is one point (dim 0) and every network in it is
    # the same up to round-off (distances ~1e-9 <Fn>), so "closer" means nothing there
    for mu in sorted({r["mu"] for r in rows if r["mu"] > 0}):
        pairs = [(r["d_lig_sel"], r["d_lig_cd"]) for r in rows if r["mu"] == mu
                 and r.get("d_lig_sel") is not None and r.get("d_lig_cd") is not None]
        if not pairs:
            continue
        sel, cd = (np.array(v) for v in zip(*pairs))
        verdicts.append(Verdict(
            f"selection mu={mu:g}", f"(ours, beyond the paper) at mu = {mu:g} the elastic "
                                    "selection — minimum complementary energy over S — predicts "
                                    "the stiff LIGGGHTS network better than the jammed "
                                    "contact-dynamics state (closer on every packing and kt/kn)",
            f"rms distance to LIGGGHTS {np.mean(sel):.3g} <Fn> (selection) against "
            f"{np.mean(cd):.3g} (jammed state), closer on {int((sel < cd).sum())} of "
            f"{sel.size} packings x kt/kn",
            "reproduced" if (sel < cd).all() else "refuted"))
    missing = []
    for r in rows:
        if r.get("d_lig_sel") is None and r.get("lig_runs"):
            best = min(r["lig_runs"], key=lambda q: q["distance_to_S"])
            missing.append(f"mu = {r['mu']:g}, seed {r['seed']}, kt/kn = {r['kt_ratio']:.3g}: "
                           f"no kn of the ladder landed (best K = {best['K']:g}: "
                           f"{best['distance_to_S']:.2g} <Fn> from S, {best['unmatched']} "
                           f"contacts outside the rigid network, {best['lost']} lost)")
    if missing:
        table += ("\n\nLIGGGHTS networks left out (no kn of the ladder within the landing tolerance of S "
                  "with the rigid contact set; new or lost contacts mean the soft packing moved):\n\n"
                  + "\n".join(f"- {m}" for m in missing))
    write_section(out, "selection", "Where in S a soft code lands: the elastic selection",
                  "Distances (rms per contact, in <Fn>) between the LIGGGHTS network at the "
                  "stiffest converged kn, the pymunk network, the elastic selection (sel; "
                  "sel_ov: springs starting from the rigid packing's overlaps), elastic "
                  "solutions with true Coulomb sliding on given sliding sets (na_*), the "
                  "jammed contact-dynamics state (cd) and the centre of S; see "
                  "`studies/selection.md` for the method.\n\n" + table, verdicts,
                  {"rows": len(rows)}, ["selection.png"])
