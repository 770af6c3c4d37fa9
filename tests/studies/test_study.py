"""Study sweeps: the quick fig1 study on the local pool and on a Dask LocalCluster."""
import json

import numpy as np
import pytest

from forcespace.cli import main
from forcespace_studies import fig1
from forcespace_studies.runner import Task, run_tasks

KEYS = ("mu", "mu_sample", "seed", "z", "dim_S", "degree_of_indeterminacy",
        "dof_excess_full", "eta_hit_and_run", "eta_relax")


def rows(results):
    return [{k: row[k] for k in KEYS} for r in results for row in r["rows"]]


def run_quick(name, out, capsys) -> dict:
    """Run ``forcespace study NAME --quick`` on two local workers; its JSON summary."""
    assert main(["study", name, "--quick", "--workers", "2", "-o", str(out), "--quiet"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.slow
def test_fig1_quick_local_pool_resumes_and_equals_dask(tmp_path, capsys):
    local = tmp_path / "local"
    summary = run_quick("fig1", local, capsys)
    assert summary["failed"] == 0 and summary["rows"] == 10
    assert (local / "fig1.csv").is_file() and (local / "fig1.png").is_file()
    assert (local / "fig1.pdf").is_file() and len(summary["verdicts"]) >= 6
    # the report inside the study directory names every claim; a quick run's verdicts
    # are smoke tests (the outcome its numbers would give is kept beside)
    assert not (tmp_path / "REPORT.md").exists()
    report = (local / "REPORT.md").read_text()
    verdicts = json.loads((local / "verdicts.json").read_text())["verdicts"]
    for v in verdicts:
        assert v["claim"] in report and v["verdict"] == "smoke test (quick run)"
        assert v["quick_outcome"] in (("reproduced", "refuted", "not decidable",
                                       "not applicable") if v["kind"] == "paper" else
                                      ("supported", "not supported", "not decidable"))
    # fresh rows carry the plate contacts and rank A: the rank-based degree is decided
    rank_row = [v for v in verdicts if "rank of the equilibrium matrix" in v["claim"]][0]
    assert rank_row["kind"] == "ours" and rank_row["quick_outcome"] == "supported"
    assert "(fig1.png)" in report and "**reproduced**" not in report
    tasks = fig1.tasks(quick=True)
    done = run_tasks(tasks, local, progress=False)        # everything is skipped now
    # physics of the quick sweep: z falls with mu, frictionless packings are isostatic
    r = rows(done)
    assert all(x["z"] == 4.0 for x in r if x["mu"] == 0.0)
    z = {x["mu"]: x["z"] for x in r if x["seed"] == 1 and x["mu"] > 0}
    assert z[0.01] > z[0.1] > z[1.0] > 3.0
    # the accuracy floor: frictionless S is a point, the walk's spread is round-off
    floor = [x["eta_relax"] for x in r if x["mu"] == 0.0 and x["mu_sample"] == 0.0]
    assert len(floor) == 1 and all(0 <= e < 1e-8 for e in floor)
    # the packing of each (mu, seed) was jammed once and shared by its tasks
    assert sorted(p.name for p in (local / "packings").glob("*.h5")) == sorted(
        [f"quick_n30_mu{mu:.6g}_s{s}.h5" for mu in (0.01, 0.1, 1.0) for s in (1, 2)]
        + ["quick_n30_mu0_s1.h5"])
    assert all(x["dim_S"] >= 0 and x["eta_hit_and_run"] >= 0 for x in r)
    # every sampling run records its convergence; determinate S have eta 0 exactly
    for x in r:
        for k in ("hit_and_run", "relax"):
            if x["dim_S"] and x.get(f"n_{k}"):
                assert x[f"converged_{k}"] == (x[f"ess_{k}"] >= 100 and x[f"rhat_{k}"] <= 1.05
                                               and x[f"stop_{k}"].startswith("converged"))
        if x["dim_S"] == 0 and x["mu_sample"] > 0:
            assert x["eta_hit_and_run"] == x["eta_relax"] == 0.0
    # with friction switched on, eta of the same packing grows with mu (the squares)
    sq = sorted((x["mu_sample"], x["eta_hit_and_run"]) for x in r
                if x["mu"] == 0.0 and x["seed"] == 1)
    assert [e for _, e in sq] == sorted(e for _, e in sq)
    # the same tasks through a Dask cluster on loopback give the same numbers
    distributed = pytest.importorskip("distributed")
    sub = [t for t in tasks if t.name in ("mu0.1_s1", "mu1_s2")]
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  protocol="tcp", host="127.0.0.1",
                                  dashboard_address=":0") as cluster:    # any free port
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        remote = run_tasks(sub, tmp_path / "dask", scheduler=cluster.scheduler_address,
                           progress=False)
    mine = rows([x for x in done if x["task"] in ("mu0.1_s1", "mu1_s2")])
    # equal up to round-off (one BLAS thread per pool worker, the default in Dask's)
    assert rows(remote) == [{k: pytest.approx(v, rel=1e-5) if isinstance(v, float) else v
                             for k, v in row.items()} for row in mine]


def test_fig1_full_plan_is_seed_major_and_complete():
    # 20 mu x 10 seeds of own-mu packings, and for seeds 1-5 the mu = 0 packing sampled at
    # mu = 0 and at each of the 20 mu (the squares): 305 tasks, none twice; an interrupted
    # run leaves complete seed rounds (every task of seed s before any of seed s + 1)
    full = fig1.tasks()
    names = [t.name for t in full]
    assert len(names) == len(set(names)) == 20 * 10 + 5 * 21 == 305
    seeds = [t.params["seed"] for t in full]
    assert seeds == sorted(seeds)
    own = {(t.params["mu"], t.params["seed"]) for t in full if t.params.get("mu_sample") is None}
    assert own == {(mu, s) for mu in fig1.MUS for s in range(1, 11)}
    squares = [t for t in full if t.params.get("mu_sample") is not None]
    assert {t.params["mu"] for t in squares} == {0.0}
    assert {(t.params["mu_sample"], t.params["seed"]) for t in squares} == {
        (ms, s) for ms in (0.0, *fig1.MUS) for s in range(1, 6)}


def test_fig2_full_plan_follows_fig1_packings_seed_major():
    # one task per own-mu fig1 packing, none twice, in fig1's seed order: a fig2 run
    # stopped (or run beside an unfinished fig1) holds complete seed rounds
    from forcespace_studies import fig2
    full = fig2.tasks()
    assert len({t.name for t in full}) == len(full) == 20 * 10
    seeds = [t.params["seed"] for t in full]
    assert seeds == sorted(seeds)
    mine = [(t.params["mu"], t.params["seed"]) for t in full]
    theirs = [(t.params["mu"], t.params["seed"]) for t in fig1.tasks()
              if t.params.get("mu_sample") is None]
    assert mine == theirs


def test_a_failing_task_is_a_result_and_names_must_be_unique(tmp_path):
    bad = Task("bad", "forcespace_studies.fig1:packing_task",
               dict(scene="quick", n_disks=0, slice_height=10.0, cap=2, mu=0.1, seed=1))
    (res,) = run_tasks([bad], tmp_path, progress=False)
    assert res["ok"] is False and "disks.n" in res["error"]
    assert (tmp_path / "tasks" / "bad.json").is_file()
    from forcespace.errors import InputError
    with pytest.raises(InputError, match="unique"):
        run_tasks([bad, bad], tmp_path, progress=False)


def test_slope_and_peak_helpers_recover_known_answers():
    from forcespace_studies import stats
    mu = np.logspace(-4, -2, 5)
    fit = stats.slope_interval(np.repeat(mu, 3), np.repeat(3.0 * mu ** 1.0, 3)
                               * np.exp(np.tile([-0.01, 0.0, 0.01], 5)))
    assert abs(fit["slope"] - 1.0) < 1e-3 and fit["se"] < 0.01 and fit["lo"] < 1 < fit["hi"]
    # eta = exp(-(log10 mu - log10 0.07)^2) with 2 % noise: the parabola finds 0.07
    rng = np.random.default_rng(0)
    groups = {m: np.exp(-(np.log10(m / 0.07)) ** 2) * (1 + 0.02 * rng.normal(size=8))
              for m in np.logspace(-2, 0, 9)}
    pk = stats.peak_bootstrap(groups, (0.01, 1.0), n_boot=300)
    assert pk["peak"] == pytest.approx(0.07, rel=0.05) and pk["lo"] < 0.07 < pk["hi"]
    assert stats.interval_verdict(pk["lo"], pk["hi"], stats.near(0.1)) == "reproduced"
    # a curve that rises to the edge of the window has no maximum inside it
    assert stats.peak_bootstrap({m: np.array([m, m]) for m in (0.01, 0.1, 1.0)},
                                (0.01, 1.0), n_boot=50)["peak"] is None


@pytest.mark.slow
def test_fig3_quick_distances_boundary_and_uniformity(tmp_path, capsys):
    out = tmp_path / "fig3"
    summary = run_quick("fig3", out, capsys)
    assert summary["failed"] == 0 and summary["usable"] == 3
    assert (out / "fig3.png").is_file() and (out / "fig3.pdf").is_file()
    tasks = sorted((out / "tasks").glob("*.json"))
    for f in tasks:
        r = json.loads(f.read_text())
        assert r["dim_S"] >= 2 and r["n_hit_and_run"] >= 400 and r["n_relax"] >= 400
        assert r["converged_hit_and_run"] and r["converged_relax"] and r["converged_null"]
        # x0 in 10 random 2-D sections: a distance over the section's extent, in [0, 1/2]
        # (no point of a convex region is farther than half its width from its boundary)
        for key in ("jammed_edge_ratio", "uniform_edge_ratio"):
            assert len(r[key]) == 10 and all(0 <= v <= 0.5 for v in r[key])
        for a in ("hit_and_run", "relax"):
            # own centre: the mean distance in units of itself is 1 by construction
            assert np.mean(r[f"l_{a}_centre_{a}"]) == pytest.approx(1.0, rel=1e-12)
        # Gauss-Seidel ends every relaxation on the Coulomb surface of some contact;
        # uniform samples are inside (S can be ~1e-6 <Fn> thin at mu = 0.01, so a few come
        # within the 1e-7 <Fn> boundary tolerance)
        assert r["on_boundary_fraction_relax"] == 1.0
        assert r["on_boundary_fraction_hit_and_run"] <= 0.25
        # two uniform runs agree on eta far better than the walk and hit-and-run
        assert abs(np.log(r["eta_null"] / r["eta_hit_and_run"])) < 0.35
    report = (out / "REPORT.md").read_text()
    assert "(fig3.png)" in report and "uniformly" in report
    # one task through a Dask cluster on loopback gives the same numbers
    distributed = pytest.importorskip("distributed")
    from forcespace_studies import fig3
    task = fig3.tasks(quick=True)[0]
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  protocol="tcp", host="127.0.0.1",
                                  dashboard_address=":0") as cluster:    # any free port
        (remote,) = run_tasks([task], tmp_path / "dask", scheduler=cluster.scheduler_address,
                              progress=False)
    local = json.loads(task.result_path(out).read_text())
    assert remote["dim_S"] == local["dim_S"]
    # equal up to round-off: the local pool runs one BLAS thread per worker, the Dask
    # worker here the process's default, and the MVE rounding amplifies the last bits
    for key in ("eta_hit_and_run", "eta_relax", "l0_centre_relax_lbar_relax"):
        assert remote[key] == pytest.approx(local[key], rel=1e-5)


def test_report_says_how_much_of_the_plan_a_study_has_run(tmp_path):
    # a partial run (a long study stopped and committed) reads as one in every report
    from forcespace_studies.report import write_report, write_section
    out = tmp_path / "fig1"
    (out / "tasks").mkdir(parents=True)
    (out / "study.json").write_text(json.dumps({"study": "fig1", "quick": False,
                                                "tasks": 3}))
    (out / "tasks" / "a.json").write_text(json.dumps({"wall_seconds": 120.0}))
    write_section(out, "fig1", "T", "text", [], {}, [])
    assert "1 of 3 planned tasks: a partial run" in (out / "REPORT.md").read_text()
    for t in ("b", "c"):     # newer task files record their CPU time too
        (out / "tasks" / f"{t}.json").write_text(json.dumps({"wall_seconds": 60.0,
                                                              "cpu_seconds": 45.0}))
    write_section(out, "fig1", "T", "text", [], {}, [])
    write_report([out], tmp_path / "REPORT.md")
    for rep in (out / "REPORT.md", tmp_path / "REPORT.md"):
        text = rep.read_text()
        assert ("3 tasks; 4.0 worker-minutes of tasks; 1.5 CPU-minutes on the 2 that recorded "
                "CPU time" in text) and "partial" not in text
    (out / "tasks" / "a.json").write_text(json.dumps({"wall_seconds": 120.0,
                                                      "cpu_seconds": 90.0}))
    write_section(out, "fig1", "T", "text", [], {}, [])
    assert "3 tasks; 4.0 worker-minutes of tasks, 3.0 CPU-minutes)" in (out / "REPORT.md").read_text()


def test_report_sections_are_ordered_and_verdicts_checked(tmp_path):
    from forcespace_studies.report import RULES_VERSION, Verdict, write_report, write_section
    with pytest.raises(ValueError, match="verdict"):
        Verdict("x", "claim", "ours", "probably")
    for name in ("fig3", "fig1"):
        (tmp_path / name).mkdir()
        write_section(tmp_path / name, name, f"Title {name}", "text",
                      [Verdict(name, f"claim {name}", "42", "refuted")], {"n": 1}, ["a.png"],
                      rules_version=RULES_VERSION)
        assert f"| claim {name} |  |  | 42 | **refuted** |" in (
            tmp_path / name / "REPORT.md").read_text()
    assert not (tmp_path / "REPORT.md").exists()
    write_report([tmp_path / "fig3", tmp_path / "fig1"], tmp_path / "REPORT.md")
    report = (tmp_path / "REPORT.md").read_text()
    assert report.index("Title fig1") < report.index("Title fig3")
    assert "| fig1 | claim fig1 |  | 42 | **refuted** |" in report
    assert "(fig1/a.png)" in report
    assert "earlier rules" not in report
    assert "## Related work since 2005" in report and "Snoeijer" in report
    # a summary written before the verdict rules (no rules_version, or a study not yet
    # judged by them: version 1) is shown as it was, marked, and named at the top
    doc = json.loads((tmp_path / "fig1" / "verdicts.json").read_text())
    del doc["rules_version"]
    (tmp_path / "fig1" / "verdicts.json").write_text(json.dumps(doc))
    write_report([tmp_path / "fig3", tmp_path / "fig1"], tmp_path / "REPORT.md")
    report = (tmp_path / "REPORT.md").read_text()
    assert "| fig1 | claim fig1 |  | 42 | **refuted (earlier rules)** |" in report
    assert "| fig3 | claim fig3 |  | 42 | **refuted** |" in report
    assert "**Summarised under earlier rules** (fig1)" in report


@pytest.mark.slow
def test_fig2_quick_clusters_per_packing(tmp_path, capsys, monkeypatch):
    from forcespace_studies.report import RULES_VERSION
    out = tmp_path / "fig2"
    summary = run_quick("fig2", out, capsys)
    assert summary["failed"] == 0 and "fig2.png" in summary["figures"]
    rows = [json.loads(f.read_text()) for f in sorted((out / "tasks").glob("*.json"))]
    assert len(rows) == 6
    for r in rows:
        if not r["dim_S"]:
            continue
        # a circuit basis: as many clusters as degrees of freedom, split over the domains
        assert r["n_clusters"] == r["dim_S"] == sum(r["domain_dims"])
        assert r["density_rho"] == pytest.approx(r["n_elementary"] / r["slice_disks"])
        assert 0 < r["largest_domain_fraction"] <= r["varying_fraction"] <= 1
        # the elementary clusters (one degree of freedom) have >= 2 contacts each
        assert all(s >= 2 for s in r["elementary_sizes_contacts"])
        # a domain of dimension 1 is an elementary cluster (issue 24's counting defect)
        assert r["n_elementary"] >= sum(d["dim"] == 1 for d in r["domains"])
        # per domain what the other-loads verdicts need, decided from the task file
        assert len(r["domains"]) == r["n_domains"] and "error_other_loads" not in r
        for d in r["domains"]:
            assert {"contacts", "dim", "percolates", "found_again", "jaccard"} <= set(d)
            assert 0 <= d["jaccard"] <= 1 and (not d["found_again"] or d["jaccard"] == 1)
        assert r["other_loads"]["dim_S_change"] == r["other_loads"]["dim_S"] - r["dim_S"]
        # the other loads are generic (inside the full S): the slice's S under them is no
        # lower-dimensional face (the projected loads alone took seed 2 at mu 0.01 to 0)
        assert r["other_loads"]["dim_S_change"] >= 0
    # localisation: the largest domain is smaller at mu = 1 than at mu = 0.01
    big = {r["mu"]: r["largest_domain_fraction"] for r in rows if r["seed"] == 1}
    assert big[1.0] < big[0.01]
    assert "Fig. 2" in (out / "REPORT.md").read_text()
    doc = json.loads((out / "verdicts.json").read_text())
    assert doc["rules_version"] == RULES_VERSION
    assert [v["kind"] for v in doc["verdicts"]][:3] == ["paper"] * 3
    assert all(v["rule"] for v in doc["verdicts"])
    # --report-only runs nothing: with the packings gone the summary jams none again, the
    # example panels say the packing is not there, and the verdicts stay
    import shutil

    from forcespace_studies import common

    shutil.rmtree(out / "packings")

    def no_jam(*a, **k):
        raise AssertionError("a summary jammed a packing")
    monkeypatch.setattr(common, "jam", no_jam)
    assert main(["study", "fig2", "--quick", "-o", str(out), "--report-only", "--quiet"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["verdicts"] == summary["verdicts"] and "fig2.png" in again["figures"]
    assert not (out / "packings").exists()


def _fig2_row(task, mu, dim, domains, slice_contacts=200, dim_again=None, **kw):
    """A hand-made fig2 task result: ``domains`` as the task stores them."""
    elem = [d["contacts"] for d in domains if d["dim"] == 1]
    big = max((d["contacts"] for d in domains), default=0)
    row = {"task": task, "ok": True, "params": {"mu": mu}, "mu": mu, "seed": 1,
           "dim_S": dim, "slice_contacts": slice_contacts, "slice_disks": 100,
           "n_elementary": len(elem), "elementary_sizes_contacts": elem,
           "elementary_sizes_disks": [4] * len(elem), "density_rho": len(elem) / 100,
           "largest_domain_fraction": big / slice_contacts,
           "varying_fraction": sum(d["contacts"] for d in domains) / slice_contacts,
           "percolates": any(d["percolates"] for d in domains), "domains": domains}
    if dim:
        row["other_loads"] = {"dim_S": dim_again if dim_again is not None else dim,
                              "dim_S_change": (dim_again if dim_again is not None else dim)
                              - dim, "n_domains": len(domains)}
    return dict(row, **kw)


def _dom(contacts, dim, percolates, found, jaccard):
    return {"contacts": contacts, "disks": contacts // 2, "dim": dim, "percolates": percolates,
            "found_again": found, "jaccard": jaccard, "dim_again": dim}


def test_fig2_same_clusters_judged_on_localised_domains_percolating_apart():
    """Issue 24: the percolating domain that changes by one contact (and loses a degree of
    freedom) under the other loads is reported as missed on its own line (ours); the
    localised domains that come back reproduce the paper's claim. A determinate packing
    keeps its row (rho 0, out of the localisation verdicts); failed tasks are listed per
    mu."""
    from forcespace_studies import fig2

    perc = _dom(190, 40, True, False, 189 / 190)       # one contact dropped
    results = [
        _fig2_row("mu0.1_s1", 0.1, 40, [perc], dim_again=39),
        _fig2_row("mu0.1_s2", 0.1, 41, [dict(perc, dim=41)], dim_again=39),
        _fig2_row("mu1_s1", 1.0, 2, [_dom(5, 1, False, True, 1.0), _dom(11, 1, False, True,
                                                                        1.0)]),
        _fig2_row("mu1_s2", 1.0, 1, [_dom(8, 1, False, True, 1.0)]),
        _fig2_row("mu1_s3", 1.0, 0, []),                  # determinate
        {"task": "mu1_s4", "ok": False, "params": {"mu": 1.0}, "error": "NumericalError: x"}]
    numbers, verdicts = fig2.judge(results)
    assert [x.kind for x in verdicts] == ["paper", "paper", "paper", "ours"]
    same = verdicts[2]
    assert same.verdict == "reproduced" and "3 of 3 localised domains" in same.ours
    assert "localised" in same.rule and "0.8" in same.rule
    ours = verdicts[3]
    assert ours.verdict == "not supported" and "0 of 2 percolating domains" in ours.ours
    assert "Jaccard" in ours.ours and "mean 0.995" in ours.ours
    assert "-1 to -2" in ours.ours or "-2 to -1" in ours.ours
    assert numbers["other_loads"]["percolating"]["dim_S_change"] == {"mean": -1.5, "min": -2,
                                                                      "max": -1}
    # localisation needs 10 packings with dim S > 0 above mu = 0.2 (test_verdict_readings)
    assert verdicts[0].verdict == "not decidable"
    assert "2 above; 10 above are needed" in verdicts[0].ours
    assert verdicts[1].verdict == "reproduced"
    assert "5-11 contacts" in verdicts[1].ours
    # the determinate packing keeps its row: rho 0 counted at mu = 1
    mu1 = [b for b in numbers["by_mu"] if b["mu"] == 1.0][0]
    assert mu1["packings"] == 3 and mu1["determinate"] == 1
    assert mu1["rho_mean"] == pytest.approx((0.02 + 0.01 + 0.0) / 3)
    assert numbers["failures_by_mu"] == {"1": ["mu1_s4: task failed: NumericalError: x"]}
    assert numbers["packings_determinate"] == 1 and numbers["tasks_failed"] == 1


def test_fig2_localised_domains_that_do_not_come_back_refute_the_claim():
    """The rule can fail: localised domains missed on most packings (a contact set that
    moves) refute the claim; one packing's miss among several found is not decidable."""
    from forcespace_studies import fig2

    miss = [_fig2_row(f"mu1_s{s}", 1.0, 1, [_dom(8, 1, False, False, 0.6)]) for s in range(4)]
    _, verdicts = fig2.judge(miss)
    same = [x for x in verdicts if x.claim.startswith("The same clusters")][0]
    assert same.verdict == "refuted" and "0 of 4 localised domains" in same.ours
    assert not any(x.kind == "ours" for x in verdicts)      # no percolating domain
    mixed = [_fig2_row(f"mu1_s{s}", 1.0, 1, [_dom(8, 1, False, s > 0, 1.0 if s else 0.7)])
             for s in range(4)]
    _, verdicts = fig2.judge(mixed)
    same = [x for x in verdicts if x.claim.startswith("The same clusters")][0]
    assert same.verdict == "not decidable" and "3 of 4" in same.ours
    # no indeterminate packing at small mu: the localisation claim cannot be decided
    assert verdicts[0].verdict == "not decidable"


@pytest.mark.slow
def test_pointforce_quick_and_report_only(tmp_path, capsys):
    out = tmp_path / "pointforce"
    summary = run_quick("pointforce", out, capsys)
    assert summary["failed"] == 0
    rows = [json.loads(f.read_text()) for f in sorted((out / "tasks").glob("*.json"))]
    by_mu = json.loads((out / "verdicts.json").read_text())["numbers"]["by_mu"]
    for mu in ("0.01", "0.1", "1"):
        # a layer whose control run (no force) displaced a disk is counted, not judged
        restless = [r for r in rows if r["mu"] == float(mu)
                    and r.get("control_max_displacement", 0.0) > 0.1]
        assert by_mu[mu]["restless"] == len(restless)
    for r in rows:
        if not r["carries_any_force"] and r["rearranged"]:
            # the region holds displaced disks only, reaches no deeper than the floor
            assert 1 <= r["region_size"] <= r["displaced_total"]
            assert r["push_max_displacement"] > 0.1
            assert 0 <= r["depth"] <= r["thickness"] and r["thickness"] > 5
            assert r["reaches_floor"] == (r["floor_gap"] < 2.0)
    assert summary["pushed"] >= 2
    doc = json.loads((out / "verdicts.json").read_text())
    from forcespace_studies.report import RULES_VERSION
    assert doc["rules_version"] == RULES_VERSION and (out / "pointforce_by_mu.csv").is_file()
    # summarising again without running anything gives the same report
    before = (out / "REPORT.md").read_text()
    assert main(["study", "pointforce", "--quick", "-o", str(out), "--report-only"]) == 0
    assert (out / "REPORT.md").read_text() == before


def test_max_point_force_is_where_rigid_disks_start_to_move():
    import forcespace as fs
    from forcespace.engine.push import push
    from forcespace.measures import surface_disk
    from forcespace.space.loads import max_point_force
    from paths import INPUTS
    p = fs.jam(INPUTS / "layer.toml", physics__mu=0.1, physics__plate_mu=0.1, disks__n=40,
               box__width=20.0)
    k = surface_disk(p)
    f_star = max_point_force(p, k)
    assert np.isfinite(f_star) and f_star > 0
    below = push(p, k, 0.9 * f_star)          # the network carries it: no rearrangement
    assert below.at_rest and below.displacement.max() < 0.01
    above = push(p, k, 1.05 * f_star)         # it cannot: disks give way by > 0.1 R
    assert above.displacement.max() > 0.1


def test_near_is_half_a_decade_and_intervals_decide():
    from forcespace_studies.stats import interval_verdict, near
    assert interval_verdict(0.0316227766, 0.164, near(0.1)) == "reproduced"
    assert interval_verdict(0.01, 1.0, near(0.1)) == "not decidable"
    assert interval_verdict(0.5, 10.0, near(0.1)) == "refuted"


@pytest.mark.slow
def test_size_quick_scaled_boxes_and_indeterminacy_bookkeeping(tmp_path, capsys):
    from forcespace_studies import size
    from forcespace_studies.report import RULES_VERSION
    out = tmp_path / "size"
    summary = run_quick("size", out, capsys)
    assert summary["failed"] == 0 and summary["rows"] == 6
    assert (out / "size.png").is_file() and (out / "size.pdf").is_file()
    assert (out / "size.csv").is_file() and (out / "size_by_n.csv").is_file()
    doc = json.loads((out / "verdicts.json").read_text())
    assert doc["rules_version"] == RULES_VERSION
    # the paper's claim (eta grows with n, n <= 500: every quick size) per uniform sampler
    # on the slice; the open question (grows without bound) per sampler and scope
    paper = [v for v in doc["verdicts"] if "paper's range" in v["claim"]]
    assert sorted(v["sampler"] for v in paper) == ["billiard", "hit_and_run"]
    for v in paper:
        assert v["kind"] == "paper" and v["quick_outcome"] in (
            "reproduced", "refuted", "not decidable")
        assert v["claim"] in (out / "REPORT.md").read_text()
    # the thermodynamic limit: one verdict per fit with a model comparison, decided by the
    # three laws and the slope at the two largest sizes (rule 7)
    limits = [v for v in doc["verdicts"] if "without bound" in v["claim"]]
    assert sorted((v["sampler"], "window" in v["claim"]) for v in limits) == [
        ("billiard", False), ("billiard", True), ("hit_and_run", False),
        ("hit_and_run", True)]
    slopes = doc["numbers"]["eta_slopes"]
    for v in limits:
        assert v["kind"] == "hypothesis"
        scope = "window" if "window" in v["claim"] else "slice"
        f = slopes[f"{v['sampler']}/{scope}/mu0.1"]
        m, local = f["models"], f["local_slope"]
        assert v["quick_outcome"] == size.LIMIT_VERDICT[size.limit_call(m, local)]
        assert f"{m['aic_power_minus_saturating']:.2f}" in v["ours"]
        assert f"{m['aic_log_minus_saturating']:.2f}" in v["ours"]
        assert local is None or local["sizes"][1] == 60
    assert "relax" not in doc["numbers"]["runs_per_mu_and_n"]
    before = {f.name: f.read_text() for f in (out / "tasks").glob("*.json")}
    done = run_tasks(size.tasks(quick=True), out, progress=False)   # resumes: nothing to run
    assert {f.name: f.read_text() for f in (out / "tasks").glob("*.json")} == before
    rows = {r["task"]: r for r in done}
    assert sorted(rows) == [f"n{n}_mu0.1_s{s}" for n in (40, 50, 60) for s in (1, 2)]
    # seed-major: every size of seed 1 before any of seed 2
    assert [t.params["seed"] for t in size.tasks(quick=True)] == [1, 1, 1, 2, 2, 2]
    # the full sweep: fewer packings where they cost most, the creeping (n, mu) last
    full = size.tasks()
    per = {}
    for t in full:
        per.setdefault((t.params["n_disks"], t.params["mu"]), []).append(t.params["seed"])
    assert per[(5000, 0.1)] == [1, 2, 3, 4] and per[(2000, 0.1)] == list(range(1, 11))
    late = {(n, mu) for n, mu in size.FULL["last"]}
    first_late = min(i for i, t in enumerate(full)
                     if (t.params["n_disks"], t.params["mu"]) in late)
    assert all((t.params["n_disks"], t.params["mu"]) in late for t in full[first_late:])
    # ... in the order listed: every seed of n = 2000 before any of n = 5000
    assert [(t.params["n_disks"], t.params["seed"]) for t in full[first_late:]] == [
        (2000, s) for s in range(1, 11)] + [(5000, s) for s in range(1, 5)]
    # the box keeps its shape: width and slice height scale by sqrt(n / 40) from the
    # quick scene (20 R, 10 R), so the slice holds the same share of the disks
    share = {}
    for r in done:
        f = np.sqrt(r["n"] / 40)
        assert r["width"] == pytest.approx(20 * f) and r["slice_height"] == pytest.approx(10 * f)
        share.setdefault(r["n"], []).append(r["slice_disks"] / r["n"])
    assert 0.75 < np.mean(share[60]) / np.mean(share[40]) < 1.33
    for r in done:
        nc, n_in, d = r["slice_contacts"], r["slice_disks"], r["dim_S"]
        # S lies in the null space of 3 n_in equilibrium rows: 2Nc - 3n_in <= degree, and
        # implicit equalities (sliding, zero-force contacts) only lower dim S further
        assert 2 * nc - 3 * n_in <= r["degree_of_indeterminacy"] and 0 <= d <= \
            r["degree_of_indeterminacy"]
        # frictional packings are hypostatic against frictionless isostaticity (z < 4)
        assert 0 <= r["dim_S_over_Nc"] < 0.5
        # both uniform samplers: eta vanishes exactly when S is a point, a spread is
        # smaller than the forces, and the two agree (the same measure) within 15 %
        for k in ("billiard", "hit_and_run"):
            assert r[f"converged_{k}"]
            assert (r[f"eta_{k}"] > 0) == (d > 0) and r[f"eta_{k}"] < 1
            assert (r[f"eta_window_{k}"] > 0) == (r["window_varying_fraction"] > 0)
        if d:
            assert r["eta_billiard"] == pytest.approx(r["eta_hit_and_run"], rel=0.15)
        assert "eta_relax" not in r and "n_relax" not in r
        assert r["n_elementary"] <= d and r["density_rho"] == pytest.approx(
            r["n_elementary"] / n_in)
        assert 0 <= r["largest_domain_fraction"] <= r["varying_fraction"] <= 1
        assert (r["varying_fraction"] > 0) == (d > 0)
        # the fixed window (the n0 slice, 20 R x 10 R) holds a subset of the slice's
        # contacts; at n0 = 40 it is the slice itself, with the same eta
        assert (r["window_width"], r["window_height"]) == (20.0, 10.0)
        assert 0 < r["window_contacts"] <= nc
        if r["n"] == 40:
            assert r["window_contacts"] == nc
            assert r["eta_window_billiard"] == pytest.approx(r["eta_billiard"])
            assert r["window_varying_fraction"] == pytest.approx(r["varying_fraction"])
    # the larger packings are indeterminate: a fit of eta against n exists
    assert all(rows[f"n60_mu0.1_s{s}"]["dim_S"] > 0 for s in (1, 2))


def test_a_kept_packing_is_reused_only_under_the_overrides_it_was_jammed_with(tmp_path):
    from forcespace.errors import InputError
    from forcespace_studies.common import shared_packing
    from forcespace.model.scene import parse_scene_text
    # the override reaches the packing's own scene record ...
    tight = {"solver__tolerance": 1e-8}
    p, t_jam = shared_packing(tmp_path, "quick", 0.3, 1, 24, overrides=tight)
    assert t_jam > 0
    assert parse_scene_text(p.scene_text)["solver.tolerance"] == 1e-8
    # ... the same protocol reuses it, another one refuses it by file and key
    again, t_again = shared_packing(tmp_path, "quick", 0.3, 1, 24, overrides=tight)
    assert t_again == 0.0 and np.array_equal(again.x, p.x)
    with pytest.raises(InputError, match=r"quick_n24_mu0.3_s1\.h5: solver\.tolerance = 1e-08"):
        shared_packing(tmp_path, "quick", 0.3, 1, 24, overrides={"solver__tolerance": 1e-6})


def test_size_report_names_the_packings_whose_static_solve_restarted():
    from forcespace_studies import size
    rows = [dict(n=800, mu=1.0, seed=3, static_restart="exact point"),
            dict(n=800, mu=1.0, seed=4, static_restart=""), dict(n=100, mu=0.1, seed=1)]
    assert "1 of 3 packings (n = 800, mu = 1, seed 3)" in size.restarts_note(rows)
    assert size.restarts_note(rows[1:]) == ""


def test_size_names_the_packings_whose_frame_was_widened():
    from forcespace_studies import size
    rows = [dict(n=5000, mu=1.0, seed=4, widening_billiard=2.59e-8),
            dict(n=5000, mu=1.0, seed=3), dict(n=100, mu=0.1, seed=1, widening_hit_and_run=0)]
    assert "of S): n = 5000, mu = 1, seed 4 (billiard, 2.6e-08 <Fn>)." in size.widening_note(rows)
    assert size.widening_note(rows[1:]) == ""


def test_size_counts_a_failed_analysis_as_failed_not_as_not_run():
    from forcespace_studies import size

    rows = [{"mu": 1, "n": 800, "converged_billiard": True, "eta_billiard": 0.01},
            {"mu": 1, "n": 800, "eta_billiard": 0.02, "converged_billiard": False},
            {"mu": 1, "n": 800, "error_billiard": "NumericalError: ..."},
            {"mu": 1, "n": 800, "error_analysis": "range LP failed"},
            {"mu": 1, "n": 800, "converged_billiard": True, "eta_billiard": 0.0}]
    assert size.counts(rows, 1, 800, "billiard") == {
        "packings": 5, "converged": 2, "excluded": 1, "failed": 2, "not_run": 0}
    # hit-and-run did not run at this n (above its largest): the failed analysis is its one failure
    assert size.counts(rows, 1, 800, "hit_and_run") == {
        "packings": 5, "converged": 0, "excluded": 0, "failed": 1, "not_run": 4}


def test_size_model_comparison_tells_a_power_law_from_saturation():
    from forcespace_studies import size
    n = np.repeat([100.0, 200.0, 400.0, 800.0, 2000.0], 6)
    rng = np.random.default_rng(1)
    noise = np.exp(rng.normal(0, 0.03, n.size))
    power = size.compare_models(n, 1e-3 * n ** 0.4 * noise)
    assert power["preferred"] == "power" and power["power"]["b"] == pytest.approx(0.4, abs=0.02)
    sat = size.compare_models(n, 0.02 * (1 - 5 * n ** -0.5) * noise)
    assert sat["preferred"] == "saturating"
    assert sat["saturating"]["eta_inf"] == pytest.approx(0.02, rel=0.05)
    assert sat["saturating"]["c"] == pytest.approx(5, rel=0.1)
    # scatter large against the difference: no law favoured
    wide = size.compare_models(n, 1e-3 * n ** 0.1 * np.exp(rng.normal(0, 0.5, n.size)))
    assert wide["preferred"] == "no law favoured"
    assert size.compare_models(n[:3], n[:3])["preferred"].startswith("no fit")


def test_size_slope_decision_and_what_would_decide_it():
    from forcespace_studies import size
    n = np.repeat([100.0, 200.0, 500.0, 1000.0, 2000.0], 3)
    wiggle = np.exp(np.tile([-0.02, 0.0, 0.02], 5))
    grows = size.slope_interval(n, 1e-3 * n ** 0.5 * wiggle)
    assert grows["slope"] == pytest.approx(0.5, abs=1e-3)
    assert size.classify(*grows["ci95"]) == "grows"
    flat = size.slope_interval(n, 1e-3 * wiggle)
    assert size.classify(*flat["ci95"]) == "intensive"
    assert size.classify(-0.5, -0.1) == "decreases"
    # large scatter: undecided; the size said to decide it does, at the fitted scatter
    rng = np.random.default_rng(3)
    noisy = size.slope_interval(n, 1e-3 * n ** 0.05 * np.exp(rng.normal(0, 0.15, n.size)))
    assert size.classify(*noisy["ci95"]) == "undecided"
    need = size.needed(noisy, n)
    big = need["size_with_added_packings"]
    assert big is not None and big > 2000 and need["packings_factor_same_sizes"] > 1
    from scipy.stats import t as student
    xx = np.log(np.concatenate([n, np.full(need["add_packings"], float(big))]))
    hw = student.ppf(0.975, xx.size - 2) * noisy["resid_sd"] / np.sqrt(
        ((xx - xx.mean()) ** 2).sum())
    assert hw <= need["half_width_needed"] < noisy["ci95"][1] - noisy["slope"]


# ---------------------------------------------------------------------------
# selection: landing labels and the verdicts counted over packings (hand-made results)
# ---------------------------------------------------------------------------
def _run(K, distance, unmatched=0, run_converged=True, steps=300_000, lost=1):
    return {"K": K, "kn": K * 0.1, "run_converged": run_converged, "steps": steps,
            "distance_to_S": distance, "unmatched": unmatched, "lost": lost,
            "max_overlap": 1e-7}


def test_selection_landing_labels_follow_the_ladder():
    from forcespace_studies import selection as sel
    tol = 1e-4
    assert sel.landing([_run(1e7, 4e-6)], tol)["label"] == "converged"
    # stopped at the step cap but in S: "landed", with its distance
    lab = sel.landing([_run(1e7, 1.1e-6, run_converged=False, steps=1_501_000)], tol)
    assert lab["label"] == "landed" and lab["distance"] == 1.1e-6
    assert "landed within 1.1e-06 <Fn> of S at K = 1e+07" in sel.label_text(lab)
    # task JSON of the earlier code: "converged" is the run's own flag
    old = dict(_run(1e7, 1e-6), converged=False)
    del old["run_converged"]
    assert sel.landing([old], tol)["label"] == "landed"
    # stiffest first: the first run that lands is the one kept
    ladder = [_run(1e7, 0.05, unmatched=1), _run(3e6, 5e-5, run_converged=False),
              _run(1e6, 1e-6)]
    lab = sel.landing(ladder, tol)
    assert lab["label"] == "landed" and lab["K"] == 3e6
    # a contact outside the rigid network, or too far from S: not landed, closest run named
    lab = sel.landing([_run(1e7, 0.057, unmatched=1), _run(3e6, 0.031, unmatched=1),
                       _run(1e6, 2e-4)], tol)
    assert lab["label"] == "not landed" and lab["K"] == 1e6 and lab["distance"] == 2e-4
    assert sel.landing([], tol)["label"] == "not landed"
    row = {"pym_unmatched": 0, "pym_distance_to_S": 6e-7, "pym_converged": True}
    assert sel.pymunk_landing(row, tol)["label"] == "converged"
    assert sel.pymunk_landing(dict(row, pym_unmatched=2), tol)["label"] == "not landed"


def _packing_rows(mu, seed, lig, pym_closer=True, kts=(2 / 7, 1.0)):
    """One packing's rows; lig: per kt/kn (runs, closer to the selection or not)."""
    rows = []
    for kt, (runs, near) in zip(kts, lig):
        r = {"mu": mu, "seed": seed, "kt_ratio": kt, "lig_runs": runs, "centre_radius": 0.02,
             "pym_unmatched": 0, "pym_distance_to_S": 1e-6, "pym_converged": True,
             "d_pym_sel": 0.05 if pym_closer else 0.3, "d_pym_cd": 0.2, "d_pym_centre": 0.25,
             "d_sel_cd": 0.2, "d_cd_centre": 0.1}
        if any(q["unmatched"] == 0 and q["distance_to_S"] < 1e-4 for q in runs):
            r.update(d_lig_sel=0.05 if near else 0.25, d_lig_cd=0.2, d_lig_centre=0.22)
        rows.append(r)
    return rows


def test_selection_verdicts_count_packings_not_rows(tmp_path):
    from forcespace_studies import selection as sel
    from forcespace_studies.report import RULES_VERSION
    ok, cap, bad = _run(1e7, 4e-6), _run(1e7, 2e-6, run_converged=False), \
        _run(1e7, 0.03, unmatched=1)
    params = {"landed_tol": 1e-4, "scene": "paper", "n_disks": 200, "K": [1e7],
              "pymunk": [100, 0.003], "max_steps": 1_500_000}

    def task(mu, seed, lig, **kw):
        return {"task": f"mu{mu:g}_s{seed}", "ok": True, "params": dict(params, mu=mu),
                "rows": _packing_rows(mu, seed, lig, **kw)}
    # mu = 0.1: 8 packings hold at both kt/kn (one of them with a run at the step cap),
    # one holds at kt/kn = 2/7 only (it counts against: "every kt/kn"), one holds but
    # did not land at kt/kn = 1 (left out): 8 of 9 -> exact interval (0.52, 1.00)
    res = [task(0.1, s, [([ok], True), ([cap if s == 1 else ok], True)]) for s in range(1, 9)]
    res.append(task(0.1, 9, [([ok], True), ([ok], False)]))
    res.append(task(0.1, 10, [([ok], True), ([bad, bad], True)], pym_closer=False))
    # mu = 0.5: 1 of 10 packings -> interval below 1/2; one task failed as a whole
    res += [task(0.5, s, [([ok], s == 1), ([ok], s == 1)]) for s in range(1, 11)]
    res.append({"task": "mu0.5_s11", "ok": False, "params": dict(params, mu=0.5),
                "error": "LiggghtsError: boom"})
    # mu = 0: labels only, no verdict
    res.append(task(0.0, 1, [([ok], True)], kts=(2 / 7,)))
    summary = sel.summarize(res, tmp_path)
    assert summary["failed"] == 1 and summary["rows"] == 41
    doc = json.loads((tmp_path / "verdicts.json").read_text())
    assert doc["rules_version"] == RULES_VERSION
    h = doc["numbers"]["hypothesis"]
    lig1 = h["LIGGGHTS/mu0.1"]
    assert (lig1["packings"], lig1["entered"], lig1["holds"]) == (10, 9, 8)
    assert lig1["entered_all_converged"] == 8 and lig1["entered_with_capped_runs"] == 1
    assert lig1["capped_max_distance"] == 2e-6 and lig1["not_landed_seeds"] == [10]
    assert lig1["per_kt"] == {"0.286": {"holds": 9, "packings": 9},
                              "1": {"holds": 8, "packings": 9}}
    assert lig1["ci95"][0] == pytest.approx(0.5175, abs=1e-3) and lig1["verdict"] == "supported"
    # pymunk has no ladder: all 10 packings enter, 9 hold -> supported
    assert (h["pymunk/mu0.1"]["entered"], h["pymunk/mu0.1"]["holds"]) == (10, 9)
    lig5 = h["LIGGGHTS/mu0.5"]
    assert (lig5["entered"], lig5["holds"], lig5["verdict"]) == (10, 1, "not supported")
    assert "LIGGGHTS/mu0" not in h                     # S is a point: no verdict at mu = 0
    v = {(x["claim"].split(" lands")[0], x["claim"].split("mu = ")[1][:3]): x
         for x in doc["verdicts"]}
    assert len(v) == 4 and {x["kind"] for x in doc["verdicts"]} == {"hypothesis"}
    assert v[("LIGGGHTS", "0.1")]["verdict"] == "supported"
    assert "8 of 9 packings" in v[("LIGGGHTS", "0.1")]["ours"]
    assert "Clopper-Pearson" in v[("LIGGGHTS", "0.1")]["rule"]
    assert doc["numbers"]["failed_per_mu"] == {"0.5": ["mu0.5_s11: task failed: LiggghtsError: boom"]}
    assert doc["numbers"]["labels"]["mu0.1"]["lig"] == {"converged": 18, "landed": 1,
                                                       "not landed": 1}
    text = doc["text"]
    assert "landed within 2e-06 <Fn> of S at K = 1e+07 (stopped at the step cap" in text
    assert "mu = 0.1, seed 10, kt/kn = 1: not landed" in text
    assert "1 of 22 tasks failed" in text
    # too few packings: not decidable, and how many would decide it
    rows = [dict(r, landed_tol=1e-4) for s in (1, 2, 3)
            for r in _packing_rows(0.1, s, [([ok], True), ([ok], True)])]
    few = sel.judge(rows, "lig", 0.1)
    assert (few["holds"], few["entered"], few["verdict"]) == (3, 3, "not decidable")
    assert few["needed"] == 6


def test_selection_binomial_helpers():
    from forcespace_studies.stats import binomial_interval, majority_call, packings_to_decide
    lo, hi = binomial_interval(9, 10)
    assert lo == pytest.approx(0.5550, abs=1e-4) and hi == pytest.approx(0.99747, abs=1e-4)
    assert majority_call(9, 10) == "most" and majority_call(8, 10) == "undecided"
    assert majority_call(0, 10) == "few" and majority_call(5, 10) == "undecided"
    assert packings_to_decide(5, 10) is None and packings_to_decide(3, 3) == 6


def test_samplers_given_the_tasks_analysis_sample_the_same_chain_without_a_second_one(
        tmp_path, monkeypatch):
    # run_samplers hands the task's ForceSpace to billiard and hit-and-run: their frame is
    # built from it (the LPs are deterministic, so the chains are bit-identical to those
    # that analyse S themselves) and S is analysed once, not once per sampler
    import forcespace as fs
    from ensemble_cases import lattice_rows
    from forcespace_studies.common import run_samplers, sampler
    from forcespace.space import force_space as F

    _, prob = lattice_rows(3, 2, 0.5)
    an = fs.ForceSpace().compute(prob)
    own, given = {}, {}
    names = ("billiard", "hit_and_run")
    ens_own = run_samplers(own, [(k, sampler(k, 4, 300, None)) for k in names], prob,
                           tmp_path, "_own")
    calls = []
    real = F._analyze
    monkeypatch.setattr(F, "_analyze", lambda *a, **k: calls.append(1) or real(*a, **k))
    ens_given = run_samplers(given, [(k, sampler(k, 4, 300, None)) for k in names], prob,
                             tmp_path, "_given", analysis=an)
    assert calls == []
    for k in names:
        assert ens_own[k].n_samples == ens_given[k].n_samples > 0
        np.testing.assert_array_equal(ens_own[k].samples, ens_given[k].samples)
        assert own[f"eta_{k}"] == given[f"eta_{k}"]


def test_a_sampler_failing_on_a_corrupt_work_file_fails_its_task(tmp_path, monkeypatch):
    # run_samplers recorded any ForcespaceError as the sampler's result: a task whose
    # work files were corrupt was marked "ok" with error_NAME rows and never retried
    # (issue 48). A method that fails (NumericalError) stays a result (rule 5).
    import h5py
    import forcespace as fs
    from ensemble_cases import lattice_rows
    from forcespace.errors import InputError, NumericalError
    from forcespace_studies.common import run_samplers, sampler

    _, prob = lattice_rows(3, 2, 0.5)
    runs = [("hit_and_run", sampler("hit_and_run", 4, 20, None))]
    row = {}
    run_samplers(row, runs, prob, tmp_path)
    work = tmp_path / "hit_and_run.h5"
    with h5py.File(work, "r+") as f:
        f["samples"][0, 0, 0] += 1.0
    with pytest.raises(InputError, match=f"{work}: samples\\[0\\]"):
        run_samplers({}, runs, prob, tmp_path)
    work.unlink()

    def fails(self, *a, **k):
        raise NumericalError("the walk failed")

    monkeypatch.setattr(fs.HitAndRun, "compute", fails)
    row = {}
    assert run_samplers(row, runs, prob, tmp_path) == {"hit_and_run": None}
    assert row["error_hit_and_run"] == "NumericalError: the walk failed"
