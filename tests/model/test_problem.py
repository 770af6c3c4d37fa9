"""Statics: the equilibrium matrix, loads, slices and rattlers on hand-built systems."""
import numpy as np
import pytest

from ensemble_cases import _packing, groove, pyramid
from forcespace.errors import InputError
from forcespace.model.walls import TOP
from forcespace.model.problem import build_problem, full_problem, slice_problem


def test_groove_matrix_matches_hand_derivation():
    th, W = np.pi / 6, 2.0
    p, prob = groove(th, 0.3, W)
    s, c = np.sin(th), np.cos(th)
    # columns fn1, ft1, fn2, ft2; rows fx, fy, torque/r of the loaded disk
    expect = np.array([[s, -c, -s, -c],
                       [c, s, c, -s],
                       [0, -1, 0, -1]])
    assert np.allclose(prob.A.toarray(), expect)
    assert np.allclose(prob.b, [0.0, W, 0.0])          # A x = -(gravity load)
    assert prob.violation(prob.x_jammed) < 1e-14       # fn = W / (2 cos th), ft = 0
    x = prob.forces_from_packing(p.fn, p.ft)
    fn, ft = prob.to_packing_forces(x + 1.0)
    assert np.allclose(fn[prob.contacts], p.fn[prob.contacts] + 1.0)


def test_degree_of_indeterminacy_counts_when_full_row_rank():
    from forcespace.space.force_space import ForceSpace
    p, prob = pyramid(4, 0.5)
    an = ForceSpace(ranges=False, centre=False).compute(prob)
    assert an.full_row_rank
    assert an.degree_of_indeterminacy == 2 * prob.n_contacts - 3 * prob.n_interior == 14


def _column(mu=0.4, F=3.0):
    """5 unit disks stacked at y = 1, 3, ..., 9 between plates at 0 and 10,
    plus a free disk far away (a rattler). All contacts carry F vertically."""
    x = [0, 0, 0, 0, 0, 20.0]
    y = [1, 3, 5, 7, 9, 5.0]
    a = [-1, 0, 1, 2, 3, 4]
    b = [0, 1, 2, 3, 4, TOP]
    p = _packing(x, y, np.ones(6), a, b, [F] * 6, [0.0] * 6, mu, gravity=0.0,
                 plate_mu=0.0, y_bottom=0.0)
    p.normal[-1] = (0.0, 1.0)
    p.y_top = 10.0
    p.top_force = F
    return p


def test_slice_keeps_middle_disks_and_turns_outside_contacts_into_loads():
    F = 3.0
    p = _column(F=F)
    assert p.rattlers()[5] and not p.rattlers()[:5].any()
    prob = slice_problem(p, 5.0)                      # |y - 5| <= 2.5: disks 1, 2, 3
    assert list(prob.disks) == [1, 2, 3]
    assert list(prob.contacts) == [2, 3]              # 1-2 and 2-3 are unknowns
    assert sorted(prob.load_contacts) == [1, 4]       # 0-1 and 3-4 are loads
    assert list(prob.rattlers) == [5]
    # disk 1 is pushed up by F from disk 0, disk 3 pushed down by F from disk 4
    assert np.allclose(prob.b[[1, 7]], [-F, F])
    assert np.allclose(prob.A @ prob.x_jammed, prob.b)
    assert prob.A.shape == (9, 4)


def test_full_problem_supports_bottom_loads_top():
    p = _column()
    prob = full_problem(p)
    assert list(prob.disks) == [0, 1, 2, 3, 4]
    assert list(prob.contacts) == [0, 1, 2, 3, 4]     # floor contact is an unknown
    assert list(prob.load_contacts) == [5]            # the top plate's force is fixed
    assert prob.mu[0] == 0.0 and np.all(prob.mu[1:] == 0.4)
    assert prob.violation(prob.x_jammed) < 1e-14
    a, b, nx, ny = prob.contact_geometry()            # the floor contact: a support below
    assert a[0] == -1 and b[0] == 0 and (nx[0], ny[0]) == (0.0, 1.0)


def test_inconsistent_loads_are_projected_and_reported():
    p = _column()
    p.fn[1] *= 1.0 + 1e-6                            # unbalanced slice by 1e-6 F
    prob = slice_problem(p, 5.0)
    assert 1e-7 < prob.meta["load_inconsistency"] < 1e-5


def test_bad_input_is_one_clear_error():
    p = _column()
    with pytest.raises(InputError, match="height"):
        slice_problem(p, -1.0)
    with pytest.raises(InputError, match="no non-rattler disk"):
        build_problem(p, np.zeros(6, bool), (), "slice")
    p.fn[2] = np.nan
    with pytest.raises(InputError, match="finite"):
        full_problem(p)
