"""The point-force study's bookkeeping and verdicts on hand-made results (no dynamics)."""
import json

import numpy as np
import pytest

from forcespace_studies import pointforce
from forcespace_studies.report import RULES_VERSION


def layer(mu, seed, depth, censored=False, **kw):
    """A finished task's result: a judged push unless ``kw`` says otherwise."""
    row = {"task": f"mu{mu:g}_s{seed}", "ok": True, "mu": mu, "seed": seed,
           "params": {"mu": mu, "seed": seed, "scene": "layer", "n_disks": 320,
                      "width": 42.0},
           "thickness": 64.0, "carries_any_force": False, "f_star_over_weight": 2.0,
           "control_max_displacement": 1e-5, "rearranged": True, "push_at_rest": True,
           "depth": depth, "reaches_floor": censored, "region_size": 5}
    row.update(kw)
    return row


def results(depths: dict, censored=()) -> list:
    return [layer(mu, s, d, (mu, s) in censored) for mu, ds in depths.items()
            for s, d in enumerate(ds, 1)]


def summarize(tmp_path, res, min_pushes=3):
    (tmp_path / "study.json").write_text(json.dumps(
        {"study": "pointforce", "quick": False, "config": {"min_pushes": min_pushes}}))
    summary = pointforce.summarize(res, tmp_path)
    return summary, json.loads((tmp_path / "verdicts.json").read_text())


def test_summary_counts_medians_and_a_shallow_mu_near_0_1(tmp_path):
    res = results({0.01: [20, 25, 30, 35, 40, 45], 0.1: [1, 2, 3, 4, 5, 30],
                   1.0: [15, 20, 22, 63, 63, 3]}, censored={(1.0, 4), (1.0, 5)})
    # layers that are not judged, each for its reason, and a failed task
    res += [layer(0.1, 7, 0.5, control_max_displacement=0.3),        # restless
            layer(0.1, 8, None, rearranged=False),                    # no rearrangement
            layer(0.1, 9, 0.5, push_at_rest=False),                   # still moving
            layer(0.1, 10, None, carries_any_force=True),
            {"task": "mu1_s7", "ok": False, "params": {"mu": 1.0, "seed": 7},
             "error": "NumericalError: not jammed"}]
    st = pointforce.per_mu(res)
    s = st[0.1]
    assert (s["tasks"], s["layers"], s["judged"], s["restless"], s["no_rearrangement"],
            s["push_not_at_rest"], s["carries_any_force"], s["failed"]) == (10, 10, 6, 1, 1,
                                                                          1, 1, 0)
    assert s["depth_median"] == 3.5 and s["depth_lo"] <= 3.5 <= s["depth_hi"]
    assert s["deep_fraction"] == pytest.approx(1 / 6) and s["censored_fraction"] == 0.0
    assert st[1.0]["failed"] == 1 and st[1.0]["judged"] == 6
    assert st[1.0]["depth_median"] == 21.0
    assert st[1.0]["censored_fraction"] == pytest.approx(2 / 6)
    summary, doc = summarize(tmp_path, res)
    assert summary["failed"] == 1 and summary["pushed"] == 18
    assert doc["rules_version"] == RULES_VERSION and doc["numbers"]["tasks_failed"] == 1
    assert "mu1_s7: NumericalError" in doc["numbers"]["failed"][0]
    paper, ours = doc["verdicts"]
    assert paper["kind"] == "paper" and paper["verdict"] == "reproduced"
    assert doc["numbers"]["shallowest_median_mu"]["mu"] == 0.1
    assert ours["kind"] == "ours" and ours["verdict"] == "supported"      # rule 3
    assert (tmp_path / "pointforce.png").is_file()
    assert "1 of 23 tasks failed" in doc["text"]


def test_summary_refutes_a_minimum_at_an_end_and_censoring_undecides(tmp_path):
    res = results({0.01: [20, 25, 30, 35, 40, 45], 0.1: [20, 22, 24, 26, 28, 30],
                   1.0: [1, 2, 2, 3, 3, 4]})
    (tmp_path / "a").mkdir()
    _, doc = summarize(tmp_path / "a", res)
    paper, ours = doc["verdicts"]
    assert doc["numbers"]["shallowest_median_mu"]["mu"] == 1.0
    assert paper["verdict"] == "refuted" and ours["verdict"] == "not supported"
    # the shallowest mu has half its pushes cut off by the floor (a thin layer): its
    # median is only a lower bound, the claim is not decidable
    res = results({0.01: [20, 25, 30, 35, 40, 45], 0.1: [5, 5, 5, 8, 8, 8],
                   1.0: [20, 22, 24, 26, 28, 30]},
                  censored={(0.1, 4), (0.1, 5), (0.1, 6)})
    (tmp_path / "b").mkdir()
    _, doc = summarize(tmp_path / "b", res)
    assert doc["numbers"]["shallowest_median_mu"]["mu"] == 0.1
    assert doc["verdicts"][0]["verdict"] == "not decidable"
    # too few judged pushes per mu (a partial run): the claim stays in the table, not
    # decidable, with the counts
    (tmp_path / "c").mkdir()
    _, doc = summarize(tmp_path / "c", res, min_pushes=7)
    (paper,) = doc["verdicts"]
    assert paper["verdict"] == "not decidable" and paper["kind"] == "paper"
    assert "mu = 0.1: 6" in paper["ours"] and "0 mu have the 7" in paper["ours"]


def test_bootstrap_statistics_by_hand():
    from forcespace_studies.stats import argmax_bootstrap, bootstrap_stat, difference_interval
    v = np.array([1.0, 2.0, 3.0, 100.0])
    med = bootstrap_stat({0: v}, np.median)[0]
    assert med[0] == 2.5 and med[1] >= 1.0 and med[2] <= 100.0
    assert difference_interval(np.ones(5), np.zeros(5)) == (1.0, 1.0, 1.0)
    # the smallest median, not the smallest mean (an outlier pulls the mean of 0.1 up)
    groups = {0.01: np.full(6, 9.0), 0.1: np.r_[np.full(5, 1.0), 1e3]}
    assert argmax_bootstrap({m: -g for m, g in groups.items()}, stat=np.median)[0] == 0.1
    assert argmax_bootstrap({m: -g for m, g in groups.items()})[0] == 0.01
