"""Issue 45: seven verdicts read as their data and the paper's words say, pinned on
hand-made rows (each reading here gave another verdict under the earlier one)."""
import numpy as np
import pytest

from forcespace_studies import fig1, fig2, fig3, size
from forcespace_studies.report import Verdict

from test_study import _dom, _fig2_row


def test_the_vocabulary_follows_the_kind_of_claim():
    """Rule 3: the project's own tests and open questions are supported / not supported,
    the paper's claims reproduced / refuted."""
    Verdict("x", "claim", "42", "supported", kind="ours")
    Verdict("x", "claim", "42", "not decidable", kind="hypothesis")
    with pytest.raises(ValueError, match="ours"):
        Verdict("x", "claim", "42", "refuted", kind="ours")
    with pytest.raises(ValueError, match="paper"):
        Verdict("x", "claim", "42", "supported")


# ---------------------------------------------------------------------------
# fig1: a trend judged by a trend test; the plate unknowns counted
# ---------------------------------------------------------------------------
def _eta_groups(top_mu_values):
    """eta per packing (10 per mu): a maximum at 0.1, lower beyond, the largest mu half
    determinate (eta = 0) with a wide scatter (``top_mu_values``)."""
    rng = np.random.default_rng(4)
    out = {}
    for m in (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0):
        out[m] = 0.05 * np.exp(-np.log10(m / 0.1) ** 2 / 2) * (1 + 0.1 * rng.normal(size=10))
    out[10.0] = np.array(top_mu_values, float)
    return out


def test_eta_decreasing_beyond_the_maximum_is_judged_by_a_trend_over_every_packing():
    """The largest mu alone (half determinate, one packing as high as the peak) cannot
    tell; every packing from mu = 0.1 on can: Kendall's tau over 70 packings. The earlier
    reading (the largest mu's interval below the peak's) said not decidable here."""
    eta = _eta_groups([0, 0, 0, 0, 0, 0.09, 0.06, 0.08, 0.07, 0.08])
    numbers = {}
    v = [x for x in fig1._eta_verdicts([], eta, "hit_and_run", numbers)
         if x.claim == "eta decreases beyond the maximum"][0]
    assert v.verdict == "reproduced" and "trend" in v.rule
    t = numbers["eta_trend_beyond_maximum_hit_and_run"]
    assert t["points"] == 70 and t["tau"] < -0.3 and t["p_decreasing"] < 1e-6
    assert t["determinate"] == 5 and "5 of them determinate" in v.ours
    # a rise beyond 0.1 refutes it; no order at all cannot decide it
    up = {m: v * (m if m >= 0.1 else 1) for m, v in _eta_groups([0.5] * 10).items()}
    assert [x for x in fig1._eta_verdicts([], up, "relax", {})
            if x.claim.startswith("eta decreases")][0].verdict == "refuted"
    rng = np.random.default_rng(1)
    flat = {m: 0.05 * (1 + 0.2 * rng.normal(size=10)) for m in _eta_groups([0] * 10)}
    assert [x for x in fig1._eta_verdicts([], flat, "relax", {})
            if x.claim.startswith("eta decreases")][0].verdict == "not decidable"


def test_trend_test_recovers_a_known_order_with_ties():
    from forcespace_studies.stats import trend_test
    x = np.repeat([1.0, 2.0, 3.0, 4.0], 5)
    y = np.concatenate([np.full(5, 3.0), np.full(5, 2.0), np.zeros(5), np.zeros(5)])
    t = trend_test(x, y)
    assert t["call"] == "decreases" and -1 < t["tau"] < -0.8      # ties keep |tau-b| < 1
    assert trend_test(x, -y)["call"] == "increases"
    assert trend_test(x[:2], y[:2])["call"] == "no trend"


def _small_mu_rows(plates: bool):
    """Full packings at small mu as the paper counts them: n = 100 disks, Nc = 200
    contacts (z = 4), of them 8 on the top plate (loads: no unknowns in the full problem)
    and 9 on the frictionless bottom plate (one unknown each); rank A = 3n - 1 (the
    horizontal balance of the whole packing holds identically)."""
    n, nc, top, bottom = 100, 200, 8, 9
    unknowns = 2 * (nc - top - bottom) + bottom
    rank = 3 * n - 1
    rows = []
    for seed in range(1, 6):
        r = {"mu": 0.001, "mu_sample": 0.001, "seed": seed, "z": 4.0, "dim_S": 80,
             "nc_full": nc, "n_full": n, "dof_excess_full": 2 * nc - 3 * n,
             "dof_rank_full": unknowns - rank}
        if plates:
            r.update(unknowns_full=unknowns, rank_full=rank, nc_top_full=top,
                     nc_bottom_full=bottom)
        rows.append(r)
    return rows


def test_rank_degree_counts_the_plate_unknowns_as_the_paper_counts_them():
    """unknowns - rank A = 375 - 299 = 76 is 0.76 of Nc/2: the earlier reading refuted the
    claim for bookkeeping; counted as the paper counts (two per contact, plates included)
    2Nc - rank A = 101, 1.01 of Nc/2: supported. Rows without the plate counts cannot
    split the gap: not decidable."""
    numbers = {}
    v = [x for x in fig1._packing_verdicts(_small_mu_rows(True), [], numbers)
         if "rank" in x.claim][0]
    assert v.kind == "ours" and v.verdict == "supported"
    assert "(2Nc - rank A) / (Nc/2) = 1.010" in v.ours and "3n - rank A = 1-1" in v.ours
    assert "2 N_top + N_bottom = 25.0" in v.ours and "0.760" in v.ours
    d = numbers["dof_over_half_nc_small_mu"]
    assert d["plates_share"] == [25.0, 0.0] and d["three_n_minus_rank"] == [1, 1]
    old = [x for x in fig1._packing_verdicts(_small_mu_rows(False), [], {})
           if "rank" in x.claim][0]
    assert old.verdict == "not decidable" and "24.0 ± 0.0 per packing" in old.ours


def test_packing_row_counts_the_plates_and_the_rank_of_a_real_packing():
    """On a jammed packing (400 disks, mu = 0.01): the x-rows of the full problem's
    equilibrium matrix sum to zero (no horizontal plate force), so rank A = 3n - 1 for a
    rigid packing; its unknowns are two per disk-disk contact and one per bottom-plate
    contact; the gap between the counting degree and unknowns - rank A is the plates'
    share less that one identity."""
    import forcespace as fs
    from forcespace import read_packing

    from paths import DATA
    p = read_packing(DATA / "paper_fast_n400_mu0.01_s3.h5")
    r = fig1.packing_row(p, 0.01)
    top, bottom = r["nc_top_full"], r["nc_bottom_full"]
    assert top > 5 and bottom > 5
    # the full problem also keeps touching contacts that carry no force (here one)
    full = fs.full_problem(p)
    idle = int((~p.force_bearing()[np.asarray(full.contacts)]).sum())
    assert idle == 1
    assert r["unknowns_full"] == 2 * (r["nc_full"] - top - bottom + idle) + bottom
    free = np.setdiff1d(np.arange(full.n_columns), full.fixed_columns())
    assert abs(full.A[0::3][:, free].sum(axis=0)).max() < 1e-12    # the x-rows sum to 0
    assert r["rank_full"] == 3 * r["n_full"] - 1
    assert r["dof_excess_full"] - r["dof_rank_full"] == 2 * top + bottom - 1 - 2 * idle
    assert abs((2 * r["nc_full"] - r["rank_full"]) / (r["nc_full"] / 2) - 1) < 0.1


# ---------------------------------------------------------------------------
# fig3: which planes, the mobilised packings beside; one row per test of ours
# ---------------------------------------------------------------------------
def _fig3_rows():
    """20 packings: 2 with a contact exactly at the Coulomb limit (every section has x0
    on its edge), 18 with x0 inside S, farther from the sections' boundaries than the
    uniform samples on 16 of them, yet nearer S's boundary than the median uniform
    sample on all 20."""
    rows = []
    for s in range(20):
        exact = s < 2
        jam = [0.0] * 10 if exact else [0.15] * 10
        uni = [0.05] * 10 if 2 <= s < 18 else [0.3] * 10
        rows.append({"seed": s + 1, "jammed_edge_ratio": jam, "uniform_edge_ratio": uni,
                     "jammed_min_slack": 0.0 if exact else 1e-6,
                     "jammed_slack_rank_hit_and_run": 0.0 if exact else 0.2})
    return rows


def test_fig3_edge_says_which_planes_and_splits_our_two_tests():
    """The earlier reading judged x0 in sections and in S in one row (refuted, though
    its halves disagree); now the paper's claim names its planes and reports the exactly
    mobilised packings beside, and each of our tests has its own row."""
    from matplotlib.figure import Figure

    rows = _fig3_rows()
    numbers = {}
    out = fig3._edge_verdicts(Figure().subplots(), rows, rows, numbers)
    assert len(out) == 3
    edge, sections, in_s = out
    assert edge.kind == "paper" and "random planes" in edge.claim
    assert edge.verdict == "refuted" and edge.ours.startswith("2 of 20 packings")
    assert "2 packings have a contact exactly at the Coulomb limit" in edge.ours
    assert "100 % of their sections" in edge.ours and "0 % of their sections" in edge.ours
    assert numbers["edge_ratio"]["packings_at_coulomb_limit_exactly"] == 2
    assert sections.kind == in_s.kind == "ours"
    assert "sections" in sections.claim and "S itself" in in_s.claim
    assert sections.verdict == "not supported" and "4 of 20 packings" in sections.ours
    assert in_s.verdict == "supported" and "20 of 20 packings" in in_s.ours


# ---------------------------------------------------------------------------
# fig2: localisation judged where the data place the transition
# ---------------------------------------------------------------------------
def test_fig2_localisation_is_judged_from_where_the_data_place_the_transition():
    """At mu = 0.5 (the paper's example) the domains still span; from mu = 0.85 on they
    are small. The earlier window (mu >= 0.5, all together) could not decide; the window
    found from the data does, and says the transition lies above 0.5."""
    results = []
    for mu, share, perc in ((0.1, 0.95, True), (0.5, 0.8, True), (0.85, 0.05, False),
                            (2.0, 0.05, False), (5.0, 0.05, False)):
        for s in range(10):
            doms = [_dom(int(200 * share), 4, perc, True, 1.0)]
            results.append(_fig2_row(f"mu{mu}_s{s}", mu, 4, doms))
    numbers, verdicts = fig2.judge(results)
    loc = verdicts[0]
    assert loc.verdict == "reproduced"
    assert "between mu = 0.5 and 0.85, above the paper's mu = 0.5 example" in loc.ours
    assert "at mu = 0.5: mean share 0.80, 10 of 10" in loc.ours
    assert numbers["localised_from"]["mu"] == 0.85
    assert numbers["localised_from"]["packings"] == 30
    # spanning at every mu: no window localises, the last one refutes it
    spans = [_fig2_row(f"mu{mu}_s{s}", mu, 4, [_dom(180, 4, True, True, 1.0)])
             for mu in (0.1, 1.0) for s in range(10)]
    assert fig2.judge(spans)[1][0].verdict == "refuted"


# ---------------------------------------------------------------------------
# size: three laws, the check at the largest sizes, the paper's range
# ---------------------------------------------------------------------------
def test_size_three_laws_tell_a_logarithm_from_a_power_law_and_saturation():
    n = np.repeat([100.0, 200.0, 400.0, 800.0, 2000.0, 5000.0, 20000.0], 8)
    rng = np.random.default_rng(2)
    noise = np.exp(rng.normal(0, 0.02, n.size))
    log = size.compare_models(n, (0.002 + 0.003 * np.log(n)) * noise)
    assert log["preferred"] == "logarithmic"
    assert log["logarithmic"]["b"] == pytest.approx(0.003, rel=0.05)
    assert log["logarithmic"]["a"] == pytest.approx(0.002, abs=0.001)
    # a logarithm starting below zero (a < 0) is fitted too
    neg = size.compare_models(n, (-0.01 + 0.004 * np.log(n)) * noise)
    assert neg["logarithmic"]["a"] == pytest.approx(-0.01, rel=0.05)
    power = size.compare_models(n, 1e-3 * n ** 0.4 * noise)
    assert power["preferred"] == "power"
    sat = size.compare_models(n, 0.02 * (1 - 5 * n ** -0.5) * noise)
    assert sat["preferred"] == "saturating"
    # each law's slope between the two largest sizes, against the data's there
    local = size.local_slope(n, (0.002 + 0.003 * np.log(n)) * noise, log)
    assert local["sizes"] == [5000, 20000] and local["agrees"]["logarithmic"]
    b = local["bootstrap_ci95"]       # percentile bootstrap, beside: narrower than Welch's
    assert local["ci95"][0] < b[0] < local["slope"] < b[1] < local["ci95"][1]
    x1, x2 = np.log(5000), np.log(20000)
    assert local["predicted"]["logarithmic"] == pytest.approx(
        np.log((0.002 + 0.003 * x2) / (0.002 + 0.003 * x1)) / (x2 - x1), rel=0.05)
    assert local["predicted"]["power"] == pytest.approx(log["power"]["b"])
    assert not local["agrees"]["saturating"]


def _size_rows(eta_of_n, sizes=(100, 200, 400, 800, 2000, 5000), mu=0.1, seed=0, noise=0.15):
    rng = np.random.default_rng(seed)
    rows = []
    for n in sizes:
        for s in range(4 if n >= 5000 else 10):
            e = float(eta_of_n(n) * np.exp(rng.normal(0, noise)))
            rows.append({"task": f"n{n}_mu{mu}_s{s}", "n": n, "mu": mu, "seed": s + 1,
                         "converged_billiard": True, "eta_billiard": e,
                         "eta_window_billiard": None, "window_contacts": None,
                         "window_width": 42.0, "window_height": 28.0, "percolates": True})
    return rows


def test_size_levels_off_only_where_the_largest_sizes_agree_with_saturation():
    """Saturation favoured by AIC over both unbounded laws, but the largest size still
    grows (at slope 0.3 from n = 2000 to 5000, as the size study's mu = 0.1 window does):
    the earlier reading said "levels off" (not supported); the data at the largest sizes
    disagree with the saturating law: not decidable. Growth up to 500 disks is the
    paper's own claim: reproduced."""
    def eta(n):
        def sat(m):
            return 0.06 * (1 - 8.85 * m ** -0.5)
        return sat(n) if n < 5000 else sat(2000) * (5000 / 2000) ** 0.3
    numbers, verdicts = size.judge(_size_rows(eta, noise=0.05))
    limit = [v for v in verdicts if "without bound" in v.claim][0]
    paper = [v for v in verdicts if "paper's range" in v.claim][0]
    f = numbers["eta_slopes"]["billiard/slice/mu0.1"]
    assert f["models"]["aic_power_minus_saturating"] > size.AIC_MARGIN      # the old call
    assert f["models"]["preferred"] == "saturating"
    assert not f["local_slope"]["agrees"]["saturating"]
    assert limit.verdict == "not decidable" and limit.kind == "hypothesis"
    assert "slope between n = 2000 and 5000" in limit.ours
    assert paper.kind == "paper" and paper.verdict == "reproduced"
    assert "30 converged packings at 3 sizes" in paper.ours
    # saturation that the largest sizes agree with: levels off (not supported)
    _, verdicts = size.judge(_size_rows(lambda n: 0.06 * (1 - 8.85 * n ** -0.5), noise=0.05))
    limit = [v for v in verdicts if "without bound" in v.claim][0]
    assert limit.verdict == "not supported" and "levels off" in limit.ours
    # unbounded growth favoured and agreeing at the largest sizes: supported
    _, verdicts = size.judge(_size_rows(lambda n: 1e-3 * n ** 0.5))
    assert [v for v in verdicts if "without bound" in v.claim][0].verdict == "supported"


def test_a_summary_under_the_second_rules_is_marked_until_summarised_again(tmp_path):
    """Verdicts written under rules version 2 (before issue 45) are shown as written and
    marked; the sentence about the first rules (no rule 1 or 4) is not said of them."""
    from forcespace_studies.report import RULES_VERSION, write_report, write_section
    assert RULES_VERSION == 3
    (tmp_path / "fig1").mkdir()
    write_section(tmp_path / "fig1", "fig1", "Title", "text",
                  [Verdict("fig1", "claim", "42", "refuted", kind="paper")], {}, [],
                  rules_version=2)
    report = write_report([tmp_path / "fig1"], tmp_path / "REPORT.md").read_text()
    assert "**refuted (earlier rules)**" in report and "--report-only" in report
    assert "rule 1 (one verdict per sampler)" not in report


# ---------------------------------------------------------------------------
# spheres3d (issue 43): z -> 6 at mu -> 0, falling towards 4 at large mu, static
# ---------------------------------------------------------------------------
def _sphere_rows(z_by_mu, residual=1e-12):
    """Five packings per mu with z = the given mean +- 0.01 (hand-made rows)."""
    return [{"mu": mu, "seed": s, "n": 500, "z": z + 0.01 * (s - 3) / 2,
             "packing_fraction": 0.62 - 0.04 * mu, "rattler_fraction": 0.07 + 0.2 * mu,
             "residual": residual, "coulomb_violation": 0.0, "cpu_seconds": 100.0}
            for mu, z in z_by_mu.items() for s in range(1, 6)]


def test_spheres3d_readings_judge_z_at_both_ends_and_the_static_residual():
    from forcespace_studies import spheres3d

    def calls(rows):
        return [v.verdict for v in spheres3d.verdicts(rows)[0]]

    good = {0.0: 5.99, 0.01: 5.85, 0.1: 5.35, 1.0: 4.3}
    assert calls(_sphere_rows(good)) == ["reproduced", "supported", "supported"]
    # z at mu = 0 off 6 by more than 0.05 (an isostaticity that fails)
    assert calls(_sphere_rows({**good, 0.0: 5.9}))[0] == "refuted"
    # z decreasing but stuck nearer 6 than 4 at mu = 1; z rising with mu
    assert calls(_sphere_rows({**good, 1.0: 5.2}))[1] == "not supported"
    assert calls(_sphere_rows({0.0: 4.3, 0.01: 5.35, 0.1: 5.85, 1.0: 5.99}))[1] == \
        "not supported"
    # a largest mu below 1 cannot tell "towards 4" from a plateau: not decidable
    assert calls(_sphere_rows({0.0: 5.99, 0.01: 5.85, 0.1: 5.35}))[1] == "not decidable"
    # one packing above the static tolerance
    assert calls(_sphere_rows(good, residual=2e-10))[2] == "not supported"
    # the table's +- is the standard error over the seeds (sd 0.0079 / sqrt 5)
    assert "5.990 ± 0.004" in spheres3d.table(_sphere_rows(good))
