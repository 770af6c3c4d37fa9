"""The measured study's noise conditions on a committed packing: a network whose weakest
forces are unknown (the contacts kept as geometry) still holds the truth in S; removed,
the same contacts leave S empty."""
import numpy as np

import forcespace as fs
from forcespace_studies.measured import noisy_check, weakest_unknown

from paths import DATA


def test_weakest_forces_unknown_keep_the_truth_in_S():
    p = fs.read_packing(DATA / "paper_mu1_seed2.h5")
    prob = fs.frame_problem(p, "slice=28")
    keep = np.arange(p.n_contacts)
    known = weakest_unknown(p, keep, prob, 0.05)
    c = prob.contacts
    fb = np.flatnonzero(p.force_bearing()[c])
    assert (~known).sum() == round(0.05 * fb.size) > 0
    mag = np.hypot(p.fn[c], p.ft[c])
    assert mag[~known].max() <= mag[fb][known[fb]].min()       # the weakest ones
    rng = np.random.default_rng(0)
    row = noisy_check(p, 0.0, 0.05, 28.0, rng, missing="unknown")
    assert row["feasible"] and row["distance"] < 1e-9 and row["truth_inside"] == 1.0
    assert row["n_unknown_force"] == (~known).sum() and row["missing"] == "unknown"
    assert row["err_input"] > 0            # an unknown force counts as 0 in the input
    gone = noisy_check(p, 0.0, 0.05, 28.0, rng, missing="removed")
    assert not gone["feasible"] and gone["distance"] > 0.1
