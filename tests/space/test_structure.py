"""Elementary clusters: hand-built packings with known clusters, invariants on a paper slice."""
import json

import numpy as np
import pytest
import scipy.linalg as sla

import forcespace as fs
from ensemble_cases import shared_support_grooves
from forcespace.cli import main
from forcespace.space.structure import decompose, extreme_pair
from forcespace.space.force_space import ForceSpace
from paths import PACKINGS

TA, TB, MU = np.pi / 6, np.pi / 5, 0.3


def test_two_grooves_on_a_shared_support_are_exactly_two_elementary_clusters():
    p, prob = shared_support_grooves(TA, TB, MU)
    an = ForceSpace(ranges=True).compute(prob)
    assert an.dim == 2 and an.bounded
    dec = decompose(prob, an, p)
    assert len(dec.clusters) == 2 and dec.n_elementary == 2
    found = sorted(tuple(prob.contacts[c.contacts]) for c in dec.clusters)
    assert found == [(0, 1), (2, 3)]                      # S1-A, S2-A | S2-B, S3-B
    # each cluster's self-stress by hand (ensemble_cases.groove): fn1 = fn2 = N(s),
    # ft1 = s, ft2 = -s with dN/ds = -tan(theta): direction (-tan th, 1, -tan th, -1)
    for c in dec.clusters:
        theta = TA if prob.contacts[c.contacts[0]] == 0 else TB
        expected = np.array([-np.tan(theta), 1.0, -np.tan(theta), -1.0])
        v = c.vector[np.concatenate([[2 * j, 2 * j + 1] for j in c.contacts])]
        cos = abs(v @ expected) / np.linalg.norm(v) / np.linalg.norm(expected)
        assert cos == pytest.approx(1.0, abs=1e-10)
        assert c.dof == 1 and c.disks.size == 1
    assert dec.density == pytest.approx(2 / 2)           # two clusters on two interior disks


def test_decomposition_invariants_on_a_paper_slice():
    p = fs.read_packing(PACKINGS / "paper_mu0.5.h5")
    prob = fs.slice_problem(p, 28.0)
    an = ForceSpace(ranges=False).compute(prob)
    dec = decompose(prob, an, p)
    N = an.affine_basis
    assert sum(g.dim for g in dec.domains) == an.dim
    for gi, g in enumerate(dec.domains):
        mine = [c for c in dec.clusters if c.domain == gi]
        assert len(mine) == g.dim                          # one circuit per degree of freedom
        V = np.column_stack([c.vector for c in mine])
        assert np.linalg.matrix_rank(V, tol=1e-8) == g.dim   # they span the domain
        for c in mine:
            # a self-stress of the free directions: in span(N) ...
            assert np.linalg.norm(c.vector - N @ (N.T @ c.vector)) < 1e-8
            # ... with minimal support: only one direction of span(N) lives on it
            rest = np.setdiff1d(np.arange(N.shape[0]), c.columns)
            s = sla.svdvals(N[rest])
            assert N.shape[1] - (s > 1e-6).sum() == 1         # (VARY_TOL: round-off below)
            assert set(c.contacts) <= set(g.contacts)
    # the two networks of Fig. 2 are admissible and differ on varying contacts only
    x1, x2 = extreme_pair(prob, an, seed=1)
    assert prob.violation(x1) < 1e-8 and prob.violation(x2) < 1e-8
    moved = np.flatnonzero(np.hypot(*(x2 - x1).reshape(-1, 2).T) > 1e-7 * prob.force_scale)
    assert set(moved) <= set(np.concatenate([g.contacts for g in dec.domains]))


def test_draw_difference_and_analyze_clusters_cli(tmp_path, capsys):
    src = PACKINGS / "paper_mu0.5.h5"
    assert main(["analyze", str(src), "--slice", "28", "--clusters", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    cl = out["clusters"]
    assert sum(cl["domain_dims"]) == out["dim_S"] and cl["n_clusters"] == out["dim_S"]
    assert cl["density_rho"] == pytest.approx(cl["n_elementary"] / out["n_interior"])
    # one name per count (the top level said "n_elementary_clusters": 0 for what is the
    # number of one-dimensional domains, beside clusters.n_elementary = 10 on the mu = 0.1
    # slice): the domains of dim 1 are elementary clusters, others lie in larger domains
    assert "n_elementary_clusters" not in out and out["domain_dims"] == cl["domain_dims"]
    assert out["n_domains_of_dim_1"] == cl["domain_dims"].count(1) <= cl["n_elementary"]
    assert "n_domains_of_dim_1" in out["domains_convention"]
    fig = tmp_path / "fig2.png"
    assert main(["draw", str(src), "--difference", "--slice", "28", "-o", str(fig)]) == 0
    assert fig.is_file() and fig.with_suffix(".pdf").is_file()
    p, prob = shared_support_grooves(TA, TB, 0.0)        # frictionless: S is a point
    fs.write_packing(p, tmp_path / "det.h5")
    assert main(["draw", str(tmp_path / "det.h5"), "--difference", "--full",
                 "-o", str(tmp_path / "d.png")]) == 2
    assert "dimension >= 1" in capsys.readouterr().err


def test_domains_of_dimension_one_are_elementary_clusters_on_an_ill_conditioned_slice():
    """mu = 10 (paper scene, seed 3): three domains of dimension 1 whose null vectors
    leak ~3e-9 of their norm outside them. The decomposition once counted 0 clusters
    there (a null space cut at round-off), so rho was 0 where it is 3 / 105. Every
    domain of dimension k holds k clusters; a domain of dimension 1 is one elementary
    cluster."""
    from paths import DATA
    p = fs.read_packing(DATA / "paper_mu10_seed3.h5")
    prob = fs.slice_problem(p, 28.0)
    an = ForceSpace().compute(prob)
    dec = decompose(prob, an, p)
    assert [g.dim for g in dec.domains] == [1, 1, 1]
    for gi, g in enumerate(dec.domains):
        mine = [c for c in dec.clusters if c.domain == gi]
        assert len(mine) == g.dim and all(c.elementary for c in mine)
        assert set(mine[0].contacts) == set(g.contacts)       # the circuit is the domain
    assert dec.n_elementary == 3 and dec.density == pytest.approx(3 / prob.n_interior)
