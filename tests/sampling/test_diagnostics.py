"""The convergence diagnostics (sampling/diagnostics.py) are ArviZ's: the port of its
bulk ESS, tail ESS and rank-normalised split R-hat gives ArviZ's own numbers."""
import warnings

import numpy as np

from forcespace.sampling import diagnostics as dg


def test_ess_and_rhat_equal_arviz():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import arviz
    rng = np.random.default_rng(1)
    for k in range(20):
        chains, draws = int(rng.integers(2, 6)), int(rng.integers(4, 300))
        v = rng.normal(size=(chains, draws)).cumsum(1) * rng.random() \
            + rng.normal(size=(chains, 1)) * rng.random()
        if k % 5 == 0:
            v = np.round(v, 1)                       # ties: average ranks
        for ours, theirs in ((dg.ess_bulk(v), arviz.ess(v, method="bulk")),
                             (dg.ess_tail(v), arviz.ess(v, method="tail")),
                             (dg.rhat_rank(v), arviz.rhat(v, method="rank"))):
            assert abs(ours - theirs) <= 1e-12 * abs(theirs), (k, ours, theirs)
    assert np.isnan(dg.rhat_rank(np.ones((1, 10))))  # one chain: no R-hat (as ArviZ)
