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


def test_rank_normalisation_and_quantile_are_scipys_bit_for_bit():
    """Issue 46: the ranks, Phi^-1 and type-7 quantiles are computed without importing
    scipy.stats (~0.3 CPU s, a quarter of a dim-228 run): the same numbers, bit for bit,
    as scipy.stats.rankdata(method="average") + norm.ppf and mstats.mquantiles, ties
    (rounded draws, a constant chain) included, and NaN stays NaN."""
    from scipy import stats
    from scipy.stats.mstats import mquantiles

    rng = np.random.default_rng(0)
    for t in range(60):
        v = rng.normal(size=(4, int(rng.integers(2, 80))))
        if t % 3 == 0:
            v = np.round(v, 1)
        if t % 7 == 0:
            v[:] = 1.0
        r = stats.rankdata(v, method="average")
        ref = stats.norm.ppf((r - 0.375) / (r.size + 0.25)).reshape(v.shape)
        assert np.array_equal(dg._z_scale(v), ref)
        for q in (0.05, 0.95):
            assert dg._quantile7(v, q) == mquantiles(v, q, alphap=1, betap=1)[0]
    v = rng.normal(size=(4, 10))
    v[1, 3] = np.nan
    assert np.isnan(dg.ess_bulk(v)) and np.isnan(dg.rhat_rank(v))
