"""Where in S a soft code lands: the elastic selection against LIGGGHTS and pymunk.

Tasks: one per (mu, seed), seed-major (every mu of seed 1, then of seed 2, ...), so an
interrupted run holds complete seed rounds: a packing jammed from the bundled scene
and kept in the task's directory, its plate S
(``forcespace.plate_problem``: the S of the soft runs, whose top plate is
load-controlled), and per kt/kn:

* ``lig``: LIGGGHTS (hooke/stiffness, tangential history, load ramped in) down the
  stiffness ladder K (kn = K <Fn>/R), stiffest first: the first network that has no
  contact outside the rigid network and lies within ``landed_tol`` of S is kept. Its
  label (:func:`landing`): "converged" when the run also met LIGGGHTS' own stop test
  (static residual and plate force within tolerance), "landed" when it stopped at the
  step cap (its distance to S is stated), "not landed" when no K of the ladder landed;
* ``sel``: :class:`forcespace.Selection` -- minimum complementary energy over S,
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

and once per packing ``pym`` (pymunk: impulses, no stiffness; labelled like
``lig``), ``cd`` (the jammed contact-dynamics state) and ``centre`` (Chebyshev centre
of S). Soft networks are mapped onto S first: soft contacts matched to the rigid
ones, forces taken in the rigid contact frames (a rigid contact the soft run lost
carries 0; a soft contact absent from the rigid network cannot be mapped: such a
network does not land), then the Euclidean projection onto S. Every distance is the
rms per-contact difference in units of <Fn>. Sliding contacts (|ft| >= mu fn
(1 - 1e-2)) are counted in each network.

The hypothesis (per mu > 0 and soft code, judged by the report's rules): the soft
code lands where the elastic selection says -- closer to ``sel`` than to both
references that need no soft physics, the jammed state ``cd`` and the centre of S,
at every kt/kn of the packing; counted over packings (:func:`judge`).

The tasks import ``forcespace_adapters`` (installed alongside forcespace)
inside the task function only: forcespace itself never imports the adapters.
"""
from __future__ import annotations

from itertools import combinations
from pathlib import Path

import numpy as np

import forcespace as fs
from forcespace.extend import (chebyshev_centre, distance_to_S, implicit_equalities,
                               packing_overlaps)
from .runner import Task

from .common import shared_packing
from .stats import binomial_interval, bootstrap_mean, majority_call, packings_to_decide

# landed_tol: a soft network counts when it has no contact outside the rigid network
# and lies this close to S (/ <Fn>); at K = 1e5 the geometry change alone puts it ~1e-3
# away (quick), from K = 1e6 on below 1e-4 (soft_vs_rigid.md, liggghts_ladder.md).
# packings: (mu, packings = seeds 1..k). mu = 0 keeps 3: its S is one point (frictionless
# and isostatic), every admissible network is the same up to round-off, so there is
# nothing to predict; its packings check that the codes land in that point.
# Cost (measured, one full task, mu = 0.1 seed 1, nice'd on a busy 2-core machine): jam
# 19 CPU s, the task 81 CPU s (LIGGGHTS 15 s: both kt/kn converged at K = 1e7 in ~290 000
# steps, 8-9 s each; the analysis 65 s; pymunk 0.3 s): ~100 CPU s per packing, 23
# packings ~40 CPU min. A packing whose stiffest K does not land runs the rest of the
# ladder (each run at most max_steps = 1.5e6 steps, ~45 CPU s).
QUICK = dict(scene="quick", n_disks=30, packings=((0.1, 1), (0.5, 1)), kt_ratios=(2 / 7, 1.0),
             K=(1e5,), pymunk=(30, 0.01), max_steps=300_000, landed_tol=1e-2)
FULL = dict(scene="paper", n_disks=200, packings=((0.0, 3), (0.1, 10), (0.5, 10)),
            kt_ratios=(2 / 7, 1.0), K=(1e7, 3e6, 1e6), pymunk=(100, 0.003),
            max_steps=1_500_000, landed_tol=1e-4)
NETWORKS = ("lig", "pym", "sel", "sel_ov", "na_sel", "na_lig", "cd", "centre")
SLIDE_TOL = 1e-2      # sliding: |ft| >= mu fn (1 - SLIDE_TOL) (soft forces are mapped onto
#                       the rigid frames, which turns ft by ~overlap/R: 1e-5..1e-3 of mu fn)
PYMUNK_MAX_STEPS = 20_000
CODES = {"lig": "LIGGGHTS", "pym": "pymunk"}
REFERENCES = ("cd", "centre")    # the predictions that need no soft physics
CONVERGED, LANDED, NOT_LANDED = "converged", "landed", "not landed"


def config(quick: bool) -> dict:
    return QUICK if quick else FULL


def tasks(quick: bool = False) -> list[Task]:
    cfg = config(quick)
    out = []
    for seed in range(1, max(k for _, k in cfg["packings"]) + 1):
        for mu, k in cfg["packings"]:
            if seed > k:
                continue
            # without friction kt never enters (no tangential force in any network):
            # one ratio is the whole answer, the second would repeat it bit for bit
            ratios = list(cfg["kt_ratios"]) if mu > 0 else list(cfg["kt_ratios"])[:1]
            out.append(Task(f"mu{mu:g}_s{seed}", "forcespace_studies.selection:landing_task",
                            dict(scene=cfg["scene"], n_disks=cfg["n_disks"], mu=mu, seed=seed,
                                 kt_ratios=ratios, K=list(cfg["K"]),
                                 pymunk=list(cfg["pymunk"]), max_steps=cfg["max_steps"],
                                 landed_tol=cfg["landed_tol"])))
    return out


def lands(run: dict, landed_tol: float) -> bool:
    """A soft network lands in S: no contact outside the rigid network (every soft
    contact maps onto a rigid one) and within ``landed_tol`` <Fn> (rms per contact) of S."""
    return run["unmatched"] == 0 and float(run["distance_to_S"]) < landed_tol


def _run_converged(run: dict) -> bool:
    # task JSON written before the key was named run_converged call it "converged": the
    # soft run's own stop test, never whether the network landed
    return bool(run.get("run_converged", run.get("converged")))


def landing(runs, landed_tol: float) -> dict:
    """The label of one packing and kt/kn, from the LIGGGHTS runs of the ladder in the
    order tried (stiffest first): the first run that :func:`lands` is the network kept,
    "converged" when it also met LIGGGHTS' stop test (static residual and plate force
    within tolerance), "landed" when it stopped at the step cap; no run lands: "not
    landed", with the run closest to S. {label, K, distance, steps, unmatched, lost}."""
    for q in runs:
        if lands(q, landed_tol):
            return {"label": CONVERGED if _run_converged(q) else LANDED, "K": q.get("K"),
                    "distance": float(q["distance_to_S"]), "steps": q.get("steps"),
                    "unmatched": 0, "lost": q.get("lost")}
    if not runs:
        return {"label": NOT_LANDED, "K": None, "distance": float("nan"), "steps": None,
                "unmatched": None, "lost": None}
    best = min(runs, key=lambda q: float(q["distance_to_S"]))
    return {"label": NOT_LANDED, "K": best.get("K"), "distance": float(best["distance_to_S"]),
            "steps": best.get("steps"), "unmatched": best["unmatched"], "lost": best.get("lost")}


def pymunk_landing(row: dict, landed_tol: float) -> dict:
    """:func:`landing` of the packing's one pymunk run (no stiffness ladder)."""
    return landing([{"K": None, "unmatched": row["pym_unmatched"],
                     "distance_to_S": row["pym_distance_to_S"],
                     "lost": row.get("pym_lost"),
                     "run_converged": row.get("pym_converged")}], landed_tol)


def label_text(lab: dict) -> str:
    """A landing label as the report writes it."""
    at = f" at K = {lab['K']:g}" if lab.get("K") is not None else ""
    if lab["label"] == CONVERGED:
        return f"converged{at} ({lab['distance']:.2g} <Fn> from S)"
    if lab["label"] == LANDED:
        steps = f", {lab['steps']} steps" if lab.get("steps") is not None else ""
        return (f"landed within {lab['distance']:.2g} <Fn> of S{at} (stopped at the step "
                f"cap{steps})")
    if lab.get("unmatched") is None:
        return "not landed (no run)"
    best = f"best K = {lab['K']:g}: " if lab.get("K") is not None else ""
    return (f"not landed ({best}{lab['distance']:.2g} <Fn> from S, {lab['unmatched']} "
            f"contact(s) outside the rigid network, {lab['lost']} lost)")


def _sliding(x, mu, scale):
    fn, ft = x[0::2], x[1::2]
    return (mu > 0) & (fn > 1e-6 * scale) & (np.abs(ft) >= mu * fn * (1 - SLIDE_TOL))


def nonassociated(S, kn, kt, overlap, sliding, sign, opened):
    """Linear springs with true (non-associated) Coulomb sliding on a given set.

    Sticking contacts: fn/kn = overlap + n.(u_a - u_b), ft/kt from the slip
    (the compatibility rows of :mod:`forcespace.space.selection`); ``sliding`` (m,)
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
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks)
    origin = "jammed" if t_jam else "reused"
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
                                                       max_steps=PYMUNK_MAX_STEPS))
        soft.meta.update({k: v for k, v in info.items()
                          if isinstance(v, (bool, int, float, str))})
        fs.write_packing(soft, pfile, kind="soft_network")
    x_pym, c_pym = landed(soft)
    base.update({"pym_distance_to_S": c_pym["relative_distance"],
                 "pym_unmatched": c_pym["unmatched_contacts"],
                 "pym_lost": c_pym["lost_contacts"],
                 "pym_converged": c_pym["soft_run_converged"]})
    base["pym_label"] = pymunk_landing(base, landed_tol)["label"]

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
            # run_converged: LIGGGHTS' own stop test (static residual, plate force);
            # whether its network landed in S: lands()
            rec = {"K": k, "kn": kn, "run_converged": bool(info.get("converged")),
                   "steps": info.get("steps"), "distance_to_S": c["relative_distance"],
                   "unmatched": c["unmatched_contacts"], "lost": c["lost_contacts"],
                   "max_overlap": c["max_overlap"]}
            tried.append(rec)
            if lands(rec, landed_tol):
                lig = (xl, rec)
                break
        sel = fs.Selection(kt_ratio=ratio).compute(S)
        xs = {"pym": x_pym, "sel": sel.x, "cd": S.x_jammed, "centre": centre}
        row = dict(base, kt_ratio=ratio, lig_runs=tried,
                   n_sliding_sel=int(sel.sliding_contacts.size),
                   lig_label=landing(tried, landed_tol)["label"])
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
ROW_KEYS = ["task", "mu", "seed", "kt_ratio", "packing", "n_contacts", "centre_radius",
            "lig_label", "lig_K", "lig_run_converged", "lig_steps", "lig_distance_to_S",
            "pym_label", "pym_converged", "pym_distance_to_S", "lig_closer", "pym_closer"] + [
    f"d_{a}_{b}" for a, b in PAIRS] + [
    "d_pym_centre", "n_sliding_lig", "n_sliding_sel", "n_sliding_sel_ov", "n_sliding_cd",
    "n_sliding_pym", "n_sliding_lig_and_sel_ov", "share_sliding_sel_ov",
    "d_lig_sel_ov_sticking", "d_lig_sel_sticking", "na_lig_violation", "na_sel_violation",
    "na_lig_residual", "lig_slip", "lig_normal_misfit", "sel_slip", "sel_normal_misfit",
    "pym_slip", "pym_normal_misfit", "cd_slip", "cd_normal_misfit", "centre_slip",
    "centre_normal_misfit", "kt_effect_lig", "kt_effect_sel", "kt_effect_cosine"]


# ----------------------------------------------------------------------------
# the decision: packings are the unit
# ----------------------------------------------------------------------------
def _rows(results) -> list[dict]:
    """The rows of the tasks that ran, each with its task's name and landing tolerance,
    labelled (:func:`landing`, :func:`pymunk_landing`) and with the per-row test
    (:func:`closer`) of both codes."""
    out = []
    for res in results:
        if not res.get("ok"):
            continue
        tol = float((res.get("params") or {}).get("landed_tol", FULL["landed_tol"]))
        for r in res.get("rows", []):
            r = dict(r, task=res.get("task"), landed_tol=tol)
            lab = landing(r.get("lig_runs") or [], tol)
            r["lig_label"] = lab["label"]
            if lab["label"] != NOT_LANDED:
                r["lig_run_converged"] = lab["label"] == CONVERGED
            r["pym_label"] = pymunk_landing(r, tol)["label"]
            for code in CODES:
                r[f"{code}_closer"] = closer(r, code)
            out.append(r)
    return out


def _label(row: dict, code: str) -> dict:
    if code == "lig":
        return landing(row.get("lig_runs") or [], row["landed_tol"])
    return pymunk_landing(row, row["landed_tol"])


def closer(row: dict, code: str):
    """Is the soft network of ``code`` ("lig", "pym") closer to the elastic selection
    than to every reference that needs no soft physics (the jammed state, the centre
    of S)? None when the network did not land or a distance is missing."""
    if _label(row, code)["label"] == NOT_LANDED:
        return None
    d = [row.get(f"d_{code}_{b}") for b in ("sel",) + REFERENCES]
    if any(x is None or not np.isfinite(x) for x in d):
        return None
    return bool(d[0] < min(d[1:]))


def judge(rows: list[dict], code: str, mu: float) -> dict:
    """The hypothesis for ``code`` at ``mu``, counted over packings.

    A packing (seed) enters when its soft network landed at every kt/kn of it (labels
    "converged" or "landed", counted apart); it counts for the hypothesis when
    :func:`closer` holds at every kt/kn. Verdict: "supported" when the exact 95 %
    interval of the fraction of entered packings that count lies above 1/2, "not
    supported" when below, else "not decidable" (``needed``: the packings that would
    decide it if the fraction stayed)."""
    packs: dict = {}
    for r in rows:
        if r["mu"] == mu:
            packs.setdefault(r["seed"], []).append(r)
    per = []
    for seed, rs in sorted(packs.items()):
        rs = sorted(rs, key=lambda r: r["kt_ratio"])
        labs = [_label(r, code) for r in rs]
        tests = [closer(r, code) for r in rs]
        entered = all(t is not None for t in tests)
        ratio = None
        if entered:
            ratio = float(np.mean([r[f"d_{code}_sel"] / max(min(r[f"d_{code}_{b}"]
                                                                 for b in REFERENCES), 1e-300)
                                   for r in rs]))
        per.append({"seed": seed, "labels": [q["label"] for q in labs],
                    "landed_distances": [q["distance"] for q in labs
                                         if q["label"] != NOT_LANDED],
                    "kt_ratios": [r["kt_ratio"] for r in rs], "tests": tests,
                    "entered": entered, "holds": entered and all(tests),
                    "all_converged": entered and all(q["label"] == CONVERGED for q in labs),
                    "ratio": ratio,
                    "distances": {b: float(np.mean([r[f"d_{code}_{b}"] for r in rs]))
                                  for b in ("sel",) + REFERENCES} if entered else None})
    ent = [q for q in per if q["entered"]]
    n, k = len(ent), sum(q["holds"] for q in ent)
    conv = [q for q in ent if q["all_converged"]]
    lo, hi = binomial_interval(k, n)
    call = majority_call(k, n) if n else "undecided"
    verdict = {"most": "supported", "few": "not supported"}.get(call, "not decidable")
    kts = sorted({kt for q in ent for kt in q["kt_ratios"]})
    capped = [d for q in ent for lab, d in zip(q["labels"], q["landed_distances"])
              if lab == LANDED]
    boot = bootstrap_mean({"ratio": [q["ratio"] for q in ent],
                           **{net: [q["distances"][net] for q in ent]
                              for net in ("sel",) + REFERENCES}}) if n else {}
    radius = [r["centre_radius"] for r in rows if r["mu"] == mu and r.get("centre_radius")]
    return {"code": code, "mu": mu, "packings": len(per), "entered": n, "holds": k,
            "centre_radius": float(np.mean(radius)) if radius else float("nan"),
            "fraction": k / n if n else None, "ci95": [lo, hi], "call": call,
            "verdict": verdict, "needed": packings_to_decide(k, n) if call == "undecided"
            else None,
            "entered_all_converged": len(conv), "holds_all_converged":
                sum(q["holds"] for q in conv),
            "entered_with_capped_runs": n - len(conv),
            "capped_max_distance": max(capped) if capped else None,
            "not_landed_seeds": [q["seed"] for q in per if not q["entered"]],
            "per_kt": {f"{kt:.3g}": {"holds": sum(1 for q in ent for t, x in
                                                  zip(q["kt_ratios"], q["tests"])
                                                  if t == kt and x), "packings": n}
                       for kt in kts},
            "ratio_to_nearest_reference": boot.get("ratio"),
            "mean_distance": {net: boot.get(net) for net in ("sel",) + REFERENCES},
            "per_packing": per}


def _verdict(j: dict):
    from .report import Verdict

    name, mu = CODES[j["code"]], j["mu"]
    claim = (f"{name} lands where the elastic selection says (mu = {mu:g}): its network "
             f"is closer to the selection — minimum complementary energy over S — than to "
             f"the jammed contact-dynamics state and to the centre of S, at every kt/kn")
    rule = ("per packing: rms distance (networks projected onto S) to the selection below "
            "that to the jammed state and to the centre of S at every kt/kn of the "
            "packing; a packing enters when its soft network landed at every kt/kn (no "
            "contact outside the rigid network, within the landing tolerance of S); "
            "supported when the exact (Clopper-Pearson) 95 % interval of the fraction of "
            "entered packings lies above 1/2, not supported when below, not decidable "
            "otherwise")
    if not j["entered"]:
        return Verdict("selection", claim, f"no packing entered ({j['packings']} run, none "
                       "landed at every kt/kn)", "not decidable", kind="hypothesis", rule=rule)
    lo, hi = j["ci95"]
    ours = (f"holds on {j['holds']} of {j['entered']} packings (fraction "
            f"{j['fraction']:.2f}, 95 % exact interval {lo:.2f}–{hi:.2f}); entered "
            f"{j['entered']} of {j['packings']}: {j['entered_all_converged']} with every "
            f"kt/kn converged, {j['entered_with_capped_runs']} with a run stopped at the "
            f"step cap that landed"
            + (f" within {j['capped_max_distance']:.2g} <Fn> of S"
               if j["capped_max_distance"] is not None else "")
            + f"; not landed: {len(j['not_landed_seeds'])}"
            + (f" (seeds {', '.join(map(str, j['not_landed_seeds']))})"
               if j["not_landed_seeds"] else "")
            + "; per kt/kn: " + ", ".join(f"{kt}: {c['holds']} of {c['packings']}"
                                          for kt, c in j["per_kt"].items())
            + f"; on the packings with every run converged: {j['holds_all_converged']} "
              f"of {j['entered_all_converged']}")
    r, m = j["ratio_to_nearest_reference"], j["mean_distance"]
    if r:
        ours += (f"; distance to the selection / to the nearer reference {r[0]:.2f} "
                 f"[{r[1]:.2f}, {r[2]:.2f}] (mean over packings, bootstrap 95 %); mean "
                 f"distances to selection / jammed / centre {m['sel'][0]:.3g} / "
                 f"{m['cd'][0]:.3g} / {m['centre'][0]:.3g} <Fn> (S's inscribed radius "
                 f"{j['centre_radius']:.2g} <Fn>)")
    if j["needed"]:
        ours += (f"; undecided: at this fraction {j['needed']} packings would decide it")
    elif j["call"] == "undecided":
        ours += "; undecided, and no number of packings decides it at this fraction"
    return Verdict("selection", claim, ours, j["verdict"], kind="hypothesis", rule=rule)


def summarize(results: list[dict], out) -> dict:
    """selection.csv (one row per packing and kt/kn, with the landing labels),
    selection_table.md (means over packings), selection.png/.pdf, verdicts.json and
    REPORT.md."""
    from .report import (RULES_VERSION, failed_tasks_note, failures_per_mu, write_csv,
                         write_section)

    out = Path(out)
    rows = _rows(results)
    failed = [r for r in results if not r.get("ok")]
    write_csv(out / "selection.csv", rows, ROW_KEYS)
    table = _table(rows)
    (out / "selection_table.md").write_text(
        "rms per-contact distance / <Fn> (mean ± std over packings; landed LIGGGHTS "
        "networks only)\n\n" + table + "\n")
    mus = sorted({r["mu"] for r in rows})
    judged = [judge(rows, code, mu) for mu in mus if mu > 0 for code in CODES]
    verdicts = [_verdict(j) for j in judged]
    figures = []
    if rows:
        _figure(rows, judged, out)
        figures = ["selection.png"]
    numbers = {"rows": len(rows), "tasks": len(results), "tasks_failed": len(failed),
               "failed": [f"{r.get('task')}: {r.get('error')}" for r in failed],
               "failed_per_mu": failures_per_mu(failed),
               "labels": {f"mu{mu:g}": {code: {lab: sum(1 for r in rows if r["mu"] == mu
                                                         and r[f"{code}_label"] == lab)
                                               for lab in (CONVERGED, LANDED, NOT_LANDED)}
                                        for code in CODES} for mu in mus},
               "hypothesis": {f"{CODES[j['code']]}/mu{j['mu']:g}":
                              {k: v for k, v in j.items() if k != "per_packing"}
                              for j in judged},
               "per_packing": {f"{CODES[j['code']]}/mu{j['mu']:g}": j["per_packing"]
                               for j in judged}}
    text = _text(rows, results, judged, table) + failed_tasks_note(failed, results)
    write_section(out, "selection", "Where in S a soft code lands: the elastic selection",
                  text, verdicts, numbers, figures, rules_version=RULES_VERSION)
    return {"tasks": len(results), "failed": len(failed), "rows": len(rows),
            "table": str(out / "selection.csv"), "markdown": str(out / "selection_table.md"),
            "figure": str(out / "selection.png"), "verdicts": [v.verdict for v in verdicts]}


def _stat(vals):
    v = [x for x in vals if x is not None and np.isfinite(x)]
    return (float(np.mean(v)), float(np.std(v)), len(v)) if v else (np.nan, np.nan, 0)


def _table(rows) -> str:
    """Markdown: per (mu, kt/kn) the mean ± std over packings of every pair's distance."""
    lines = ["| mu | kt/kn | packings (LIGGGHTS landed) | " + " | ".join(
        f"{a}–{b}" for a, b in PAIRS) + " | sliding lig / sel / sel_ov / cd |",
             "|" + "---|" * (len(PAIRS) + 4)]
    for mu, ratio in sorted({(r["mu"], r["kt_ratio"]) for r in rows}):
        g = [r for r in rows if r["mu"] == mu and r["kt_ratio"] == ratio]
        cells = []
        for a, b in PAIRS:
            m, s, n = _stat([r.get(f"d_{a}_{b}") for r in g])
            cells.append("–" if n == 0 else f"{m:.3g} ± {s:.2g}" if n > 1 else f"{m:.3g}")
        sl = " / ".join(f"{_stat([r.get(k) for r in g])[0]:.3g}" for k in
                        ("n_sliding_lig", "n_sliding_sel", "n_sliding_sel_ov", "n_sliding_cd"))
        landed = sum(r["lig_label"] != NOT_LANDED for r in g)
        lines.append(f"| {mu:g} | {ratio:.3g} | {len(g)} ({landed}) | " + " | ".join(cells)
                     + f" | {sl} |")
    return "\n".join(lines)


def _protocol(rows, results) -> str:
    from forcespace_adapters.liggghts import PRECISION_FACTOR, LiggghtsOptions
    from forcespace_adapters.pymunk_sim import PymunkOptions

    params = next((r.get("params") for r in results if r.get("params")), {}) or {}
    lo, po = LiggghtsOptions(), PymunkOptions()
    it, dt = params.get("pymunk", ("?", "?"))
    K = ", ".join(f"{k:g}" for k in sorted(params.get("K", ()), reverse=True))
    kts = sorted({r["kt_ratio"] for r in rows if r["mu"] > 0})
    return (
        f"Protocol. Packings: the {params.get('scene', '?')} scene, "
        f"{params.get('n_disks', '?')} disks, jammed by contact dynamics, one per (mu, "
        f"seed); S is the plate S (the top plate's contacts are unknowns, its load a row), "
        f"the S the soft runs see. **LIGGGHTS** 3.8: hooke/stiffness with tangential "
        f"history (Coulomb-capped spring), kn = K <Fn>/R on the ladder K = {K} tried "
        f"stiffest first (the first network that lands is kept), kt/kn = "
        f"{', '.join(f'{k:.3g}' for k in kts)} (one ratio at mu = 0, where kt never "
        f"enters), damping ratio {lo.damping_ratio:g}, dt = t_c × {lo.dt_fraction:g}, loads "
        f"ramped in over {lo.ramp_steps} steps, frictionless load-controlled top plate "
        f"(servo, integral term near convergence); a run stops when, with velocities "
        f"zeroed, every disk's residual is below 1e-6 <Fn> raised to the precision floor "
        f"{PRECISION_FACTOR:g} K ulp(L) (1.4e-5 <Fn> at K = 1e7 in the paper box) and the "
        f"plate force is within tolerance × sqrt(N_top), checked every {lo.check_every} "
        f"steps, else at {params.get('max_steps', '?')} steps. **pymunk** 7: one run per "
        f"packing (no stiffness), {it} solver iterations, dt = {dt} sqrt(m_min R/<Fn>), "
        f"damping {po.damping:g}, slop {po.slop:g} R, bias {po.bias:g}, loads ramped over "
        f"{po.ramp_steps} steps, stop at a residual of {po.tolerance:g} <Fn> or "
        f"{PYMUNK_MAX_STEPS} steps. **Mapping onto S**: soft contacts are matched to the "
        f"rigid ones and their forces taken in the rigid contact frames (a rigid contact "
        f"the soft run lost carries 0); then the Euclidean projection onto S; distances are "
        f"between projections, rms per contact in <Fn>. A soft network **lands** when it "
        f"has no contact outside the rigid network and lies within "
        f"{params.get('landed_tol', '?'):g} <Fn> of S. Labels: **converged** — it landed "
        f"and the run met its own stop test; **landed** — it landed but the run stopped at "
        f"the step cap (the distance is stated); **not landed** — no K of the ladder "
        f"landed (the packing leaves the verdict, its closest run is listed). The "
        f"elastic selection (sel) is `forcespace.Selection`: minimum complementary energy of "
        f"linear springs (kt/kn as in LIGGGHTS) over S, springs starting stress-free.")


def _text(rows, results, judged, table) -> str:
    if not rows:
        return "No finished task."
    lines = [_protocol(rows, results), ""]
    lines += ["Decision (fixed before the run): per mu > 0 and soft code, the packing is "
              "the unit. A packing counts for the hypothesis when the code's network is "
              "closer to the selection than to the jammed state and to the centre of S at "
              "every kt/kn (both kt/kn are one packing's test, not two samples); it enters "
              "only when the code landed at every kt/kn. Supported: the exact "
              "(Clopper-Pearson) 95 % interval of the fraction of entered packings above "
              "1/2; not supported: below; otherwise not decidable. At mu = 0 there is no "
              "verdict: S is one point (frictionless, isostatic), every network in it is "
              "the same up to round-off (distances ~1e-9 <Fn>), so its packings only check "
              "that the codes land there.", ""]
    lines += ["| mu | code | packings | converged (all kt/kn) | landed at the step cap | "
              "not landed | entered | holds | fraction [95 % exact] | verdict |",
              "|" + "---|" * 10]
    for mu in sorted({r["mu"] for r in rows}):
        for code in CODES:
            j = next((j for j in judged if j["mu"] == mu and j["code"] == code), None)
            if j is None:      # mu = 0: labels only
                packs = sorted({r["seed"] for r in rows if r["mu"] == mu})
                labs = [r[f"{code}_label"] for r in rows if r["mu"] == mu]
                dist = [_label(r, code)["distance"] for r in rows if r["mu"] == mu
                        and r[f"{code}_label"] != NOT_LANDED]
                lines.append(f"| {mu:g} | {CODES[code]} | {len(packs)} | "
                             f"{labs.count(CONVERGED)} | {labs.count(LANDED)} | "
                             f"{labs.count(NOT_LANDED)} | – | – | – | no verdict "
                             f"(S is a point; landed within "
                             f"{max(dist) if dist else float('nan'):.2g} <Fn>) |")
                continue
            lo, hi = j["ci95"]
            frac = (f"{j['fraction']:.2f} [{lo:.2f}, {hi:.2f}]" if j["entered"] else "–")
            lines.append(f"| {mu:g} | {CODES[code]} | {j['packings']} | "
                         f"{j['entered_all_converged']} | {j['entered_with_capped_runs']} | "
                         f"{len(j['not_landed_seeds'])} | {j['entered']} | {j['holds']} | "
                         f"{frac} | {j['verdict']} |")
    labelled = []
    for r in sorted(rows, key=lambda r: (r["mu"], r["seed"], r["kt_ratio"])):
        for code in CODES:
            if code == "pym" and r["kt_ratio"] != min(q["kt_ratio"] for q in rows
                                                       if q["mu"] == r["mu"]
                                                       and q["seed"] == r["seed"]):
                continue        # one pymunk run per packing
            lab = _label(r, code)
            if lab["label"] != CONVERGED:
                kt = f", kt/kn = {r['kt_ratio']:.3g}" if code == "lig" else ""
                labelled.append(f"- {CODES[code]}, mu = {r['mu']:g}, seed {r['seed']}{kt}: "
                                f"{label_text(lab)}")
    lines += ["", "Soft networks not labelled converged (a landed one enters the verdicts, "
              "a not-landed one leaves its packing out):", ""]
    lines += labelled or ["- none: every run converged and landed"]
    lines += ["", "Distances between the networks per mu and kt/kn (the LIGGGHTS columns over "
              "the landed networks only):", "", table]
    return "\n".join(lines)


def _figure(rows, judged, out) -> None:
    """Left: every pair's distance per (mu, kt/kn); right: per entered packing and
    kt/kn, the distance of each soft network to the selection against that to the
    nearer reference (below the diagonal: closer to the selection)."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

    from forcespace.extend import save_figure

    fig = Figure(figsize=(15, 5))
    ax, bx = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.5, 1]})
    groups = sorted({(r["mu"], r["kt_ratio"]) for r in rows})
    for i, (a, b) in enumerate(PAIRS):
        for k, (mu, ratio) in enumerate(groups):
            v = [r.get(f"d_{a}_{b}") for r in rows if r["mu"] == mu and r["kt_ratio"] == ratio]
            v = [x for x in v if x is not None]
            if v:
                ax.plot(np.full(len(v), k + (i - len(PAIRS) / 2) * 0.07), np.maximum(v, 1e-12),
                        MARKERS[i % len(MARKERS)], color=f"C{i % 10}", mfc="none")
        ax.plot([], [], MARKERS[i % len(MARKERS)], color=f"C{i % 10}", mfc="none",
                label=f"{a}–{b}")
    ax.set_xticks(np.arange(len(groups)), [f"mu={mu:g}\nkt/kn={ratio:.2g}"
                                           for mu, ratio in groups])
    ax.set_yscale("log")
    ax.set_ylabel("rms distance per contact / <Fn>")
    ax.set_title("Where in S the networks land (lig: LIGGGHTS, pym: pymunk, sel: elastic "
                 "selection, sel_ov: from the rigid overlaps,\nna_*: true Coulomb on given "
                 "sliding sets, cd: jammed, centre of S); landed LIGGGHTS networks only",
                 fontsize=8)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
    lim = [np.inf, 0.0]
    for i, mu in enumerate(sorted({r["mu"] for r in rows if r["mu"] > 0})):
        for code, mk in (("lig", "o"), ("pym", "s")):
            for lab, fill in ((CONVERGED, True), (LANDED, False)):
                seeds = {q["seed"] for j in judged if j["mu"] == mu and j["code"] == code
                         for q in j["per_packing"] if q["entered"]}
                pts = [(min(r[f"d_{code}_{b}"] for b in REFERENCES), r[f"d_{code}_sel"])
                       for r in rows if r["mu"] == mu and r["seed"] in seeds
                       and _label(r, code)["label"] == lab]
                if not pts:
                    continue
                x, y = np.array(pts).T
                lim = [min(lim[0], x.min(), y.min()), max(lim[1], x.max(), y.max())]
                bx.plot(x, y, mk, color=f"C{i}", mfc=f"C{i}" if fill else "none", alpha=0.7,
                        label=f"mu = {mu:g}, {CODES[code]}, {lab}"
                              + (" (step cap)" if lab == LANDED else ""))
    if np.isfinite(lim[0]) and lim[1] > 0:
        span = [lim[0] / 1.5, lim[1] * 1.5]
        bx.plot(span, span, "k:", lw=0.8, label="equal distance")
        bx.set(xscale="log", yscale="log", xlim=span, ylim=span, aspect="equal")
        for axis in (bx.xaxis, bx.yaxis):      # 1, 2, 5 per decade: S spans ~1 decade
            axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
            axis.set_major_formatter(FormatStrFormatter("%g"))
            axis.set_minor_formatter(NullFormatter())
        bx.legend(fontsize=7, loc="best", framealpha=0.6)
    bx.set(xlabel="distance to the nearer of jammed state and centre of S / <Fn>",
           ylabel="distance to the elastic selection / <Fn>")
    bx.set_title("entered packings, each kt/kn; below the diagonal: the soft network is\n"
                 "closer to the selection (filled: converged; open: landed, step cap)",
                 fontsize=8)
    save_figure(fig, out / "selection.png", tight=True)
