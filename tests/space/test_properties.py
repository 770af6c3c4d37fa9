"""Property-based tests (hypothesis) over random small packings.

Systems: rows of unit disks resting in the grooves of a fixed support row
(``lattice_rows``), with random width, height, friction, weight and, for the
mirror property, reflected x -> -x. Properties: the analysis of S is invariant
under scaling all forces and equivariant under mirroring (ft changes sign);
hit-and-run samples lie in S; the walk and eta do not depend on the load scale.
"""
import dataclasses

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ensemble_cases import lattice_rows
from forcespace.sampling.diagnostics import read_ensemble
from forcespace.sampling.hit_and_run import HitAndRun
from forcespace.measures import eta
from forcespace.space.force_space import ForceSpace
from forcespace.model.problem import build_problem

SETTINGS = settings(max_examples=6, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow])
systems = st.tuples(st.integers(2, 4), st.integers(1, 2),
                    st.floats(0.05, 0.5), st.floats(0.2, 5.0))


def rebuild(p, n_support, **changes):
    """The lattice_rows problem of packing p with fields replaced (same contacts)."""
    q = dataclasses.replace(p, **changes)
    sup = np.zeros(p.n_disks, bool)
    sup[:n_support] = True
    return build_problem(q, ~sup, (), "prop", support_mask=sup,
                         rattlers=np.zeros(p.n_disks, bool))


@SETTINGS
@given(systems, st.integers(-12, 12))
def test_analysis_is_invariant_under_force_scaling(system, k):
    width, rows, mu, W = system
    p, prob = lattice_rows(width, min(rows, width), mu, W=W)
    s = 10.0 ** k
    scaled = rebuild(p, width + 1, gravity=p.gravity * s, fn=p.fn * s, ft=p.ft * s)
    a, b = ForceSpace(ranges=True).compute(prob), ForceSpace(ranges=True).compute(scaled)
    assert (a.feasible, a.bounded, a.dim) == (b.feasible, b.bounded, b.dim)
    assert np.array_equal(a.implicit_rows, b.implicit_rows)
    if a.bounded:
        tol = 1e-7 * prob.force_scale
        assert np.allclose(b.fn_range, a.fn_range * s, rtol=1e-6, atol=tol * s)
        assert np.allclose(b.ft_range, a.ft_range * s, rtol=1e-6, atol=tol * s)


@SETTINGS
@given(systems)
def test_mirrored_packing_has_the_mirrored_S(system):
    width, rows, mu, W = system
    p, prob = lattice_rows(width, min(rows, width), mu, W=W)
    nrm = p.normal * [-1.0, 1.0]
    mirror = rebuild(p, width + 1, x=-p.x, normal=nrm, point=p.point * [-1.0, 1.0],
                     ft=-p.ft)
    a, b = ForceSpace(ranges=True).compute(prob), ForceSpace(ranges=True).compute(mirror)
    assert a.dim == b.dim and a.bounded == b.bounded
    if a.bounded:
        tol = 1e-7 * prob.force_scale
        assert np.allclose(b.fn_range, a.fn_range, atol=tol)
        assert np.allclose(b.ft_range, -a.ft_range[:, ::-1], atol=tol)   # ft -> -ft


@SETTINGS
@given(systems, st.integers(-40, 40), st.integers(0, 2**16))
def test_hit_and_run_samples_lie_in_S_and_eta_ignores_the_load_scale(tmp_path_factory, system,
                                                                      k, seed):
    # a binary load scale 2^k (1e-12 .. 1e12) is exact in floating point: the sampler
    # works at <Fn> = 1, so it must then produce the same walk, scaled, and the same eta
    # (a decimal scale changes the last bits of the LPs' input, and with it which of
    # several optimal vertices they return: same distribution, another walk)
    width, rows, mu, W = system
    p, prob = lattice_rows(width, min(rows, width), mu, W=W)
    if not ForceSpace(ranges=False).compute(prob).bounded:
        return
    s = 2.0 ** k
    scaled = rebuild(p, width + 1, gravity=p.gravity * s, fn=p.fn * s, ft=p.ft * s)
    d = tmp_path_factory.mktemp("har")
    HitAndRun(40, seed=seed, thin=5, burn_in=50).compute(prob, output=d / "a.h5").summary()
    HitAndRun(40, seed=seed, thin=5, burn_in=50).compute(scaled, output=d / "b.h5").summary()
    A, B = read_ensemble(d / "a.h5").samples, read_ensemble(d / "b.h5").samples
    for pr, X in ((prob, A), (scaled, B)):
        assert max(pr.violation(x) for x in X) <= 1e-9
    assert np.array_equal(B, A * s)
    assert eta(B) == eta(A)
