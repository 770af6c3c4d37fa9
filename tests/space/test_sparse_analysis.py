"""The sparse analysis path (frontier sweep, LU circuits, IPM LPs) equals the dense one.

Large problems (>= SWEEP_MIN_COLUMNS columns) take the sparse path; here it is
forced on the paper packings (and a tiling, the structure of the large
benchmarks) and compared with the dense path: dimensions exactly, the centre
radius to 1e-9 <Fn> (each centre holding that ball in S), ranges to 1e-9 <Fn>,
the varying contacts and the domains identical.
"""
import numpy as np
import pytest
import scipy.sparse as sp

from forcespace import config, read_packing
from forcespace.linalg import sweep_null_space
from forcespace.model.packing import tile
from forcespace.model.problem import slice_problem
from forcespace.space.force_space import ForceSpace
from forcespace.space.structure import domains
from paths import PACKINGS


def _both(monkeypatch, prob, ranges):
    """(analysis, domains) by the dense path, then by the sparse path."""
    out = []
    for th in (10**9, 0):
        monkeypatch.setattr(config, "SWEEP_MIN_COLUMNS", th)
        an = ForceSpace(ranges=ranges).compute(prob)
        out.append((an, domains(prob, an)))
    return out


def _same(prob, dense, sparse, ranges):
    (a, da), (b, db) = dense, sparse
    s = prob.force_scale
    for name in ("feasible", "bounded", "dim", "rank_A", "degree_of_indeterminacy",
                 "n_sliding", "n_zero"):
        assert getattr(a, name) == getattr(b, name), name
    assert np.array_equal(a.implicit_rows, b.implicit_rows)
    assert abs(a.radius - b.radius) <= 1e-9 * s    # LP tolerance, <Fn> units
    # the centre LP's optimum need not be unique (the sparse path's interior point may
    # return another optimal vertex): each centre must lie in S and hold the ball of the
    # common radius inside S's affine hull
    G, _, _ = prob.inequalities()
    for an in (a, b):
        free = np.setdiff1d(np.arange(G.shape[0]), an.implicit_rows)
        width = np.linalg.norm(G[free] @ an.affine_basis, axis=1)
        assert prob.violation(an.centre) <= 1e-9
        assert np.all(-(G[free] @ an.centre) >= an.radius * width - 1e-9 * s)
    if ranges:
        for r1, r2 in ((a.fn_range, b.fn_range), (a.ft_range, b.ft_range)):
            assert np.nanmax(np.abs(r1 - r2)) <= 1e-9 * s
    assert np.array_equal(a.varying, b.varying)
    assert sorted((tuple(d.contacts), d.dim) for d in da) == \
        sorted((tuple(d.contacts), d.dim) for d in db)
    if a.dim:   # the same affine hull (another orthonormal basis of it)
        N1, N2 = a.affine_basis, b.affine_basis
        assert np.linalg.norm(N1 @ (N1.T @ N2) - N2) < 1e-10
        assert np.abs(N2.T @ N2 - np.eye(N2.shape[1])).max() < 1e-12
        # both affine points lie in the same hull: their difference is along N
        assert np.abs((np.eye(N1.shape[0]) - N1 @ N1.T) @ (b.affine_point - a.affine_point)
                      ).max() < 1e-9 * s


@pytest.mark.parametrize("mu,ranges", [("0", True), ("0.01", False), ("0.1", True),
                                       ("0.5", True)])
def test_sparse_path_equals_dense_on_paper_packings(monkeypatch, mu, ranges):
    prob = slice_problem(read_packing(PACKINGS / f"paper_mu{mu}.h5"), 28.0)
    _same(prob, *_both(monkeypatch, prob, ranges), ranges)


def test_sparse_path_equals_dense_on_a_tiling(monkeypatch):
    prob = slice_problem(tile(read_packing(PACKINGS / "paper_mu0.1.h5"), 3), 28.0)
    _same(prob, *_both(monkeypatch, prob, False), False)


def test_sweep_null_space_matches_svd():
    # banded sparse matrix with dependent rows and an empty column
    rng = np.random.default_rng(3)
    r, n = 120, 150
    M = sp.random(r, n, density=0.0, random_state=1).tolil()
    for i in range(r):
        for j in range(max(0, i - 3), min(n - 1, i + 4)):
            M[i, j] = rng.normal()
    M[50] = M[10] + 2 * M[11]           # dependent rows
    M[:, 140] = 0.0                     # a column in no row
    M = M.tocsr()
    rhs = M @ rng.normal(size=n) + 1e-3 * rng.normal(size=r)
    res = sweep_null_space(M, rhs, chunk=7)
    Md = M.toarray()
    u, s, vt = np.linalg.svd(Md)
    rank = int((s > 1e-10 * s[0] * max(M.shape)).sum())
    assert res.rank == rank and res.basis.shape == (n, n - rank)
    N = res.basis
    assert np.abs(N.T @ N - np.eye(n - rank)).max() < 1e-12
    assert np.abs(Md @ N).max() < 1e-12
    step = vt[:rank].T @ ((u[:, :rank].T @ rhs) / s[:rank])
    assert np.abs(res.step - step).max() < 1e-10
    assert sweep_null_space(M, basis=False, chunk=5).rank == rank



def test_strict_rows_by_clarabel_equal_highs_ipm_and_the_exact_test(monkeypatch):
    """Issue 46: the large path's strict-rows LP by Clarabel (config.INTERIOR_SOLVERS; 15x
    faster than HiGHS' IPX on the 5000-disk slice) gives a point of S and the same strict
    rows as HiGHS' interior point, which are the rows the simplex test (tight_rows) finds
    not implicit; max sum fn agrees across solvers."""
    from forcespace.space.lp import unit_problem
    from forcespace.space.questions import (interior_max_sum_fn, interior_strict_rows,
                                            tight_rows)

    prob = slice_problem(read_packing(PACKINGS / "paper_mu0.1.h5"), 28.0)
    P, _ = unit_problem(prob)
    implicit = tight_rows(P, config.IMPLICIT_TOL)
    found, msum = {}, {}
    for solver in ("clarabel", "highs-ipm"):
        monkeypatch.setitem(config.INTERIOR_SOLVERS, "strict_rows", solver)
        monkeypatch.setitem(config.INTERIOR_SOLVERS, "max_sum_fn", solver)
        x, strict = interior_strict_rows(P)
        assert P.violation(x) <= 10 * config.INTERIOR_TOL
        found[solver] = strict
        msum[solver] = interior_max_sum_fn(P)
    assert np.array_equal(found["clarabel"], found["highs-ipm"])
    assert np.array_equal(np.flatnonzero(~found["clarabel"]), implicit)
    assert msum["clarabel"] == pytest.approx(msum["highs-ipm"], rel=1e-8)



@pytest.mark.parametrize("solver", ["clarabel", "highs-ipm"])
def test_interior_lp_ends_inside_its_optimal_face(solver):
    """Both interior points end in the relative interior of a non-unique optimal face, what
    the strict-rows LP relies on (a row strict somewhere is strict at the solution): max
    s1 + s2 over s1 <= x, s2 <= 1 - x, 0 <= s <= 0.1, 0 <= x <= 1 (the strict-rows LP of
    the interval [0, 1]); the optimal face is s = 0.1, x in [0.1, 0.9], whose vertices
    leave one row tight. Infeasible: status 2, unbounded: 3."""
    from forcespace.space.lp import solve_lp_interior

    inf = np.inf
    A_ub = sp.csr_matrix(np.array([[-1.0, 1.0, 0.0], [1.0, 0.0, 1.0]]))   # (x, s1, s2)
    none = sp.csr_matrix((0, 3))
    st, z = solve_lp_interior(np.array([0.0, -1.0, -1.0]), A_ub, np.array([0.0, 1.0]), none,
                              np.zeros(0), np.zeros(3), np.array([1.0, 0.1, 0.1]), tol=1e-10,
                              solver=solver)
    assert st == 0 and z[1:] == pytest.approx([0.1, 0.1], abs=1e-8)
    assert min(z[0] - z[1], 1 - z[0] - z[2]) > 0.05           # both rows strict
    st, _ = solve_lp_interior(np.zeros(3), A_ub, np.array([-1.0, -1.0]), none, np.zeros(0),
                              np.zeros(3), np.full(3, inf), tol=1e-10, solver=solver)
    assert st == 2
    st, _ = solve_lp_interior(np.array([-1.0, 0.0, 0.0]), none, np.zeros(0), none,
                              np.zeros(0), np.zeros(3), np.full(3, inf), tol=1e-10,
                              solver=solver)
    assert st == 3


def test_clarabel_almost_solved_is_taken_only_when_the_point_checks(monkeypatch):
    """Clarabel's "AlmostSolved" (it ends so on the 5000-disk slice's strict-rows LP, one
    step short of 1e-10) is an answer only when the point, clipped to its bounds, meets
    the rows to 10 tol and the duality gap is below 1e3 tol; else status 1 (the caller
    takes the exact path)."""
    import clarabel

    from forcespace.space.lp import solve_lp_clarabel

    class Fake:
        def __init__(self, x, gap):
            self.status, self.x = "AlmostSolved", x
            self.obj_val, self.obj_val_dual = -x[0], -x[0] - gap

    answer = {}
    monkeypatch.setattr(clarabel, "DefaultSolver",
                        lambda *args: type("S", (), {"solve": lambda self: answer["sol"]})())
    A_ub, none = sp.csr_matrix(np.array([[1.0, 1.0]])), sp.csr_matrix((0, 2))
    args = (np.array([-1.0, 0.0]), A_ub, np.array([1.0]), none, np.zeros(0), np.zeros(2),
            np.full(2, np.inf), 1e-10)
    for x, gap, status in (([0.7, 0.3 - 1e-12], 1e-9, 0), ([0.7, 0.3 + 1e-6], 1e-9, 1),
                           ([0.7, 0.3], 1e-3, 1), ([0.7, -1e-13], 1e-9, 0)):
        answer["sol"] = Fake(np.array(x), gap)
        st, z = solve_lp_clarabel(*args)
        assert st == status, (x, gap)
        if st == 0:
            assert z.min() >= 0.0                      # clipped to its bounds
