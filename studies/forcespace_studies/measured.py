"""Measured networks against S: the readers' round trip, and noisy networks checked.

Two kinds of task, each on one jammed packing (bundled scene, mu, seed):

* ``rt_*`` -- the round trip of every reader: the packing written as a CSV pair, a PeGS
  frame in the matrix layout and in PeGS2's own files (pixels, y down, both estimates of
  a contact equal) and a LIGGGHTS dump pair (:mod:`forcespace.io.readers`), read back,
  and S of the same region compared with the native file's: dim S and every contact's
  range of fn and ft (contacts matched by their two disks; max |difference| in <Fn>).
  Region: the paper's slice for the formats with a period (CSV, LAMMPS); for PeGS (an
  image has no period, its writers leave the contacts across the periodic seam out) the
  slice minus the disks with such a contact, on both.
* ``noise_*`` -- the jammed network as a measurement: Gaussian noise of ``levels`` x <Fn>
  added to fn and ft of every force-bearing contact (<Fn> the jammed mean), with and
  without the weakest ``drop`` fraction of the force-bearing contacts removed (a
  photoelastic inversion misses weak contacts), and with the weakest ``drop`` fraction of
  the slice's force-bearing unknown contacts kept as geometry with their force unknown
  (``missing="unknown"``: the image shows the disks touching, the fit gives no force;
  at the slice's boundary, where forces are loads, they stay measured), checked on the
  paper's slice
  (:class:`forcespace.space.measured.Measured`: its loads are the noisy forces at the
  contacts that cross the slice's boundary). Per condition: whether S at the measured
  loads is empty (and the smallest relaxation), the distance to S (at the measured loads,
  or at the least adjusted loads when S is empty), the fraction of true contact forces
  (fn and ft both) inside their reported ranges, and the rms errors of the noisy input
  (an unknown force counted as 0) and of the nearest admissible network against the truth,
  over the slice's unknown contacts.

The readings of the hypotheses are the constants below, fixed before the runs.
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

import forcespace as fs
from forcespace import (Measured, Region, frame_problem, read_csv_pair, read_lammps_dump,
                        read_pegs, read_pegs2)
from forcespace.extend import (Measurement, write_csv_pair, write_lammps_dump, write_pegs,
                               write_pegs2)

from .common import shared_packing
from .runner import Task

FORMATS = ("csv", "pegs", "pegs2", "lammps")
PIXEL = 0.05              # [R per pixel] of the PeGS frames (disks 20-40 pixels across)
RT_TOL = 1e-9             # [<Fn>] a round trip keeps S: equal dim S, every range within this
INSIDE_TOL = 1e-6         # [<Fn>] a true force lies in its range to this (config.VARY_TOL)
COVERS = 0.95             # "the ranges contain the truth": >= 95 % of the true forces inside
QUICK = dict(scene="quick", n_disks=40, slice_height=10.0, rt=((0.1, 1), (0.5, 1), (1.0, 1)),
             noise=((0.5, 2),), levels=(0.0, 0.01, 0.05, 0.2), drop=0.05)
FULL = dict(scene="paper", n_disks=200, slice_height=28.0, rt=((0.1, 3), (0.5, 3), (1.0, 3)),
            noise=((0.1, 10), (0.5, 10)), levels=(0.0, 0.01, 0.05, 0.2), drop=0.05)


def config(quick: bool) -> dict:
    return QUICK if quick else FULL


def tasks(quick: bool = False) -> list[Task]:
    cfg = config(quick)
    common = dict(scene=cfg["scene"], n_disks=cfg["n_disks"], slice_height=cfg["slice_height"])
    out = [Task(f"rt_mu{mu:g}_s{seed}", "forcespace_studies.measured:round_trip_task",
                dict(common, mu=mu, seed=seed))
           for mu, k in cfg["rt"] for seed in range(1, k + 1)]
    out += [Task(f"noise_mu{mu:g}_s{seed}", "forcespace_studies.measured:noise_task",
                 dict(common, mu=mu, seed=seed, levels=list(cfg["levels"]), drop=cfg["drop"]))
            for mu, k in cfg["noise"] for seed in range(1, k + 1)]
    return out


# ---------------------------------------------------------------------- round trip
def slice_disks(p, height: float) -> np.ndarray:
    """Indices of the disks of the paper's slice (centres within height/2 of the middle
    between the plates)."""
    yc = 0.5 * (p.y_bottom + p.y_top) if np.isfinite(p.y_top) else 0.5 * (p.y.min() + p.y.max())
    return np.flatnonzero(np.abs(p.y - yc) <= 0.5 * height)


def seam_disks(p) -> np.ndarray:
    """Disks with a contact across the periodic seam (image != 0)."""
    k = p.image != 0
    return np.unique(np.concatenate([p.a[k], p.b[k]]))


def write_format(p, fmt: str, directory):
    """Write ``p`` in ``fmt`` into ``directory``; returns the reader call that reads it."""
    d = Path(directory)
    if fmt == "csv":
        write_csv_pair(p, d)
        return lambda: read_csv_pair(d / "particles.csv", d / "contacts.csv", mu=p.mu,
                                     wall_mu=p.plate_mu, width=p.width, length_unit="R",
                                     force_unit="F0")
    if fmt == "pegs":
        files = write_pegs(p, d, pixel_scale=PIXEL)["paths"]
        return lambda: read_pegs(files["particles"], pixel_scale=PIXEL, mu=p.mu,
                                 wall_mu=p.plate_mu, edge_column=4, length_unit="R",
                                 force_unit="F0")
    if fmt == "pegs2":
        files = write_pegs2(p, d, pixel_scale=PIXEL)["paths"]
        return lambda: read_pegs2(files["adjacency"], files["positions"], pixel_scale=PIXEL,
                                  mu=p.mu, wall_mu=p.plate_mu, length_unit="R",
                                  force_unit="F0")
    atoms, contacts = write_lammps_dump(p, d)
    return lambda: read_lammps_dump(atoms, contacts, mu=p.mu, wall_mu=p.plate_mu,
                                    length_unit="R", force_unit="F0")


def _ranges_by_pair(p, prob, S) -> dict:
    """{(disk, disk): (fn_min, fn_max, ft_min, ft_max)} of the problem's disk-pair contacts."""
    out = {}
    for j, k in enumerate(prob.contacts):
        a, b = int(p.a[k]), int(p.b[k])
        out[(min(a, b), max(a, b))] = np.concatenate([S.fn_range[j], S.ft_range[j]])
    return out


def round_trip(p, fmt: str, directory, height: float) -> dict:
    """Write ``p`` as ``fmt``, read it back and compare S of the same region (module
    docstring): {format, region_disks, dim_native, dim_read, n_contacts_native,
    n_contacts_read, matched, max_range_diff (<Fn>), same (bool)}."""
    region = slice_disks(p, height)
    if fmt.startswith("pegs"):
        region = np.setdiff1d(region, seam_disks(p))
    t0 = time.process_time()
    q = write_format(p, fmt, directory)()
    t_read = time.process_time() - t0
    out = {"format": fmt, "region_disks": int(region.size), "read_cpu_s": t_read}
    res = []
    for pk in (p, q):
        prob = frame_problem(pk, Region("disks", region))
        S = fs.ForceSpace(ranges=True).compute(prob)
        res.append((pk, prob, S))
    (_, pn, Sn), (_, pr, Sr) = res
    rn, rr = _ranges_by_pair(p, pn, Sn), _ranges_by_pair(q, pr, Sr)
    common = set(rn) & set(rr)
    diff = max((float(np.max(np.abs(rn[k] - rr[k]))) for k in common), default=0.0)
    out.update(dim_native=Sn.dim, dim_read=Sr.dim, n_contacts_native=pn.n_contacts,
               n_contacts_read=pr.n_contacts, matched=len(common),
               max_range_diff=diff / pn.force_scale)
    out["same"] = bool(out["dim_native"] == out["dim_read"] and len(common) == len(rn)
                       == len(rr) and out["max_range_diff"] <= RT_TOL)
    return out


def round_trip_task(scene: str, n_disks: int, mu: float, seed: int, slice_height: float,
                    workdir) -> dict:
    wd = Path(workdir)
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks)
    rows = [dict(mu=mu, seed=seed, **round_trip(p, fmt, wd / fmt, slice_height))
            for fmt in FORMATS]
    return {"mu": mu, "seed": seed, "jam_s": t_jam, "rows": rows}


# ---------------------------------------------------------------------- noise
def noisy(p, level: float, drop: float, rng):
    """(the measured packing, indices of the packing's contacts it keeps): Gaussian noise
    of ``level`` x <Fn> on fn and ft of every force-bearing contact, the weakest ``drop``
    fraction of them (by |F|) removed."""
    s = p.mean_normal_force()
    fb = np.flatnonzero(p.force_bearing())
    fn, ft = p.fn.copy(), p.ft.copy()
    fn[fb] += level * s * rng.standard_normal(fb.size)
    ft[fb] += level * s * rng.standard_normal(fb.size)
    weak = fb[np.argsort(np.hypot(p.fn[fb], p.ft[fb]))[:int(round(drop * fb.size))]]
    keep = np.setdiff1d(np.arange(p.n_contacts), weak)
    fields = {k: getattr(p, k)[keep] for k in ("a", "b", "normal", "point", "image", "gap")}
    q = dataclasses.replace(
        p, fn=fn[keep], ft=ft[keep], source="", **fields,
        measurement=Measurement(known=np.ones(keep.size, bool), provenance={
            "format": "synthetic: a jammed network with noise", "noise": level, "drop": drop}))
    return q, keep


def weakest_unknown(p, keep, prob, drop: float) -> np.ndarray:
    """(m,) bool: False at the weakest ``drop`` fraction (by true |F|) of the problem's
    force-bearing contacts (their force unknown), True elsewhere."""
    known = np.ones(prob.n_contacts, bool)
    c = keep[prob.contacts]
    fb = np.flatnonzero(p.force_bearing()[c])
    mag = np.hypot(p.fn[c], p.ft[c])[fb]
    known[fb[np.argsort(mag)[:int(round(drop * fb.size))]]] = False
    return known


def noisy_check(p, level: float, drop: float, height: float, rng,
                missing: str = "removed") -> dict:
    """One condition of a noise task (module docstring): the row of numbers. ``missing``:
    the weakest ``drop`` contacts "removed", or "unknown" (kept as geometry)."""
    q, keep = noisy(p, level, drop if missing == "removed" else 0.0, rng)
    prob = frame_problem(q, Region("slice", height))
    known = weakest_unknown(p, keep, prob, drop if missing == "unknown" else 0.0)
    check = Measured(ranges=True).compute(prob, known=known)
    s = prob.force_scale
    truth = prob.forces_from_packing(p.fn[keep], p.ft[keep])
    row = {"level": level, "drop": drop, "missing": missing if drop else "none",
           "n_unknown_force": int((~known).sum()), "n_contacts": prob.n_contacts,
           "force_scale": s,
           "feasible": check.feasible, "loads": check.loads, "dim": check.dim,
           "relaxation": None if check.relaxation_total is None else check.relaxation_total / s,
           "load_adjustment": check.load_adjustment, "distance": check.distance,
           "distance_joint": check.distance_joint, "message": check.message}
    if check.nearest is None:
        return row
    rms = lambda v: float(np.sqrt(np.mean(np.sum(v.reshape(-1, 2) ** 2, axis=1))) / s)  # noqa
    measured = np.where(np.repeat(known, 2), check.x, 0.0)      # unknown: 0
    row.update(err_input=rms(measured - truth), err_nearest=rms(check.nearest - truth))
    row["ratio"] = row["err_nearest"] / row["err_input"] if row["err_input"] > 0 else None
    if check.fn_range is not None:
        tol = INSIDE_TOL * s
        t_fn, t_ft = truth[0::2], truth[1::2]
        inside = ((t_fn >= check.fn_range[:, 0] - tol) & (t_fn <= check.fn_range[:, 1] + tol)
                  & (t_ft >= check.ft_range[:, 0] - tol) & (t_ft <= check.ft_range[:, 1] + tol))
        row.update(truth_inside=float(inside.mean()),
                   measured_inside=float(check.inside.mean()))
    return row


def noise_task(scene: str, n_disks: int, mu: float, seed: int, slice_height: float, levels,
               drop: float, workdir) -> dict:
    wd = Path(workdir)
    p, t_jam = shared_packing(wd.parents[1], scene, mu, seed, n_disks)
    rng = np.random.default_rng([41, seed, int(round(1e6 * mu))])
    rows = []
    for level in levels:
        for d, missing in ((0.0, "removed"), (drop, "removed"), (drop, "unknown")):
            t0 = time.process_time()
            row = noisy_check(p, float(level), d, slice_height, rng, missing)
            rows.append(dict(mu=mu, seed=seed, cpu_s=time.process_time() - t0, **row))
    return {"mu": mu, "seed": seed, "jam_s": t_jam, "rows": rows}


# ---------------------------------------------------------------------- summary
RT_KEYS = ("mu", "seed", "format", "region_disks", "dim_native", "dim_read",
           "n_contacts_native", "n_contacts_read", "matched", "max_range_diff", "same",
           "read_cpu_s")
NOISE_KEYS = ("mu", "seed", "level", "drop", "missing", "n_unknown_force", "n_contacts",
              "feasible", "relaxation", "loads",
              "load_adjustment", "dim", "distance", "distance_joint", "err_input",
              "err_nearest", "ratio", "truth_inside", "measured_inside", "cpu_s", "message")


def _rows(results, kind):
    return [row for r in results if r.get("ok") and r["task"].startswith(kind)
            for row in r["rows"]]


def by_condition(rows) -> list[dict]:
    """Per (mu, noise level, drop, missing): medians and 95 % bootstrap intervals over
    packings."""
    from .stats import bootstrap_stat

    def key_of(r):
        return r["mu"], r["level"], r["drop"], r.get("missing", "removed" if r["drop"] else
                                                      "none")
    out = []
    for key in sorted({key_of(r) for r in rows}):
        g = [r for r in rows if key_of(r) == key]
        row = {"mu": key[0], "level": key[1], "drop": key[2], "missing": key[3],
               "packings": len(g),
               "S_empty": sum(not r["feasible"] for r in g)}
        for name in ("distance", "truth_inside", "ratio", "err_input", "err_nearest",
                     "load_adjustment", "relaxation"):
            v = [r[name] for r in g if r.get(name) is not None]
            if v:
                med, lo, hi = bootstrap_stat({0: v})[0]
                row.update({name: med, f"{name}_lo": lo, f"{name}_hi": hi})
        row["nearer"] = sum(r.get("ratio") is not None and r["ratio"] < 1 for r in g)
        out.append(row)
    return out


def _verdicts(rt, cond):
    from .report import Verdict

    verdicts = []
    bad = [r for r in rt if not r["same"]]
    worst = max((r["max_range_diff"] for r in rt), default=float("nan"))
    verdicts.append(Verdict(
        "measured", "Round trip: written as a CSV pair, a PeGS frame (the matrices and "
        "PeGS2's own files) and a LIGGGHTS dump and read back, a jammed packing gives the "
        "native file's S", f"{len(rt) - len(bad)} of "
        f"{len(rt)} (packing, format) pairs: equal dim S, every range within {worst:.1e} <Fn>",
        "supported" if rt and not bad else "not supported" if rt else "not decidable",
        kind="ours", rule=f"dim S equal and max |range difference| <= {RT_TOL:g} <Fn> "
                                "for every pair"))
    noisy = [c for c in cond if c["level"] > 0 and c["missing"] == "none"]
    for mu in sorted({c["mu"] for c in noisy}):
        g = sorted((c for c in noisy if c["mu"] == mu), key=lambda c: c["level"])
        d = [c.get("distance") for c in g]
        grows = all(a is not None and b is not None and b > a for a, b in zip(d, d[1:]))
        verdicts.append(Verdict(
            "measured", f"mu = {mu:g}: the distance to S grows with the noise level",
            "; ".join(f"{c['level']:.0%}: {c.get('distance', float('nan')):.3g} "
                      f"[{c.get('distance_lo', float('nan')):.3g}, "
                      f"{c.get('distance_hi', float('nan')):.3g}] <Fn>" for c in g),
            "supported" if grows else "not supported", kind="ours",
            rule="the median over packings rises from each level to the next"))
        cover = [c.get("truth_inside") for c in g]
        verdicts.append(Verdict(
            "measured", f"mu = {mu:g}: the reported ranges contain the true contact forces",
            "; ".join(f"{c['level']:.0%}: {c.get('truth_inside', float('nan')):.0%} of the "
                      "true forces inside (median)" for c in g),
            "supported" if all(v is not None and v >= COVERS for v in cover) else
            "not supported", kind="ours",
            rule=f"median fraction >= {COVERS:.0%} at every noise level"))
        for missing, (text, _, _) in MISSING.items():
            g = sorted((c for c in cond if c["mu"] == mu and c["level"] > 0
                        and c["missing"] == missing), key=lambda c: c["level"])
            if g:
                verdicts.append(_closer(mu, text, g))
    return verdicts


def _closer(mu, text, g):
    """The verdict: the nearest admissible network is closer to the truth than the input,
    for the conditions ``g`` (one per noise level > 0)."""
    from .report import Verdict

    better = [c.get("ratio_hi") for c in g]
    return Verdict(
        "measured", f"mu = {mu:g}, {text}: the nearest admissible network is closer to the "
        "truth than the noisy input", "; ".join(
            f"{c['level']:.0%}: error ratio {c.get('ratio', float('nan')):.2f} "
            f"[{c.get('ratio_lo', float('nan')):.2f}, {c.get('ratio_hi', float('nan')):.2f}]"
            f", nearer in {c['nearer']} of {c['packings']}" for c in g),
        "supported" if all(v is not None and v < 1 for v in better) else
        "not supported" if all(v is not None and c["ratio_lo"] > 1 for v, c in
                               zip(better, g)) else "not decidable", kind="ours",
        rule="rms error of the nearest network / that of the input, median over packings: "
             "the 95 % bootstrap interval below 1 at every level (not supported: above 1 at "
             "every level)")


def summarize(results: list[dict], out) -> dict:
    """measured_roundtrip.csv, measured_noise.csv (one row per packing and condition),
    measured_by_condition.csv, measured.png/.pdf, verdicts.json and REPORT.md."""
    from .report import RULES_VERSION, failed_tasks_note, write_csv, write_section

    out = Path(out)
    rt, noise = _rows(results, "rt_"), _rows(results, "noise_")
    failed = [r for r in results if not r.get("ok")]
    write_csv(out / "measured_roundtrip.csv", rt, RT_KEYS)
    write_csv(out / "measured_noise.csv", noise, NOISE_KEYS)
    cond = by_condition(noise)
    if cond:
        keys = list(dict.fromkeys(k for c in cond for k in c))   # every condition's columns
        write_csv(out / "measured_by_condition.csv", cond, keys)
    verdicts = _verdicts(rt, cond)
    figures = []
    if cond:
        _figure(cond, out)
        figures = ["measured.png"]
    numbers = {"tasks": len(results), "tasks_failed": len(failed),
               "failed": [f"{r['task']}: {r.get('error')}" for r in failed],
               "round_trip": {"pairs": len(rt), "same": sum(r["same"] for r in rt),
                              "max_range_diff": max((r["max_range_diff"] for r in rt),
                                                    default=None)},
               "conditions": cond}
    text = _text(rt, cond) + failed_tasks_note(failed, results)
    write_section(out, "measured", "Measured networks against S", text, verdicts, numbers,
                  figures, rules_version=RULES_VERSION)
    return {"tasks": len(results), "failed": len(failed), "round_trips": len(rt),
            "noise_rows": len(noise), "verdicts": [v.verdict for v in verdicts]}


def _text(rt, cond) -> str:
    lines = [
        "Readers of measured frames (`forcespace convert csv|pegs|pegs2|lammps`) and the check "
        "of a measured network against S (`forcespace check`, `forcespace.space.measured."
        "Measured`). **Round trip**: each jammed packing written in each format and read "
        "back; S of the same region compared with the native file's (the paper's slice; for "
        "PeGS and PeGS2, whose frames have no period, the slice minus the disks with a "
        "contact across the periodic seam, on both). The ranges come from warm-started LPs "
        "in S's affine hull, each answer checked by its multipliers and polished to the "
        "exact vertex (HiGHS stops at a basis optimal to its 1e-10 tolerances, which left "
        "ends up to 1.6e-9 <Fn> apart on bit-different inputs before the polish).",
        "", "| mu | format | pairs | equal dim S | max range difference [<Fn>] |",
        "| --- | --- | --- | --- | --- |"]
    for mu in sorted({r["mu"] for r in rt}):
        for fmt in FORMATS:
            g = [r for r in rt if r["mu"] == mu and r["format"] == fmt]
            if g:
                lines.append(f"| {mu:g} | {fmt} | {len(g)} | "
                             f"{sum(r['dim_native'] == r['dim_read'] for r in g)} | "
                             f"{max(r['max_range_diff'] for r in g):.1e} |")
    lines += [
        "", "**Noise**: the jammed network as a measurement, Gaussian noise of the level x "
        "<Fn> on fn and ft of every force-bearing contact (the loads of the slice included), "
        "every contact measured, or the weakest 5 % of the force-bearing contacts removed "
        "(a photoelastic inversion misses weak contacts), or the weakest 5 % of the slice's "
        "force-bearing contacts kept as geometry with their force unknown (the image shows "
        "the contact, the fit no force); checked on the paper's slice. Where S at the "
        "measured loads is empty, the check goes on at the least adjusted loads (the network "
        "and boundary forces nearest to the measurement that balance the slice). Errors "
        "against the truth: rms per contact over the slice's contacts, an unknown force "
        "counted as 0 in the input. Medians over packings, 95 % bootstrap intervals:", "",
        "| mu | noise | contacts | packings | S empty | distance to S [<Fn>] | true "
        "forces inside ranges | error nearest / error input | nearer to the truth |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for c in cond:
        f = lambda k, fmt: (format(c[k], fmt) if c.get(k) is not None else "–")  # noqa: E731
        lines.append(f"| {c['mu']:g} | {c['level']:.0%} | {MISSING[c['missing']][0]} | "
                     f"{c['packings']} | "
                     f"{c['S_empty']} | {f('distance', '.3g')} | {f('truth_inside', '.0%')} | "
                     f"{f('ratio', '.2f')} [{f('ratio_lo', '.2f')}, {f('ratio_hi', '.2f')}] | "
                     f"{c['nearer']} of {c['packings']} |")
    return "\n".join(lines)


MISSING = {"none": ("every contact measured", "-", "o"),
           "removed": ("weakest 5 % removed", "--", "s"),
           "unknown": ("weakest 5 % force unknown", "-.", "^")}


def _figure(cond, out) -> None:
    """measured.png/.pdf: distance to S, true forces inside their ranges, error ratio
    against the noise level (0 included), per mu and condition (MISSING)."""
    from matplotlib.figure import Figure

    from forcespace.extend import save_figure

    fig = Figure(figsize=(13.5, 5.0))
    axes = fig.subplots(1, 3)
    levels = sorted({c["level"] for c in cond})
    for i, mu in enumerate(sorted({c["mu"] for c in cond})):
        for missing, (text, ls, mk) in MISSING.items():
            g = sorted((c for c in cond if c["mu"] == mu and c["missing"] == missing),
                       key=lambda c: c["level"])
            style = dict(color=f"C{i}", ls=ls, marker=mk, capsize=2,
                         mfc="none" if missing != "none" else f"C{i}",
                         label=f"$\\mu = {mu:g}$, {text}")
            for ax, key in zip(axes, ("distance", "truth_inside", "ratio")):
                pts = [(levels.index(c["level"]), c[key], c[f"{key}_lo"], c[f"{key}_hi"])
                       for c in g if c.get(key) is not None and (key == "truth_inside"
                                                                 or c[key] > 1e-12)]
                if pts:
                    x, y, lo, hi = (np.array(v) for v in zip(*pts))
                    ax.errorbar(x, y, yerr=[y - lo, hi - y], **style)
    for ax in axes:
        ax.set_xticks(range(len(levels)), [f"{100 * v:g} %" for v in levels])
        ax.set_xlabel(r"noise on $f_n$, $f_t$ [% of $\langle F_n\rangle$]")
    axes[0].set(yscale="log", title="distance to S",
                ylabel=r"distance to $S$ / $\langle F_n\rangle$ (rms per contact)")
    axes[1].set(ylim=(-0.03, 1.03), title="true forces inside the reported ranges",
                ylabel="fraction of true forces inside their ranges")
    axes[2].axhline(1.0, color="k", lw=0.8, ls=":")
    axes[2].set(yscale="log", title="nearest admissible network against the input",
                ylabel="rms error against the truth: nearest / input")
    handles, labels = axes[1].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle("jammed networks with noise, checked on the paper's slice: medians over "
                 "packings, 95 % bootstrap intervals", fontsize=9)
    fig.tight_layout(rect=(0, 0.12, 1, 0.96))
    save_figure(fig, out / "measured.png")
